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
    /// Feed-forward slope: duty (per-mille) per wheel RPM above the dead-band.
    pub ff_duty_per_rpm: f32,
    /// Feed-forward start-up offset: the duty (per-mille) at which a wheel starts to turn,
    /// i.e. the dead-band M_min of THESIS 3.4 expressed as duty.
    pub ff_deadband_duty: f32,
    /// Time constant of the reference model the PI tracks (ms): the feed-forward moves the
    /// wheel along this first-order response, the PI corrects only deviations from it
    /// (two-degree-of-freedom control; avoids integral overshoot on large steps).
    pub reference_tau_ms: f32,
    /// Largest duty change per second (per-mille/s): the output slew limit.
    pub duty_slew_per_s: f32,
    /// No encoder edge for this long means the wheel stands still (ms).
    pub standstill_after_ms: u16,
    /// Announce repetition interval until welcomed (ms).
    pub announce_interval_ms: u16,
    /// No valid frame from the host for this long drops the session and announces again
    /// with a fresh nonce (ms), so a restarted host can reconnect.
    pub relink_after_ms: u16,
    /// Longest a [`puzzlebot_protocol::HostMsg::WheelSpeedHold`] keeps the wheels driving
    /// without a further command (ms): the bound on how far a robot drives blind, 1 s (45 mm
    /// at the crossing speed; the bridged stretches measured are under 10 mm).
    pub max_hold_ms: u16,
}

impl Default for Firmware {
    fn default() -> Self {
        Firmware {
            loop_hz: 50.0,
            schedule_rpm: [123.0, 265.0, 495.0],
            // Tuned with `cargo run --release -p puzzlebot-firmware-core --example tune`
            // against the first-order motor model of `puzzlebot_firmware_core::model`
            // (no-load 520 RPM at full duty and 3.7 V, time constant 30 ms, dead-band 80
            // per-mille), worst case over motor gains ±10 % and steps of 60–123 / 200–265 /
            // 400–450 RPM: ±2 % settling 0.23 / 0.21 / 0.20 s, overshoot ≤ 3.5 %.
            pi: [
                PiGains { kp: 0.85, ki: 60.0 },
                PiGains { kp: 1.10, ki: 86.0 },
                PiGains { kp: 0.95, ki: 98.0 },
            ],
            max_rpm: 450.0,
            failsafe_timeout_ms: 200,
            telemetry_hz: 50,
            encoder_edges_per_rev: 48,
            low_battery_mv: 3400,
            // 1000 − 80 per-mille span 520 RPM (model above): 920 / 520 ≈ 1.77.
            ff_duty_per_rpm: 1.77,
            ff_deadband_duty: 80.0,
            reference_tau_ms: 50.0,
            duty_slew_per_s: 20_000.0,
            standstill_after_ms: 150,
            announce_interval_ms: 250,
            relink_after_ms: 1000,
            max_hold_ms: 1000,
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
