//! Freshness and authenticity across the life of a link: replay within and across
//! sessions (robot reboot, host restart), reflection, every single-bit flip, truncation and
//! extension, and the host's pending/active session logic.

mod common;

use common::*;
use puzzlebot_protocol::session::{HostReceived, PENDING_OFFERS};
use puzzlebot_protocol::*;

fn every_host_session_msg() -> Vec<HostMsg> {
    vec![
        HostMsg::WheelSpeed {
            left_rpm: -1000.0,
            right_rpm: 1000.0,
        },
        HostMsg::RawDuty {
            left: -1000,
            right: 1000,
        },
        HostMsg::Stop,
        HostMsg::EmergencyStop,
        HostMsg::ClearEmergencyStop,
        HostMsg::SetParams(ParamSet {
            pi: [PiGains { kp: 0.3, ki: 1.5 }; 3],
            failsafe_timeout_ms: 200,
            telemetry_hz: 30,
        }),
        HostMsg::Ping {
            seq: u32::MAX,
            host_time_us: u64::MAX,
        },
    ]
}

fn every_robot_session_msg() -> Vec<RobotMsg> {
    vec![
        RobotMsg::Telemetry(Telemetry {
            uptime_ms: u32::MAX,
            measured_rpm: [1.0, -2.0],
            target_rpm: [3.0, -4.0],
            duty: [i16::MIN, i16::MAX],
            encoder_counts: [i32::MIN, i32::MAX],
            battery_mv: u16::MAX,
            rssi_dbm: i8::MIN,
            flags: u16::MAX,
            last_command_counter: u64::MAX,
        }),
        RobotMsg::Pong {
            seq: 1,
            host_time_us: 2,
        },
        RobotMsg::ParamsReply { rejected: None },
        RobotMsg::ParamsReply {
            rejected: Some(ParamRejection::GainOutOfRange),
        },
    ]
}

#[test]
fn replay_within_a_session_is_rejected_in_both_directions() {
    let (mut host, mut robot) = pair();
    for m in every_host_session_msg() {
        let f = host_frame(&mut host, &m);
        assert_eq!(robot.receive(&f).map(|(_, g)| g), Ok(m));
        assert_eq!(robot.receive(&f), Err(Rejection::Replay));
    }
    for m in every_robot_session_msg() {
        let f = robot_frame(&mut robot, &m);
        assert!(matches!(to_host(&mut host, &f), Ok(HostReceived::Message(_, g)) if g == m));
        assert_eq!(to_host(&mut host, &f).err(), Some(Rejection::Replay));
    }
}

#[test]
fn reordering_within_the_window_is_accepted_once() {
    let (mut host, mut robot) = pair();
    let a = host_frame(&mut host, &HostMsg::Stop);
    let b = host_frame(&mut host, &HostMsg::EmergencyStop);
    assert!(robot.receive(&b).is_ok());
    assert!(robot.receive(&a).is_ok(), "late but inside the window");
    assert_eq!(robot.receive(&a), Err(Rejection::Replay));
}

#[test]
fn frames_of_an_earlier_robot_boot_are_rejected() {
    let mut host = HostSession::new(ID, robot_key());
    let mut robot = RobotSession::new(ID, robot_key(), nonce(1));
    let (_, old_welcome) = handshake(&mut host, &mut robot, nonce(101));
    // Captured traffic of boot 1, partly delivered, partly not (an attacker kept copies).
    let delivered = host_frame(
        &mut host,
        &HostMsg::WheelSpeed {
            left_rpm: 50.0,
            right_rpm: 50.0,
        },
    );
    assert!(robot.receive(&delivered).is_ok());
    let undelivered = host_frame(
        &mut host,
        &HostMsg::WheelSpeed {
            left_rpm: 400.0,
            right_rpm: -400.0,
        },
    );
    let old_telemetry = robot_frame(
        &mut robot,
        &RobotMsg::Pong {
            seq: 5,
            host_time_us: 6,
        },
    );

    // Reboot: new RobotSession with a new boot nonce, new handshake.
    let mut robot = RobotSession::new(ID, robot_key(), nonce(2));
    // The old welcome no longer opens a session (it answers the old nonce).
    assert_eq!(robot.receive(&old_welcome), Err(Rejection::StaleHandshake));
    handshake(&mut host, &mut robot, nonce(102));
    // Neither delivered nor undelivered frames of boot 1 verify under the new session.
    assert_eq!(robot.receive(&delivered), Err(Rejection::BadTag));
    assert_eq!(robot.receive(&undelivered), Err(Rejection::BadTag));
    // The host refuses the old boot's telemetry, too.
    assert_eq!(
        to_host(&mut host, &old_telemetry).err(),
        Some(Rejection::BadTag)
    );
    // And the old welcome is refused now that the new session exists.
    assert_eq!(robot.receive(&old_welcome), Err(Rejection::StaleHandshake));
    assert_linked(&mut host, &mut robot);
}

