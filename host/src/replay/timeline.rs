//! A run as a timeline: the robots' bodies, every 10 Hz sample of their poses and couplings,
//! the host's pair status changes and events, read from a run folder's `run.mcap` or, without
//! one, from its `telemetry.jsonl`, `events.jsonl` and `simulator.json`.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::Context;
use puzzlebot_params::geometry::Geometry;
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::RobotId;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::record::foxglove::yaw_of;
use crate::record::{Recording, RunInfo, RUN_MCAP};

/// One robot's body: id, kind and the geometry it is drawn with.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// Robot id.
    pub id: RobotId,
    /// Pilot or non-pilot.
    pub kind: RobotKind,
    /// Footprint, anchor and knob geometry (m, body frame).
    pub geometry: Geometry,
}

/// One coupling between two robots at one sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Coupling {
    /// Anchor (`a`'s anchor in `b`'s opening) or knob (`a`'s knob in `b`'s hole).
    pub kind: Kind,
    /// Robot with the anchor or knob.
    pub a: RobotId,
    /// Robot with the opening or hole.
    pub b: RobotId,
    /// Inserting, coupled or releasing.
    pub state: State,
}

/// Which coupling (the simulator's `LinkKind`, ordered; the same names in JSON).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Kind {
    /// Anchor head in an opening.
    Anchor,
    /// Knob in a hole.
    Knob,
}

/// Progress of a coupling (the simulator's `LinkState`, ordered; the same names in JSON).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub enum State {
    /// Entering.
    Inserting,
    /// Holding.
    Coupled,
    /// Released, not yet apart.
    Releasing,
}

/// Every robot's pose and every coupling at one instant.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Sample {
    /// Time (s since the run started).
    pub t: f64,
    /// Pose [x, y, yaw] (m, m, rad) of every robot seen at this instant.
    pub poses: BTreeMap<RobotId, [f64; 3]>,
    /// Couplings.
    pub couplings: Vec<Coupling>,
}

/// A pair of the host's plan changed status.
#[derive(Debug, Clone, PartialEq)]
pub struct PairChange {
    /// Time (s).
    pub t: f64,
    /// Pair index in the plan.
    pub pair: u64,
    /// Robot with the anchor or knob.
    pub a: RobotId,
    /// Robot with the opening or hole.
    pub b: RobotId,
    /// `anchor_opening` or `knob_hole`.
    pub kind: String,
    /// New status: `decoupled`, `head_aligned`, `head_inserted` or `connected`.
    pub to: String,
}

/// A logged event.
#[derive(Debug, Clone, PartialEq)]
pub struct Note {
    /// Time (s).
    pub t: f64,
    /// `coordinator`, `gate` or `simulator`.
    pub source: String,
    /// The coordinator's event as JSON (with its `event` tag), or a sentence.
    pub data: Value,
}

/// Where the couplings of a timeline come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CouplingSource {
    /// The simulator's ground truth (`run.mcap`).
    Simulator,
    /// The host's connected pairs (runs without a recording).
    Host,
}

/// A run, sample by sample.
#[derive(Debug, Clone)]
pub struct Timeline {
    /// Every robot's body, by id.
    pub bodies: Vec<Body>,
    /// Terrain.
    pub terrain: Terrain,
    /// Samples in time order.
    pub samples: Vec<Sample>,
    /// The host's pair status changes in time order.
    pub pairs: Vec<PairChange>,
    /// Events in time order.
    pub notes: Vec<Note>,
    /// Where [`Sample::couplings`] come from.
    pub couplings_from: CouplingSource,
}

/// Nanoseconds of a recording time, the key that groups one sample's messages.
fn key(t: f64) -> u64 {
    crate::record::foxglove::nanos(t)
}

impl Timeline {
    /// Read the run folder `dir`: its `run.mcap` if there is one, else its telemetry.
    pub fn from_folder(dir: &Path) -> anyhow::Result<Timeline> {
        if !dir.is_dir() {
            anyhow::bail!("{}: not a run folder", dir.display());
        }
        let mcap = dir.join(RUN_MCAP);
        if mcap.is_file() {
            return Ok(Timeline::from_recording(&Recording::read(&mcap)?));
        }
        Timeline::from_telemetry(dir)
    }

