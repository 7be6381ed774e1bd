//! The robot's session state machine under hostile and replayed host frames.

use std::collections::HashSet;

use puzzlebot_protocol::session::HostReceived;
use puzzlebot_protocol::{
    peek_header, Direction, FirmwareVersion, HostMsg, HostSession, RobotKind, RobotMsg,
    RobotSession, Stream, MAX_DATAGRAM,
};

use super::input::{mutate, next_host_nonce, retag};
use super::samples::session_samples_host;
use super::{check_host_bounds, input_key, Input, ROBOT_ID};

/// Robot side: an established robot session receives raw bytes, genuine host frames,
/// replays, mutations of genuine frames (optionally re-tagged), welcomes old and new, and
/// restarts with fresh nonces.
pub fn fuzz_robot_session(data: &[u8]) {
    let mut inp = Input::new(data);
    let key = input_key(data);
    let hello = key.hello_key();
    let mut host = HostSession::new(ROBOT_ID, key.clone());
    let mut robot = RobotSession::new(ROBOT_ID, key.clone(), [0x11; 16]);
    let mut host_nonce_seq = 0u32;
    let mut buf = [0u8; MAX_DATAGRAM];
    let mut wbuf = [0u8; MAX_DATAGRAM];

    // Handshake through the real API.
    let n = robot
        .announce(
            RobotKind::NonPilot,
            FirmwareVersion {
                major: 0,
                minor: 1,
                patch: 0,
            },
            &mut buf,
        )
        .expect("announce seals");
    let HostReceived::Announce { welcome_len, .. } = host
        .receive(
            &buf[..n],
            || next_host_nonce(&mut host_nonce_seq),
            &mut wbuf,
        )
        .expect("host accepts announce")
    else {
        panic!("announce not recognised");
    };
    let mut welcomes: Vec<Vec<u8>> = vec![wbuf[..welcome_len].to_vec()];
    robot.receive(&welcomes[0]).expect("robot accepts welcome");
    // Tell the host the session is proven.
    let n = robot
        .send(&RobotMsg::ParamsReply { rejected: None }, &mut buf)
        .expect("seal");
    host.receive(
        &buf[..n],
        || next_host_nonce(&mut host_nonce_seq),
        &mut wbuf,
    )
    .expect("host proves session");

    let samples = session_samples_host();
    // Genuine host frames of the current robot session and of earlier ones.
    let mut sent: Vec<(u32, Vec<u8>)> = Vec::new();
    let mut epoch = 0u32;
    let mut accepted: HashSet<(u32, u64)> = HashSet::new();
    let mut session_key = Some(key.session_key(&[0x11; 16], &[1; 16]));

    while let Some(cmd) = inp.byte() {
        let mut frame: Vec<u8>;
        let mut retagged = false;
        match cmd % 6 {
            0 => {
                let len = inp.byte().unwrap_or(0) as usize;
                frame = inp.take(len).to_vec();
            }
            1 => {
                let i = inp.byte().unwrap_or(0) as usize % samples.len();
                let Ok(n) = host.send(&samples[i], &mut buf) else {
                    continue;
                };
                sent.push((epoch, buf[..n].to_vec()));
                // Sometimes only capture (the frame is lost / delayed).
                if inp.byte().unwrap_or(0) & 1 == 1 {
                    continue;
                }
                frame = buf[..n].to_vec();
            }
            2 | 3 => {
                if sent.is_empty() {
                    continue;
                }
                let i = inp.byte().unwrap_or(0) as usize % sent.len();
                frame = sent[i].1.clone();
                if cmd % 6 == 3 && mutate(&mut inp, &mut frame) {
                    // Re-tag under the key its stream uses (a compromised sender).
                    if let Ok(h) = peek_header(&frame) {
                        let k = match h.stream {
                            Stream::Hello => Some(&hello),
                            Stream::Session => session_key.as_ref(),
                        };
                        if let Some(k) = k {
                            retag(k, &mut frame);
                            retagged = true;
                        }
                    }
                }
            }
            4 => {
                // Replay a captured welcome (old or current).
                let i = inp.byte().unwrap_or(0) as usize % welcomes.len();
                frame = welcomes[i].clone();
            }
            _ => {
                // Robot loses the link: fresh nonce, new handshake with the host.
                // (Nonces are unique per restart: a robot that reuses a nonce is outside
                // the protocol's guarantees, see README "Nonces".)
                let mut nonce = inp.nonce();
                epoch += 1;
                nonce[..4].copy_from_slice(&epoch.to_le_bytes());
                nonce[15] = 0x99;
                robot.restart(nonce);
                let n = robot
                    .announce(
                        RobotKind::Pilot,
                        FirmwareVersion {
                            major: 0,
                            minor: 1,
                            patch: 0,
                        },
                        &mut buf,
                    )
                    .expect("announce seals");
                let mut issued = None;
                let mut nonce_fn = || {
                    let n = next_host_nonce(&mut host_nonce_seq);
                    issued = Some(n);
                    n
                };
                let r = host.receive(&buf[..n], &mut nonce_fn, &mut wbuf);
                let Ok(HostReceived::Announce {
                    welcome_len,
                    new_session: true,
                    ..
                }) = r
                else {
                    panic!("host refused a genuine announce: {r:?}");
                };
                let hn = issued.expect("a new session draws a host nonce");
                let w = wbuf[..welcome_len].to_vec();
                welcomes.push(w.clone());
                robot.receive(&w).expect("robot accepts the fresh welcome");
                // From here on, frames re-tagged with the old session key must fail.
                session_key = Some(key.session_key(&nonce, &hn));
                let n = robot
                    .send(&RobotMsg::ParamsReply { rejected: None }, &mut buf)
                    .expect("seal");
                // The robot's first frame proves the new session to the host.
                host.receive(
                    &buf[..n],
                    || next_host_nonce(&mut host_nonce_seq),
                    &mut wbuf,
                )
                .expect("host takes over the robot's new session");
                assert!(host.is_established());
                assert!(!host.has_pending());
                continue;
            }
        }
        let was_established = robot.is_established();
        let result = robot.receive(&frame);
        match result {
            Ok((h, msg)) => {
                assert!(frame.len() <= MAX_DATAGRAM);
                assert_eq!(h.robot_id, ROBOT_ID);
                assert_eq!(h.direction, Direction::HostToRobot);
                assert!(msg.validate(), "invalid message accepted: {msg:?}");
                check_host_bounds(&msg);
                match msg {
                    HostMsg::Welcome { robot_nonce, .. } => {
                        assert!(!was_established, "second welcome accepted in one session");
                        assert_eq!(&robot_nonce, robot.robot_nonce());
                        // Only retagged or genuine welcomes can open a session.
                        assert!(retagged || welcomes.contains(&frame));
                    }
                    _ => {
                        assert!(
                            accepted.insert((epoch, h.counter)),
                            "counter {} accepted twice in one session",
                            h.counter
                        );
                        if !retagged {
                            assert!(
                                sent.iter().any(|(e, f)| *e == epoch && *f == frame),
                                "a frame that the host never sealed in this session was accepted"
                            );
                        }
                    }
                }
            }
            Err(_) => {
                // A rejection never changes whether a session exists.
                assert_eq!(was_established, robot.is_established());
            }
        }
    }
}
