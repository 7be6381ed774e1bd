//! Numbers of the 3-D world that the shared parameter set does not carry: body shape details
//! THESIS leaves open, solver settings, and the connector limits in the form the stability
//! gate uses (so the physics checks the gate on the same terms).

use puzzlebot_params::RobotParams;

/// Settings of the 3-D crossing world (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config3d {
    /// Physics step (s).
    pub dt: f64,
    /// Solver iterations per step (rapier `num_solver_iterations`).
    pub solver_iterations: usize,
    /// Mass of one wheel with its tyre (kg); the chassis carries the rest of the robot's
    /// mass. Not in THESIS; wheel, tyre and the last gear stage: 10 g (lighter wheels let
    /// the engine's iterative solver sag the chassis onto them by millimetres).
    pub wheel_mass: f64,
    /// Height of the chassis underside above the ground (m). Not in THESIS; 5 mm.
    pub chassis_clearance: f64,
    /// Friction coefficient of the printed chassis on a platform. Not in THESIS; 0.3.
    pub chassis_friction: f64,
    /// Height of the anchor and knobs above the ground (m); as the gate: the centre of mass
    /// height (`geometry.com_height`).
    pub coupling_height_from_com: bool,
    /// Damping of the free axes of a soft anchor (N·m·s/rad and N·s/m): the TPU beams'
    /// internal friction (THESIS 4.2); keeps a chain from ringing.
    pub anchor_damping: f64,
    /// Wheel speed below which a gearbox counts as standing and holds by static friction
    /// (rad/s at the wheel; 5 RPM, under the firmware's smallest command).
    pub wheel_rest_speed: f64,
    /// Depth of the catch floor under every gap, below the lowest platform (m).
    pub catch_depth: f64,
    /// A robot with a corner of its underside this far below the lowest platform top has
    /// fallen (m).
    pub fall_depth: f64,
    /// Tilt of gravity about the world y axis (rad): the whole terrain as a slope falling
    /// towards +x at this angle (0: level).
    pub slope: f64,
    /// A connector opens when its wrench stays over its limits this long (s): the printed TPU
    /// parts ride out the milliseconds of an impact. Not in THESIS; 10 ms.
    pub break_after: f64,
    /// Gravity comes on linearly over this time from the start (s): the assembly is set down
    /// gently instead of dropped, so the connector springs start without ringing.
    pub settle_time: f64,
    /// Natural frequency of the engine's soft contacts (Hz; rapier's default 30). The
    /// engine scales a contact's stiffness with the mass of the body it holds, so at 30 Hz a
    /// 10 g wheel sinks about a millimetre under a robot's share of weight.
    pub contact_frequency: f64,
}

impl Default for Config3d {
    fn default() -> Self {
        Config3d {
            dt: 0.004,
            solver_iterations: 4,
            wheel_mass: 0.01,
            chassis_clearance: 0.005,
            chassis_friction: 0.3,
            coupling_height_from_com: true,
            anchor_damping: 1e-3,
            wheel_rest_speed: 0.5,
            catch_depth: 0.2,
            fall_depth: 0.01,
            slope: 0.0,
            break_after: 0.01,
            settle_time: 0.3,
            contact_frequency: 30.0,
        }
    }
}

impl Config3d {
    /// Check ranges; the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        let pos = [
            ("dt", self.dt),
            ("wheel_mass", self.wheel_mass),
            ("catch_depth", self.catch_depth),
            ("fall_depth", self.fall_depth),
            ("contact_frequency", self.contact_frequency),
        ];
        for (n, v) in pos {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("physics3d config {n}: must be > 0, got {v}"));
            }
        }
        let nonneg = [
            ("chassis_clearance", self.chassis_clearance),
            ("chassis_friction", self.chassis_friction),
            ("anchor_damping", self.anchor_damping),
            ("wheel_rest_speed", self.wheel_rest_speed),
            ("break_after", self.break_after),
            ("settle_time", self.settle_time),
        ];
        for (n, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("physics3d config {n}: must be ≥ 0, got {v}"));
            }
        }
        if !(self.slope.is_finite() && self.slope.abs() < std::f64::consts::FRAC_PI_2) {
            return Err(format!(
                "physics3d config slope: must be within ±π/2, got {}",
                self.slope
            ));
        }
        if self.solver_iterations == 0 {
            return Err("physics3d config solver_iterations: must be ≥ 1".into());
        }
        Ok(())
    }

    /// Height of the couplings above the robot's ground plane (m).
    pub fn coupling_height(&self, p: &RobotParams) -> f64 {
        if self.coupling_height_from_com {
            f64::from(p.geometry.com_height)
        } else {
            0.5 * f64::from(p.geometry.height)
        }
    }
}

/// Strength of one connector (DESIGN §8) as the stability gate's box limits: every force
/// component within `force`, every moment component within `moment` (host/stability's
/// PuzzleBot adapter: the hold force times a lever of half the body height).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Strength {
    /// Largest force component (N).
    pub force: f64,
    /// Largest moment component (N·m).
    pub moment: f64,
}

impl Strength {
    /// Lever of the moment limits (m): half the body height, as the gate.
    pub fn lever(p: &RobotParams) -> f64 {
        0.5 * f64::from(p.geometry.height)
    }

    /// A soft anchor (THESIS 4.4.1: holds 500 g when locked).
    pub fn anchor(p: &RobotParams) -> Strength {
        let f = f64::from(p.coupling.anchor_hold_force);
        Strength {
            force: f,
            moment: f * Self::lever(p),
        }
    }

    /// A knob (THESIS 5.5.3: ≥ 3.2 N).
    pub fn knob(p: &RobotParams) -> Strength {
        let f = f64::from(p.coupling.knob_hold_force);
        Strength {
            force: f,
            moment: f * Self::lever(p),
        }
    }

    /// True when a wrench (force, moment; components in the connector frame) exceeds it.
    pub fn exceeded(&self, force: [f64; 3], moment: [f64; 3]) -> bool {
        force.iter().any(|f| f.abs() > self.force) || moment.iter().any(|m| m.abs() > self.moment)
    }
}