    /// The run of `info` before its first sample: bodies and terrain, nothing else (a live
    /// page starts from it; couplings come from the host's pairs).
    pub fn of_info(info: &RunInfo) -> Timeline {
        Timeline {
            bodies: bodies_of(&info.robots, &info.params),
            terrain: info.terrain.clone(),
            samples: Vec::new(),
            pairs: Vec::new(),
            notes: Vec::new(),
            couplings_from: CouplingSource::Host,
        }
    }

    /// The timeline of a recording.
    pub fn from_recording(rec: &Recording) -> Timeline {
        let bodies = bodies_of(&rec.info.robots, &rec.info.params);
        let mut samples: BTreeMap<u64, Sample> = BTreeMap::new();
        let mut pairs = Vec::new();
        let mut notes = Vec::new();
        for m in &rec.messages {
            let robot = m
                .topic
                .strip_prefix("/robot_")
                .and_then(|r| r.strip_suffix("/pose/true"))
                .and_then(|id| id.parse::<RobotId>().ok());
            if let Some(id) = robot {
                let p = &m.data["pose"];
                let pos = &p["position"];
                if let (Some(x), Some(y), Some(yaw)) =
                    (pos["x"].as_f64(), pos["y"].as_f64(), yaw_of(p))
                {
                    let s = samples.entry(key(m.t)).or_default();
                    s.t = m.t;
                    s.poses.insert(id, [x, y, yaw]);
                }
                continue;
            }
            match m.topic.as_str() {
                "/couplings/true" => {
                    let s = samples.entry(key(m.t)).or_default();
                    s.t = m.t;
                    s.couplings = links_of(&m.data);
                }
                "/pairs/status" => pairs.extend(pair_change(m.t, &m.data)),
                "/events" => {
                    let source = m.data["name"].as_str().unwrap_or("").to_string();
                    let text = m.data["message"].as_str().unwrap_or("");
                    let data = match source.as_str() {
                        "coordinator" => serde_json::from_str(text).unwrap_or(Value::Null),
                        _ => Value::String(text.to_string()),
                    };
                    notes.push(Note {
                        t: m.t,
                        source,
                        data,
                    });
                }
                _ => {}
            }
        }
        Timeline {
            bodies,
            terrain: rec.info.terrain.clone(),
            samples: samples
                .into_values()
                .filter(|s| !s.poses.is_empty())
                .collect(),
            pairs,
            notes,
            couplings_from: CouplingSource::Simulator,
        }
    }

