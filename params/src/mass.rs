//! Masses (THESIS 5.5.3).

use crate::RobotKind;
use serde::{Deserialize, Serialize};

/// Mass of one robot.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Mass {
    /// Total mass (kg). THESIS 5.5.3: pilot 104.2 g, non-pilot 109.7 g.
    pub mass: f32,
    /// Centre of mass in the body frame, x and y (m).
    pub com: [f32; 2],
}

impl Mass {
    /// THESIS value for `kind`.
    pub fn for_kind(kind: RobotKind) -> Self {
        Mass {
            mass: match kind {
                RobotKind::Pilot => 0.1042,
                RobotKind::NonPilot => 0.1097,
            },
            com: [0.0, 0.0],
        }
    }
}

impl Default for Mass {
    fn default() -> Self {
        Mass::for_kind(RobotKind::NonPilot)
    }
}
