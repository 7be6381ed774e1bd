//! Fuzz harness shared by the cargo-fuzz targets (`protocol/fuzz/fuzz_targets/*.rs`) and by
//! the stable regression test (`protocol/tests/fuzz_regression.rs`, which includes this file).
//!
//! Every entry point takes arbitrary bytes, drives the real decoder / session code with
//! them and checks invariants; a broken invariant panics (that is how the fuzzer reports it).
//!
//! Two kinds of input reach the decoders:
//! - raw bytes, exactly as an attacker on the network could send them;
//! - structure-aware mutations: a genuine sealed frame (every message variant) with a short
//!   program of edits applied (flip, set, insert, delete, truncate, append, counter rewrite)
//!   and optionally a *re-computed tag* under the real key, so the fuzzer gets past
//!   authentication and exercises payload decoding and the session state machines.
//!
//! The invariants checked:
//! - nothing panics; decoders never accept a frame longer than `MAX_DATAGRAM`;
//! - a frame that was not re-tagged is accepted only if it is byte-identical to a genuine
//!   frame of the current session that was not accepted before (no forgery, no replay);
//! - no counter is ever accepted twice within one session (replay window);
//! - an accepted message passes its own validation and re-encodes to an equal message;
//! - a proven host session is never displaced by replayed, forged or mutated frames.

#![allow(dead_code)]

use std::collections::HashSet;

use puzzlebot_protocol::pose::{decode_poses, encode_poses, BodyPose, POSE_BODY_LEN};
use puzzlebot_protocol::pose::{MAX_POSE_DATAGRAM, POSE_HEADER_LEN};
use puzzlebot_protocol::session::HostReceived;
use puzzlebot_protocol::{
    open, peek_header, seal, Announce, Direction, FirmwareVersion, FleetKey, Header, HostMsg,
    HostSession, Message, Nonce, ParamRejection, ParamSet, PiGains, ResetReason, RobotKey,
    RobotKind, RobotMsg, RobotSession, SessionKey, Stream, Telemetry, HEADER_LEN, MAX_DATAGRAM,
    TAG_LEN,
};

/// Robot id used by every harness.
pub const ROBOT_ID: u16 = 7;

/// The fleet key of the harness (a fixed test key).
pub fn fleet_key() -> FleetKey {
    FleetKey([0x5a; 32])
}

/// The harness robot's key.
pub fn robot_key() -> RobotKey {
    fleet_key().robot_key(ROBOT_ID)
}

/// A robot key that depends on the whole fuzz input.
///
/// With a fixed key the fuzzer can learn a genuine tag from one execution (comparison
/// tracing sees it) and replay it in the next, where that frame was not yet sealed: a
/// "forgery" no network attacker could make. Keying each execution by its own input makes
/// every tag unpredictable to the fuzzer, as it is to an attacker without the fleet key.
pub fn input_key(data: &[u8]) -> RobotKey {
    let k = robot_key().hello_key();
    let a = k.tag(data);
    let b = k.tag(&a);
    let mut fleet = [0u8; 32];
    fleet[..16].copy_from_slice(&a);
    fleet[16..].copy_from_slice(&b);
    FleetKey(fleet).robot_key(ROBOT_ID)
}

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
fn session_samples_host() -> Vec<HostMsg> {
    host_samples()
        .into_iter()
        .filter(|m| !m.is_hello())
        .collect()
}

fn session_samples_robot() -> Vec<RobotMsg> {
    robot_samples()
        .into_iter()
        .filter(|m| !m.is_hello())
        .collect()
}

/// A cursor over fuzz input; every read returns `None` once the input is used up.
pub struct Input<'a> {
    data: &'a [u8],
}

impl<'a> Input<'a> {
    /// Wrap `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Input { data }
    }
    /// Next byte.
    pub fn byte(&mut self) -> Option<u8> {
        let (&b, rest) = self.data.split_first()?;
        self.data = rest;
        Some(b)
    }
    /// Up to `n` next bytes.
    pub fn take(&mut self, n: usize) -> &'a [u8] {
        let n = n.min(self.data.len());
        let (a, b) = self.data.split_at(n);
        self.data = b;
        a
    }
    /// A nonce (zero-padded when input runs out).
    pub fn nonce(&mut self) -> Nonce {
        let mut n = [0u8; 16];
        let t = self.take(16);
        n[..t.len()].copy_from_slice(t);
        n
    }
}

/// Apply a short edit program from `inp` to `frame`; returns true when the program asked
/// for the tag to be recomputed (then `retag` must be applied by the caller).
fn mutate(inp: &mut Input<'_>, frame: &mut Vec<u8>) -> bool {
    let ops = inp.byte().unwrap_or(1) % 4 + 1;
    let mut retag = false;
    for _ in 0..ops {
        let Some(op) = inp.byte() else { break };
        let pos = inp.byte().unwrap_or(0) as usize;
        let val = inp.byte().unwrap_or(0);
        let len = frame.len();
        match op % 9 {
            0 if len > 0 => frame[pos % len] ^= 1 << (val % 8),
            1 if len > 0 => frame[pos % len] = val,
            2 => frame.insert(pos % (len + 1), val),
            3 if len > 0 => {
                frame.remove(pos % len);
            }
            4 => frame.truncate(pos % (len + 1)),
            5 => frame.extend(std::iter::repeat_n(val, pos % 8 + 1)),
            6 if len >= HEADER_LEN => {
                // Rewrite the 48-bit counter (little-endian) with a small or large value.
                let c: u64 = if val & 1 == 0 {
                    (pos as u64) >> 1
                } else {
                    (1u64 << 48) - 1 - pos as u64
                };
                frame[4..10].copy_from_slice(&c.to_le_bytes()[..6]);
            }
            7 => retag = true,
            // Swap the direction / stream flag bits.
            8 if len > 1 => frame[1] ^= val & 3,
            _ => {}
        }
    }
    retag
}

