//! Stable-toolchain fallback for the cargo-fuzz targets: the very same harness functions
//! (`protocol/fuzz/src/harness/`) run over the committed seed corpus
//! (`protocol/fuzz/seeds/<target>/`) and a few thousand deterministic pseudo-random
//! inputs (fresh bytes and mutations of the seeds), so CI exercises the fuzzed code paths
//! and their invariants without nightly.
//!
//! Regenerate the seeds (after a message change):
//! `PUZZLEBOT_WRITE_SEEDS=1 cargo test -p puzzlebot-protocol --test fuzz_regression -- --ignored write_seeds`

#[path = "../fuzz/src/harness/mod.rs"]
mod harness;

use std::fs;
use std::path::PathBuf;

use puzzlebot_protocol::pose::{encode_poses, BodyPose, MAX_POSE_DATAGRAM};
use puzzlebot_protocol::{open, seal, Header, HostMsg, Message, RobotMsg, Stream};
use puzzlebot_protocol::{MAX_DATAGRAM, TAG_LEN};

fn seed_dir(target: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz")
        .join("seeds")
        .join(target)
}

fn seeds(target: &str) -> Vec<Vec<u8>> {
    let dir = seed_dir(target);
    let mut files: Vec<_> = fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("seed folder {}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    files.sort();
    let out: Vec<Vec<u8>> = files
        .iter()
        .map(|p| fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))
        .collect();
    assert!(!out.is_empty(), "no seeds in {}", dir.display());
    out
}

/// xorshift64*: deterministic, dependency-free.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// Seeds as they are, then `n` inputs: half fresh random bytes, half seeds with a few
/// random byte edits (the cheap half of what libFuzzer does).
fn run(target: &str, n: usize, max_len: usize, f: fn(&[u8])) {
    let seeds = seeds(target);
    for s in &seeds {
        f(s);
    }
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ target.len() as u64);
    for i in 0..n {
        let mut input = if i % 2 == 0 {
            let len = rng.below(max_len + 1);
            (0..len).map(|_| rng.next() as u8).collect::<Vec<u8>>()
        } else {
            seeds[rng.below(seeds.len())].clone()
        };
        for _ in 0..rng.below(4) {
            if input.is_empty() {
                break;
            }
            let p = rng.below(input.len());
            match rng.below(3) {
                0 => input[p] ^= 1 << rng.below(8),
                1 => input[p] = rng.next() as u8,
                _ => input.insert(p, rng.next() as u8),
            }
        }
        f(&input);
    }
}

#[test]
fn envelope_seeds_and_random_inputs() {
    run("envelope", 20000, 160, harness::fuzz_envelope);
}

#[test]
fn robot_session_seeds_and_random_inputs() {
    run("robot_session", 20000, 200, harness::fuzz_robot_session);
}

#[test]
fn host_session_seeds_and_random_inputs() {
    run("host_session", 20000, 200, harness::fuzz_host_session);
}

#[test]
fn pose_seeds_and_random_inputs() {
    run("poses", 20000, 200, harness::fuzz_poses);
}

/// The envelope seeds reach the payload decoder: each one, tagged with the harness key,
/// opens as exactly one message (otherwise the invariants would be checked on nothing).
#[test]
fn envelope_seeds_decode_every_variant() {
    let key = harness::robot_key().session_key(&[3; 16], &[4; 16]);
    let mut host_ok = 0;
    let mut robot_ok = 0;
    for s in seeds("envelope") {
        let body = &s[..s.len().min(MAX_DATAGRAM - TAG_LEN)];
        let mut frame = body.to_vec();
        frame.extend_from_slice(&key.tag(body));
        host_ok += usize::from(open::<HostMsg>(&key, &frame).is_ok());
        robot_ok += usize::from(open::<RobotMsg>(&key, &frame).is_ok());
    }
    assert_eq!(host_ok, harness::host_samples().len());
    assert_eq!(robot_ok, harness::robot_samples().len());
}

fn body_of<M: Message>(msg: &M, hello: bool) -> Vec<u8> {
    let key = harness::robot_key().session_key(&[3; 16], &[4; 16]);
    let header = Header {
        direction: M::DIRECTION,
        stream: if hello {
            Stream::Hello
        } else {
            Stream::Session
        },
        robot_id: harness::ROBOT_ID,
        counter: 5,
    };
    let mut out = [0u8; MAX_DATAGRAM];
    let n = seal(&key, header, msg, &mut out).expect("seal");
    out[..n - TAG_LEN].to_vec()
}

