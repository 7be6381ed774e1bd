//! The datagram size budget (DESIGN.md §4, §9): a wheel-speed command ≤ 48 bytes,
//! telemetry ≤ 96 bytes, any datagram ≤ 128 bytes. Sizes are measured by sealing every
//! variant with the field values that encode shortest and longest (postcard varints grow
//! with magnitude; floats and nonces are fixed), and a property test checks that random
//! values never fall outside those bounds.
//!
//! `cargo test -p puzzlebot-protocol --test sizes -- --nocapture` prints the table used in
//! `protocol/README.md`.

mod common;

use common::*;
use proptest::prelude::*;
use puzzlebot_protocol::*;

const WHEEL_SPEED_BUDGET: usize = 48;
const TELEMETRY_BUDGET: usize = 96;
/// DESIGN.md §9: a command datagram fits 64 bytes.
const COMMAND_BUDGET: usize = 64;

fn frame_len<M: Message>(msg: &M) -> usize {
    let h = Header {
        direction: M::DIRECTION,
        stream: if msg.hello() {
            Stream::Hello
        } else {
            Stream::Session
        },
        robot_id: u16::MAX,
        counter: MAX_COUNTER,
    };
    let mut out = [0u8; MAX_DATAGRAM];
    seal(&SessionKey([1; 32]), h, msg, &mut out).expect("fits a datagram")
}

fn host_name(m: &HostMsg) -> &'static str {
    match m {
        HostMsg::Welcome { .. } => "Welcome",
        HostMsg::WheelSpeed { .. } => "WheelSpeed",
        HostMsg::RawDuty { .. } => "RawDuty",
        HostMsg::Stop => "Stop",
        HostMsg::EmergencyStop => "EmergencyStop",
        HostMsg::ClearEmergencyStop => "ClearEmergencyStop",
        HostMsg::SetParams(_) => "SetParams",
        HostMsg::Ping { .. } => "Ping",
        HostMsg::UpdateBegin { .. } => "UpdateBegin",
        HostMsg::UpdateChunk { .. } => "UpdateChunk",
        HostMsg::WheelSpeedHold { .. } => "WheelSpeedHold",
    }
}

fn robot_name(m: &RobotMsg) -> &'static str {
    match m {
        RobotMsg::Announce(_) => "Announce",
        RobotMsg::Telemetry(_) => "Telemetry",
        RobotMsg::Pong { .. } => "Pong",
        RobotMsg::ParamsReply { .. } => "ParamsReply",
        RobotMsg::UpdateStatus(_) => "UpdateStatus",
    }
}

fn params(g: f32, failsafe_timeout_ms: u16, telemetry_hz: u8) -> ParamSet {
    ParamSet {
        pi: [PiGains { kp: g, ki: g }; 3],
        failsafe_timeout_ms,
        telemetry_hz,
    }
}

/// (shortest, longest) instance of every host variant.
fn host_extremes() -> Vec<(HostMsg, HostMsg)> {
    vec![
        (
            HostMsg::Welcome {
                robot_nonce: [0; 16],
                host_nonce: [0; 16],
            },
            HostMsg::Welcome {
                robot_nonce: [0xff; 16],
                host_nonce: [0xff; 16],
            },
        ),
        (
            HostMsg::WheelSpeed {
                left_rpm: 0.0,
                right_rpm: 0.0,
            },
            HostMsg::WheelSpeed {
                left_rpm: -MAX_COMMAND_RPM,
                right_rpm: MAX_COMMAND_RPM,
            },
        ),
        (
            HostMsg::RawDuty { left: 0, right: 0 },
            HostMsg::RawDuty {
                left: i16::MIN,
                right: i16::MIN,
            },
        ),
        (HostMsg::Stop, HostMsg::Stop),
        (HostMsg::EmergencyStop, HostMsg::EmergencyStop),
        (HostMsg::ClearEmergencyStop, HostMsg::ClearEmergencyStop),
        (
            HostMsg::SetParams(params(0.0, 0, 0)),
            HostMsg::SetParams(params(f32::MAX, u16::MAX, u8::MAX)),
        ),
        (
            HostMsg::Ping {
                seq: 0,
                host_time_us: 0,
            },
            HostMsg::Ping {
                seq: u32::MAX,
                host_time_us: u64::MAX,
            },
        ),
        (
            HostMsg::UpdateBegin {
                transfer: 0,
                total_len: 0,
            },
            HostMsg::UpdateBegin {
                transfer: u32::MAX,
                total_len: u32::MAX,
            },
        ),
        (
            HostMsg::UpdateChunk {
                offset: 0,
                data: [0; UPDATE_CHUNK],
            },
            HostMsg::UpdateChunk {
                offset: u32::MAX,
                data: [0xff; UPDATE_CHUNK],
            },
        ),
        (
            HostMsg::WheelSpeedHold {
                left_rpm: 0.0,
                right_rpm: 0.0,
                hold_ms: 0,
            },
            HostMsg::WheelSpeedHold {
                left_rpm: -MAX_COMMAND_RPM,
                right_rpm: MAX_COMMAND_RPM,
                hold_ms: u16::MAX,
            },
        ),
    ]
}