/// A fresh host nonce per call (unique within one execution).
fn next_host_nonce(seq: &mut u32) -> Nonce {
    *seq += 1;
    let mut n = [0xC3; 16];
    n[..4].copy_from_slice(&seq.to_le_bytes());
    n
}

/// Replace the last `TAG_LEN` bytes of `frame` with a valid tag under `key`
/// (frames shorter than a header plus one payload byte are left alone).
fn retag(key: &SessionKey, frame: &mut [u8]) {
    if frame.len() < HEADER_LEN + TAG_LEN + 1 {
        return;
    }
    let body = frame.len() - TAG_LEN;
    let t = key.tag(&frame[..body]);
    frame[body..].copy_from_slice(&t);
}

/// The numeric bounds an accepted host message must respect, computed independently of
/// `HostMsg::validate` (in wide integers, so no overflow can hide a violation).
pub fn check_host_bounds(msg: &HostMsg) {
    match *msg {
        HostMsg::WheelSpeed {
            left_rpm,
            right_rpm,
        } => {
            for v in [left_rpm, right_rpm] {
                assert!(
                    v.is_finite() && f64::from(v).abs() <= 1000.0,
                    "wheel speed {v}"
                );
            }
        }
        HostMsg::RawDuty { left, right } => {
            for d in [left, right] {
                assert!(i32::from(d).abs() <= 1000, "duty {d}");
            }
        }
        _ => {}
    }
}

/// Re-seal an accepted message with its header and check it opens to the same message.
fn check_reencodes<M: Message + core::fmt::Debug>(key: &SessionKey, h: Header, msg: &M) {
    assert!(msg.valid(), "accepted an invalid message {msg:?}");
    let mut out = [0u8; MAX_DATAGRAM];
    let n = seal(key, h, msg, &mut out).expect("an accepted message re-seals");
    let (h2, m2) = open::<M>(key, &out[..n]).expect("a re-sealed message opens");
    assert_eq!(h, h2);
    let a = postcard::to_allocvec(msg).expect("encode");
    let b = postcard::to_allocvec(&m2).expect("encode");
    assert_eq!(a, b, "message changed through seal/open");
}

/// Envelope decoder: `peek_header` and `open` of both message types on raw bytes, then the
/// same bytes with a valid tag appended so payload decoding is reached.
pub fn fuzz_envelope(data: &[u8]) {
    let key = input_key(data).session_key(&[3; 16], &[4; 16]);
    let peek = peek_header(data);
    let hm = open::<HostMsg>(&key, data);
    let rm = open::<RobotMsg>(&key, data);
    if data.len() > MAX_DATAGRAM {
        assert!(peek.is_err() && hm.is_err() && rm.is_err());
    }
    // A fuzzer cannot forge HMAC-SHA256: raw input never authenticates.
    assert!(hm.is_err() && rm.is_err(), "forged frame accepted");

    // Structure-aware: treat the input as header + payload and tag it with the real key.
    let body_len = data.len().min(MAX_DATAGRAM - TAG_LEN);
    let mut frame = data[..body_len].to_vec();
    frame.extend_from_slice(&key.tag(&frame));
    let header = peek_header(&frame);
    if let Ok((h, m)) = open::<HostMsg>(&key, &frame) {
        assert_eq!(Ok(h), header);
        assert_eq!(h.direction, Direction::HostToRobot);
        check_host_bounds(&m);
        assert_eq!(h.stream == Stream::Hello, m.is_hello());
        check_reencodes(&key, h, &m);
    }
    if let Ok((h, m)) = open::<RobotMsg>(&key, &frame) {
        assert_eq!(Ok(h), header);
        assert_eq!(h.direction, Direction::RobotToHost);
        assert_eq!(h.stream == Stream::Hello, m.is_hello());
        check_reencodes(&key, h, &m);
    }
}

/// Pose stream decoder: never panics, delivers exactly `count` bodies, and what it accepts
/// re-encodes to an equal datagram (up to unused flag bits).
pub fn fuzz_poses(data: &[u8]) {
    let mut got: Vec<BodyPose> = Vec::new();
    let r = decode_poses(data, |b| got.push(b));
    match r {
        Ok(h) => {
            assert_eq!(got.len(), h.count);
            assert_eq!(data.len(), POSE_HEADER_LEN + h.count * POSE_BODY_LEN);
            let mut out = vec![0u8; MAX_POSE_DATAGRAM];
            let n = encode_poses(h.time_us, h.frame, &got, &mut out);
            assert_eq!(n, data.len());
            let mut again = Vec::new();
            let h2 = decode_poses(&out[..n], |b| again.push(b)).expect("re-encoded poses decode");
            assert_eq!(h, h2);
            assert_eq!(got, again);
        }
        Err(_) => assert!(got.is_empty(), "bodies delivered from a rejected datagram"),
    }
}

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
