//! One test per `Rejection` reason, each produced by a realistic frame, and a check that
//! together they cover every reason.

mod common;

use std::collections::BTreeSet;
use std::sync::Mutex;

use common::*;
use puzzlebot_protocol::pose::{encode_poses, BodyPose, MAX_POSE_DATAGRAM};
use puzzlebot_protocol::*;

/// Reasons produced so far by the tests of this file.
static SEEN: Mutex<BTreeSet<Rejection>> = Mutex::new(BTreeSet::new());

fn expect(got: Result<impl std::fmt::Debug, Rejection>, want: Rejection) {
    match got {
        Err(r) => {
            assert_eq!(r, want, "wrong reason");
            SEEN.lock().expect("lock").insert(r);
        }
        Ok(v) => panic!("expected {want}, got Ok({v:?})"),
    }
}

#[test]
fn oversized_pose_datagram_on_the_command_port() {
    // A misconfigured motion-capture bridge sends a 6-body pose datagram (132 bytes) to a robot.
    let bodies = [BodyPose {
        robot_id: ID,
        x: 0.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.0,
        tracked: true,
    }; 6];
    let mut buf = [0u8; MAX_POSE_DATAGRAM];
    let n = encode_poses(1, 1, &bodies, &mut buf);
    assert!(n > MAX_DATAGRAM);
    let (_, mut robot) = pair();
    expect(robot.receive(&buf[..n]), Rejection::Oversized);
    // And a genuine frame with junk appended past the bound.
    let (mut host, mut robot) = pair();
    let mut f = host_frame(&mut host, &HostMsg::Stop);
    f.resize(MAX_DATAGRAM + 1, 0);
    expect(robot.receive(&f), Rejection::Oversized);
}

#[test]
fn truncated_frame_from_a_short_read() {
    let (mut host, mut robot) = pair();
    let f = host_frame(&mut host, &HostMsg::Stop);
    expect(robot.receive(&f[..20]), Rejection::Truncated);
    expect(robot.receive(&[]), Rejection::Truncated);
    expect(
        robot.receive(&f[..HEADER_LEN + TAG_LEN]),
        Rejection::Truncated,
    );
}

#[test]
fn bad_version_from_a_newer_host() {
    let (mut host, mut robot) = pair();
    let mut f = host_frame(&mut host, &HostMsg::Stop);
    f[0] = PROTOCOL_VERSION + 1;
    expect(robot.receive(&f), Rejection::BadVersion);
}

#[test]
fn wrong_direction_when_a_frame_is_reflected() {
    let (mut host, mut robot) = pair();
    // The host's own command bounced back to it (reflection).
    let cmd = host_frame(
        &mut host,
        &HostMsg::WheelSpeed {
            left_rpm: 100.0,
            right_rpm: 100.0,
        },
    );
    expect(to_host(&mut host, &cmd), Rejection::WrongDirection);
    // The robot's telemetry reflected to the robot.
    let t = robot_frame(
        &mut robot,
        &RobotMsg::Pong {
            seq: 1,
            host_time_us: 2,
        },
    );
    expect(robot.receive(&t), Rejection::WrongDirection);
    // A reflected welcome/announce on the hello stream too.
    let mut r2 = RobotSession::new(ID, robot_key(), nonce(9));
    let mut a = [0u8; MAX_DATAGRAM];
    let n = r2.announce(RobotKind::Pilot, FW, &mut a).expect("announce");
    expect(r2.receive(&a[..n]), Rejection::WrongDirection);
    // Generic open refuses the other direction before checking the tag.
    let key = robot_key().hello_key();
    expect(open::<RobotMsg>(&key, &cmd), Rejection::WrongDirection);
}

