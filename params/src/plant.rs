//! Simulated motor, gearbox, encoder, battery and body contact numbers (owned by `hil-sim`).
//!
//! THESIS gives the electrical facts (3.7 V 1000 mAh LiPo, 0.1 A average draw, DRV8833,
//! 5.5.1), the v1 motor point "0.9 mN·m with 370 mA" at 1–4 V (2.3.3), the output range
//! −450…450 RPM (5.2.3), the wheel radius 17 mm and base 40 mm (2.3.4), the masses (5.5.3)
//! and the robot push force 0.5–0.72 N (4.4.1, 5.5.2). It does not give the motor's
//! resistance, constants, inertia or friction: those below are chosen so that the model
//! reproduces the facts it does give (each field says which), for an N20-class micro gear
//! motor. The encoder resolution is NOT here: it is
//! `firmware::Firmware::encoder_edges_per_rev` (one source of truth).

use crate::RobotKind;
use serde::{Deserialize, Serialize};

/// Physical plant of one robot for the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Plant {
    /// Battery nominal voltage (V), the open-circuit voltage at `battery_initial_soc` 0.5.
    /// THESIS 5.5.1: 3.7 V LiPo.
    pub battery_voltage: f32,
    /// Battery capacity (mAh). THESIS 5.5.1: 1000.
    pub battery_capacity_mah: f32,
    /// Battery internal resistance (Ω): sag under load. Typical for a 1 Ah LiPo cell.
    pub battery_resistance: f32,
    /// Open-circuit voltage swing from empty to full (V): 3.7 ± 0.4 V covers 3.3…4.1 V.
    pub battery_voltage_swing: f32,
    /// State of charge at power-up (0…1); 0.5 gives the nominal voltage.
    pub battery_initial_soc: f32,
    /// Current drawn by everything but the motors (A). THESIS 5.5.1: 0.1 A average.
    pub idle_current: f32,
    /// Pilot robots have four wheels (poor turning); non-pilots two wheels + casters.
    pub four_wheels: bool,
    /// Armature resistance (Ω). With `motor_k` it gives 0.8 mN·m at 370 mA (THESIS 2.3.3:
    /// 0.9 mN·m at 370 mA), a stall current of 0.74 A at 3.7 V (DRV8833: 1 A per bridge)
    /// and a loaded wheel time constant of ≈ 34 ms (firmware/core tunes its PI for 30 ms).
    pub motor_resistance: f32,
    /// Armature inductance (H). Typical N20: 0.5 mH (L/R ≈ 55 µs).
    pub motor_inductance: f32,
    /// Torque constant k_t (N·m/A) = back-EMF constant k_e (V·s/rad) in SI units.
    /// Chosen so the unloaded wheel runs ≈ 540 RPM at 3.7 V through the gearbox, which leaves
    /// the 450 RPM of THESIS 5.2.3 reachable under load.
    pub motor_k: f32,
    /// Rotor plus first gear stage inertia (kg·m², motor side). Typical N20: 5·10⁻⁹.
    pub rotor_inertia: f32,
    /// Gear reduction motor:wheel. A 30:1 N20 gearbox (15,000 → 500 RPM class).
    pub gear_ratio: f32,
    /// Gearbox efficiency (torque).
    pub gear_efficiency: f32,
    /// Static (break-away) friction torque at the wheel shaft (N·m): the start-up
    /// dead-band M_min of THESIS 3.4. 2.7 mN·m needs ≈ 8 % duty to start at 3.7 V
    /// (`Firmware::ff_deadband_duty` = 80 per-mille).
    pub friction_static: f32,
    /// Coulomb friction torque at the wheel shaft while turning (N·m).
    pub friction_coulomb: f32,
    /// Viscous friction at the wheel shaft (N·m·s/rad).
    pub friction_viscous: f32,
    /// Longitudinal tyre–floor friction coefficient μ. With the robot's weight it limits
    /// the push of one robot to ≈ 0.5–0.65 N (THESIS 4.4.1, 5.5.2: 0.5–0.72 N).
    pub wheel_friction: f32,
    /// Lateral tyre friction coefficient (scrub when the body yaws over offset wheels).
    pub wheel_lateral_friction: f32,
    /// Tyre slip angle (rad) at which the lateral force saturates (cornering stiffness):
    /// a rolling wheel resists sideways slip less the faster it rolls, which is why the
    /// four-wheeled pilot "needs forward speed to turn" (THESIS 3.5.1, Figure 3.13).
    pub slip_angle_saturation: f32,
    /// Longitudinal slip speed (m/s) below which traction grows linearly with slip.
    pub traction_slip_speed: f32,
    /// Distance of the wheel axles from the body centre along x (m): ± for the two axles of
    /// a four-wheeled pilot; ahead of the centre for the single axle of a two-wheeled robot
    /// (0 for the chapter-5 non-pilot, whose axle is on the centre).
    pub wheel_axle_offset: f32,
    /// Fraction of the weight on the driven wheels (the rest on the casters; pilots: 1).
    pub wheel_load_fraction: f32,
    /// Caster distance from the centre along x (m), front and back (non-pilots).
    pub caster_offset: f32,
    /// Radius of the ball casters (m, non-pilots): the arc a caster rolls over a platform
    /// edge on. Not in THESIS; 4 mm (THESIS Fig 5.3 A).
    pub caster_radius: f32,
    /// Sliding friction coefficient of the ball casters (non-pilots).
    pub caster_friction: f32,
    /// How far the ball casters stand clear of the ground when the robot rests level on its
    /// wheels (m, non-pilots): most of the weight stays on the driven wheels, a caster
    /// carries load only once the body pitches by `caster_lift / caster_offset`. Not in
    /// THESIS; 0.5 mm.
    pub caster_lift: f32,
    /// Yaw moment of inertia of the body (kg·m²): a 50 × 50 mm box of the robot's mass.
    pub yaw_inertia: f32,
    /// Highest step up the robot can drive onto (m); higher edges block it like a wall.
    pub max_climb: f32,
}

