#![no_main]
//! cargo-fuzz target: see `src/harness/decoders.rs` (`fuzz_poses`).
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    puzzlebot_protocol_fuzz::harness::fuzz_poses(data);
});
