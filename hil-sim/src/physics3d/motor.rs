//! The drive of one side of a robot in the 3-D world: the DC motor behind its DRV8833 bridge
//! and the gearbox, with the constants of the 2-D plant ([`DriveModel`], one source of truth),
//! turned into a wheel-joint motor of the physics engine.
//!
//! The armature settles within L/R ≈ 55 µs, far below the 2 ms step, so the current is taken
//! at steady state: `i = (a·V − g·k·N·ω) / R` (`a`, `g` from [`Bridge::drive`]). The wheel
//! torque is then affine in the wheel speed, `τ = A − B·ω` with `A = η N k a V / R` and
//! `B = η N k g k N / R + b_visc`: a velocity motor with damping `B` and target `A / B`, which
//! the engine solves implicitly (stable for any step). Gearbox friction: Coulomb torque
//! against the motion while turning; a standing gearbox holds up to the static friction
//! (the start-up dead-band M_min of THESIS 3.4) as long as the drive torque stays below it.

use crate::drive::{Bridge, DriveModel};

/// What the wheel joint's motor should do this step (engine `ForceBased` motor model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointDrive {
    /// Target relative speed of the wheel (rad/s).
    pub target_vel: f64,
    /// Damping (N·m·s/rad): torque per rad/s of speed error.
    pub damping: f64,
    /// Largest torque magnitude (N·m).
    pub max_torque: f64,
}

/// Damping used to hold a standing gearbox (N·m·s/rad): stiff enough to stop a wheel in one
/// step, bounded by the static friction torque.
const HOLD_DAMPING: f64 = 1.0;

/// Motor state of one side (armature current and what the battery sees).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SideMotor {
    /// Armature current at the last step (A).
    pub current: f64,
}

impl SideMotor {
    /// The joint motor for this step, shared over `wheels` wheels geared to the motor
    /// (pilots: 2 per side, each taking half the torque), at wheel speed `omega` (rad/s),
    /// battery voltage `vbat` (V) and bridge command `cmd`; updates the current.
    pub fn joint_drive(
        &mut self,
        m: &DriveModel,
        cmd: Bridge,
        vbat: f64,
        omega: f64,
        rest_speed: f64,
        wheels: usize,
    ) -> JointDrive {
        let (a, g) = cmd.drive();
        let share = 1.0 / wheels.max(1) as f64;
        // Quasi-static armature: i = (a V − g k N ω) / R.
        self.current = (a * vbat - g * m.k * m.n * omega) / m.res;
        let torque_k = m.eta * m.n * m.k;
        let drive_a = torque_k * a * vbat / m.res;
        let damp_b = torque_k * g * m.k * m.n / m.res + m.b_visc;
        if omega.abs() < rest_speed && drive_a.abs() <= m.t_static {
            // Standing, and the motor cannot break the gearbox loose: it holds.
            return JointDrive {
                target_vel: 0.0,
                damping: HOLD_DAMPING * share,
                max_torque: (m.t_static - drive_a.abs()).max(0.0) * share,
            };
        }
        let dir = if omega.abs() >= rest_speed {
            omega.signum()
        } else {
            drive_a.signum()
        };
        let a_net = drive_a - m.t_coulomb * dir;
        JointDrive {
            target_vel: a_net / damp_b,
            damping: damp_b * share,
            max_torque: f64::MAX,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_params::{RobotKind, RobotParams};

    fn model() -> DriveModel {
        let p = RobotParams::for_kind(RobotKind::NonPilot);
        DriveModel::new(RobotKind::NonPilot, &p.plant, &p.mass, &p.geometry)
    }

    #[test]
    fn the_torque_line_matches_the_motor_at_stall_and_no_load() {
        let m = model();
        let full = Bridge { in1: 1000, in2: 0 };
        let mut s = SideMotor::default();
        let d = s.joint_drive(&m, full, 3.7, 10.0, 0.5, 1);
        // Torque at 10 rad/s from the line against the motor equations directly.
        let i = (3.7 - m.k * m.n * 10.0) / m.res;
        let tau = m.eta * m.n * m.k * i - m.b_visc * 10.0 - m.t_coulomb;
        assert!((d.damping * (d.target_vel - 10.0) - tau).abs() < 1e-9);
        assert!((s.current - i).abs() < 1e-12);
        // No-load speed lands near the 2-D plant's top speed (455–560 RPM).
        let rpm = d.target_vel * 60.0 / core::f64::consts::TAU;
        assert!((455.0..600.0).contains(&rpm), "{rpm}");
    }

    #[test]
    fn a_small_duty_leaves_the_gearbox_standing() {
        let m = model();
        let mut s = SideMotor::default();
        let d = s.joint_drive(&m, Bridge { in1: 60, in2: 0 }, 3.7, 0.0, 0.5, 1);
        assert_eq!(d.target_vel, 0.0);
        assert!(d.max_torque > 0.0 && d.max_torque < m.t_static);
        let d = s.joint_drive(&m, Bridge { in1: 300, in2: 0 }, 3.7, 0.0, 0.5, 1);
        assert!(d.target_vel > 0.0);
    }
}