#[test]
fn frames_of_an_earlier_host_run_are_rejected() {
    let mut host1 = HostSession::new(ID, robot_key());
    let mut robot = RobotSession::new(ID, robot_key(), nonce(1));
    let (announce1, welcome1) = handshake(&mut host1, &mut robot, nonce(101));
    let old_cmd = host_frame(
        &mut host1,
        &HostMsg::WheelSpeed {
            left_rpm: 300.0,
            right_rpm: 300.0,
        },
    );
    // The host restarts: no state survives. It cannot send anything yet.
    let mut host2 = HostSession::new(ID, robot_key());
    assert_eq!(
        host2.send(&HostMsg::Stop, &mut [0u8; MAX_DATAGRAM]),
        Err(EncodeError::NoSession)
    );
    // The robot's failsafe fires; it announces again with a fresh nonce.
    robot.restart(nonce(2));
    handshake(&mut host2, &mut robot, nonce(102));
    // Frames and welcomes of host run 1 are dead.
    assert_eq!(robot.receive(&old_cmd), Err(Rejection::BadTag));
    assert_eq!(robot.receive(&welcome1), Err(Rejection::StaleHandshake));
    // The old announce replayed to the new host only yields an unproven offer.
    assert!(matches!(
        host2.receive(&announce1, || nonce(150), &mut [0u8; MAX_DATAGRAM]),
        Ok(HostReceived::Announce {
            new_session: true,
            ..
        })
    ));
    assert_linked(&mut host2, &mut robot);
}

#[test]
fn a_flipped_direction_bit_does_not_verify() {
    // Reflection with the direction bit rewritten: the direction is inside the tag.
    let (mut host, mut robot) = pair();
    let mut cmd = host_frame(&mut host, &HostMsg::Stop);
    cmd[1] ^= 1;
    assert_eq!(to_host(&mut host, &cmd).err(), Some(Rejection::BadTag));
    let mut t = robot_frame(&mut robot, &RobotMsg::ParamsReply { rejected: None });
    t[1] ^= 1;
    assert_eq!(robot.receive(&t), Err(Rejection::BadTag));
}

/// Every single-bit flip of every frame kind (both streams, both directions) is
/// rejected, and rejected frames leave the session able to accept the original.
#[test]
fn every_bit_flip_of_every_frame_is_rejected() {
    let (mut host, mut robot) = pair();
    let mut flips = 0usize;
    for m in every_host_session_msg() {
        let f = host_frame(&mut host, &m);
        for bit in 0..f.len() * 8 {
            let mut g = f.clone();
            g[bit / 8] ^= 1 << (bit % 8);
            assert!(
                robot.receive(&g).is_err(),
                "{m:?}: bit {bit} flipped was accepted"
            );
            flips += 1;
        }
        assert_eq!(robot.receive(&f).map(|(_, x)| x), Ok(m));
    }
    for m in every_robot_session_msg() {
        let f = robot_frame(&mut robot, &m);
        for bit in 0..f.len() * 8 {
            let mut g = f.clone();
            g[bit / 8] ^= 1 << (bit % 8);
            assert!(
                to_host(&mut host, &g).is_err(),
                "{m:?}: bit {bit} flipped was accepted"
            );
            flips += 1;
        }
        assert!(to_host(&mut host, &f).is_ok());
    }
    // Hello stream: announce and welcome.
    let mut host2 = HostSession::new(ID, robot_key());
    let mut robot2 = RobotSession::new(ID, robot_key(), nonce(3));
    let mut a = [0u8; MAX_DATAGRAM];
    let n = robot2
        .announce(RobotKind::Pilot, FW, &mut a)
        .expect("announce");
    for bit in 0..n * 8 {
        let mut g = a[..n].to_vec();
        g[bit / 8] ^= 1 << (bit % 8);
        assert!(
            host2
                .receive(&g, || nonce(1), &mut [0u8; MAX_DATAGRAM])
                .is_err(),
            "announce bit {bit}"
        );
        flips += 1;
    }
    assert!(!host2.has_pending(), "no flipped announce created an offer");
    let mut w = [0u8; MAX_DATAGRAM];
    let Ok(HostReceived::Announce { welcome_len, .. }) =
        host2.receive(&a[..n], || nonce(103), &mut w)
    else {
        panic!("announce refused");
    };
    for bit in 0..welcome_len * 8 {
        let mut g = w[..welcome_len].to_vec();
        g[bit / 8] ^= 1 << (bit % 8);
        assert!(robot2.receive(&g).is_err(), "welcome bit {bit}");
        assert!(!robot2.is_established());
        flips += 1;
    }
    assert!(robot2.receive(&w[..welcome_len]).is_ok());
    assert!(flips > 4000, "{flips} flips");
}

