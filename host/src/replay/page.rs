//! `replay.html`: one self-contained page (inline script and SVG, no network) that plays a
//! [`Timeline`] back: the arena and terrain, every robot's body to scale with its anchor and
//! knobs, couplings, the plan's pairs coloured by status, a time slider, play/pause, speed.
//!
//! The page shows the state it draws in `<pre id="state">` (JSON: `t`, `robots` with `id`,
//! `x`, `y`, `yaw`, `couplings` with `kind`, `a`, `b`, `pairs` with their `status`) and on
//! every robot's `<g class="robot" data-id data-x data-y data-yaw>`; `replay.html#t=12.5`
//! opens it paused at 12.5 s.

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde_json::{json, Value};

use super::milestones::milestones;
use super::timeline::{CouplingSource, Kind, State, Timeline};
use super::words::describe_note;

/// File name of the replay page in a run folder.
pub const REPLAY_HTML: &str = "replay.html";

/// The page template (`__TITLE__`, `__DATA__` filled in by [`html`]).
const TEMPLATE: &str = include_str!("page.html");

/// Round to 0.1 mm (positions in m) or 1 mrad.
fn r4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

/// The data the page draws, compact: flat pose arrays per robot (null where a robot is not
/// seen), couplings per sample as `[kind, a, b, state]` (kind 0 anchor, 1 knob; state 0
/// inserting, 1 coupled, 2 releasing), pair changes as `[t, pair, a, b, kind, status]`.
pub fn data(tl: &Timeline) -> Value {
    let robots: Vec<Value> = tl
        .bodies
        .iter()
        .map(|b| {
            let g = &b.geometry;
            json!({
                "id": b.id, "kind": format!("{:?}", b.kind),
                "length": g.length, "width": g.width,
                "anchor": g.anchor_head, "opening": g.anchor_opening,
                "knob": g.knob_left, "side": g.side_point_x, "knob_len": g.knob_length,
            })
        })
        .collect();
    let mut poses = serde_json::Map::new();
    for b in &tl.bodies {
        let mut flat = Vec::with_capacity(tl.samples.len() * 3);
        for s in &tl.samples {
            match s.poses.get(&b.id) {
                Some(p) => flat.extend(p.iter().map(|&v| json!(r4(v)))),
                None => flat.extend([Value::Null, Value::Null, Value::Null]),
            }
        }
        poses.insert(b.id.to_string(), Value::Array(flat));
    }
    let links: Vec<Value> = tl
        .samples
        .iter()
        .map(|s| {
            s.couplings
                .iter()
                .map(|c| {
                    let k = u8::from(c.kind == Kind::Knob);
                    let st = match c.state {
                        State::Inserting => 0,
                        State::Coupled => 1,
                        State::Releasing => 2,
                    };
                    json!([k, c.a, c.b, st])
                })
                .collect()
        })
        .collect();
    let pairs: Vec<Value> = tl
        .pairs
        .iter()
        .map(|c| {
            let st = ["decoupled", "head_aligned", "head_inserted", "connected"]
                .iter()
                .position(|s| *s == c.to)
                .unwrap_or(0);
            json!([
                r4(c.t),
                c.pair,
                c.a,
                c.b,
                u8::from(c.kind == "knob_hole"),
                st
            ])
        })
        .collect();
    let events: Vec<Value> = tl
        .notes
        .iter()
        .filter_map(|n| describe_note(n).map(|text| json!([r4(n.t), n.source, text])))
        .collect();
    let marks: Vec<Value> = milestones(tl)
        .iter()
        .map(|m| json!([r4(m.t), m.label]))
        .collect();
    let terrain: Vec<Value> = tl
        .terrain
        .platforms
        .iter()
        .map(|p| json!({"name": p.name, "height": p.height, "polygon": p.polygon}))
        .collect();
    json!({
        "couplings_from": match tl.couplings_from {
            CouplingSource::Simulator => "simulator",
            CouplingSource::Host => "host",
        },
        "robots": robots,
        "terrain": terrain,
        "t": tl.samples.iter().map(|s| r4(s.t)).collect::<Vec<_>>(),
        "poses": poses,
        "links": links,
        "pairs": pairs,
        "events": events,
        "milestones": marks,
    })
}

/// The page of `tl` titled `title`.
pub fn html(tl: &Timeline, title: &str) -> String {
    // `</` inside the JSON would end the script element; `<\/` is the same JSON string.
    let data = data(tl).to_string().replace("</", "<\\/");
    TEMPLATE
        .replace("__TITLE__", &super::page_escape(title))
        .replace("__DATA__", &data)
}

/// The live page of a run that has not started, titled `title`: the same page as [`html`],
/// which adds every sample the server at `events` (relative URL, server-sent events) streams.
pub fn live_html(tl: &Timeline, title: &str, events: &str) -> String {
    let mut d = data(tl);
    d["live"] = json!(events);
    let data = d.to_string().replace("</", "<\\/");
    TEMPLATE
        .replace("__TITLE__", &super::page_escape(title))
        .replace("__DATA__", &data)
}

/// Write `dir/replay.html` for the timeline `tl` of run folder `dir`; returns its path.
pub fn write(dir: &Path, tl: &Timeline) -> anyhow::Result<PathBuf> {
    let path = dir.join(REPLAY_HTML);
    std::fs::write(&path, html(tl, &super::title_of(dir)))
        .with_context(|| format!("{}", path.display()))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::timeline::{Body, Coupling, Sample};
    use std::collections::BTreeMap;

    #[test]
    fn the_page_is_self_contained_and_carries_every_sample() {
        let g = puzzlebot_params::FleetParams::default().non_pilot.geometry;
        let tl = Timeline {
            bodies: vec![Body {
                id: 3,
                kind: puzzlebot_params::RobotKind::NonPilot,
                geometry: g,
            }],
            terrain: Default::default(),
            samples: (0..3)
                .map(|i| Sample {
                    t: f64::from(i) * 0.1,
                    poses: BTreeMap::from([(3, [0.123_456, 0.0, 0.5])]),
                    couplings: vec![Coupling {
                        kind: Kind::Knob,
                        a: 3,
                        b: 4,
                        state: State::Coupled,
                    }],
                })
                .collect(),
            pairs: Vec::new(),
            notes: Vec::new(),
            couplings_from: CouplingSource::Simulator,
        };
        let page = html(&tl, "a <run>");
        assert!(page.contains("<title>a &lt;run&gt; · PuzzleBot replay</title>"));
        for remote in ["http://", "https://", "src=", "href="] {
            let found = page
                .lines()
                .any(|l| l.contains(remote) && !l.contains("http://www.w3.org/2000/svg"));
            assert!(!found, "the page loads nothing from elsewhere ({remote})");
        }
        let d = data(&tl);
        assert_eq!(d["poses"]["3"].as_array().unwrap().len(), 9);
        assert_eq!(d["poses"]["3"][0], json!(0.1235));
        assert_eq!(d["links"][2], json!([[1, 3, 4, 1]]));
    }
}
