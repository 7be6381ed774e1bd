#![no_main]
//! cargo-fuzz target: see `src/harness/robot_session.rs` (`fuzz_robot_session`).
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    puzzlebot_protocol_fuzz::harness::fuzz_robot_session(data);
});