#[test]
fn truncation_and_extension_at_every_length_are_rejected() {
    let (mut host, mut robot) = pair();
    let f = host_frame(
        &mut host,
        &HostMsg::WheelSpeed {
            left_rpm: 1.0,
            right_rpm: 2.0,
        },
    );
    for len in 0..f.len() {
        let r = robot.receive(&f[..len]);
        assert!(
            matches!(r, Err(Rejection::Truncated | Rejection::BadTag)),
            "cut to {len}: {r:?}"
        );
    }
    for extra in 1..=(MAX_DATAGRAM + 10 - f.len()) {
        let mut g = f.clone();
        g.extend(std::iter::repeat_n(0xAA, extra));
        let r = robot.receive(&g);
        let want = if g.len() > MAX_DATAGRAM {
            Rejection::Oversized
        } else {
            Rejection::BadTag
        };
        assert_eq!(r, Err(want), "extended by {extra}");
    }
    assert!(robot.receive(&f).is_ok());
}

#[test]
fn a_replayed_old_announce_does_not_displace_the_proven_session() {
    let mut host = HostSession::new(ID, robot_key());
    let mut robot = RobotSession::new(ID, robot_key(), nonce(1));
    let (old_announce, _) = handshake(&mut host, &mut robot, nonce(101));
    // Reboot with a new nonce; the proven session is the new one.
    let mut robot = RobotSession::new(ID, robot_key(), nonce(2));
    handshake(&mut host, &mut robot, nonce(102));
    // The attacker replays boot 1's announce: a new offer, but the active session stays.
    let r = host.receive(&old_announce, || nonce(103), &mut [0u8; MAX_DATAGRAM]);
    assert!(matches!(
        r,
        Ok(HostReceived::Announce {
            new_session: true,
            ..
        })
    ));
    assert!(host.is_established());
    assert_linked(&mut host, &mut robot);
    // The current session's own announce (duplicated datagram) is answered, not re-keyed.
    let mut a = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::NonPilot, FW, &mut a)
        .expect("announce");
    let r = host.receive(&a[..n], || panic!("no new nonce"), &mut [0u8; MAX_DATAGRAM]);
    assert!(matches!(
        r,
        Ok(HostReceived::Announce {
            new_session: false,
            ..
        })
    ));
    assert_linked(&mut host, &mut robot);
    // Robot traffic keeps flowing under the active session.
    let t = robot_frame(
        &mut robot,
        &RobotMsg::Pong {
            seq: 1,
            host_time_us: 1,
        },
    );
    assert!(to_host(&mut host, &t).is_ok());
}

#[test]
fn a_rebooted_robot_takes_over_after_its_first_valid_frame() {
    let (mut host, mut robot_boot1) = pair();
    let mut robot = RobotSession::new(ID, robot_key(), nonce(2));
    let mut a = [0u8; MAX_DATAGRAM];
    let mut w = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::Pilot, FW, &mut a)
        .expect("announce");
    let Ok(HostReceived::Announce { welcome_len, .. }) =
        host.receive(&a[..n], || nonce(102), &mut w)
    else {
        panic!("announce refused");
    };
    assert!(robot.receive(&w[..welcome_len]).is_ok());
    // Until the robot proves the new session, commands still go out under the old one:
    // the new boot refuses them, the old session (were it alive) would accept them.
    let f = host_frame(&mut host, &HostMsg::Stop);
    assert_eq!(robot.receive(&f), Err(Rejection::BadTag));
    assert!(robot_boot1.receive(&f).is_ok());
    assert!(host.has_pending());
    // The robot's first session frame proves the offer: it becomes the active session.
    prove(&mut host, &mut robot);
    assert!(!host.has_pending());
    assert_linked(&mut host, &mut robot);
    // Boot 1's frames are now refused by the host.
    let old = robot_frame(&mut robot_boot1, &RobotMsg::ParamsReply { rejected: None });
    assert_eq!(to_host(&mut host, &old).err(), Some(Rejection::BadTag));
}

