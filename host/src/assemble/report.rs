//! What an assembly run leaves behind: its report, the event files of its run folder and its
//! summary on the console (the simulator's ground truth a simulated run is checked against:
//! [`super::truth`]).

use std::collections::BTreeMap;
use std::path::PathBuf;

use puzzlebot_assembly::{Event, RunState};
use puzzlebot_protocol::messages::RobotId;
use serde::Serialize;

use super::controller::AssemblyController;
use super::gate::GateStop;
use crate::control::RunSummary;
use crate::report::RunFolder;

/// What `puzzlebot run SCENARIO.toml` left behind.
#[derive(Debug, Clone, Serialize)]
pub struct AssemblyReport {
    /// Run folder.
    pub folder: PathBuf,
    /// Final scenario state.
    pub state: RunState,
    /// Coordinator events (also in `events.jsonl` / `assembly_events.jsonl`).
    pub events: Vec<Event>,
    /// Gate stops.
    pub gate_stops: Vec<GateStop>,
    /// Loop summary.
    #[serde(skip)]
    pub summary: RunSummary,
    /// Final ground-truth poses (simulated runs).
    pub final_poses: BTreeMap<RobotId, [f64; 3]>,
    /// Pairs coupled in the simulator's ground truth at the end (a, b).
    pub coupled_truth: Vec<(RobotId, RobotId)>,
    /// Every coupling and decoupling in the simulator's ground truth, in order: what the
    /// host's pair status changes (`events`) can be checked against.
    pub coupling_truth: Vec<TruthCoupling>,
    /// MPC ticks with a failed solve.
    pub mpc_failures: u64,
    /// Robots that fell (simulator ground truth).
    pub fallen: Vec<RobotId>,
    /// Failed MPC solves by reason.
    pub mpc_failure_reasons: BTreeMap<String, u64>,
}

/// A coupling or decoupling in the simulator's ground truth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TruthCoupling {
    /// Simulator time (s since the simulated fleet started).
    pub t_sim: f64,
    /// Coupled (true) or came apart (false).
    pub coupled: bool,
    /// Anchor or knob.
    pub kind: crate::replay::timeline::Kind,
    /// Robot with the anchor / knob.
    pub a: RobotId,
    /// Robot with the opening / hole.
    pub b: RobotId,
}

/// One robot's ground truth at one sample of a lockstep run (`telemetry.jsonl`; a real-time
/// run's records also carry the link's telemetry, see `control.rs`).
#[derive(Debug, Serialize)]
pub struct TruthRecord {
    /// Controller time (s).
    pub t: f64,
    /// Robot.
    pub robot: RobotId,
    /// Pose [x, y, θ] (m, m, rad).
    pub truth: [f64; 3],
    /// Forward speed (m/s).
    pub v: f64,
    /// Turn rate (rad/s).
    pub omega: f64,
    /// Wheel speeds (RPM).
    pub wheel_rpm: [f64; 2],
    /// Motor duty (per mille); none from the 3-D world, which does not report it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub duty: Option<[i16; 2]>,
}

/// The report of a run of `ctl` on real robots recorded in `folder`: no ground truth, the
/// final poses are the last measured ones.
pub(crate) fn report_measured(
    folder: &RunFolder,
    ctl: &AssemblyController,
    summary: RunSummary,
    final_poses: BTreeMap<RobotId, [f64; 3]>,
) -> AssemblyReport {
    AssemblyReport {
        folder: folder.dir().to_path_buf(),
        coupling_truth: Vec::new(),
        state: ctl.state().clone(),
        events: ctl.events.clone(),
        gate_stops: ctl.gate_stops.clone(),
        summary,
        final_poses,
        coupled_truth: Vec::new(),
        mpc_failures: ctl.mpc_failures,
        mpc_failure_reasons: ctl.mpc_failure_reasons.clone(),
        fallen: Vec::new(),
    }
}

/// Every coordinator event and gate stop of `ctl` into the run folder's `events.jsonl`, and
/// the coordinator events alone into `assembly_events.jsonl`.
pub(crate) fn write_events(folder: &mut RunFolder, ctl: &AssemblyController) -> anyhow::Result<()> {
    #[derive(Serialize)]
    struct GateRec<'a> {
        t: f64,
        event: &'static str,
        #[serde(flatten)]
        stop: &'a GateStop,
    }
    let mut lines = String::new();
    for e in &ctl.events {
        folder.event(e)?;
        lines.push_str(&serde_json::to_string(e)?);
        lines.push('\n');
    }
    for g in &ctl.gate_stops {
        let rec = GateRec {
            t: g.t,
            event: "gate_stop",
            stop: g,
        };
        folder.event(&rec)?;
        lines.push_str(&serde_json::to_string(&rec)?);
        lines.push('\n');
    }
    std::fs::write(folder.dir().join("assembly_events.jsonl"), lines)?;
    Ok(())
}

/// Human-readable summary of an assembly run.
pub fn describe(r: &AssemblyReport) -> String {
    let mut s = format!(
        "run folder: {}\nscenario state: {:?}\n",
        r.folder.display(),
        r.state
    );
    for e in &r.events {
        if let Ok(j) = serde_json::to_string(e) {
            s.push_str(&format!("  {j}\n"));
        }
    }
    for g in &r.gate_stops {
        s.push_str(&format!(
            "  t={:.2} s gate stopped {:?}: safe advance {:.4} m along {:.1}°, {:?}\n",
            g.t,
            g.robots,
            g.safe_advance,
            g.heading.to_degrees(),
            g.limited_by
        ));
    }
    s.push_str(&format!(
        "ground-truth couplings at the end: {:?}\nMPC ticks with a failed solve: {}\n",
        r.coupled_truth, r.mpc_failures
    ));
    for (why, n) in &r.mpc_failure_reasons {
        s.push_str(&format!("  {n} × {why}\n"));
    }
    s
}
