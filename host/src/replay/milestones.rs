//! The moments of a run worth a picture: the start, formation complete, the end of every
//! move, the dissolved assembly and the end, found in the coordinator's events.

use super::timeline::Timeline;

/// One milestone.
#[derive(Debug, Clone, PartialEq)]
pub struct Milestone {
    /// Time (s).
    pub t: f64,
    /// What happened, for a caption (`formed`, `after move 0.5 m`, `dissolved`).
    pub label: String,
}

/// Coordinator behaviours that move an assembly (their step's end is a milestone).
const MOVES: [&str; 3] = ["velocity", "go_to", "track"];

/// Milestones closer than this to the one before are merged into it (s).
const MERGE_S: f64 = 0.5;

/// The milestones of `tl` in time order: start, formation complete, after each move,
/// dissolved, end.
pub fn milestones(tl: &Timeline) -> Vec<Milestone> {
    let Some(first) = tl.samples.first() else {
        return Vec::new();
    };
    let mut out = vec![Milestone {
        t: first.t,
        label: "start".into(),
    }];
    let mut behaviour = String::new();
    let mut label = String::new();
    for n in tl.notes.iter().filter(|n| n.source == "coordinator") {
        let d = &n.data;
        match d["event"].as_str().unwrap_or("") {
            "step_started" => d["label"].as_str().unwrap_or("").clone_into(&mut label),
            "behaviour_started" => d["name"].as_str().unwrap_or("").clone_into(&mut behaviour),
            "formation_complete" => out.push(Milestone {
                t: n.t,
                label: "formed".into(),
            }),
            "step_finished" if MOVES.contains(&behaviour.as_str()) => out.push(Milestone {
                t: n.t,
                label: if label.is_empty() {
                    "after the move".into()
                } else {
                    format!("after {label}")
                },
            }),
            "step_finished" if behaviour == "decouple" => out.push(Milestone {
                t: n.t,
                label: "dissolved".into(),
            }),
            _ => {}
        }
    }
    out.push(Milestone {
        t: tl.end(),
        label: "end".into(),
    });
    let mut merged: Vec<Milestone> = Vec::new();
    for m in out {
        match merged.last_mut() {
            Some(last) if m.t - last.t < MERGE_S => {
                if last.label != "start" && m.label != "end" {
                    last.label = format!("{}, {}", last.label, m.label);
                }
            }
            _ => merged.push(m),
        }
    }
    merged
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::timeline::{CouplingSource, Note, Sample};
    use serde_json::json;

    #[test]
    fn a_formed_moved_dissolved_run_has_its_five_milestones() {
        let note = |t: f64, v: serde_json::Value| Note {
            t,
            source: "coordinator".into(),
            data: v,
        };
        let tl = Timeline {
            bodies: Vec::new(),
            terrain: Default::default(),
            samples: (0..700)
                .map(|i| Sample {
                    t: f64::from(i) * 0.1,
                    ..Sample::default()
                })
                .collect(),
            pairs: Vec::new(),
            notes: vec![
                note(0.0, json!({"event": "step_started", "label": "form"})),
                note(0.0, json!({"event": "behaviour_started", "name": "form"})),
                note(45.9, json!({"event": "formation_complete"})),
                note(45.9, json!({"event": "step_finished"})),
                note(
                    47.1,
                    json!({"event": "step_started", "label": "move 0.5 m"}),
                ),
                note(
                    47.1,
                    json!({"event": "behaviour_started", "name": "velocity"}),
                ),
                note(57.2, json!({"event": "step_finished"})),
                note(58.4, json!({"event": "step_started", "label": "dissolve"})),
                note(
                    58.4,
                    json!({"event": "behaviour_started", "name": "decouple"}),
                ),
                note(66.2, json!({"event": "step_finished"})),
            ],
            couplings_from: CouplingSource::Simulator,
        };
        let m = milestones(&tl);
        let labels: Vec<&str> = m.iter().map(|x| x.label.as_str()).collect();
        assert_eq!(
            labels,
            ["start", "formed", "after move 0.5 m", "dissolved", "end"]
        );
        assert!((m[1].t - 45.9).abs() < 1e-9 && (m[4].t - 69.9).abs() < 1e-9);
    }
}