/// Writes the seed corpus (run by hand, see the file header).
#[test]
#[ignore = "writes files; run by hand to regenerate the seed corpus"]
fn write_seeds() {
    if std::env::var_os("PUZZLEBOT_WRITE_SEEDS").is_none() {
        return;
    }
    let write = |target: &str, name: &str, bytes: &[u8]| {
        let dir = seed_dir(target);
        fs::create_dir_all(&dir).expect("create seed dir");
        fs::write(dir.join(name), bytes).expect("write seed");
    };
    // Envelope: header + payload of every variant (the harness appends a valid tag).
    for (i, m) in harness::host_samples().iter().enumerate() {
        write("envelope", &format!("host-{i}"), &body_of(m, m.is_hello()));
    }
    for (i, m) in harness::robot_samples().iter().enumerate() {
        write("envelope", &format!("robot-{i}"), &body_of(m, m.is_hello()));
    }
    write("envelope", "short-header", &[1, 3, 7, 0, 0, 0, 0, 0, 0, 0]);

    // Robot session programs (op codes: see fuzz_robot_session).
    let robot_programs: [(&str, Vec<u8>); 8] = [
        (
            "send-each",
            vec![
                1, 0, 0, 1, 1, 0, 1, 2, 0, 1, 3, 0, 1, 4, 0, 1, 5, 0, 1, 6, 0,
            ],
        ),
        ("replay", vec![1, 0, 0, 2, 0, 2, 0]),
        ("reorder", vec![1, 0, 1, 1, 1, 0, 2, 0, 2, 0]),
        (
            "mutate",
            vec![1, 0, 1, 3, 0, 2, 0, 3, 1, 3, 20, 4, 4, 30, 0],
        ),
        ("retag", vec![1, 0, 1, 3, 0, 2, 1, 3, 0, 7, 0, 0]),
        (
            "old-welcome",
            vec![
                5, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 4, 0, 4, 1,
            ],
        ),
        (
            "restart-replay",
            vec![
                1, 0, 0, 5, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 9, 2, 0,
            ],
        ),
        ("raw", vec![0, 12, 1, 3, 7, 0, 9, 9, 9, 9, 9, 9, 9, 9]),
    ];
    for (name, p) in &robot_programs {
        write("robot_session", name, p);
    }
    // Host session programs (op codes: see fuzz_host_session).
    let host_programs: [(&str, Vec<u8>); 8] = [
        ("handshake", vec![2, 5, 1, 0, 0, 1, 1, 0, 1, 2, 0]),
        ("replay", vec![2, 5, 1, 0, 0, 3, 2, 3, 2]),
        (
            "reboot",
            vec![
                2, 5, 1, 0, 1, 6, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 2, 3, 2,
                5, 3, 1,
            ],
        ),
        ("old-announce", vec![2, 5, 1, 0, 1, 3, 0]),
        (
            "forged-announce",
            vec![2, 5, 1, 0, 1, 4, 0, 0, 1, 40, 9, 7, 0, 0],
        ),
        ("host-restart", vec![2, 5, 7, 0, 2, 5, 1, 0, 0]),
        ("mutate", vec![2, 5, 1, 0, 1, 4, 2, 3, 1, 20, 0]),
        (
            "raw",
            vec![
                0, 30, 1, 2, 7, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1,
                1, 1, 1,
            ],
        ),
    ];
    for (name, p) in &host_programs {
        write("host_session", name, p);
    }
    // Poses: empty frame, two bodies, the largest frame.
    let body = |id: u16| BodyPose {
        robot_id: id,
        x: 0.25 * f32::from(id),
        y: -0.5,
        z: 0.0,
        yaw: 1.0,
        tracked: id.is_multiple_of(2),
    };
    let mut out = vec![0u8; MAX_POSE_DATAGRAM];
    for (name, count) in [("empty", 0u16), ("two", 2), ("full", 72)] {
        let bodies: Vec<BodyPose> = (0..count).map(body).collect();
        let n = encode_poses(1_000_000, 42, &bodies, &mut out);
        write("poses", name, &out[..n]);
    }
}
