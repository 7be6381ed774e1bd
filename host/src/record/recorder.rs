//! What a lockstep run records: every robot's true and measured pose and footprint at 10 Hz,
//! every wheel command at the command rate, the simulator's couplings, the host's pair
//! status changes and every event, buffered and written as one MCAP file at the end.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context;
use puzzlebot_assembly::coordinator::{Event, EventKind};
use puzzlebot_params::RobotKind;
use puzzlebot_protocol::{HostMsg, RobotId};
use puzzlebot_sim::mechanics::{Link, LinkState};
use puzzlebot_sim::{EventKind as SimEventKind, LinkKind, World};
use serde_json::{json, Value};

use super::foxglove as fg;
use super::{RunInfo, RUN_ATTACHMENT};
use crate::assemble::{AssemblyReport, GateStop};
use crate::control::FleetView;

/// Interval between pose, footprint and coupling samples (s): 10 Hz.
pub const SAMPLE_PERIOD: f64 = 0.1;

mod world3d;

/// One buffered message.
struct Msg {
    topic: String,
    log_time: u64,
    data: Vec<u8>,
}

/// Records a lockstep run in memory; [`Recorder::write`] writes `run.mcap`.
pub struct Recorder {
    info: RunInfo,
    /// Schema name of each topic.
    schemas: BTreeMap<String, &'static str>,
    messages: Vec<Msg>,
    next_sample: f64,
    /// Simulator events already recorded.
    sim_events_seen: usize,
    /// Events of the 3-D world already recorded ([`world3d`]).
    events_3d_seen: usize,
}

/// Schema (name, JSON Schema) of every schema name used.
fn schema_of(name: &str) -> Value {
    match name {
        "foxglove.PoseInFrame" => fg::pose_in_frame_schema(),
        "foxglove.SceneUpdate" => fg::scene_update_schema(),
        "foxglove.Log" => fg::log_schema(),
        "puzzlebot.WheelCommand" => json!({
            "title": "puzzlebot.WheelCommand",
            "description": "The host's command to one robot: wheel speeds, or stop",
            "type": "object",
            "properties": {
                "timestamp": {"type": "object", "title": "time"},
                "left_rpm": {"type": "number"},
                "right_rpm": {"type": "number"},
                "stop": {"type": "boolean"}
            }
        }),
        "puzzlebot.Couplings" => json!({
            "title": "puzzlebot.Couplings",
            "description": "Every coupling in the simulator's ground truth",
            "type": "object",
            "properties": {
                "timestamp": {"type": "object", "title": "time"},
                "links": {"type": "array", "items": {"type": "object", "properties": {
                    "kind": {"type": "string", "enum": ["Anchor", "Knob"]},
                    "a": {"type": "integer", "description": "robot with the anchor / knob"},
                    "b": {"type": "integer", "description": "robot with the opening / hole"},
                    "state": {"type": "string", "enum": ["Inserting", "Coupled", "Releasing"]},
                    "legs": {"type": "array", "items": {"type": "boolean"}}
                }}}
            }
        }),
        _ => json!({
            "title": "puzzlebot.PairStatus",
            "description": "A connection pair of the host's plan changed status",
            "type": "object",
            "properties": {
                "timestamp": {"type": "object", "title": "time"},
                "pair": {"type": "integer"},
                "a": {"type": "integer"},
                "b": {"type": "integer"},
                "kind": {"type": "string", "enum": ["anchor_opening", "knob_hole"]},
                "from": {"type": "string"},
                "to": {"type": "string"}
            }
        }),
    }
}

/// Colour of a robot's anchor head by the state of its anchor coupling (`None`: free).
fn anchor_color(state: Option<LinkState>) -> [f64; 4] {
    match state {
        None => [0.6, 0.6, 0.6, 1.0],
        Some(LinkState::Inserting) => [1.0, 0.6, 0.0, 1.0],
        Some(LinkState::Coupled) => [0.1, 0.7, 0.2, 1.0],
        Some(LinkState::Releasing) => [0.9, 0.1, 0.1, 1.0],
    }
}

