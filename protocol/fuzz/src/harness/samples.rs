//! One genuine sample of every message variant, with boundary values.

use puzzlebot_protocol::{
    Announce, FirmwareVersion, HostMsg, ParamRejection, ParamSet, PiGains, ResetReason, RobotKind,
    RobotMsg, Telemetry,
};

/// One sample of every host message variant, with boundary values.
pub fn host_samples() -> Vec<HostMsg> {
    vec![
        HostMsg::Welcome {
            robot_nonce: [1; 16],
            host_nonce: [2; 16],
        },
        HostMsg::WheelSpeed {
            left_rpm: 123.5,
            right_rpm: -450.0,
        },
        HostMsg::WheelSpeedHold {
            left_rpm: -1000.0,
            right_rpm: 1000.0,
            hold_ms: u16::MAX,
        },
        HostMsg::RawDuty {
            left: -1000,
            right: 1000,
        },
        HostMsg::Stop,
        HostMsg::EmergencyStop,
        HostMsg::ClearEmergencyStop,
        HostMsg::SetParams(ParamSet {
            pi: [
                PiGains { kp: 0.5, ki: 2.0 },
                PiGains { kp: 0.7, ki: 3.0 },
                PiGains { kp: 1.1, ki: 4.5 },
            ],
            failsafe_timeout_ms: 200,
            telemetry_hz: 20,
        }),
        HostMsg::Ping {
            seq: u32::MAX,
            host_time_us: u64::MAX,
        },
        HostMsg::UpdateBegin {
            transfer: 0xdead_beef,
            total_len: 1_966_080,
        },
        HostMsg::UpdateChunk {
            offset: u32::MAX,
            data: [0xa5; puzzlebot_protocol::UPDATE_CHUNK],
        },
    ]
}

/// One sample of every robot message variant, with boundary values.
pub fn robot_samples() -> Vec<RobotMsg> {
    vec![
        RobotMsg::Announce(Announce {
            kind: RobotKind::Pilot,
            firmware: FirmwareVersion {
                major: 1,
                minor: 2,
                patch: 3,
            },
            protocol_version: puzzlebot_protocol::PROTOCOL_VERSION,
            robot_nonce: [9; 16],
            reset_reason: ResetReason::Panic,
        }),
        RobotMsg::Telemetry(Telemetry {
            uptime_ms: u32::MAX,
            measured_rpm: [450.0, -450.0],
            target_rpm: [f32::MAX, f32::MIN],
            duty: [i16::MIN, i16::MAX],
            encoder_counts: [i32::MIN, i32::MAX],
            battery_mv: 3700,
            rssi_dbm: -128,
            flags: u16::MAX,
            last_command_counter: u64::MAX,
        }),
        RobotMsg::Pong {
            seq: 77,
            host_time_us: 1_000_000,
        },
        RobotMsg::ParamsReply { rejected: None },
        RobotMsg::ParamsReply {
            rejected: Some(ParamRejection::TelemetryRateOutOfRange),
        },
        RobotMsg::UpdateStatus(puzzlebot_protocol::UpdateStatus {
            transfer: 7,
            received: 4096,
            state: puzzlebot_protocol::UpdateState::Refused(
                puzzlebot_protocol::UpdateRefusal::NotNewer,
            ),
        }),
    ]
}

/// Session messages only (no hello-stream variants).
pub(super) fn session_samples_host() -> Vec<HostMsg> {
    host_samples()
        .into_iter()
        .filter(|m| !m.is_hello())
        .collect()
}

pub(super) fn session_samples_robot() -> Vec<RobotMsg> {
    robot_samples()
        .into_iter()
        .filter(|m| !m.is_hello())
        .collect()
}
