//! Experiments run in the lockstep simulator: THESIS 5.2.3's coupling experiment
//! ([`coupling`]) and randomized assembly episodes ([`assemblies`]: the measure of whether
//! assemblies form, move and dissolve from any start).

pub mod assemblies;
pub mod coupling;
pub mod cross_step;
pub mod crossing;
pub mod crossing_regate;
pub mod crossing_report;
pub mod episode;
pub mod tip_point;
pub mod verdict;
pub mod workers;

pub use coupling::*;
