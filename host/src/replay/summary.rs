//! The end of an assembly run on the terminal: a short table (or, with `--json`, the same as
//! JSON), numbers rounded to what they mean: times to 0.1 s, distances to 1 mm.

use std::fmt::Write as _;
use std::path::PathBuf;

use puzzlebot_assembly::coordinator::EventKind;
use puzzlebot_assembly::RunState;
use puzzlebot_protocol::RobotId;
use serde::Serialize;

use super::timeline::{Kind, State, Timeline};
use crate::assemble::AssemblyReport;

/// One scenario step.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepRow {
    /// Index (0-based).
    pub index: usize,
    /// Label.
    pub label: String,
    /// Start (s, 0.1 s).
    pub start_s: f64,
    /// End (s, 0.1 s), if it ended.
    pub end_s: Option<f64>,
    /// `done`, `failed: …` or `not finished`.
    pub result: String,
}

/// One robot at the end.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RobotRow {
    /// Robot id.
    pub id: RobotId,
    /// `pilot` or `non-pilot`.
    pub kind: String,
    /// Path length (mm).
    pub travelled_mm: i64,
    /// Final position (mm).
    pub end_mm: [i64; 2],
    /// Final heading (degrees, whole).
    pub end_deg: i64,
    /// Fell (simulator).
    pub fell: bool,
}

/// What a run did, for the terminal.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Run folder.
    pub folder: PathBuf,
    /// `finished`, or why not.
    pub result: String,
    /// Simulated (or driven) time (s, 0.1 s).
    pub run_s: f64,
    /// When the formation completed (s, 0.1 s).
    pub formed_s: Option<f64>,
    /// Pairs of the last plan.
    pub pairs_planned: Option<usize>,
    /// Couplings at the end `(a, b, kind)` (simulator, or the host's view without one).
    pub coupled_at_end: Vec<(RobotId, RobotId, String)>,
    /// Steps.
    pub steps: Vec<StepRow>,
    /// Robots.
    pub robots: Vec<RobotRow>,
    /// Stops by the stability gate.
    pub gate_stops: usize,
    /// MPC ticks with a failed solve.
    pub mpc_failures: u64,
    /// Files worth opening: (what, path).
    pub files: Vec<(String, PathBuf)>,
}

/// `x` to 0.1.
fn tenth(x: f64) -> f64 {
    (x * 10.0).round() / 10.0
}

/// Metres to whole millimetres.
fn mm(x: f64) -> i64 {
    (x * 1e3).round() as i64
}

impl Summary {
    /// The summary of `report`, with robots and couplings from its timeline `tl` and `files`.
    pub fn new(
        report: &AssemblyReport,
        tl: Option<&Timeline>,
        files: Vec<(String, PathBuf)>,
    ) -> Summary {
        let mut steps: Vec<StepRow> = Vec::new();
        let mut formed_s = None;
        let mut pairs_planned = None;
        for e in &report.events {
            match &e.kind {
                EventKind::StepStarted { index, label } => steps.push(StepRow {
                    index: *index,
                    label: label.clone(),
                    start_s: tenth(e.t),
                    end_s: None,
                    result: "not finished".into(),
                }),
                EventKind::StepFinished { index } | EventKind::StepFailed { index, .. } => {
                    if let Some(s) = steps.iter_mut().rev().find(|s| s.index == *index) {
                        s.end_s = Some(tenth(e.t));
                        s.result = match &e.kind {
                            EventKind::StepFailed { reason, .. } => format!("failed: {reason}"),
                            _ => "done".into(),
                        };
                    }
                }
                EventKind::FormationComplete => formed_s = formed_s.or(Some(tenth(e.t))),
                EventKind::Planned { pairs, .. } => pairs_planned = Some(*pairs),
                _ => {}
            }
        }
        let result = match &report.state {
            RunState::Finished => "finished".to_string(),
            RunState::Failed { index, reason } => format!("failed at step {index}: {reason}"),
            RunState::Running { index } => format!("stopped at step {index} (time limit)"),
        };
        let last_event = report.events.last().map_or(0.0, |e| e.t);
        let mut robots = Vec::new();
        let mut coupled_at_end: Vec<(RobotId, RobotId, String)> = Vec::new();
        if let Some(tl) = tl {
            for b in &tl.bodies {
                let path: Vec<[f64; 3]> = tl
                    .samples
                    .iter()
                    .filter_map(|s| s.poses.get(&b.id).copied())
                    .collect();
                let travelled: f64 = path
                    .windows(2)
                    .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
                    .sum();
                // The run's own end (a run that went on in the 3-D world ends there).
                let end = report
                    .final_poses
                    .get(&b.id)
                    .copied()
                    .or(path.last().copied())
                    .unwrap_or_default();
                robots.push(RobotRow {
                    id: b.id,
                    kind: match b.kind {
                        puzzlebot_params::RobotKind::Pilot => "pilot".into(),
                        puzzlebot_params::RobotKind::NonPilot => "non-pilot".into(),
                    },
                    travelled_mm: mm(travelled),
                    end_mm: [mm(end[0]), mm(end[1])],
                    end_deg: end[2].to_degrees().round() as i64,
                    fell: report.fallen.contains(&b.id),
                });
            }
            if let Some(s) = tl.samples.last() {
                coupled_at_end = s
                    .couplings
                    .iter()
                    .filter(|c| c.state == State::Coupled)
                    .map(|c| {
                        let k = match c.kind {
                            Kind::Anchor => "anchor",
                            Kind::Knob => "knob",
                        };
                        (c.a, c.b, k.to_string())
                    })
                    .collect();
            }
        } else {
            coupled_at_end = report
                .coupled_truth
                .iter()
                .map(|&(a, b)| (a, b, String::new()))
                .collect();
        }
        Summary {
            folder: report.folder.clone(),
            result,
            run_s: tenth(tl.map_or(last_event, |tl| tl.end().max(last_event))),
            formed_s,
            pairs_planned,
            coupled_at_end,
            steps,
            robots,
            gate_stops: report.gate_stops.len(),
            mpc_failures: report.mpc_failures,
            files,
        }
    }