fn telemetry_with(small: bool) -> Telemetry {
    if small {
        Telemetry {
            uptime_ms: 0,
            measured_rpm: [0.0; 2],
            target_rpm: [0.0; 2],
            duty: [0; 2],
            encoder_counts: [0; 2],
            battery_mv: 0,
            rssi_dbm: 0,
            flags: 0,
            last_command_counter: 0,
        }
    } else {
        Telemetry {
            uptime_ms: u32::MAX,
            measured_rpm: [f32::MAX; 2],
            target_rpm: [f32::MIN; 2],
            duty: [i16::MIN; 2],
            encoder_counts: [i32::MIN; 2],
            battery_mv: u16::MAX,
            rssi_dbm: i8::MIN,
            flags: u16::MAX,
            last_command_counter: u64::MAX,
        }
    }
}

/// (shortest, longest) instance of every robot variant.
fn robot_extremes() -> Vec<(RobotMsg, RobotMsg)> {
    let announce = |n: u8, reset_reason| Announce {
        kind: RobotKind::NonPilot,
        firmware: FirmwareVersion {
            major: n,
            minor: n,
            patch: n,
        },
        protocol_version: n,
        robot_nonce: [n; 16],
        reset_reason,
    };
    let last_reason = ResetReason::ALL[ResetReason::ALL.len() - 1];
    vec![
        (
            RobotMsg::Announce(announce(0, ResetReason::ALL[0])),
            RobotMsg::Announce(announce(0xff, last_reason)),
        ),
        (
            RobotMsg::Telemetry(telemetry_with(true)),
            RobotMsg::Telemetry(telemetry_with(false)),
        ),
        (
            RobotMsg::Pong {
                seq: 0,
                host_time_us: 0,
            },
            RobotMsg::Pong {
                seq: u32::MAX,
                host_time_us: u64::MAX,
            },
        ),
        (
            RobotMsg::ParamsReply { rejected: None },
            RobotMsg::ParamsReply {
                rejected: Some(ParamRejection::TelemetryRateOutOfRange),
            },
        ),
        (
            RobotMsg::UpdateStatus(UpdateStatus {
                transfer: 0,
                received: 0,
                state: UpdateState::Idle,
            }),
            RobotMsg::UpdateStatus(UpdateStatus {
                transfer: u32::MAX,
                received: u32::MAX,
                state: UpdateState::Refused(UpdateRefusal::Flash),
            }),
        ),
    ]
}

fn host_bounds(name: &str) -> (usize, usize) {
    host_extremes()
        .iter()
        .find(|(a, _)| host_name(a) == name)
        .map(|(a, b)| (frame_len(a), frame_len(b)))
        .expect("every variant has extremes")
}

fn robot_bounds(name: &str) -> (usize, usize) {
    robot_extremes()
        .iter()
        .find(|(a, _)| robot_name(a) == name)
        .map(|(a, b)| (frame_len(a), frame_len(b)))
        .expect("every variant has extremes")
}