    /// The timeline of a run folder without a recording: poses from `telemetry.jsonl` (ground
    /// truth where there is one), events and pair statuses from `events.jsonl`, bodies and
    /// terrain from `simulator.json` (default non-pilots on flat ground without one), and the
    /// host's connected pairs as couplings.
    pub fn from_telemetry(dir: &Path) -> anyhow::Result<Timeline> {
        let tel = dir.join("telemetry.jsonl");
        let text = std::fs::read_to_string(&tel).with_context(|| {
            format!(
                "{}: no {RUN_MCAP} and no telemetry.jsonl: not a run folder",
                dir.display()
            )
        })?;
        let mut samples: BTreeMap<u64, Sample> = BTreeMap::new();
        for (i, line) in text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty())
        {
            let rec: TelemetryLine = serde_json::from_str(line)
                .with_context(|| format!("{}:{}", tel.display(), i + 1))?;
            if let Some(p) = rec.truth.or(rec.pose) {
                let s = samples.entry(key(rec.t)).or_default();
                s.t = rec.t;
                s.poses.insert(rec.robot, p);
            }
        }
        let mut pairs = Vec::new();
        let mut notes = Vec::new();
        let ev = dir.join("events.jsonl");
        if let Ok(text) = std::fs::read_to_string(&ev) {
            for (i, line) in text
                .lines()
                .enumerate()
                .filter(|(_, l)| !l.trim().is_empty())
            {
                let v: Value = serde_json::from_str(line)
                    .with_context(|| format!("{}:{}", ev.display(), i + 1))?;
                let t = v["t"]
                    .as_f64()
                    .with_context(|| format!("{}:{}: field `t`", ev.display(), i + 1))?;
                pairs.extend(pair_change(t, &v));
                let source = if v["event"] == "gate_stop" {
                    "gate"
                } else {
                    "coordinator"
                };
                notes.push(Note {
                    t,
                    source: source.into(),
                    data: v,
                });
            }
        }
        let (bodies, terrain) = match std::fs::read_to_string(dir.join("simulator.json")) {
            Ok(text) => {
                let sim: SimulatorFile = serde_json::from_str(&text)
                    .with_context(|| format!("{}", dir.join("simulator.json").display()))?;
                let robots: Vec<(RobotId, RobotKind)> =
                    sim.robots.iter().map(|r| (r.id, r.kind)).collect();
                (bodies_of(&robots, &sim.params), sim.terrain)
            }
            Err(_) => {
                let mut ids: Vec<RobotId> = samples
                    .values()
                    .flat_map(|s| s.poses.keys())
                    .copied()
                    .collect();
                ids.sort_unstable();
                ids.dedup();
                let robots: Vec<(RobotId, RobotKind)> = ids
                    .into_iter()
                    .map(|id| (id, RobotKind::NonPilot))
                    .collect();
                (bodies_of(&robots, &FleetParams::default()), Terrain::flat())
            }
        };
        // A real-time run's records carry the link's clock; its controller (events, pair
        // statuses) starts at the first record.
        let mut samples: Vec<Sample> = samples.into_values().collect();
        let t0 = samples.first().map_or(0.0, |s| s.t);
        for s in &mut samples {
            s.t -= t0;
            s.couplings = host_connected(&pairs, s.t);
        }
        Ok(Timeline {
            bodies,
            terrain,
            samples,
            pairs,
            notes,
            couplings_from: CouplingSource::Host,
        })
    }

    /// Time of the last sample (s).
    pub fn end(&self) -> f64 {
        self.samples.last().map_or(0.0, |s| s.t)
    }

    /// The index of the last sample at or before `t` (the first one before the run starts).
    pub fn index_at(&self, t: f64) -> usize {
        self.samples
            .partition_point(|s| s.t <= t + 1e-9)
            .saturating_sub(1)
    }

    /// The body of robot `id`.
    pub fn body(&self, id: RobotId) -> Option<&Body> {
        self.bodies.iter().find(|b| b.id == id)
    }

    /// Every pair's status at `t`: (pair, a, b, kind, status), by pair index.
    pub fn pair_status_at(&self, t: f64) -> Vec<(u64, RobotId, RobotId, &str, &str)> {
        let mut at: BTreeMap<u64, &PairChange> = BTreeMap::new();
        for c in self.pairs.iter().filter(|c| c.t <= t + 1e-9) {
            at.insert(c.pair, c);
        }
        at.into_values()
            .map(|c| (c.pair, c.a, c.b, c.kind.as_str(), c.to.as_str()))
            .collect()
    }
}

/// One line of `telemetry.jsonl` (lockstep ground truth, or a real-time tick record).
#[derive(Deserialize)]
struct TelemetryLine {
    t: f64,
    robot: RobotId,
    #[serde(default)]
    truth: Option<[f64; 3]>,
    #[serde(default)]
    pose: Option<[f64; 3]>,
}

/// What a replay needs of a run folder's `simulator.json` (the simulator's scenario).
#[derive(Deserialize)]
struct SimulatorFile {
    robots: Vec<SimulatorRobot>,
    #[serde(default)]
    terrain: Terrain,
    #[serde(default)]
    params: FleetParams,
}

/// A robot of [`SimulatorFile`].
#[derive(Deserialize)]
struct SimulatorRobot {
    id: RobotId,
    kind: RobotKind,
}

fn bodies_of(robots: &[(RobotId, RobotKind)], params: &FleetParams) -> Vec<Body> {
    let mut b: Vec<Body> = robots
        .iter()
        .map(|&(id, kind)| Body {
            id,
            kind,
            geometry: params.robot(kind).geometry,
        })
        .collect();
    b.sort_by_key(|b| b.id);
    b
}