#[test]
fn replayed_announces_between_welcome_and_proof_do_not_lock_the_robot_out() {
    // Old announces captured from earlier boots.
    let mut host = HostSession::new(ID, robot_key());
    let mut olds = Vec::new();
    for b in 0..PENDING_OFFERS as u8 - 1 {
        let mut r = RobotSession::new(ID, robot_key(), nonce(50 + b));
        let mut a = [0u8; MAX_DATAGRAM];
        let n = r.announce(RobotKind::Pilot, FW, &mut a).expect("announce");
        olds.push(a[..n].to_vec());
    }
    let mut robot = RobotSession::new(ID, robot_key(), nonce(2));
    let mut a = [0u8; MAX_DATAGRAM];
    let mut w = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::Pilot, FW, &mut a)
        .expect("announce");
    let Ok(HostReceived::Announce { welcome_len, .. }) =
        host.receive(&a[..n], || nonce(102), &mut w)
    else {
        panic!("announce refused");
    };
    // The attacker injects replayed announces right after the genuine one.
    for (k, old) in (0u8..).zip(&olds) {
        assert!(host
            .receive(old, || nonce(110 + k), &mut [0u8; MAX_DATAGRAM])
            .is_ok());
    }
    assert!(robot.receive(&w[..welcome_len]).is_ok());
    prove(&mut host, &mut robot);
    assert_linked(&mut host, &mut robot);
}

#[test]
fn a_flood_of_replayed_announces_only_delays_the_handshake() {
    // More replayed announces than offer slots evict the genuine offer; the robot's first
    // frame is then refused, its failsafe re-announces with a fresh nonce, and it recovers.
    let mut host = HostSession::new(ID, robot_key());
    let mut robot = RobotSession::new(ID, robot_key(), nonce(2));
    let mut a = [0u8; MAX_DATAGRAM];
    let mut w = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::Pilot, FW, &mut a)
        .expect("announce");
    let Ok(HostReceived::Announce { welcome_len, .. }) =
        host.receive(&a[..n], || nonce(102), &mut w)
    else {
        panic!("announce refused");
    };
    for b in 0..PENDING_OFFERS as u8 {
        let mut r = RobotSession::new(ID, robot_key(), nonce(60 + b));
        let mut o = [0u8; MAX_DATAGRAM];
        let m = r.announce(RobotKind::Pilot, FW, &mut o).expect("announce");
        assert!(host
            .receive(&o[..m], || nonce(120 + b), &mut [0u8; MAX_DATAGRAM])
            .is_ok());
    }
    assert!(robot.receive(&w[..welcome_len]).is_ok());
    let f = robot_frame(&mut robot, &RobotMsg::ParamsReply { rejected: None });
    assert_eq!(to_host(&mut host, &f).err(), Some(Rejection::BadTag));
    assert!(!host.is_established());
    robot.restart(nonce(3));
    handshake(&mut host, &mut robot, nonce(103));
    assert_linked(&mut host, &mut robot);
}

#[test]
fn a_second_welcome_for_the_same_nonce_is_refused() {
    // Two hosts (or a host restarted mid-handshake) answer the same announce: the robot
    // takes the first welcome only.
    let mut robot = RobotSession::new(ID, robot_key(), nonce(1));
    let mut a = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::Pilot, FW, &mut a)
        .expect("announce");
    let mut w1 = [0u8; MAX_DATAGRAM];
    let mut w2 = [0u8; MAX_DATAGRAM];
    let mut h1 = HostSession::new(ID, robot_key());
    let mut h2 = HostSession::new(ID, robot_key());
    let Ok(HostReceived::Announce {
        welcome_len: l1, ..
    }) = h1.receive(&a[..n], || nonce(101), &mut w1)
    else {
        panic!()
    };
    let Ok(HostReceived::Announce {
        welcome_len: l2, ..
    }) = h2.receive(&a[..n], || nonce(102), &mut w2)
    else {
        panic!()
    };
    assert!(robot.receive(&w1[..l1]).is_ok());
    assert_eq!(robot.receive(&w2[..l2]), Err(Rejection::Replay));
    assert_eq!(robot.receive(&w1[..l1]), Err(Rejection::Replay));
}

#[test]
fn a_host_reset_requires_a_new_handshake() {
    let (mut host, mut robot) = pair();
    host.reset();
    assert!(!host.is_established());
    assert_eq!(
        host.send(&HostMsg::Stop, &mut [0u8; MAX_DATAGRAM]),
        Err(EncodeError::NoSession)
    );
    robot.restart(nonce(5));
    handshake(&mut host, &mut robot, nonce(105));
    assert_linked(&mut host, &mut robot);
}

