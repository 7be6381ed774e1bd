//! Host drive mapping and calibration numbers (THESIS 3.5.1, 3.10).

use crate::RobotKind;
use serde::{Deserialize, Serialize};

/// Calibration of (v, ω) to wheel commands and the feasible v–ω set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Drive {
    /// k_v: linear speed per unit of mean wheel command (THESIS 3.5.1).
    pub k_v: f32,
    /// k_ω: angular speed per unit of differential wheel command (THESIS 3.5.1).
    pub k_omega: f32,
    /// Butterfly point A = (v, ω): the corner of the feasible set (THESIS 3.5.1).
    pub butterfly_a: [f32; 2],
    /// Butterfly point B = (v, 0): the top speed straight ahead (THESIS 3.5.1).
    pub butterfly_b: [f32; 2],
    /// Largest wheel speed command magnitude (RPM). THESIS 5.2.3: 450.
    pub max_rpm: f32,
    /// Smallest non-zero wheel speed that moves the robot (RPM): start-up dead-band M_min.
    pub min_rpm: f32,
}

impl Drive {
    /// THESIS 3.5.1 (v2 robots) for `kind`; `max_rpm`/`min_rpm` for the chapter-5 robot.
    pub fn for_kind(kind: RobotKind) -> Self {
        match kind {
            RobotKind::NonPilot => Drive {
                k_v: 0.0006,
                k_omega: 0.0142,
                butterfly_a: [0.037, -2.19],
                butterfly_b: [0.11, 0.0],
                max_rpm: 450.0,
                min_rpm: 20.0,
            },
            RobotKind::Pilot => Drive {
                k_v: 0.0024,
                k_omega: 0.0033,
                butterfly_a: [0.34, -0.561],
                butterfly_b: [0.47, 0.0],
                max_rpm: 450.0,
                min_rpm: 20.0,
            },
        }
    }

    /// Smallest turning radius the butterfly set allows (m): |ω| ≤ (A_ω / A_v)|v| on its
    /// edge O–A (THESIS 3.5.1), so v / ω ≥ A_v / |A_ω| at any speed. Pilot 0.61 m,
    /// non-pilot 17 mm.
    pub fn min_turn_radius(&self) -> f64 {
        f64::from(self.butterfly_a[0]) / f64::from(self.butterfly_a[1].abs()).max(1e-9)
    }
}

impl Default for Drive {
    fn default() -> Self {
        Drive::for_kind(RobotKind::NonPilot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pilot_turns_no_tighter_than_0_6_m() {
        let pilot = Drive::for_kind(RobotKind::Pilot).min_turn_radius();
        let non_pilot = Drive::for_kind(RobotKind::NonPilot).min_turn_radius();
        assert!((pilot - 0.34 / 0.561).abs() < 1e-6, "{pilot}");
        assert!((non_pilot - 0.037 / 2.19).abs() < 1e-6, "{non_pilot}");
    }
}
