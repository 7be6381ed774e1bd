//! DRV8833 dual H-bridge mapping: two PWM inputs per motor (THESIS 5.5.1).
//!
//! DRV8833 truth table per bridge (xIN1, xIN2 → outputs):
//!
//! | IN1 | IN2 | function |
//! |---|---|---|
//! | 0 | 0 | coast (outputs high-Z) |
//! | PWM | 0 | forward, fast decay (coast during off time) |
//! | 1 | PWM | forward, slow decay (brake during off time): IN2 duty = 1 − d |
//! | 0 | PWM | reverse, fast decay |
//! | PWM | 1 | reverse, slow decay: IN1 duty = 1 − d |
//! | 1 | 1 | brake (both low-side on) |
//!
//! Slow decay gives a nearly linear duty–speed curve and is the default. The board glue
//! maps [`HBridge::in1`]/[`HBridge::in2`] to two PWM channels; a motor mounted mirrored is
//! handled by swapping its two pins in the pin map, not here.

use puzzlebot_protocol::DUTY_FULL_SCALE;

/// PWM full scale of [`HBridge`] inputs: `in1`/`in2` are per-mille of the PWM period
/// (0 = always low, 1000 = always high).
pub const PWM_FULL_SCALE: u16 = DUTY_FULL_SCALE as u16;

/// What one motor should do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotorCommand {
    /// Outputs floating: the wheel spins freely; nothing is driven.
    Coast,
    /// Both low-side switches on: the motor is shorted and stops quickly.
    Brake,
    /// Signed duty, per-mille (−1000…1000); positive drives the wheel forward.
    Duty(i16),
}

/// Current-decay mode during the PWM off time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Decay {
    /// Brake during the off time (linear speed–duty curve). Default.
    #[default]
    Slow,
    /// Coast during the off time.
    Fast,
}

/// Duty of the two inputs of one bridge, each 0…[`PWM_FULL_SCALE`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HBridge {
    /// xIN1 duty (per-mille high time).
    pub in1: u16,
    /// xIN2 duty (per-mille high time).
    pub in2: u16,
}

impl HBridge {
    /// Both inputs low.
    pub const COAST: HBridge = HBridge { in1: 0, in2: 0 };
    /// Both inputs high.
    pub const BRAKE: HBridge = HBridge {
        in1: PWM_FULL_SCALE,
        in2: PWM_FULL_SCALE,
    };

    /// The input duties for `cmd` in `decay` mode.
    pub fn drive(cmd: MotorCommand, decay: Decay) -> HBridge {
        let full = PWM_FULL_SCALE;
        match cmd {
            MotorCommand::Coast => HBridge::COAST,
            MotorCommand::Brake => HBridge::BRAKE,
            MotorCommand::Duty(d) => {
                let mag = d.unsigned_abs().min(full);
                match (decay, d >= 0) {
                    (Decay::Slow, true) => HBridge {
                        in1: full,
                        in2: full - mag,
                    },
                    (Decay::Slow, false) => HBridge {
                        in1: full - mag,
                        in2: full,
                    },
                    (Decay::Fast, true) => HBridge { in1: mag, in2: 0 },
                    (Decay::Fast, false) => HBridge { in1: 0, in2: mag },
                }
            }
        }
    }

    /// The effective signed duty these inputs apply (inverse of [`HBridge::drive`]):
    /// `None` for coast.
    pub fn effective_duty(&self) -> Option<i16> {
        let (a, b) = (self.in1.min(PWM_FULL_SCALE), self.in2.min(PWM_FULL_SCALE));
        if a == 0 && b == 0 {
            return None;
        }
        // Voltage across the motor averages (in1 − in2) of the supply in either mode.
        Some(a as i16 - b as i16)
    }
}

/// The four PWM inputs of the DRV8833, as returned by [`crate::Robot::tick`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MotorOutputs {
    /// Left motor (bridge A).
    pub left: HBridge,
    /// Right motor (bridge B).
    pub right: HBridge,
}

impl MotorOutputs {
    /// Both motors coasting.
    pub const COAST: MotorOutputs = MotorOutputs {
        left: HBridge::COAST,
        right: HBridge::COAST,
    };
    /// Both motors braking.
    pub const BRAKE: MotorOutputs = MotorOutputs {
        left: HBridge::BRAKE,
        right: HBridge::BRAKE,
    };

    /// True when neither motor is driven (coast or brake on both).
    pub fn is_stopped(&self) -> bool {
        [self.left, self.right]
            .iter()
            .all(|h| h.effective_duty().unwrap_or(0) == 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_table() {
        assert_eq!(
            HBridge::drive(MotorCommand::Coast, Decay::Slow),
            HBridge::COAST
        );
        assert_eq!(
            HBridge::drive(MotorCommand::Brake, Decay::Fast),
            HBridge::BRAKE
        );
        let f = HBridge::drive(MotorCommand::Duty(300), Decay::Fast);
        assert_eq!((f.in1, f.in2), (300, 0));
        let r = HBridge::drive(MotorCommand::Duty(-300), Decay::Fast);
        assert_eq!((r.in1, r.in2), (0, 300));
        let f = HBridge::drive(MotorCommand::Duty(300), Decay::Slow);
        assert_eq!((f.in1, f.in2), (1000, 700));
        let r = HBridge::drive(MotorCommand::Duty(-300), Decay::Slow);
        assert_eq!((r.in1, r.in2), (700, 1000));
        // Zero duty in slow decay is a brake; in fast decay a coast.
        assert_eq!(
            HBridge::drive(MotorCommand::Duty(0), Decay::Slow),
            HBridge::BRAKE
        );
        assert_eq!(
            HBridge::drive(MotorCommand::Duty(0), Decay::Fast),
            HBridge::COAST
        );
        // Out-of-range duties saturate.
        let s = HBridge::drive(MotorCommand::Duty(i16::MIN), Decay::Slow);
        assert_eq!((s.in1, s.in2), (0, 1000));
    }

    #[test]
    fn effective_duty_round_trips() {
        for d in (-1000..=1000).step_by(50) {
            for decay in [Decay::Slow, Decay::Fast] {
                let h = HBridge::drive(MotorCommand::Duty(d), decay);
                assert_eq!(h.effective_duty().unwrap_or(0), d, "{d} {decay:?}");
            }
        }
        assert!(MotorOutputs::BRAKE.is_stopped() && MotorOutputs::COAST.is_stopped());
    }
}
