//! Recording lockstep runs: [`recording`] installs a [`Recorder`] on this thread for the
//! duration of a closure, and every lockstep run inside it feeds the recorder each command
//! period ([`observe`]).

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use puzzlebot_protocol::{HostMsg, RobotId};
use puzzlebot_sim::World;

use super::Recorder;
use crate::assemble::AssemblyReport;
use crate::control::FleetView;

thread_local! {
    static TAP: RefCell<Option<Recorder>> = const { RefCell::new(None) };
}

/// Run `f` with `rec` recording every lockstep run on this thread; returns `f`'s result and
/// the recorder.
pub fn recording<R>(rec: Recorder, f: impl FnOnce() -> R) -> (R, Recorder) {
    /// Removes the recorder even when `f` panics.
    struct Clear;
    impl Drop for Clear {
        fn drop(&mut self) {
            TAP.with(|t| t.borrow_mut().take());
        }
    }
    TAP.with(|t| *t.borrow_mut() = Some(rec));
    let clear = Clear;
    let out = f();
    let rec = TAP.with(|t| t.borrow_mut().take());
    drop(clear);
    (
        out,
        rec.expect("the recorder stays installed while `f` runs"),
    )
}

/// Called by the lockstep loop once per command period at controller time `t` (a no-op
/// unless [`recording`] is running on this thread).
pub(crate) fn observe(t: f64, world: &World, view: &FleetView, sent: &[(RobotId, HostMsg)]) {
    TAP.with(|tap| {
        if let Some(rec) = tap.borrow_mut().as_mut() {
            rec.sample(t, world, view, sent);
        }
    });
}

/// The lockstep run on this thread moves to the 3-D world on `terrain` (a no-op unless
/// [`recording`] is running on this thread).
pub(crate) fn enter_3d(terrain: &puzzlebot_params::terrain::Terrain) {
    TAP.with(|tap| {
        if let Some(rec) = tap.borrow_mut().as_mut() {
            rec.enter_3d(terrain);
        }
    });
}

/// Called once per controller period of the 3-D part of a lockstep run at controller time
/// `t` (a no-op unless [`recording`] is running on this thread).
pub(crate) fn observe_3d(t: f64, world: &puzzlebot_sim::physics3d::World3d) {
    TAP.with(|tap| {
        if let Some(rec) = tap.borrow_mut().as_mut() {
            rec.sample_3d(t, world);
        }
    });
}

/// [`crate::assemble::run_scenario_lockstep`], recorded: the run folder also gets
/// `run.mcap`. Returns the report and the recording's path.
pub fn run_scenario_lockstep(
    scenario: puzzlebot_assembly::Scenario,
    sim: puzzlebot_sim::Scenario,
    runs_dir: &Path,
    max_duration: f64,
) -> anyhow::Result<(AssemblyReport, PathBuf)> {
    let rec = Recorder::new(&sim);
    let (report, rec) = recording(rec, || {
        crate::assemble::run_scenario_lockstep(scenario, sim, runs_dir, max_duration)
    });
    let report = report?;
    let path = rec.finish(&report)?;
    Ok((report, path))
}