#[test]
fn bad_flags_reserved_bit_or_wrong_stream() {
    let (mut host, mut robot) = pair();
    // A future sender sets a reserved flag bit.
    let mut f = host_frame(&mut host, &HostMsg::Stop);
    f[1] |= 0x80;
    expect(robot.receive(&f), Rejection::BadFlags);
    // A buggy sender seals a command on the hello stream under the hello key.
    let hello = robot_key().hello_key();
    let mut out = [0u8; MAX_DATAGRAM];
    let h = Header {
        direction: Direction::HostToRobot,
        stream: Stream::Hello,
        robot_id: ID,
        counter: 50,
    };
    let n = seal(&hello, h, &HostMsg::Stop, &mut out).expect("seal");
    expect(robot.receive(&out[..n]), Rejection::BadFlags);
    // ... or a telemetry frame on the hello stream to the host.
    let h = Header {
        direction: Direction::RobotToHost,
        stream: Stream::Hello,
        robot_id: ID,
        counter: 51,
    };
    let n = seal(
        &hello,
        h,
        &RobotMsg::ParamsReply { rejected: None },
        &mut out,
    )
    .expect("seal");
    expect(to_host(&mut host, &out[..n]), Rejection::BadFlags);
}

#[test]
fn unknown_robot_when_a_frame_reaches_the_wrong_robot() {
    // Robot 8's command arrives at robot 7 (address reuse after a DHCP change).
    let key8 = fleet().robot_key(8);
    let mut host8 = HostSession::new(8, key8.clone());
    let mut robot8 = RobotSession::new(8, key8, nonce(8));
    handshake(&mut host8, &mut robot8, nonce(108));
    let f = host_frame(&mut host8, &HostMsg::Stop);
    let (_, mut robot7) = pair();
    expect(robot7.receive(&f), Rejection::UnknownRobot);
    // And robot 8's telemetry at robot 7's host session.
    let (mut host7, _) = pair();
    let t = robot_frame(&mut robot8, &RobotMsg::ParamsReply { rejected: None });
    expect(to_host(&mut host7, &t), Rejection::UnknownRobot);
}

#[test]
fn bad_tag_for_another_fleet_or_a_corrupted_frame() {
    // A host of another fleet (different fleet key) that happens to use the same ids and nonces.
    let other = FleetKey([0x43; 32]).robot_key(ID);
    let mut host_b = HostSession::new(ID, other.clone());
    let mut robot_b = RobotSession::new(ID, other, nonce(1));
    handshake(&mut host_b, &mut robot_b, nonce(101));
    let foreign = host_frame(&mut host_b, &HostMsg::Stop);
    let (mut host, mut robot) = pair();
    expect(robot.receive(&foreign), Rejection::BadTag);
    // A bit flipped in the payload.
    let mut f = host_frame(
        &mut host,
        &HostMsg::WheelSpeed {
            left_rpm: 10.0,
            right_rpm: 10.0,
        },
    );
    f[HEADER_LEN + 2] ^= 0x10;
    expect(robot.receive(&f), Rejection::BadTag);
}

#[test]
fn replay_of_a_duplicated_datagram() {
    let (mut host, mut robot) = pair();
    let f = host_frame(&mut host, &HostMsg::EmergencyStop);
    assert!(robot.receive(&f).is_ok());
    expect(robot.receive(&f), Rejection::Replay);
    // Robot → host as well.
    let t = robot_frame(&mut robot, &RobotMsg::ParamsReply { rejected: None });
    assert!(to_host(&mut host, &t).is_ok());
    expect(to_host(&mut host, &t), Rejection::Replay);
}

#[test]
fn too_old_when_delayed_past_the_window() {
    let (mut host, mut robot) = pair();
    let late = host_frame(&mut host, &HostMsg::Stop);
    for _ in 0..replay::REPLAY_WINDOW {
        let f = host_frame(&mut host, &HostMsg::Stop);
        assert!(robot.receive(&f).is_ok());
    }
    expect(robot.receive(&late), Rejection::TooOld);
}

