//! Every message of DESIGN.md §4, as plain serde types encoded with postcard.
//!
//! Speeds are wheel (output-shaft) RPM as `f32`; duties are signed per-mille of full PWM.
//! [`validate`](HostMsg::validate) rejects non-finite and absurd numbers before any
//! message reaches control code.

use serde::{Deserialize, Serialize};

use crate::crypto::Nonce;

/// Robot id within a fleet.
pub type RobotId = u16;

/// Largest wheel speed magnitude a command may carry (RPM); firmware clamps to its own range.
pub const MAX_COMMAND_RPM: f32 = 1000.0;
/// Full-scale duty in per-mille.
pub const DUTY_FULL_SCALE: i16 = 1000;

/// Pilot robots have four wheels and turn poorly; non-pilots two wheels and casters (THESIS 3.4, 5.2.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RobotKind {
    /// Four-wheeled robot that can climb onto a platform but turns poorly.
    Pilot,
    /// Two wheels and ball casters; turns almost in place.
    NonPilot,
}

/// Firmware semantic version.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct FirmwareVersion {
    /// Major.
    pub major: u8,
    /// Minor.
    pub minor: u8,
    /// Patch.
    pub patch: u8,
}

/// Proportional-integral gains of one scheduling point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PiGains {
    /// Proportional gain (duty per-mille per RPM of error).
    pub kp: f32,
    /// Integral gain (duty per-mille per RPM·s of error).
    pub ki: f32,
}

/// Runtime parameters the host may set on a robot.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ParamSet {
    /// Gains at the three scheduling points (target-speed changes of 123, 265, 495 RPM; THESIS 5.2.3).
    pub pi: [PiGains; 3],
    /// No valid command for this long stops the motors (ms).
    pub failsafe_timeout_ms: u16,
    /// Telemetry rate (Hz); 0 disables telemetry.
    pub telemetry_hz: u8,
}

/// Messages a robot sends to the host.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum RobotMsg {
    /// Hello stream: "I am here, open a session with this nonce".
    Announce(Announce),
    /// Periodic state report.
    Telemetry(Telemetry),
    /// Answer to [`HostMsg::Ping`].
    Pong {
        /// Echo of the ping's sequence number.
        seq: u32,
        /// Echo of the host's send time (µs, host clock).
        host_time_us: u64,
    },
    /// Answer to [`HostMsg::SetParams`].
    ParamsReply {
        /// `None` when applied; the reason otherwise.
        rejected: Option<ParamRejection>,
    },
    /// Progress of an over-the-air update (answer to `UpdateBegin` / `UpdateChunk`).
    UpdateStatus(crate::update::UpdateStatus),
}

/// Robot announce (hello stream).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Announce {
    /// Pilot or non-pilot.
    pub kind: RobotKind,
    /// Firmware version.
    pub firmware: FirmwareVersion,
    /// Highest protocol version the robot speaks.
    pub protocol_version: u8,
    /// Fresh per boot and per announce cycle; the session key depends on it.
    pub robot_nonce: Nonce,
    /// Why the robot's processor last reset (the same in every announce of one boot).
    pub reset_reason: ResetReason,
}

/// Why a robot's processor last reset, as its firmware found out at boot.
///
/// Panics, CPU exceptions, stack overflows and out-of-memory all end in the panic handler
/// (the log on the USB port says which); a stalled control loop ends in the main watchdog.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ResetReason {
    /// The firmware could not tell (a simulator or test robot that was never told).
    Unknown,
    /// Power was applied (battery switched on, USB plugged in).
    PowerOn,
    /// A deliberate software restart that was not a fault (e.g. after flashing).
    Software,
    /// Panic, CPU exception, stack overflow or out-of-memory: outputs made safe, then reset.
    Panic,
    /// The control loop stopped feeding the main watchdog (hang, starved task).
    Hang,
    /// The RTC watchdog fired: start-up never reached the control loop, or the main
    /// watchdog failed to catch a hang.
    BootHang,
    /// The supply dropped below the brown-out threshold.
    BrownOut,
    /// Any other hardware reset (reset pin, debugger, USB/JTAG, clock glitch).
    Other,
}

