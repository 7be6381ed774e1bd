//! Events in words: one short line per coordinator, gate or simulator event.

use serde_json::Value;

use super::timeline::Note;

/// A robot list `[1, 2, 3]` as `1, 2, 3`.
fn ids(v: &Value) -> String {
    v.as_array()
        .map(|a| {
            a.iter()
                .map(|x| match x {
                    Value::Array(p) => p.iter().map(Value::to_string).collect::<Vec<_>>().join("–"),
                    other => other.to_string(),
                })
                .collect::<Vec<_>>()
                .join(", ")
        })
        .unwrap_or_default()
}

/// `note` in words; `None` for the coordinator's bookkeeping (behaviour starts, plans) that a
/// reader of the run does not need.
pub fn describe_note(note: &Note) -> Option<String> {
    let d = &note.data;
    if let Value::String(s) = d {
        return Some(s.clone());
    }
    let s = |k: &str| d[k].as_str().unwrap_or("").replace('_', " ");
    let n = |k: &str| d[k].to_string();
    let text = match d["event"].as_str()? {
        "step_started" => format!("step {}: {}", n("index"), s("label")),
        "step_finished" => format!("step {} done", n("index")),
        "step_failed" => format!("step {} failed: {}", n("index"), s("reason")),
        "formation_complete" => "formation complete".into(),
        "pair_status" => format!("pair {}–{} {}", n("a"), n("b"), s("to")),
        "pair_released" => format!("pair {}–{} released", n("a"), n("b")),
        "pair_recoupled" => format!("pair {}–{} coupled again", n("a"), n("b")),
        "lift_knobs" => format!("lift knob pairs {} apart by hand", ids(&d["pairs"])),
        "robot_lost" => format!("robot {} lost", n("robot")),
        "gate_stop" => format!("gate stopped {}", ids(&d["robots"])),
        "behaviour_started" | "planned" => return None,
        other => {
            let mut rest = d.clone();
            if let Some(o) = rest.as_object_mut() {
                o.remove("event");
                o.remove("t");
            }
            format!("{} {rest}", other.replace('_', " "))
        }
    };
    Some(text)
}

/// A coordinator event in words (as [`describe_note`]).
pub fn describe_event(kind: &puzzlebot_assembly::coordinator::EventKind) -> Option<String> {
    describe_note(&Note {
        t: 0.0,
        source: "coordinator".into(),
        data: serde_json::to_value(kind).ok()?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn note(v: Value) -> Note {
        Note {
            t: 1.0,
            source: "coordinator".into(),
            data: v,
        }
    }

    #[test]
    fn events_read_as_short_sentences() {
        let pair = json!({"event": "pair_status", "pair": 0, "a": 4, "b": 2,
                          "kind": "anchor_opening", "from": "head_inserted", "to": "connected"});
        assert_eq!(describe_note(&note(pair)).unwrap(), "pair 4–2 connected");
        let lift = json!({"event": "lift_knobs", "robots": [1, 2], "pairs": [[1, 6]]});
        assert_eq!(
            describe_note(&note(lift)).unwrap(),
            "lift knob pairs 1–6 apart by hand"
        );
        assert_eq!(
            describe_note(&note(json!({"event": "planned", "pairs": 5}))),
            None
        );
        let sim = Note {
            t: 1.0,
            source: "simulator".into(),
            data: json!("robot 3 fell"),
        };
        assert_eq!(describe_note(&sim).unwrap(), "robot 3 fell");
        let formed = puzzlebot_assembly::coordinator::EventKind::FormationComplete;
        assert_eq!(describe_event(&formed).unwrap(), "formation complete");
    }
}
