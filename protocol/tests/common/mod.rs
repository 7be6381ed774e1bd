//! Shared fixtures for the protocol's integration tests: keys, a handshake helper and
//! proptest strategies for every message.

#![allow(dead_code)]

use proptest::prelude::*;
use puzzlebot_protocol::session::HostReceived;
use puzzlebot_protocol::*;

/// Robot id of the fixtures.
pub const ID: RobotId = 7;

/// Fixture fleet key.
pub fn fleet() -> FleetKey {
    FleetKey([0x42; 32])
}

/// Fixture robot key.
pub fn robot_key() -> RobotKey {
    fleet().robot_key(ID)
}

/// A distinct nonce per `n`.
pub fn nonce(n: u8) -> Nonce {
    let mut a = [n; 16];
    a[0] = 0xA5;
    a
}

/// Firmware version of the fixtures.
pub const FW: FirmwareVersion = FirmwareVersion {
    major: 1,
    minor: 0,
    patch: 3,
};

/// Run a complete handshake: announce → welcome → first robot frame (proves the session).
/// Returns the announce and welcome frames as captured on the wire.
pub fn handshake(
    host: &mut HostSession,
    robot: &mut RobotSession,
    host_nonce: Nonce,
) -> (Vec<u8>, Vec<u8>) {
    let mut a = [0u8; MAX_DATAGRAM];
    let mut w = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::NonPilot, FW, &mut a)
        .expect("announce");
    let welcome_len = match host.receive(&a[..n], || host_nonce, &mut w) {
        Ok(HostReceived::Announce { welcome_len, .. }) => welcome_len,
        other => panic!("announce not accepted: {other:?}"),
    };
    let (_, msg) = robot.receive(&w[..welcome_len]).expect("welcome accepted");
    assert!(matches!(msg, HostMsg::Welcome { .. }));
    assert!(robot.is_established());
    prove(host, robot);
    (a[..n].to_vec(), w[..welcome_len].to_vec())
}

/// The robot's first session frame reaches the host.
pub fn prove(host: &mut HostSession, robot: &mut RobotSession) {
    let f = robot_frame(robot, &RobotMsg::ParamsReply { rejected: None });
    match host.receive(
        &f,
        || panic!("no new session expected"),
        &mut [0u8; MAX_DATAGRAM],
    ) {
        Ok(HostReceived::Message(_, RobotMsg::ParamsReply { rejected: None })) => {}
        other => panic!("proof frame not accepted: {other:?}"),
    }
    assert!(host.is_established());
}

/// Established pair with fresh nonces.
pub fn pair() -> (HostSession, RobotSession) {
    let mut host = HostSession::new(ID, robot_key());
    let mut robot = RobotSession::new(ID, robot_key(), nonce(1));
    handshake(&mut host, &mut robot, nonce(101));
    (host, robot)
}

/// Seal `msg` with the host session.
pub fn host_frame(host: &mut HostSession, msg: &HostMsg) -> Vec<u8> {
    let mut out = [0u8; MAX_DATAGRAM];
    let n = host.send(msg, &mut out).expect("host seals");
    out[..n].to_vec()
}

/// Seal `msg` with the robot session.
pub fn robot_frame(robot: &mut RobotSession, msg: &RobotMsg) -> Vec<u8> {
    let mut out = [0u8; MAX_DATAGRAM];
    let n = robot.send(msg, &mut out).expect("robot seals");
    out[..n].to_vec()
}

/// Deliver a robot frame to the host (a new session is never expected).
pub fn to_host(host: &mut HostSession, frame: &[u8]) -> Result<HostReceived, Rejection> {
    host.receive(frame, || nonce(200), &mut [0u8; MAX_DATAGRAM])
}

/// The host's commands still reach the robot (the proven session is intact).
pub fn assert_linked(host: &mut HostSession, robot: &mut RobotSession) {
    let f = host_frame(host, &HostMsg::Stop);
    assert_eq!(robot.receive(&f).map(|(_, m)| m), Ok(HostMsg::Stop));
}

// ---- proptest strategies ----

/// Any finite f32.
pub fn finite_f32() -> impl Strategy<Value = f32> {
    any::<f32>().prop_filter("finite", |v| v.is_finite())
}

/// Wheel speeds a command may carry.
pub fn command_rpm() -> impl Strategy<Value = f32> {
    -1000.0f32..=1000.0f32
}

/// Per-mille duties.
pub fn duty() -> impl Strategy<Value = i16> {
    -1000i16..=1000i16
}

/// Any nonce.
pub fn any_nonce() -> impl Strategy<Value = Nonce> {
    any::<[u8; 16]>()
}

/// Any parameter set (gains may be out of range: the robot answers with a reason).
pub fn param_set() -> impl Strategy<Value = ParamSet> {
    (
        prop::array::uniform3((finite_f32(), finite_f32())),
        any::<u16>(),
        any::<u8>(),
    )
        .prop_map(|(g, failsafe_timeout_ms, telemetry_hz)| ParamSet {
            pi: g.map(|(kp, ki)| PiGains { kp, ki }),
            failsafe_timeout_ms,
            telemetry_hz,
        })
}