#[test]
fn datagram_size_budget() {
    let mut rows = Vec::new();
    for (a, b) in host_extremes() {
        let stream = if a.is_hello() { "hello" } else { "session" };
        rows.push((
            host_name(&a),
            "host → robot",
            stream,
            frame_len(&a),
            frame_len(&b),
        ));
    }
    for (a, b) in robot_extremes() {
        let stream = if a.is_hello() { "hello" } else { "session" };
        rows.push((
            robot_name(&a),
            "robot → host",
            stream,
            frame_len(&a),
            frame_len(&b),
        ));
    }
    println!("| message | direction | stream | bytes min | bytes max |");
    println!("|---|---|---|---|---|");
    for (name, dir, stream, lo, hi) in &rows {
        println!("| {name} | {dir} | {stream} | {lo} | {hi} |");
    }
    let largest = rows.iter().map(|r| r.4).max().expect("rows");
    println!("largest datagram: {largest} bytes (bound {MAX_DATAGRAM})");

    let (_, wheel) = host_bounds("WheelSpeed");
    let (_, tele) = robot_bounds("Telemetry");
    assert!(wheel <= WHEEL_SPEED_BUDGET, "wheel-speed command {wheel} B");
    assert!(tele <= TELEMETRY_BUDGET, "telemetry {tele} B");
    assert!(largest <= MAX_DATAGRAM, "largest datagram {largest} B");
    for (name, dir, stream, _, hi) in &rows {
        if *dir == "host → robot" && *stream == "session" {
            assert!(*hi <= COMMAND_BUDGET, "{name}: {hi} B > {COMMAND_BUDGET}");
        }
    }
    // A typical telemetry frame: one hour up, wheels near full speed, 10^6 encoder counts,
    // a full battery, ordinary RSSI, the 108,000th command (30 Hz for an hour).
    let typical = RobotMsg::Telemetry(Telemetry {
        uptime_ms: 3_600_000,
        measured_rpm: [441.5, -437.25],
        target_rpm: [450.0, -450.0],
        duty: [612, -598],
        encoder_counts: [1_000_000, -1_000_000],
        battery_mv: 4100,
        rssi_dbm: -61,
        flags: 0,
        last_command_counter: 108_000,
    });
    let typical = frame_len(&typical);
    println!("typical telemetry: {typical} bytes");
    assert!(typical <= COMMAND_BUDGET, "typical telemetry {typical} B");

    // Pin the measured numbers so a message change that grows a frame is noticed here
    // and in the README table.
    assert_eq!(wheel, 35);
    assert_eq!(tele, 81);
    assert_eq!(largest, 81);
    assert_eq!(
        host_bounds("UpdateChunk"),
        (60, 64),
        "update chunk at the budget"
    );
    assert_eq!(HEADER_LEN + TAG_LEN, 26, "envelope overhead");
    let (lo, hi) = robot_bounds("Announce");
    assert_eq!((lo, hi), (49, 49), "announce with its reset reason");
    assert!(hi <= COMMAND_BUDGET, "announce {hi} B");
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 1024,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// No value of any field makes a frame shorter or longer than its variant's extremes.
    #[test]
    fn random_host_messages_stay_within_their_variant_bounds(m in host_msg()) {
        let (lo, hi) = host_bounds(host_name(&m));
        let n = frame_len(&m);
        prop_assert!(lo <= n && n <= hi, "{} = {} not in {}..={}", host_name(&m), n, lo, hi);
    }

    /// Every reset reason fits the announce's bounds (one byte on the wire).
    #[test]
    fn any_reset_reason_stays_within_announce_bounds(i in 0..ResetReason::ALL.len()) {
        let (lo, hi) = robot_bounds("Announce");
        let n = frame_len(&RobotMsg::Announce(Announce {
            kind: RobotKind::Pilot,
            firmware: FirmwareVersion { major: 1, minor: 2, patch: 3 },
            protocol_version: PROTOCOL_VERSION,
            robot_nonce: [7; 16],
            reset_reason: ResetReason::ALL[i],
        }));
        prop_assert!(lo <= n && n <= hi);
    }

    #[test]
    fn random_robot_messages_stay_within_their_variant_bounds(m in robot_msg()) {
        let (lo, hi) = robot_bounds(robot_name(&m));
        let n = frame_len(&m);
        prop_assert!(lo <= n && n <= hi, "{} = {} not in {}..={}", robot_name(&m), n, lo, hi);
    }

    /// Raw duties at the type's extremes too (the receiver refuses them, but the sender
    /// can seal them, so the bound must hold).
    #[test]
    fn any_raw_duty_stays_within_bounds(left in any::<i16>(), right in any::<i16>()) {
        let (lo, hi) = host_bounds("RawDuty");
        let n = frame_len(&HostMsg::RawDuty { left, right });
        prop_assert!(lo <= n && n <= hi);
    }
}
