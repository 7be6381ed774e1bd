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

mod decoders;
mod host_session;
mod input;
mod robot_session;
mod samples;

pub use decoders::{fuzz_envelope, fuzz_poses};
pub use host_session::fuzz_host_session;
pub use input::Input;
pub use robot_session::fuzz_robot_session;
pub use samples::{host_samples, robot_samples};

use puzzlebot_protocol::{
    open, seal, FleetKey, Header, HostMsg, Message, RobotKey, SessionKey, MAX_DATAGRAM,
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

/// The numeric bounds an accepted host message must respect, computed independently of
/// `HostMsg::validate` (in wide integers, so no overflow can hide a violation).
pub fn check_host_bounds(msg: &HostMsg) {
    match *msg {
        HostMsg::WheelSpeed {
            left_rpm,
            right_rpm,
        }
        | HostMsg::WheelSpeedHold {
            left_rpm,
            right_rpm,
            ..
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