/// The couplings of a `/couplings/true` message.
fn links_of(msg: &Value) -> Vec<Coupling> {
    #[derive(Deserialize)]
    struct L {
        kind: Kind,
        a: RobotId,
        b: RobotId,
        state: State,
    }
    let mut out: Vec<Coupling> = msg["links"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|l| serde_json::from_value::<L>(l.clone()).ok())
        .map(|l| Coupling {
            kind: l.kind,
            a: l.a,
            b: l.b,
            state: l.state,
        })
        .collect();
    out.sort();
    out
}

/// A pair status change (a `/pairs/status` message or a `pair_status` event).
fn pair_change(t: f64, v: &Value) -> Option<PairChange> {
    if v.get("event").is_some_and(|e| e != "pair_status") {
        return None;
    }
    let id = |k: &str| v[k].as_u64().and_then(|x| RobotId::try_from(x).ok());
    Some(PairChange {
        t,
        pair: v["pair"].as_u64()?,
        a: id("a")?,
        b: id("b")?,
        kind: v["kind"].as_str()?.to_string(),
        to: v["to"].as_str()?.to_string(),
    })
}

/// The pairs the host counts as connected at `t`, as couplings.
fn host_connected(pairs: &[PairChange], t: f64) -> Vec<Coupling> {
    let mut at: BTreeMap<u64, &PairChange> = BTreeMap::new();
    for c in pairs.iter().filter(|c| c.t <= t + 1e-9) {
        at.insert(c.pair, c);
    }
    let mut out: Vec<Coupling> = at
        .values()
        .filter(|c| c.to == "connected")
        .map(|c| Coupling {
            kind: if c.kind == "knob_hole" {
                Kind::Knob
            } else {
                Kind::Anchor
            },
            a: c.a,
            b: c.b,
            state: State::Coupled,
        })
        .collect();
    out.sort();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn folder(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("pb-timeline-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_folder_without_a_recording_is_read_from_its_telemetry_and_events() {
        let d = folder("telemetry");
        let mut tel = String::new();
        for i in 0..5 {
            let t = f64::from(i) * 0.1;
            tel += &format!("{{\"t\":{t},\"robot\":1,\"truth\":[{t},0.0,0.0]}}\n");
            tel += &format!("{{\"t\":{t},\"robot\":2,\"truth\":[{t},0.1,1.0]}}\n");
        }
        std::fs::write(d.join("telemetry.jsonl"), tel).unwrap();
        std::fs::write(
            d.join("events.jsonl"),
            "{\"t\":0.25,\"event\":\"pair_status\",\"pair\":0,\"a\":2,\"b\":1,\"kind\":\"anchor_opening\",\"from\":\"head_inserted\",\"to\":\"connected\"}\n",
        )
        .unwrap();
        let tl = Timeline::from_folder(&d).expect("timeline");
        assert_eq!(tl.samples.len(), 5);
        assert_eq!(tl.couplings_from, CouplingSource::Host);
        assert_eq!(tl.bodies.len(), 2);
        assert_eq!(tl.samples[4].poses[&2], [0.4, 0.1, 1.0]);
        assert!(tl.samples[2].couplings.is_empty());
        assert_eq!(
            tl.samples[3].couplings,
            [Coupling {
                kind: Kind::Anchor,
                a: 2,
                b: 1,
                state: State::Coupled
            }]
        );
        assert_eq!(tl.index_at(0.25), 2);
        assert_eq!(tl.index_at(-1.0), 0);
        assert_eq!(tl.pair_status_at(0.3)[0].4, "connected");
    }

    #[test]
    fn a_bad_line_is_named_by_file_and_line() {
        let d = folder("bad");
        std::fs::write(
            d.join("telemetry.jsonl"),
            "{\"t\":0.0,\"robot\":1,\"truth\":[0,0,0]}\n{\"t\":\"x\"}\n",
        )
        .unwrap();
        let e = format!("{:#}", Timeline::from_folder(&d).expect_err("bad line"));
        assert!(e.contains("telemetry.jsonl:2"), "{e}");
        let e = format!(
            "{:#}",
            Timeline::from_folder(&d.join("missing")).expect_err("no folder")
        );
        assert!(e.contains("not a run folder"), "{e}");
    }
}
