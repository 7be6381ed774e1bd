//! The host's session state machine under hostile, replayed and forged robot frames.

use std::collections::HashSet;

use puzzlebot_protocol::session::HostReceived;
use puzzlebot_protocol::{
    open, peek_header, FirmwareVersion, HostMsg, HostSession, RobotKind, RobotMsg, RobotSession,
    Stream, MAX_DATAGRAM,
};

use super::input::{mutate, retag};
use super::samples::session_samples_robot;
use super::{input_key, Input, ROBOT_ID};

/// Host side: a host session with a proven robot session receives raw bytes, genuine robot
/// frames (telemetry, pong, replies, announces), replays across robot reboots, mutations
/// (optionally re-tagged) and forged announces; the robot reboots and the host restarts.
pub fn fuzz_host_session(data: &[u8]) {
    let mut inp = Input::new(data);
    let key = input_key(data);
    let hello = key.hello_key();
    let fw = FirmwareVersion {
        major: 0,
        minor: 1,
        patch: 0,
    };
    let mut host = HostSession::new(ROBOT_ID, key.clone());
    let mut robot = RobotSession::new(ROBOT_ID, key.clone(), [0x22; 16]);
    let mut nonce_seq = 0u32;
    let mut buf = [0u8; MAX_DATAGRAM];
    let mut wbuf = [0u8; MAX_DATAGRAM];
    let samples = session_samples_robot();
    // Genuine robot frames: (robot epoch, bytes).
    let mut sent: Vec<(u32, Vec<u8>)> = Vec::new();
    let mut epoch = 0u32;
    let mut accepted: HashSet<(u32, u64)> = HashSet::new();
    // Host and robot agree on a proven session: host.send reaches the robot.
    let mut linked = false;
    let mut last_welcome: Option<Vec<u8>> = None;

    let next_nonce = |seq: &mut u32| {
        *seq += 1;
        let mut n = [0u8; 16];
        n[..4].copy_from_slice(&seq.to_le_bytes());
        n[15] = 0xee;
        n
    };

    while let Some(cmd) = inp.byte() {
        let mut frame: Vec<u8>;
        match cmd % 8 {
            0 => {
                let len = inp.byte().unwrap_or(0) as usize;
                frame = inp.take(len).to_vec();
            }
            1 => {
                let i = inp.byte().unwrap_or(0) as usize % samples.len();
                let Ok(n) = robot.send(&samples[i], &mut buf) else {
                    continue;
                };
                sent.push((epoch, buf[..n].to_vec()));
                if inp.byte().unwrap_or(0) & 1 == 1 {
                    continue;
                }
                frame = buf[..n].to_vec();
            }
            2 => {
                // The robot announces (capture it; maybe deliver).
                let Ok(n) = robot.announce(RobotKind::NonPilot, fw, &mut buf) else {
                    continue;
                };
                sent.push((epoch, buf[..n].to_vec()));
                frame = buf[..n].to_vec();
            }
            3 | 4 => {
                if sent.is_empty() {
                    continue;
                }
                let i = inp.byte().unwrap_or(0) as usize % sent.len();
                frame = sent[i].1.clone();
                if cmd % 8 == 4 && mutate(&mut inp, &mut frame) {
                    // Only the hello key is re-tagged here: forged announces with any
                    // nonce must never displace the proven session.
                    if let Ok(h) = peek_header(&frame) {
                        if h.stream == Stream::Hello {
                            retag(&hello, &mut frame);
                        }
                    }
                }
            }
            5 => {
                // Deliver the host's latest welcome to the robot, then the robot's first
                // session frame to the host.
                let Some(w) = last_welcome.take() else {
                    continue;
                };
                if robot.receive(&w).is_ok() {
                    let n = robot
                        .send(&RobotMsg::ParamsReply { rejected: None }, &mut buf)
                        .expect("seal");
                    sent.push((epoch, buf[..n].to_vec()));
                    frame = buf[..n].to_vec();
                } else {
                    continue;
                }
            }
            6 => {
                // The robot reboots: new nonce, new epoch.
                // Unique per boot (a robot that reuses a nonce is outside the guarantees).
                let mut n = inp.nonce();
                epoch += 1;
                n[..4].copy_from_slice(&epoch.to_le_bytes());
                n[15] = 0x77;
                robot = RobotSession::new(ROBOT_ID, key.clone(), n);
                linked = false;
                continue;
            }
            _ => {
                // The host restarts (or marks the robot offline).
                if inp.byte().unwrap_or(0) & 1 == 0 {
                    host = HostSession::new(ROBOT_ID, key.clone());
                } else {
                    host.reset();
                }
                linked = false;
                continue;
            }
        }
        let result = host.receive(&frame, || next_nonce(&mut nonce_seq), &mut wbuf);
        match &result {
            Ok(HostReceived::Announce { welcome_len, .. }) => {
                assert!(*welcome_len <= MAX_DATAGRAM);
                let w = wbuf[..*welcome_len].to_vec();
                let (_, m) = open::<HostMsg>(&hello, &w).expect("the host's welcome opens");
                assert!(m.is_hello());
                last_welcome = Some(w);
            }
            Ok(HostReceived::Message(h, msg)) => {
                assert!(msg.validate());
                assert!(!msg.is_hello());
                let Some(genuine_epoch) = sent.iter().find(|(_, f)| *f == frame).map(|(e, _)| *e)
                else {
                    panic!("a frame the robot never sealed was accepted");
                };
                assert!(
                    accepted.insert((genuine_epoch, h.counter)),
                    "counter {} of robot boot {genuine_epoch} accepted twice",
                    h.counter
                );
                if genuine_epoch == epoch {
                    linked = true;
                }
            }
            Err(_) => {}
        }
        if linked {
            // The proven session still carries commands to the current robot.
            let n = host
                .send(&HostMsg::Stop, &mut buf)
                .expect("host seals under its session");
            let r = robot.receive(&buf[..n]);
            assert!(r.is_ok(), "the proven session was displaced: {r:?}");
        }
    }
}