impl RunInfo {
    /// The robots, parameters and terrain of the simulator scenario `sim`.
    pub fn of_simulator(sim: &puzzlebot_sim::Scenario) -> RunInfo {
        RunInfo {
            robots: sim.robots.iter().map(|r| (r.id, r.kind)).collect(),
            params: sim.params.clone(),
            terrain: sim.terrain.clone(),
        }
    }
}

impl Recorder {
    /// A recorder for a run of the simulator scenario `sim`.
    pub fn new(sim: &puzzlebot_sim::Scenario) -> Recorder {
        Recorder {
            info: RunInfo::of_simulator(sim),
            schemas: BTreeMap::new(),
            messages: Vec::new(),
            next_sample: 0.0,
            sim_events_seen: 0,
            events_3d_seen: 0,
        }
    }

    fn push(&mut self, topic: String, schema: &'static str, t: f64, msg: &Value) {
        self.schemas.entry(topic.clone()).or_insert(schema);
        self.messages.push(Msg {
            topic,
            log_time: fg::nanos(t),
            data: serde_json::to_vec(msg).unwrap_or_default(),
        });
    }

    /// One command period of a lockstep run at controller time `t`: the commands `sent`, and
    /// every [`SAMPLE_PERIOD`] the poses the host saw in `view`, the world's ground truth,
    /// footprints, couplings and new simulator events.
    pub fn sample(&mut self, t: f64, world: &World, view: &FleetView, sent: &[(RobotId, HostMsg)]) {
        for (id, msg) in sent {
            let (l, r, stop) = match msg {
                HostMsg::WheelSpeed {
                    left_rpm,
                    right_rpm,
                }
                | HostMsg::WheelSpeedHold {
                    left_rpm,
                    right_rpm,
                    ..
                } => (f64::from(*left_rpm), f64::from(*right_rpm), false),
                _ => (0.0, 0.0, true),
            };
            let m = json!({"timestamp": fg::time(t), "left_rpm": l, "right_rpm": r, "stop": stop});
            self.push(
                format!("/robot_{id}/command"),
                "puzzlebot.WheelCommand",
                t,
                &m,
            );
        }
        if t + 1e-9 < self.next_sample {
            return;
        }
        self.next_sample = t + SAMPLE_PERIOD;
        for rv in &view.robots {
            if let Some(p) = rv.pose {
                let m = fg::pose_in_frame(t, p.x, p.y, 0.0, p.theta);
                self.push(
                    format!("/robot_{}/pose/measured", rv.id),
                    "foxglove.PoseInFrame",
                    t,
                    &m,
                );
            }
        }
        let truth = world.ground_truth();
        let links = world.links();
        let mut entities = Vec::new();
        for r in &truth.robots {
            let m = fg::pose_in_frame(t, r.pose.x, r.pose.y, r.z, r.pose.yaw);
            self.push(
                format!("/robot_{}/pose/true", r.id),
                "foxglove.PoseInFrame",
                t,
                &m,
            );
            let anchor = links
                .iter()
                .find(|(k, a, _, _)| *k == LinkKind::Anchor && *a == r.id)
                .map(|l| l.3.state);
            let knobs = links
                .iter()
                .filter(|(k, a, _, l)| {
                    *k == LinkKind::Knob && *a == r.id && l.state == LinkState::Coupled
                })
                .count();
            entities.push(self.footprint(t, r, anchor, knobs));
        }
        self.push(
            "/scene/robots".into(),
            "foxglove.SceneUpdate",
            t,
            &fg::scene_update(t, entities),
        );
        self.couplings(t, &truth, &links);
        // Simulator times are µs since the world started; the controller's start later.
        let offset = world.time_us() as f64 * 1e-6 - t;
        for e in &truth.events[self.sim_events_seen.min(truth.events.len())..] {
            let (level, text) = match e.kind {
                SimEventKind::Coupled { kind, a, b } => (2, format!("{kind:?} {a}-{b} coupled")),
                SimEventKind::Decoupled { kind, a, b } => {
                    (2, format!("{kind:?} {a}-{b} came apart"))
                }
                SimEventKind::Fell { id } => (4, format!("robot {id} fell")),
                SimEventKind::Dropped { id, height } => {
                    (3, format!("robot {id} dropped {:.0} mm", height * 1e3))
                }
                SimEventKind::Blocked { id } => (3, format!("robot {id} blocked by a step")),
                SimEventKind::Offline { id } => (3, format!("robot {id} switched off")),
                SimEventKind::Booted { id, boot } => (1, format!("robot {id} booted ({boot})")),
            };
            let te = e.t_us as f64 * 1e-6 - offset;
            self.push(
                "/events".into(),
                "foxglove.Log",
                te,
                &fg::log(te, level, "simulator", &text),
            );
        }
        self.sim_events_seen = truth.events.len();
    }

