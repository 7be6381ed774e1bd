//! Recordings of runs: `run.mcap` in the run folder (host README, "Recording"), JSON
//! messages with Foxglove's well-known schemas so Foxglove opens it without set-up.
//!
//! Lockstep runs of the simulator are recorded (feature `sim`): [`recording`] installs a
//! [`Recorder`] for the duration of a closure on the thread it is started on, and every
//! lockstep run inside it feeds the recorder each command period. Runs on other threads
//! (parallel experiment episodes) are not recorded. Reading a recording back ([`read`]) and
//! the schemas ([`foxglove`]) need no simulator.

pub mod foxglove;
pub mod read;
#[cfg(feature = "sim")]
pub mod recorder;
#[cfg(feature = "sim")]
mod tap;

pub use read::{Recording, RunInfo, RUN_ATTACHMENT};
#[cfg(feature = "sim")]
pub use recorder::{Recorder, SAMPLE_PERIOD};
#[cfg(feature = "sim")]
pub(crate) use tap::{enter_3d, observe, observe_3d};
#[cfg(feature = "sim")]
pub use tap::{recording, run_scenario_lockstep};

/// File name of a run folder's recording.
pub const RUN_MCAP: &str = "run.mcap";