    /// The summary as a short table.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "run        {}", self.folder.display());
        let _ = writeln!(s, "result     {} ({:.1} s)", self.result, self.run_s);
        let formed = match (self.formed_s, self.pairs_planned) {
            (Some(t), Some(n)) => format!("complete at {t:.1} s · {n} pairs"),
            (Some(t), None) => format!("complete at {t:.1} s"),
            (None, _) => "not complete".into(),
        };
        let _ = writeln!(s, "formation  {formed}");
        let coupled = if self.coupled_at_end.is_empty() {
            "none".to_string()
        } else {
            self.coupled_at_end
                .iter()
                .map(|(a, b, k)| format!("{a}–{b} {k}").trim_end().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(s, "coupled    {coupled} at the end");
        if self.gate_stops > 0 || self.mpc_failures > 0 {
            let _ = writeln!(
                s,
                "stops      {} by the gate · {} MPC ticks without a solution",
                self.gate_stops, self.mpc_failures
            );
        }
        if !self.steps.is_empty() {
            let w = self.steps.iter().map(|r| r.label.chars().count()).max();
            let w = w.unwrap_or(0).max(4);
            let _ = writeln!(s, "\n  # {:<w$}   start     end  result", "step");
            for r in &self.steps {
                let end = r.end_s.map_or("-".to_string(), |t| format!("{t:.1} s"));
                let _ = writeln!(
                    s,
                    "{:>3} {:<w$} {:>6.1} s {:>7}  {}",
                    r.index, r.label, r.start_s, end, r.result
                );
            }
        }
        if !self.robots.is_empty() {
            let _ = writeln!(
                s,
                "\nrobot  kind       travelled     end x     end y  heading"
            );
            for r in &self.robots {
                let _ = writeln!(
                    s,
                    "{:>5}  {:<9} {:>7} mm {:>6} mm {:>6} mm {:>6}°{}",
                    r.id,
                    r.kind,
                    r.travelled_mm,
                    r.end_mm[0],
                    r.end_mm[1],
                    r.end_deg,
                    if r.fell { "  fell" } else { "" }
                );
            }
        }
        if !self.files.is_empty() {
            s.push('\n');
            for (what, p) in &self.files {
                let _ = writeln!(s, "{what:<10} {}", p.display());
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_assembly::coordinator::Event;

    #[test]
    fn the_table_rounds_times_to_tenths_and_names_every_step() {
        let ev = |t: f64, kind: EventKind| Event { t, kind };
        let report = AssemblyReport {
            folder: "runs/x".into(),
            state: RunState::Finished,
            events: vec![
                ev(
                    0.0,
                    EventKind::StepStarted {
                        index: 0,
                        label: "form a line".into(),
                    },
                ),
                ev(
                    0.0,
                    EventKind::Planned {
                        robots: vec![1, 2],
                        pairs: 1,
                    },
                ),
                ev(12.799_999_999_999_999, EventKind::FormationComplete),
                ev(12.799_999_999_999_999, EventKind::StepFinished { index: 0 }),
            ],
            gate_stops: Vec::new(),
            summary: Default::default(),
            final_poses: Default::default(),
            coupled_truth: vec![(2, 1)],
            coupling_truth: Vec::new(),
            mpc_failures: 0,
            fallen: Vec::new(),
            mpc_failure_reasons: Default::default(),
        };
        let s = Summary::new(
            &report,
            None,
            vec![("replay".into(), "runs/x/replay.html".into())],
        );
        let t = s.table();
        assert!(t.contains("complete at 12.8 s · 1 pairs"), "{t}");
        assert!(t.contains("form a line    0.0 s  12.8 s  done"), "{t}");
        assert!(t.contains("coupled    2–1 at the end\n"), "{t}");
        assert!(t.contains("replay     runs/x/replay.html"), "{t}");
        assert!(!t.contains("12.799"), "{t}");
        let j = serde_json::to_string(&s).unwrap();
        assert!(j.contains("\"formed_s\":12.8"), "{j}");
    }
}