impl Plant {
    /// Defaults (chapter-5 robot: ESP32-C3, encoders, LiPo) for `kind`.
    pub fn for_kind(kind: RobotKind) -> Self {
        let pilot = matches!(kind, RobotKind::Pilot);
        Plant {
            battery_voltage: 3.7,
            battery_capacity_mah: 1000.0,
            battery_resistance: 0.15,
            battery_voltage_swing: 0.8,
            battery_initial_soc: 0.5,
            idle_current: 0.1,
            four_wheels: pilot,
            motor_resistance: 5.0,
            motor_inductance: 0.5e-3,
            motor_k: 2.18e-3,
            rotor_inertia: 5.0e-9,
            gear_ratio: 30.0,
            gear_efficiency: 0.7,
            friction_static: 2.7e-3,
            friction_coulomb: 1.8e-3,
            friction_viscous: 2.0e-6,
            wheel_friction: 0.6,
            wheel_lateral_friction: 0.8,
            slip_angle_saturation: 0.15,
            traction_slip_speed: 0.005,
            wheel_axle_offset: if pilot { 0.016 } else { 0.0 },
            wheel_load_fraction: if pilot { 1.0 } else { 0.8 },
            caster_offset: 0.018,
            caster_radius: 0.004,
            caster_friction: 0.05,
            caster_lift: 0.0005,
            yaw_inertia: if pilot { 4.3e-5 } else { 4.6e-5 },
            // Pilots climb onto platforms (THESIS 3.4); casters do not.
            max_climb: if pilot { 0.006 } else { 0.002 },
        }
    }

    /// The chapter-3 (v2) robots: 3 V CR2 battery, no encoders, commanded by raw 8-bit PWM
    /// through the DRV8833 (THESIS 3.4), calibrated open-loop as in THESIS 3.5.1
    /// (`hil-sim` `calibration::Procedure::thesis_3_5_1`: both motors forward, PWM 0…190,
    /// slow decay so that speed is proportional to PWM as THESIS 3.4 states).
    ///
    /// Motor, wheels (r = 17 mm, L = 40 mm, THESIS 2.3.4) and masses are the shared ones;
    /// THESIS does not give the chapter-3 gearboxes, so the gear ratio is what makes the
    /// top speed B come out: the non-pilot's B = 0.11 m/s needs a 150:1 reduction (a
    /// stock N20 ratio), the pilot's B = 0.47 m/s about 36:1. Its poor turning (k_ω/k_v =
    /// 1.4 /m against 25 /m for an ideal 40 mm track) comes from scrubbing four wheels on
    /// two axles; axle spacing, tyre and friction numbers were chosen by the `hil-sim`
    /// example `ch3_tune` (random search against k_v, k_ω, A, B). The example
    /// `ch3_calibration` prints the remaining errors.
    pub fn chapter3(kind: RobotKind) -> Self {
        let mut p = Plant::for_kind(kind);
        // CR2 lithium primary: 3 V, 850 mAh (THESIS 2.3.3), flat discharge curve.
        p.battery_voltage = 3.0;
        p.battery_capacity_mah = 850.0;
        p.battery_voltage_swing = 0.2;
        p.battery_resistance = 0.5;
        match kind {
            RobotKind::Pilot => {
                p.gear_ratio = 33.38;
                p.battery_resistance = 0.710;
                p.wheel_axle_offset = 0.02134;
                p.wheel_lateral_friction = 0.9312;
                p.slip_angle_saturation = 0.05940;
                p.friction_static = 0.9595e-3;
                p.friction_coulomb = 0.6332e-3;
                p.friction_viscous = 1.763e-7;
                p.wheel_friction = 0.7149;
                p.traction_slip_speed = 0.002028;
            }
            // The chapter-5 two-wheel body and gearbox friction, a 150:1 gearbox.
            RobotKind::NonPilot => {
                p.gear_ratio = 150.0;
            }
        }
        p
    }

    /// Wheel-shaft static friction as a fraction of the stall torque at `volts`:
    /// the duty dead-band M_min (THESIS 3.4).
    pub fn dead_band_duty(&self, volts: f32) -> f32 {
        let stall =
            volts / self.motor_resistance * self.motor_k * self.gear_ratio * self.gear_efficiency;
        self.friction_static / stall
    }
}

impl Default for Plant {
    fn default() -> Self {
        Plant::for_kind(RobotKind::NonPilot)
    }
}
