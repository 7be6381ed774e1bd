//! A simulated assembly run's report: the simulator's ground truth (final poses, couplings,
//! falls) the host's view is checked against, and its telemetry records.

use puzzlebot_protocol::messages::RobotId;

use super::controller::AssemblyController;
use super::report::{AssemblyReport, TruthCoupling, TruthRecord};
use crate::control::RunSummary;
use crate::replay::timeline::Kind;
use crate::report::RunFolder;

impl TruthRecord {
    /// The record of robot truth `r` at controller time `t`.
    pub fn of(t: f64, r: &puzzlebot_sim::RobotTruth) -> TruthRecord {
        TruthRecord {
            t,
            robot: r.id,
            truth: [r.pose.x, r.pose.y, r.pose.yaw],
            v: r.v,
            omega: r.omega,
            wheel_rpm: r.wheel_rpm,
            duty: Some(r.duty),
        }
    }
}

/// The report of a run of `ctl` recorded in `folder`, with the simulator's ground truth.
pub(crate) fn report_of(
    folder: &RunFolder,
    ctl: &AssemblyController,
    summary: RunSummary,
    truth: &puzzlebot_sim::GroundTruth,
) -> AssemblyReport {
    let final_poses = truth
        .robots
        .iter()
        .map(|r| (r.id, [r.pose.x, r.pose.y, r.pose.yaw]))
        .collect();
    let ids: Vec<RobotId> = truth.robots.iter().map(|r| r.id).collect();
    let mut coupled_truth = Vec::new();
    for &a in &ids {
        for &b in &ids {
            if a != b && truth.are_coupled(a, b) {
                coupled_truth.push((a, b));
            }
        }
    }
    let coupling_truth = truth
        .events
        .iter()
        .filter_map(|e| {
            let (coupled, kind, a, b) = match e.kind {
                puzzlebot_sim::EventKind::Coupled { kind, a, b } => (true, kind, a, b),
                puzzlebot_sim::EventKind::Decoupled { kind, a, b } => (false, kind, a, b),
                _ => return None,
            };
            Some(TruthCoupling {
                t_sim: e.t_us as f64 * 1e-6,
                coupled,
                kind: match kind {
                    puzzlebot_sim::LinkKind::Anchor => Kind::Anchor,
                    puzzlebot_sim::LinkKind::Knob => Kind::Knob,
                },
                a,
                b,
            })
        })
        .collect();
    AssemblyReport {
        folder: folder.dir().to_path_buf(),
        coupling_truth,
        state: ctl.state().clone(),
        events: ctl.events.clone(),
        gate_stops: ctl.gate_stops.clone(),
        summary,
        final_poses,
        coupled_truth,
        mpc_failures: ctl.mpc_failures,
        mpc_failure_reasons: ctl.mpc_failure_reasons.clone(),
        fallen: truth
            .robots
            .iter()
            .filter(|r| r.fallen)
            .map(|r| r.id)
            .collect(),
    }
}