#[test]
fn an_announce_that_does_not_fit_the_output_buffer_changes_nothing() {
    let mut host = HostSession::new(ID, robot_key());
    let mut robot = RobotSession::new(ID, robot_key(), nonce(1));
    let mut a = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::Pilot, FW, &mut a)
        .expect("announce");
    assert!(host
        .receive(&a[..n], || nonce(100), &mut [0u8; 20])
        .is_err());
    assert!(!host.has_pending());
}

#[test]
fn counters_stop_at_48_bits() {
    let key = robot_key().hello_key();
    let h = Header {
        direction: Direction::HostToRobot,
        stream: Stream::Session,
        robot_id: ID,
        counter: MAX_COUNTER + 1,
    };
    assert_eq!(
        seal(&key, h, &HostMsg::Stop, &mut [0u8; MAX_DATAGRAM]),
        Err(EncodeError::CounterExhausted)
    );
    let h = Header {
        counter: MAX_COUNTER,
        ..h
    };
    let mut out = [0u8; MAX_DATAGRAM];
    let n = seal(&key, h, &HostMsg::Stop, &mut out).expect("the last counter is usable");
    assert_eq!(peek_header(&out[..n]).map(|h| h.counter), Ok(MAX_COUNTER));
}

#[test]
fn keys_are_never_printed() {
    let k = robot_key();
    let s = format!("{k:?} {:?} {:?}", k.hello_key(), fleet());
    assert_eq!(
        s,
        "RobotKey(<redacted>) SessionKey(<redacted>) FleetKey(<redacted>)"
    );
    // Sessions print no key material either (robot, hello or session keys).
    let (host, robot) = pair();
    let dbg = format!("{host:?} {robot:?}");
    let session = robot_key().session_key(&nonce(1), &nonce(101));
    for raw in [robot_key().0, robot_key().hello_key().0, session.0] {
        assert!(!dbg.contains(&format!("{raw:?}")), "raw key bytes in {dbg}");
    }
    assert!(dbg.contains("<redacted>"));
}

#[test]
fn sealing_into_a_small_buffer_is_an_error_not_a_panic() {
    let (mut host, mut robot) = pair();
    for len in 0..35 {
        let mut out = vec![0u8; len];
        let r = host.send(
            &HostMsg::WheelSpeed {
                left_rpm: 1.0,
                right_rpm: 1.0,
            },
            &mut out,
        );
        assert_eq!(r, Err(EncodeError::TooLarge), "buffer of {len}");
    }
    // The failed attempts consumed counters but the session still works.
    assert_linked(&mut host, &mut robot);
}

#[test]
fn the_host_seals_nothing_under_an_unproven_offer() {
    // Host run 1 welcomes the robot, but the welcome is lost and host 1 dies. Had host 1
    // sealed commands under that offer, an attacker holding them and the lost welcome could
    // later open that session on the robot (it still announces the same nonce) and replay them.
    let mut robot = RobotSession::new(ID, robot_key(), nonce(1));
    let mut a = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::Pilot, FW, &mut a)
        .expect("announce");
    let mut host1 = HostSession::new(ID, robot_key());
    let mut w1 = [0u8; MAX_DATAGRAM];
    let Ok(HostReceived::Announce {
        welcome_len: l1, ..
    }) = host1.receive(&a[..n], || nonce(101), &mut w1)
    else {
        panic!("announce refused");
    };
    assert!(host1.has_pending());
    assert_eq!(
        host1.send(
            &HostMsg::WheelSpeed {
                left_rpm: 400.0,
                right_rpm: 400.0
            },
            &mut [0u8; MAX_DATAGRAM]
        ),
        Err(EncodeError::NoSession)
    );
    // Host 2 answers the repeated announce; the attacker delivers the stale welcome first.
    let mut host2 = HostSession::new(ID, robot_key());
    let mut w2 = [0u8; MAX_DATAGRAM];
    let Ok(HostReceived::Announce {
        welcome_len: l2, ..
    }) = host2.receive(&a[..n], || nonce(102), &mut w2)
    else {
        panic!("announce refused");
    };
    assert!(robot.receive(&w1[..l1]).is_ok());
    assert_eq!(robot.receive(&w2[..l2]), Err(Rejection::Replay));
    // The robot's telemetry does not prove anything to host 2; host 2 sends nothing.
    let t = robot_frame(&mut robot, &RobotMsg::ParamsReply { rejected: None });
    assert_eq!(to_host(&mut host2, &t).err(), Some(Rejection::BadTag));
    assert!(!host2.is_established());
    // The robot's failsafe fires (no valid command), it re-announces and recovers.
    robot.restart(nonce(2));
    handshake(&mut host2, &mut robot, nonce(103));
    assert_linked(&mut host2, &mut robot);
}
