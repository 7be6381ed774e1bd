#![no_main]
//! cargo-fuzz target: see `src/harness/host_session.rs` (`fuzz_host_session`).
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    puzzlebot_protocol_fuzz::harness::fuzz_host_session(data);
});
