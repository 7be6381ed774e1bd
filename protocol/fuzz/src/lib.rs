//! Fuzz harness for `puzzlebot-protocol`; the targets in `fuzz_targets/` call [`harness`].
//! The same module is compiled into the stable regression test `protocol/tests/fuzz_regression.rs`.
pub mod harness;