impl ResetReason {
    /// Every reason, in wire order.
    pub const ALL: [ResetReason; 8] = [
        ResetReason::Unknown,
        ResetReason::PowerOn,
        ResetReason::Software,
        ResetReason::Panic,
        ResetReason::Hang,
        ResetReason::BootHang,
        ResetReason::BrownOut,
        ResetReason::Other,
    ];

    /// True when the reset followed a fault the host should hear about.
    pub fn is_fault(self) -> bool {
        matches!(
            self,
            ResetReason::Panic | ResetReason::Hang | ResetReason::BootHang | ResetReason::BrownOut
        )
    }

    /// Short lower-case name for logs (`panic`, `hang`, ...).
    pub fn name(self) -> &'static str {
        match self {
            ResetReason::Unknown => "unknown",
            ResetReason::PowerOn => "power_on",
            ResetReason::Software => "software",
            ResetReason::Panic => "panic",
            ResetReason::Hang => "hang",
            ResetReason::BootHang => "boot_hang",
            ResetReason::BrownOut => "brown_out",
            ResetReason::Other => "other",
        }
    }
}

/// Messages the host sends to a robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum HostMsg {
    /// Hello stream: accept the announce with `robot_nonce`, open a session.
    Welcome {
        /// Echo of the announce nonce being answered.
        robot_nonce: Nonce,
        /// Fresh host nonce for this session.
        host_nonce: Nonce,
    },
    /// Target wheel speeds (RPM, output shaft).
    WheelSpeed {
        /// Left wheel RPM.
        left_rpm: f32,
        /// Right wheel RPM.
        right_rpm: f32,
    },
    /// Open-loop duties for calibration (per-mille, −1000…1000).
    RawDuty {
        /// Left duty.
        left: i16,
        /// Right duty.
        right: i16,
    },
    /// Stop both motors (not latched; a later command drives again).
    Stop,
    /// Stop and latch until [`HostMsg::ClearEmergencyStop`].
    EmergencyStop,
    /// Release a latched emergency stop (the robot stays stopped until the next command).
    ClearEmergencyStop,
    /// Set runtime parameters.
    SetParams(ParamSet),
    /// Round-trip probe.
    Ping {
        /// Sequence number echoed in the pong.
        seq: u32,
        /// Host send time (µs, host clock) echoed in the pong.
        host_time_us: u64,
    },
    /// Start or resume an over-the-air update ([`crate::update`]).
    UpdateBegin {
        /// Names the package (first four bytes of its SHA-256, little-endian).
        transfer: u32,
        /// Package length (bytes).
        total_len: u32,
    },
    /// Package bytes `offset .. offset + UPDATE_CHUNK` (the last chunk zero-padded).
    UpdateChunk {
        /// Byte offset in the package.
        offset: u32,
        /// The bytes.
        data: [u8; crate::update::UPDATE_CHUNK],
    },
    /// [`HostMsg::WheelSpeed`] that the robot keeps driving for `hold_ms` after it arrives
    /// even if no further command does (capped by the firmware's `max_hold_ms`): the stretch
    /// of a crossing where the assembly stays up only while it moves, and stopping (the
    /// failsafe) would tip it into the gap. The next drive command, stop or emergency stop
    /// ends the hold.
    WheelSpeedHold {
        /// Left wheel RPM.
        left_rpm: f32,
        /// Right wheel RPM.
        right_rpm: f32,
        /// How long to keep driving without a further command (ms).
        hold_ms: u16,
    },
}

/// Fault and state flags in telemetry (bit set).
pub mod flags {
    /// Failsafe has stopped the motors (no valid command within the timeout).
    pub const FAILSAFE: u16 = 1 << 0;
    /// Emergency stop latched.
    pub const ESTOP: u16 = 1 << 1;
    /// The robot has no key and will never drive.
    pub const UNPROVISIONED: u16 = 1 << 2;
    /// Encoder saw illegal transitions since the last report.
    pub const ENCODER_ERROR: u16 = 1 << 3;
    /// Battery below the low-voltage threshold.
    pub const LOW_BATTERY: u16 = 1 << 4;
    /// Open-loop (raw-duty) mode active.
    pub const RAW_DUTY: u16 = 1 << 5;
    /// A PI output is saturated.
    pub const SATURATED: u16 = 1 << 6;
}