    /// The scene entity of robot `r`: its body to scale, its anchor head coloured by the
    /// anchor's coupling state, its knobs (green when in a hole) and its id.
    fn footprint(
        &self,
        t: f64,
        r: &puzzlebot_sim::RobotTruth,
        anchor: Option<LinkState>,
        knobs: usize,
    ) -> Value {
        let g = &self.info.params.robot(r.kind).geometry;
        let (s, c) = r.pose.yaw.sin_cos();
        let at = |p: [f64; 2]| {
            (
                r.pose.x + c * p[0] - s * p[1],
                r.pose.y + s * p[0] + c * p[1],
            )
        };
        let h = f64::from(g.height);
        let mut e = fg::entity(t, &format!("robot_{}", r.id));
        let body = match r.kind {
            RobotKind::Pilot => [0.15, 0.3, 0.75, 0.8],
            RobotKind::NonPilot => [0.55, 0.6, 0.7, 0.8],
        };
        let size = |x: f64, y: f64, z: f64| json!({"x": x, "y": y, "z": z});
        fg::push(
            &mut e,
            "cubes",
            json!({"pose": fg::pose(r.pose.x, r.pose.y, r.z + h / 2.0, r.pose.yaw),
                   "size": size(f64::from(g.length), f64::from(g.width), h),
                   "color": fg::color(body)}),
        );
        let (ax, ay) = at([f64::from(g.anchor_head[0]), f64::from(g.anchor_head[1])]);
        fg::push(
            &mut e,
            "spheres",
            json!({"pose": fg::pose(ax, ay, r.z + h / 2.0, r.pose.yaw),
                   "size": size(0.008, 0.008, 0.008),
                   "color": fg::color(anchor_color(anchor))}),
        );
        let k = f64::from(g.knob_length);
        let knob_color = if knobs > 0 {
            [0.1, 0.7, 0.2, 1.0]
        } else {
            [0.3, 0.3, 0.3, 1.0]
        };
        for sx in [-1.0, 1.0] {
            let p = [
                f64::from(g.knob_left[0]) + sx * f64::from(g.side_point_x),
                f64::from(g.knob_left[1]) + k / 2.0,
            ];
            let (kx, ky) = at(p);
            fg::push(
                &mut e,
                "cubes",
                json!({"pose": fg::pose(kx, ky, r.z + h / 2.0, r.pose.yaw),
                       "size": size(0.004, k, 0.004), "color": fg::color(knob_color)}),
            );
        }
        fg::push(
            &mut e,
            "texts",
            json!({"pose": fg::pose(r.pose.x, r.pose.y, r.z + h + 0.01, 0.0),
                   "billboard": true, "font_size": 14.0, "scale_invariant": true,
                   "color": fg::color([0.0, 0.0, 0.0, 1.0]), "text": r.id.to_string()}),
        );
        e
    }

    /// `/couplings/true` and `/scene/couplings`: every simulator coupling, as data and as a
    /// line between the two robots' centres (anchor orange, knob blue).
    fn couplings(
        &mut self,
        t: f64,
        truth: &puzzlebot_sim::GroundTruth,
        links: &[(LinkKind, RobotId, RobotId, Link)],
    ) {
        let list: Vec<Value> = links
            .iter()
            .map(
                |(k, a, b, l)| json!({"kind": k, "a": a, "b": b, "state": l.state, "legs": l.legs}),
            )
            .collect();
        self.push(
            "/couplings/true".into(),
            "puzzlebot.Couplings",
            t,
            &json!({"timestamp": fg::time(t), "links": list}),
        );
        let mut entities = Vec::new();
        for (k, a, b, _) in links.iter().filter(|l| l.3.state == LinkState::Coupled) {
            let (Some(ra), Some(rb)) = (truth.robot(*a), truth.robot(*b)) else {
                continue;
            };
            let rgba = match k {
                LinkKind::Anchor => [1.0, 0.5, 0.0, 1.0],
                LinkKind::Knob => [0.1, 0.3, 0.9, 1.0],
            };
            let mut e = fg::entity(t, &format!("{k:?}_{a}_{b}").to_lowercase());
            let p = |r: &puzzlebot_sim::RobotTruth| json!({"x": r.pose.x, "y": r.pose.y, "z": r.z + 0.06});
            fg::push(
                &mut e,
                "lines",
                json!({"type": 0, "pose": fg::pose(0.0, 0.0, 0.0, 0.0), "thickness": 4.0,
                       "scale_invariant": true, "points": [p(ra), p(rb)],
                       "color": fg::color(rgba), "colors": [], "indices": []}),
            );
            entities.push(e);
        }
        self.push(
            "/scene/couplings".into(),
            "foxglove.SceneUpdate",
            t,
            &fg::scene_update(t, entities),
        );
    }

