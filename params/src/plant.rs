//! Simulated motor, gearbox, encoder and battery (owned by `hil-sim`).

use crate::RobotKind;
use serde::{Deserialize, Serialize};

/// Physical plant of one robot for the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Plant {
    /// Battery nominal voltage (V). THESIS 5.5.1: 3.7 V LiPo.
    pub battery_voltage: f32,
    /// Battery capacity (mAh). THESIS 5.5.1: 1000.
    pub battery_capacity_mah: f32,
    /// Battery internal resistance (Ω): sag under load.
    pub battery_resistance: f32,
    /// Pilot robots have four wheels (poor turning); non-pilots two wheels + casters.
    pub four_wheels: bool,
}

impl Plant {
    /// Defaults for `kind`.
    pub fn for_kind(kind: RobotKind) -> Self {
        Plant {
            battery_voltage: 3.7,
            battery_capacity_mah: 1000.0,
            battery_resistance: 0.15,
            four_wheels: matches!(kind, RobotKind::Pilot),
        }
    }
}

impl Default for Plant {
    fn default() -> Self {
        Plant::for_kind(RobotKind::NonPilot)
    }
}