/// Periodic robot state (DESIGN.md §4).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    /// Robot uptime (ms).
    pub uptime_ms: u32,
    /// Measured wheel speeds, left and right (RPM).
    pub measured_rpm: [f32; 2],
    /// Target wheel speeds in force (RPM).
    pub target_rpm: [f32; 2],
    /// Applied duties (per-mille).
    pub duty: [i16; 2],
    /// Cumulative encoder counts.
    pub encoder_counts: [i32; 2],
    /// Battery voltage (mV).
    pub battery_mv: u16,
    /// Wi-Fi RSSI (dBm).
    pub rssi_dbm: i8,
    /// [`flags`] bit set.
    pub flags: u16,
    /// Counter of the last host command applied (for round-trip time and loss).
    pub last_command_counter: u64,
}

/// Why a [`ParamSet`] was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ParamRejection {
    /// A gain is negative, not finite or above the sane bound.
    GainOutOfRange,
    /// Failsafe timeout outside 20…2000 ms.
    FailsafeTimeoutOutOfRange,
    /// Telemetry rate above 100 Hz.
    TelemetryRateOutOfRange,
}

/// Largest accepted PI gain (either term).
pub const MAX_GAIN: f32 = 1000.0;

impl ParamSet {
    /// Check the set against sane ranges; firmware applies only a set that passes.
    pub fn check(&self) -> Result<(), ParamRejection> {
        for g in &self.pi {
            if !(g.kp.is_finite() && g.ki.is_finite())
                || g.kp < 0.0
                || g.ki < 0.0
                || g.kp > MAX_GAIN
                || g.ki > MAX_GAIN
            {
                return Err(ParamRejection::GainOutOfRange);
            }
        }
        if !(20..=2000).contains(&self.failsafe_timeout_ms) {
            return Err(ParamRejection::FailsafeTimeoutOutOfRange);
        }
        if self.telemetry_hz > 100 {
            return Err(ParamRejection::TelemetryRateOutOfRange);
        }
        Ok(())
    }
}

impl HostMsg {
    /// Structural validity of the numbers (finite, in range); a failing message is
    /// rejected as [`crate::Rejection::MalformedPayload`] before it reaches control code.
    pub fn validate(&self) -> bool {
        match self {
            HostMsg::WheelSpeed {
                left_rpm,
                right_rpm,
            }
            | HostMsg::WheelSpeedHold {
                left_rpm,
                right_rpm,
                ..
            } => [left_rpm, right_rpm]
                .iter()
                .all(|v| v.is_finite() && v.abs() <= MAX_COMMAND_RPM),
            // A range test, not `abs()`: `i16::MIN.abs()` overflows (a panic in debug
            // builds, and in release it wraps to a negative number that passed the bound).
            HostMsg::RawDuty { left, right } => [left, right]
                .iter()
                .all(|d| (-DUTY_FULL_SCALE..=DUTY_FULL_SCALE).contains(*d)),
            // Parameter sets are range-checked by the robot with a reason reply.
            _ => true,
        }
    }

    /// True for frames of the hello stream.
    pub fn is_hello(&self) -> bool {
        matches!(self, HostMsg::Welcome { .. })
    }
}

impl RobotMsg {
    /// Structural validity of the numbers (telemetry floats finite).
    pub fn validate(&self) -> bool {
        match self {
            RobotMsg::Telemetry(t) => t
                .measured_rpm
                .iter()
                .chain(t.target_rpm.iter())
                .all(|v| v.is_finite()),
            _ => true,
        }
    }

    /// True for frames of the hello stream.
    pub fn is_hello(&self) -> bool {
        matches!(self, RobotMsg::Announce(_))
    }
}

/// Messages that can travel in an envelope: their direction and validity.
pub trait Message: Serialize + for<'de> Deserialize<'de> {
    /// The direction this message type travels.
    const DIRECTION: crate::Direction;
    /// Numbers finite and in range.
    fn valid(&self) -> bool;
    /// Belongs to the hello stream.
    fn hello(&self) -> bool;
}

impl Message for HostMsg {
    const DIRECTION: crate::Direction = crate::Direction::HostToRobot;
    fn valid(&self) -> bool {
        self.validate()
    }
    fn hello(&self) -> bool {
        self.is_hello()
    }
}

impl Message for RobotMsg {
    const DIRECTION: crate::Direction = crate::Direction::RobotToHost;
    fn valid(&self) -> bool {
        self.validate()
    }
    fn hello(&self) -> bool {
        self.is_hello()
    }
}
