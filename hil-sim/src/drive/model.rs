//! Derived drive constants of one robot and the evolving drive state.

use super::G;
use puzzlebot_params::{mass::Mass, plant::Plant, RobotKind};

/// Derived constants of one robot's drive (computed once).
#[derive(Debug, Clone, Copy)]
pub struct DriveModel {
    /// Wheel radius (m).
    pub r: f64,
    /// Wheel base (m).
    pub base: f64,
    /// Mass (kg).
    pub m: f64,
    /// Yaw inertia (kg·m²).
    pub iz: f64,
    /// Wheel-side inertia of one motor + gearbox + wheel (kg·m²).
    pub jw: f64,
    /// Motor constant (SI).
    pub k: f64,
    /// Armature resistance (Ω).
    pub res: f64,
    /// Armature inductance (H).
    pub ind: f64,
    /// Gear ratio.
    pub n: f64,
    /// Gear efficiency.
    pub eta: f64,
    /// Static friction torque at the wheel (N·m).
    pub t_static: f64,
    /// Coulomb friction torque at the wheel (N·m).
    pub t_coulomb: f64,
    /// Viscous friction (N·m·s/rad).
    pub b_visc: f64,
    /// Traction cap per side (N).
    pub traction_max: f64,
    /// Traction slope per side (N per m/s of slip).
    pub traction_c: f64,
    /// Lateral wheel contacts: (x in body frame, μ_lat·N).
    pub lateral: [(f64, f64); 4],
    /// Number of used entries of `lateral`.
    pub n_lateral: usize,
    /// Casters: (x, μ·N).
    pub casters: [(f64, f64); 2],
    /// Number of casters.
    pub n_casters: usize,
    /// Slip angle at which lateral tyre force saturates (rad).
    pub alpha_sat: f64,
    /// Battery.
    pub battery: BatteryModel,
}

/// Battery constants.
#[derive(Debug, Clone, Copy)]
pub struct BatteryModel {
    /// Open-circuit voltage at 50 % charge (V).
    pub nominal: f64,
    /// Open-circuit swing from empty to full (V).
    pub swing: f64,
    /// Internal resistance (Ω).
    pub resistance: f64,
    /// 1 / capacity (1/C).
    pub inv_capacity: f64,
    /// Current of the electronics (A).
    pub idle: f64,
}

impl DriveModel {
    /// Constants for a robot of `kind` with the given parameters.
    pub fn new(
        kind: RobotKind,
        p: &Plant,
        mass: &Mass,
        geom: &puzzlebot_params::geometry::Geometry,
    ) -> Self {
        let m = f64::from(mass.mass);
        let w = m * G;
        let _ = kind;
        let four = p.four_wheels;
        let wheel_share = if four {
            1.0
        } else {
            f64::from(p.wheel_load_fraction).clamp(0.0, 1.0)
        };
        let n_side = w * wheel_share * 0.5;
        let mu = f64::from(p.wheel_friction);
        let mu_lat = f64::from(p.wheel_lateral_friction);
        let d = f64::from(p.wheel_axle_offset);
        let mut lateral = [(0.0, 0.0); 4];
        let n_lateral = if four {
            // Two wheels per side at x = ±d; each carries a quarter of the weight.
            lateral[0] = (d, mu_lat * w * 0.25 * 2.0);
            lateral[1] = (-d, mu_lat * w * 0.25 * 2.0);
            2
        } else {
            // One axle, `wheel_axle_offset` ahead of the centre (0 for the chapter-5 robot).
            lateral[0] = (d, mu_lat * n_side * 2.0);
            1
        };
        let mut casters = [(0.0, 0.0); 2];
        let n_casters = if four {
            0
        } else {
            let nc = w * (1.0 - wheel_share) * 0.5;
            let c = f64::from(p.caster_offset);
            casters[0] = (c, f64::from(p.caster_friction) * nc);
            casters[1] = (-c, f64::from(p.caster_friction) * nc);
            2
        };
        let n = f64::from(p.gear_ratio);
        DriveModel {
            r: f64::from(geom.wheel_radius),
            base: f64::from(geom.wheel_base),
            m,
            iz: f64::from(p.yaw_inertia),
            jw: f64::from(p.rotor_inertia) * n * n,
            k: f64::from(p.motor_k),
            res: f64::from(p.motor_resistance),
            ind: f64::from(p.motor_inductance),
            n,
            eta: f64::from(p.gear_efficiency),
            t_static: f64::from(p.friction_static),
            t_coulomb: f64::from(p.friction_coulomb),
            b_visc: f64::from(p.friction_viscous),
            traction_max: mu * n_side,
            traction_c: mu * n_side / f64::from(p.traction_slip_speed).max(1e-4),
            lateral,
            n_lateral,
            casters,
            n_casters,
            alpha_sat: f64::from(p.slip_angle_saturation).max(1e-3),
            battery: BatteryModel {
                nominal: f64::from(p.battery_voltage),
                swing: f64::from(p.battery_voltage_swing),
                resistance: f64::from(p.battery_resistance),
                inv_capacity: 1.0 / (f64::from(p.battery_capacity_mah) * 3.6).max(1e-9),
                idle: f64::from(p.idle_current),
            },
        }
    }
}

/// The evolving state of one robot's drive.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DriveState {
    /// Wheel speeds left, right (rad/s, output shaft; positive drives forward).
    pub wheel: [f64; 2],
    /// Wheel angles (rad, output shaft, unwrapped).
    pub angle: [f64; 2],
    /// Armature currents (A).
    pub current: [f64; 2],
    /// Forward speed (m/s, body frame).
    pub v: f64,
    /// Sideways speed (m/s, body frame, left positive).
    pub vy: f64,
    /// Yaw rate (rad/s).
    pub omega: f64,
    /// Battery state of charge (0…1).
    pub soc: f64,
    /// Battery terminal voltage at the last step (V).
    pub battery_v: f64,
    /// Traction forces left, right at the last step (N).
    pub traction: [f64; 2],
}

impl DriveState {
    /// At rest with the battery at `soc`.
    pub fn at_rest(model: &DriveModel, soc: f64) -> DriveState {
        let soc = soc.clamp(0.0, 1.0);
        DriveState {
            soc,
            battery_v: model.battery.open_circuit(soc),
            ..DriveState::default()
        }
    }
}

impl BatteryModel {
    /// Open-circuit voltage at `soc` (linear around the nominal voltage).
    pub fn open_circuit(&self, soc: f64) -> f64 {
        self.nominal + (soc - 0.5) * self.swing
    }
}
