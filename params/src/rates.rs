//! Loop rates and link timing (THESIS 4.4.3, 5.2.3; DESIGN.md §3, §7).

use serde::{Deserialize, Serialize};

/// Rates of the control layers and link timing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Rates {
    /// Distributed MPC rate (Hz). THESIS 5.2.3: 10.
    pub mpc_hz: f32,
    /// Host velocity stabiliser and command stream rate (Hz). THESIS 4.4.3: 30.
    pub command_hz: f32,
    /// Motion-capture pose rate (Hz): 100.
    pub pose_hz: f32,
    /// A robot silent for this long is offline (ms). Issue 5: 300.
    pub offline_after_ms: u32,
    /// Poses older than this stop the robot (ms).
    pub pose_stale_after_ms: u32,
}

impl Default for Rates {
    fn default() -> Self {
        Rates {
            mpc_hz: 10.0,
            command_hz: 30.0,
            pose_hz: 100.0,
            offline_after_ms: 300,
            pose_stale_after_ms: 100,
        }
    }
}