#[test]
fn malformed_payload_from_a_buggy_or_newer_peer() {
    let (mut host, mut robot) = pair();
    // A host bug: NaN wheel speed (seal does not judge the numbers; the receiver does).
    let f = host_frame(
        &mut host,
        &HostMsg::WheelSpeed {
            left_rpm: f32::NAN,
            right_rpm: 0.0,
        },
    );
    expect(robot.receive(&f), Rejection::MalformedPayload);
    // A duty of i16::MIN (whose abs() overflows) is refused, not wrapped.
    for (left, right) in [(i16::MIN, 0), (0, i16::MIN), (1001, 0), (0, -1001)] {
        let f = host_frame(&mut host, &HostMsg::RawDuty { left, right });
        expect(robot.receive(&f), Rejection::MalformedPayload);
    }
    // A newer host's message variant (discriminant 42), correctly tagged under the hello
    // key: seal a known message, rewrite the payload's first byte, tag it again.
    let hello = robot_key().hello_key();
    let h = Header {
        direction: Direction::HostToRobot,
        stream: Stream::Hello,
        robot_id: ID,
        counter: 9,
    };
    let mut out = [0u8; MAX_DATAGRAM];
    let n = seal(&hello, h, &HostMsg::Stop, &mut out).expect("seal");
    out[HEADER_LEN] = 42;
    let tag = hello.tag(&out[..n - TAG_LEN]);
    out[n - TAG_LEN..n].copy_from_slice(&tag);
    expect(robot.receive(&out[..n]), Rejection::MalformedPayload);
    // Trailing bytes after a complete message.
    let n = seal(&hello, h, &HostMsg::Stop, &mut out).expect("seal");
    let mut g = out[..n - TAG_LEN].to_vec();
    g.push(0);
    let tag = hello.tag(&g);
    g.extend_from_slice(&tag);
    expect(robot.receive(&g), Rejection::MalformedPayload);
}

#[test]
fn no_session_before_the_welcome_or_after_a_host_reset() {
    // The robot rebooted: commands of the host's session arrive before any welcome.
    let (mut host, _) = pair();
    let f = host_frame(&mut host, &HostMsg::Stop);
    let mut fresh = RobotSession::new(ID, robot_key(), nonce(2));
    expect(fresh.receive(&f), Rejection::NoSession);
    // The host marked the robot offline: its telemetry has no session to land in.
    let (mut host, mut robot) = pair();
    host.reset();
    let t = robot_frame(&mut robot, &RobotMsg::ParamsReply { rejected: None });
    expect(to_host(&mut host, &t), Rejection::NoSession);
    // And the robot cannot send before it is welcomed.
    assert_eq!(
        fresh.send(
            &RobotMsg::ParamsReply { rejected: None },
            &mut [0u8; MAX_DATAGRAM]
        ),
        Err(EncodeError::NoSession)
    );
}

#[test]
fn stale_handshake_for_an_earlier_announce() {
    // The welcome answering the robot's previous nonce arrives after it re-announced.
    let mut host = HostSession::new(ID, robot_key());
    let mut robot = RobotSession::new(ID, robot_key(), nonce(1));
    let mut a = [0u8; MAX_DATAGRAM];
    let mut w = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::Pilot, FW, &mut a)
        .expect("announce");
    let Ok(session::HostReceived::Announce { welcome_len, .. }) =
        host.receive(&a[..n], || nonce(100), &mut w)
    else {
        panic!("announce refused");
    };
    robot.restart(nonce(2));
    expect(robot.receive(&w[..welcome_len]), Rejection::StaleHandshake);
    assert!(!robot.is_established());
}

/// Test order is not guaranteed, so this test runs every scenario above itself and checks
/// that together they produce every reason.
#[test]
fn every_reason_is_produced() {
    oversized_pose_datagram_on_the_command_port();
    truncated_frame_from_a_short_read();
    bad_version_from_a_newer_host();
    wrong_direction_when_a_frame_is_reflected();
    bad_flags_reserved_bit_or_wrong_stream();
    unknown_robot_when_a_frame_reaches_the_wrong_robot();
    bad_tag_for_another_fleet_or_a_corrupted_frame();
    replay_of_a_duplicated_datagram();
    too_old_when_delayed_past_the_window();
    malformed_payload_from_a_buggy_or_newer_peer();
    no_session_before_the_welcome_or_after_a_host_reset();
    stale_handshake_for_an_earlier_announce();
    let seen = SEEN.lock().expect("lock").clone();
    let all: BTreeSet<Rejection> = Rejection::ALL.into_iter().collect();
    assert_eq!(
        seen,
        all,
        "reasons never produced: {:?}",
        all.difference(&seen)
    );
    // Names are unique and stable.
    let names: BTreeSet<&str> = Rejection::ALL.iter().map(|r| r.name()).collect();
    assert_eq!(names.len(), Rejection::ALL.len());
}
