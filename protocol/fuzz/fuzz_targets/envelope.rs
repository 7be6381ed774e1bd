#![no_main]
//! cargo-fuzz target: see `src/harness/decoders.rs` (`fuzz_envelope`).
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    puzzlebot_protocol_fuzz::harness::fuzz_envelope(data);
});
