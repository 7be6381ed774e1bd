//! PuzzleBot host: fleet link, pose input, drive mapping, control loop, calibration,
//! run folders and the `puzzlebot` CLI (DESIGN.md §3, §7).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod app;
pub mod assemble;
pub mod calibrate;
pub mod config;
pub mod control;
pub mod drive;
pub mod experiment;
pub mod fleet_provision;
pub mod fleet_setup;
pub mod fleet_update;
pub mod link;
pub mod lockstep;
pub mod pose;
pub mod preflight;
pub mod record;
pub mod replay;
pub mod report;
pub mod simulated;