    /// The host's side of the run: its pair status changes (`/pairs/status`), and every
    /// coordinator event and gate stop (`/events`).
    pub fn host_events(&mut self, events: &[Event], gate_stops: &[GateStop]) {
        for e in events {
            if let EventKind::PairStatus {
                pair,
                a,
                b,
                kind,
                from,
                to,
            } = &e.kind
            {
                let m = json!({"timestamp": fg::time(e.t), "pair": pair, "a": a, "b": b,
                               "kind": kind, "from": from.to_string(), "to": to.to_string()});
                self.push("/pairs/status".into(), "puzzlebot.PairStatus", e.t, &m);
            }
            let text = serde_json::to_string(&e.kind).unwrap_or_default();
            let level = match e.kind {
                EventKind::StepFailed { .. }
                | EventKind::RobotLost { .. }
                | EventKind::ReplanFailed { .. } => 3,
                _ => 2,
            };
            self.push(
                "/events".into(),
                "foxglove.Log",
                e.t,
                &fg::log(e.t, level, "coordinator", &text),
            );
        }
        for g in gate_stops {
            let text = format!(
                "gate stopped {:?}: safe advance {:.3} m along {:.0}°, {:?}",
                g.robots,
                g.safe_advance,
                g.heading.to_degrees(),
                g.limited_by
            );
            self.push(
                "/events".into(),
                "foxglove.Log",
                g.t,
                &fg::log(g.t, 3, "gate", &text),
            );
        }
    }

    /// Write everything recorded to `path` (MCAP, JSON messages in time order).
    pub fn write(mut self, path: &Path) -> anyhow::Result<PathBuf> {
        let f = std::fs::File::create(path).with_context(|| format!("{}", path.display()))?;
        let mut w = mcap::WriteOptions::new()
            .profile("")
            .library("puzzlebot")
            .create(std::io::BufWriter::new(f))?;
        let mut channels = BTreeMap::new();
        for (topic, schema) in &self.schemas {
            let data = serde_json::to_vec(&schema_of(schema))?;
            let sid = w.add_schema(schema, "jsonschema", &data)?;
            let cid = w.add_channel(sid, topic, "json", &BTreeMap::new())?;
            channels.insert(topic.clone(), cid);
        }
        self.messages.sort_by_key(|m| m.log_time);
        let mut seq: BTreeMap<u16, u32> = BTreeMap::new();
        for m in &self.messages {
            let channel_id = channels[&m.topic];
            let s = seq.entry(channel_id).or_default();
            *s += 1;
            w.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id,
                    sequence: *s,
                    log_time: m.log_time,
                    publish_time: m.log_time,
                },
                &m.data,
            )?;
        }
        w.attach(&mcap::Attachment {
            log_time: 0,
            create_time: 0,
            name: RUN_ATTACHMENT.into(),
            media_type: "application/json".into(),
            data: serde_json::to_vec(&self.info)?.into(),
        })?;
        w.finish()?;
        Ok(path.to_path_buf())
    }

    /// Add the host's events of `report` and write `run.mcap` into its run folder.
    pub fn finish(mut self, report: &AssemblyReport) -> anyhow::Result<PathBuf> {
        self.host_events(&report.events, &report.gate_stops);
        self.write(&report.folder.join("run.mcap"))
    }
}
