//! PuzzleBot host: fleet link, pose input, drive mapping, control loop, calibration,
//! run folders and the `puzzlebot` CLI (DESIGN.md §3, §7).
//!
//! The simulator and everything that runs on it (the in-process simulated fleet, lockstep
//! runs, experiments, the demo) sit behind the cargo feature `sim`, on by default; build with
//! `--no-default-features` for a lean daemon that drives real robots.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod app;
pub mod assemble;
pub mod calibrate;
pub mod config;
pub mod control;
#[cfg(feature = "sim")]
pub mod crossing;
pub mod drive;
#[cfg(feature = "sim")]
pub mod experiment;
pub mod fleet_provision;
pub mod fleet_setup;
pub mod fleet_update;
pub mod link;
pub mod live;
#[cfg(feature = "sim")]
pub mod lockstep;
pub mod pose;
pub mod preflight;
pub mod record;
pub mod replay;
pub mod report;
#[cfg(feature = "sim")]
pub mod simulated;
