//! On-robot speed loop parameters (THESIS 5.2.3). Owned by `firmware/core`.

use puzzlebot_protocol::{ParamSet, PiGains};
use serde::{Deserialize, Serialize};

/// The firmware's control parameters and their defaults.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Firmware {
    /// Speed loop rate (Hz). THESIS 5.2.3: 50.
    pub loop_hz: f32,
    /// Target-speed changes (RPM) at which the three PI sets were tuned. THESIS 5.2.3.
    pub schedule_rpm: [f32; 3],
    /// PI gains at each scheduling point.
    pub pi: [PiGains; 3],
    /// Speed range (RPM). THESIS 5.2.3: −450…450.
    pub max_rpm: f32,
    /// Failsafe timeout (ms); DESIGN.md §5 default 200.
    pub failsafe_timeout_ms: u16,
    /// Telemetry rate (Hz); default 50.
    pub telemetry_hz: u8,
    /// Encoder edges per wheel revolution (all four quadrature edges counted).
    /// THESIS 5.2.3 gives "seven distinct velocity levels within 0–450 RPM" at 50 Hz:
    /// 450 RPM · 20 ms = 0.15 rev ⇒ ≈ 7 / 0.15 ≈ 47 edges per wheel revolution.
    pub encoder_edges_per_rev: u16,
    /// Battery voltage below which telemetry flags a low battery (mV).
    pub low_battery_mv: u16,
}

impl Default for Firmware {
    fn default() -> Self {
        Firmware {
            loop_hz: 50.0,
            schedule_rpm: [123.0, 265.0, 495.0],
            // Placeholder gains; firmware/core tunes and documents them against the plant.
            pi: [
                PiGains { kp: 1.0, ki: 10.0 },
                PiGains { kp: 1.0, ki: 10.0 },
                PiGains { kp: 1.0, ki: 10.0 },
            ],
            max_rpm: 450.0,
            failsafe_timeout_ms: 200,
            telemetry_hz: 50,
            encoder_edges_per_rev: 48,
            low_battery_mv: 3400,
        }
    }
}

impl Firmware {
    /// The runtime-settable part, as sent in a [`ParamSet`] message.
    pub fn param_set(&self) -> ParamSet {
        ParamSet {
            pi: self.pi,
            failsafe_timeout_ms: self.failsafe_timeout_ms,
            telemetry_hz: self.telemetry_hz,
        }
    }
}
