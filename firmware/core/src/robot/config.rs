//! The firmware parameter check: which [`Firmware`] sets can run.

use puzzlebot_params::firmware::Firmware;
use puzzlebot_protocol::ParamRejection;

/// Why a [`Firmware`] parameter set cannot run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ConfigError {
    /// `loop_hz` must be finite and within 1…1000.
    LoopRate,
    /// `encoder_edges_per_rev` must be positive.
    EncoderEdges,
    /// `max_rpm` must be finite and positive.
    MaxRpm,
    /// `schedule_rpm` must be finite and ascending.
    Schedule,
    /// `ff_duty_per_rpm`, `ff_deadband_duty`, `reference_tau_ms` must be finite, ≥ 0,
    /// dead-band < 1000.
    FeedForward,
    /// `duty_slew_per_s` must be finite and positive.
    Slew,
    /// The runtime part failed [`puzzlebot_protocol::ParamSet::check`].
    Params(ParamRejection),
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ConfigError::LoopRate => f.write_str("firmware.loop_hz must be within 1..=1000"),
            ConfigError::EncoderEdges => f.write_str("firmware.encoder_edges_per_rev must be > 0"),
            ConfigError::MaxRpm => f.write_str("firmware.max_rpm must be finite and > 0"),
            ConfigError::Schedule => {
                f.write_str("firmware.schedule_rpm must be finite and ascending")
            }
            ConfigError::FeedForward => f.write_str(
                "firmware.ff_duty_per_rpm / ff_deadband_duty / reference_tau_ms must be finite, >= 0, dead-band < 1000",
            ),
            ConfigError::Slew => f.write_str("firmware.duty_slew_per_s must be finite and > 0"),
            ConfigError::Params(r) => write!(f, "firmware pi/failsafe/telemetry: {r:?}"),
        }
    }
}

/// Check that a parameter set can run.
pub fn check_config(p: &Firmware) -> Result<(), ConfigError> {
    if !(p.loop_hz.is_finite() && (1.0..=1000.0).contains(&p.loop_hz)) {
        return Err(ConfigError::LoopRate);
    }
    if p.encoder_edges_per_rev == 0 {
        return Err(ConfigError::EncoderEdges);
    }
    if !(p.max_rpm.is_finite() && p.max_rpm > 0.0) {
        return Err(ConfigError::MaxRpm);
    }
    let s = p.schedule_rpm;
    if !(s.iter().all(|x| x.is_finite()) && s[0] < s[1] && s[1] < s[2]) {
        return Err(ConfigError::Schedule);
    }
    let ff_ok = p.ff_duty_per_rpm.is_finite()
        && p.reference_tau_ms.is_finite()
        && p.reference_tau_ms >= 0.0
        && p.ff_duty_per_rpm >= 0.0
        && p.ff_deadband_duty.is_finite()
        && (0.0..1000.0).contains(&p.ff_deadband_duty);
    if !ff_ok {
        return Err(ConfigError::FeedForward);
    }
    if !(p.duty_slew_per_s.is_finite() && p.duty_slew_per_s > 0.0) {
        return Err(ConfigError::Slew);
    }
    p.param_set().check().map_err(ConfigError::Params)
}