/// Every host message variant.
pub fn host_msg() -> impl Strategy<Value = HostMsg> {
    prop_oneof![
        (any_nonce(), any_nonce()).prop_map(|(robot_nonce, host_nonce)| HostMsg::Welcome {
            robot_nonce,
            host_nonce
        }),
        (command_rpm(), command_rpm()).prop_map(|(left_rpm, right_rpm)| HostMsg::WheelSpeed {
            left_rpm,
            right_rpm
        }),
        (duty(), duty()).prop_map(|(left, right)| HostMsg::RawDuty { left, right }),
        Just(HostMsg::Stop),
        Just(HostMsg::EmergencyStop),
        Just(HostMsg::ClearEmergencyStop),
        param_set().prop_map(HostMsg::SetParams),
        (any::<u32>(), any::<u64>())
            .prop_map(|(seq, host_time_us)| HostMsg::Ping { seq, host_time_us }),
        (any::<u32>(), any::<u32>()).prop_map(|(transfer, total_len)| HostMsg::UpdateBegin {
            transfer,
            total_len
        }),
        (any::<u32>(), any::<[u8; UPDATE_CHUNK]>())
            .prop_map(|(offset, data)| HostMsg::UpdateChunk { offset, data }),
    ]
}

/// Host messages of the session stream (everything but the welcome).
pub fn host_session_msg() -> impl Strategy<Value = HostMsg> {
    host_msg().prop_filter("session stream", |m| !m.is_hello())
}

/// Any robot kind.
pub fn robot_kind() -> impl Strategy<Value = RobotKind> {
    prop_oneof![Just(RobotKind::Pilot), Just(RobotKind::NonPilot)]
}

/// Any firmware version.
pub fn firmware() -> impl Strategy<Value = FirmwareVersion> {
    any::<(u8, u8, u8)>().prop_map(|(major, minor, patch)| FirmwareVersion {
        major,
        minor,
        patch,
    })
}

/// Any announce.
pub fn announce() -> impl Strategy<Value = Announce> {
    (
        robot_kind(),
        firmware(),
        any::<u8>(),
        any_nonce(),
        prop::sample::select(ResetReason::ALL.to_vec()),
    )
        .prop_map(
            |(kind, firmware, protocol_version, robot_nonce, reset_reason)| Announce {
                kind,
                firmware,
                protocol_version,
                robot_nonce,
                reset_reason,
            },
        )
}

/// Any telemetry with finite numbers.
pub fn telemetry() -> impl Strategy<Value = Telemetry> {
    (
        any::<u32>(),
        prop::array::uniform2(finite_f32()),
        prop::array::uniform2(finite_f32()),
        any::<[i16; 2]>(),
        any::<[i32; 2]>(),
        any::<u16>(),
        any::<i8>(),
        any::<u16>(),
        any::<u64>(),
    )
        .prop_map(
            |(
                uptime_ms,
                measured_rpm,
                target_rpm,
                duty,
                encoder_counts,
                battery_mv,
                rssi_dbm,
                flags,
                last_command_counter,
            )| Telemetry {
                uptime_ms,
                measured_rpm,
                target_rpm,
                duty,
                encoder_counts,
                battery_mv,
                rssi_dbm,
                flags,
                last_command_counter,
            },
        )
}

/// Any parameter rejection reason (or none).
pub fn param_reply() -> impl Strategy<Value = Option<ParamRejection>> {
    prop_oneof![
        Just(None),
        Just(Some(ParamRejection::GainOutOfRange)),
        Just(Some(ParamRejection::FailsafeTimeoutOutOfRange)),
        Just(Some(ParamRejection::TelemetryRateOutOfRange)),
    ]
}

/// Every robot message variant.
pub fn robot_msg() -> impl Strategy<Value = RobotMsg> {
    prop_oneof![
        announce().prop_map(RobotMsg::Announce),
        telemetry().prop_map(RobotMsg::Telemetry),
        (any::<u32>(), any::<u64>())
            .prop_map(|(seq, host_time_us)| RobotMsg::Pong { seq, host_time_us }),
        param_reply().prop_map(|rejected| RobotMsg::ParamsReply { rejected }),
        (any::<u32>(), any::<u32>(), update_state()).prop_map(|(transfer, received, state)| {
            RobotMsg::UpdateStatus(UpdateStatus {
                transfer,
                received,
                state,
            })
        }),
    ]
}

/// Every update state, with every refusal.
pub fn update_state() -> impl Strategy<Value = UpdateState> {
    use UpdateRefusal::*;
    prop_oneof![
        Just(UpdateState::Idle),
        Just(UpdateState::Receiving),
        Just(UpdateState::Installed),
        prop::sample::select(vec![
            NoUpdateKey,
            BadPackage,
            TooLarge,
            BadSignature,
            NotNewer,
            Corrupted,
            Flash
        ])
        .prop_map(UpdateState::Refused),
    ]
}

/// Robot messages of the session stream (everything but the announce).
pub fn robot_session_msg() -> impl Strategy<Value = RobotMsg> {
    robot_msg().prop_filter("session stream", |m| !m.is_hello())
}
