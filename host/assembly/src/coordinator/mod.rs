//! The per-tick coordinator: given measured poses it updates every pair's status machine
//! (THESIS Algorithm 8), picks non-conflicting active pairs (Algorithm 3 lines 6–11, Algorithm 6
//! line 4), elects segment leaders (THESIS 5.5.9) and returns one task per robot for the
//! distributed MPC. It records every status change with its time, and re-plans without a robot
//! that is lost (THESIS Algorithm 2 on the remaining fleet).
//!
//! This file holds the [`Coordinator`] itself and its tick; the rest is one concept per file:
//! `config` (settings), `role` (what a robot is told), `events` (what is recorded), `mode`
//! (behaviours and switching), `plan` (forming, re-planning), `grow` (growing around a seed),
//! `segments` (connected assemblies), `order` (which pairs start, making way), `tasks` (every
//! robot's task per mode), `approach` (staged approaches, the lane train), `routing` (routes
//! round robots), `retarget` (side pairs re-targeted), `tug` (coupling seen by a tug),
//! `motion` (moving an assembly) and `decouple` (wiggling pairs apart).

mod approach;
mod closures;
mod config;
mod decouple;
mod events;
#[cfg(test)]
mod fixtures;
mod grow;
mod mode;
mod motion;
mod order;
mod plan;
mod retarget;
mod role;
mod routing;
mod segments;
mod staging;
mod tasks;
#[cfg(test)]
mod tests;
mod train;
mod tug;

use approach::Manoeuvre;
pub use closures::Closure;
pub use config::{CoordinatorConfig, DecoupleConfig, DockConfig};
use decouple::ReleaseWatch;
pub use events::{Event, EventKind};
pub use mode::Mode;
pub use motion::VELOCITY_RAMP_S;
use motion::{ramp_pose, ramp_velocity, MotionStart};
pub use role::{RobotTask, Role};

use crate::assign::{
    assign_around_lane, assign_connection_pairs, Plan, PlanError, PlannedPair, RobotState,
};
use crate::behaviour::{point_command, rendezvous, Trajectory, Wiggle, WiggleTurn, WIGGLE_REACH};
use crate::geom::{wrap_angle, ConnPoint, PairType, Pose2};
use crate::pair::{is_inserted, measure, PairStatus, PairTolerances, TrackedPair};
use crate::route::{route, Field};
use crate::shape::ShapeSpec;
use puzzlebot_params::coupling::AnchorProbe;
use puzzlebot_params::geometry::Geometry;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::messages::RobotId;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};

/// A coupled pair the MPC must keep coupled (C_conn: THESIS (4.11), (5.23), (5.24)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MaintainPair {
    /// Robot with the anchor / knob.
    pub a: RobotId,
    /// Its connection point.
    pub point_a: ConnPoint,
    /// Its augmented point (anchor head / knob tip), body frame (m).
    pub head_a: [f64; 2],
    /// Robot with the opening / hole.
    pub b: RobotId,
    /// Its connection point.
    pub point_b: ConnPoint,
    /// Pair type.
    pub kind: PairType,
}

/// Output of one tick.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tick {
    /// Time (s).
    pub t: f64,
    /// One task per known, not lost robot, ordered by id.
    pub tasks: Vec<RobotTask>,
    /// Pairs to maintain (connected, not being released).
    pub maintain: Vec<MaintainPair>,
    /// Indices of active pairs (being aligned).
    pub active: Vec<usize>,
    /// All pairs of the current plan are connected and have been for
    /// [`CoordinatorConfig::form_settle_s`].
    pub complete: bool,
    /// Events of this tick.
    pub events: Vec<Event>,
}

/// A robot as last measured.
#[derive(Debug, Clone, Copy)]
struct Known {
    kind: RobotKind,
    pose: Pose2,
    last_seen: f64,
}

/// The planner/coordinator: plain data in (poses), plain data out (tasks, events).
#[derive(Debug, Clone)]
pub struct Coordinator {
    geometry: Geometry,
    cfg: CoordinatorConfig,
    plan: Option<Plan>,
    heading: Option<f64>,
    pairs: Vec<TrackedPair>,
    /// The plan's closing knobs ([`closures`]).
    closures: Vec<Closure>,
    /// Since when none of them has been open (s).
    closed_since: Option<f64>,
    released: BTreeSet<usize>,
    /// When each released pair was released, and the pairs re-wiggled because their head
    /// stayed in ([`Coordinator::update_released`]).
    release_watch: ReleaseWatch,
    robots: BTreeMap<RobotId, Known>,
    lost: BTreeSet<RobotId>,
    mode: Mode,
    events: Vec<Event>,
    pending: Vec<Event>,
    complete_reported: bool,
    /// Since when every planned pair has been connected (s).
    complete_since: Option<f64>,
    /// Velocity mode: each segment leader's reference origin (pose, time, initial (v, ω)):
    /// the origin of the segment's virtual rigid-body reference.
    motion_start: BTreeMap<RobotId, MotionStart>,
    /// Velocity mode: each member's measured pose in its leader's frame when the motion
    /// started (the assembly as it is: anchors bend, so the planned offsets would strain it).
    motion_offsets: BTreeMap<RobotId, Pose2>,
    /// Docking: the current driving direction (±1) per side pair; it reverses only after
    /// the robot passed its place by `DockConfig::overshoot`.
    dock_dir: std::cell::RefCell<BTreeMap<usize, Manoeuvre>>,
    /// Velocity mode: the path of every train, by leader ([`train`]).
    trains: std::cell::RefCell<BTreeMap<RobotId, train::TrainPath>>,
    /// Anchor couplings outside the plan (anchor robot, opening robot) → when first seen
    /// (s): undone by wiggling before formation goes on.
    unplanned: BTreeMap<(RobotId, RobotId), f64>,
    /// Knob couplings seen where the plan has none, (knob robot, hole robot) → when a person
    /// was last asked to lift them ([`Coordinator::watch_unplanned`]).
    knob_lifts: BTreeMap<(RobotId, RobotId), f64>,
    /// Growing the shape around this robot ([`Coordinator::form_grown`]).
    grow: Option<RobotId>,
    /// Growing: the second pilot, in the seed's lane, brought up by a train first.
    grow_lane: Option<RobotId>,
    /// Growing: where the partner of a side pair stood when its assembly first drove ahead to
    /// straighten, per pair.
    straighten_from: std::cell::RefCell<BTreeMap<usize, [f64; 2]>>,
    /// Growing: where the seed stood when the formation started; a bent assembly
    /// straightens towards it ([`Coordinator::straighten_backwards`]).
    grow_origin: Option<[f64; 2]>,
    /// Growing: where each held member of the grown assembly was first held
    /// ([`Coordinator::keep_grown`]).
    kept_at: BTreeMap<RobotId, Pose2>,
    /// Time of the current tick (s).
    now: f64,
    /// Closed-loop wiggles: the turning sense of every wiggling robot.
    wiggle_turns: BTreeMap<RobotId, WiggleTurn>,
    /// Anchor pairs under a tug: since when the pair's head has stayed inside the opening's
    /// guide while a robot of the pair drove, and where it was then ([`tug`]).
    tugs: BTreeMap<usize, tug::Tug>,
    /// Robots given a driving [`Role::Dock`] last tick, with its forward speed (m/s).
    driving: BTreeMap<RobotId, f64>,
}

impl Coordinator {
    /// A coordinator for robots with body geometry `geometry`.
    pub fn new(geometry: Geometry, cfg: CoordinatorConfig) -> Self {
        Coordinator {
            geometry,
            cfg,
            plan: None,
            heading: None,
            pairs: Vec::new(),
            closures: Vec::new(),
            closed_since: None,
            released: BTreeSet::new(),
            release_watch: ReleaseWatch::default(),
            robots: BTreeMap::new(),
            lost: BTreeSet::new(),
            mode: Mode::Hold,
            events: Vec::new(),
            pending: Vec::new(),
            complete_reported: false,
            complete_since: None,
            motion_start: BTreeMap::new(),
            motion_offsets: BTreeMap::new(),
            dock_dir: std::cell::RefCell::new(BTreeMap::new()),
            trains: Default::default(),
            unplanned: BTreeMap::new(),
            knob_lifts: BTreeMap::new(),
            grow: None,
            grow_lane: None,
            straighten_from: Default::default(),
            grow_origin: None,
            kept_at: BTreeMap::new(),
            now: 0.0,
            wiggle_turns: BTreeMap::new(),
            tugs: BTreeMap::new(),
            driving: BTreeMap::new(),
        }
    }

    /// A coordinator with tolerances from the fleet parameters and the MPC rate.
    pub fn from_params(p: &FleetParams) -> Self {
        let g = p.non_pilot.geometry;
        let cfg = CoordinatorConfig {
            tolerances: PairTolerances::from_params(&g, &p.non_pilot.coupling),
            dt: 1.0 / f64::from(p.rates.mpc_hz).max(1e-3),
            pilot_turn_radius: p.pilot.drive.min_turn_radius(),
            turn_radius: p.non_pilot.drive.min_turn_radius(),
            ..CoordinatorConfig::default()
        };
        Coordinator::new(g, cfg)
    }

    /// Current plan.
    pub fn plan(&self) -> Option<&Plan> {
        self.plan.as_ref()
    }

    /// Tracked pairs (index = pair id in tasks and events).
    pub fn pairs(&self) -> &[TrackedPair] {
        &self.pairs
    }

    /// Robots declared lost.
    pub fn lost(&self) -> &BTreeSet<RobotId> {
        &self.lost
    }

    /// Current behaviour.
    pub fn mode(&self) -> &Mode {
        &self.mode
    }

    /// True when a plan exists and all its pairs are connected now ([`Tick::complete`] also
    /// asks that they stayed so for [`CoordinatorConfig::form_settle_s`]).
    pub fn is_complete(&self) -> bool {
        self.plan.is_some()
            && self
                .pairs
                .iter()
                .enumerate()
                .all(|(i, p)| self.released.contains(&i) || p.status == PairStatus::Connected)
    }

    /// Ids of known robots that are not lost.
    pub fn robot_ids(&self) -> Vec<RobotId> {
        self.robots
            .keys()
            .copied()
            .filter(|id| !self.lost.contains(id))
            .collect()
    }

    /// Robot `id`'s kind as last seen (a robot never seen counts as a non-pilot).
    pub fn kind_of(&self, id: RobotId) -> RobotKind {
        self.robots.get(&id).map_or(RobotKind::NonPilot, |k| k.kind)
    }

    /// Last known pose of a robot.
    pub fn pose(&self, robot: RobotId) -> Option<Pose2> {
        self.robots.get(&robot).map(|k| k.pose)
    }

    fn observe(&mut self, t: f64, robots: &[RobotState]) {
        for r in robots {
            if r.pose.is_finite() && !self.lost.contains(&r.id) {
                self.robots.insert(
                    r.id,
                    Known {
                        kind: r.kind,
                        pose: r.pose,
                        last_seen: t,
                    },
                );
            }
        }
    }

    fn states(&self) -> Vec<RobotState> {
        self.robots
            .iter()
            .filter(|(id, _)| !self.lost.contains(id))
            .map(|(&id, k)| RobotState {
                id,
                kind: k.kind,
                pose: k.pose,
            })
            .collect()
    }

    /// One control tick: update statuses from `robots` (measured poses), detect lost robots,
    /// and return every robot's task.
    pub fn tick(&mut self, t: f64, robots: &[RobotState]) -> Tick {
        self.now = t;
        self.observe(t, robots);
        // Lost robots: planned robots unseen for too long (THESIS: re-plan without them).
        if let Some(plan) = &self.plan {
            let stale: Vec<RobotId> = plan
                .slot_robot
                .iter()
                .copied()
                .filter(|id| {
                    self.robots
                        .get(id)
                        .is_none_or(|k| t - k.last_seen > self.cfg.lost_after_s)
                })
                .collect();
            for id in stale {
                self.mark_lost(t, id);
            }
        }
        self.retarget_side_pairs(t);
        self.watch_unplanned(t);
        // Algorithm 8 on every tracked pair.
        for i in 0..self.pairs.len() {
            let (a, b) = (self.pairs[i].pair.a, self.pairs[i].pair.b);
            let (Some(ka), Some(kb)) = (self.robots.get(&a), self.robots.get(&b)) else {
                continue;
            };
            let (pa, pb) = (ka.pose, kb.pose);
            let tr = self.pairs[i].update(t, &pa, &pb, &self.geometry, &self.cfg.tolerances);
            self.push_transitions(i, tr);
        }
        self.update_released(t);
        self.confirm_by_tug(t);
        self.update_wiggles(t);
        self.watch_closures(t);
        self.complete_since = if self.is_complete() {
            Some(self.complete_since.unwrap_or(t))
        } else {
            None
        };
        let complete = self
            .complete_since
            .is_some_and(|since| t - since >= self.cfg.form_settle_s - 1e-9)
            && !self.closing(t, self.complete_since);
        if complete && !self.complete_reported && self.mode == Mode::Form {
            self.complete_reported = true;
            let open: Vec<(RobotId, RobotId)> = self
                .open_closures()
                .iter()
                .map(|c| (c.knob, c.hole))
                .collect();
            if !open.is_empty() {
                self.push(t, EventKind::ClosuresOpen { pairs: open });
            }
            self.push(t, EventKind::FormationComplete);
        }
        let segments = self.segments();
        if matches!(self.mode, Mode::Velocity { .. }) {
            for m in Self::members(&segments).values() {
                let leader = self.motion_leader(m);
                if let Some(k) = self.robots.get(&leader) {
                    let pose = k.pose;
                    if let std::collections::btree_map::Entry::Vacant(e) =
                        self.motion_start.entry(leader)
                    {
                        e.insert(MotionStart {
                            pose,
                            t0: t,
                            from: [0.0, 0.0],
                        });
                        for &id in m {
                            if let Some(k) = self.robots.get(&id) {
                                self.motion_offsets.insert(id, pose.relative(&k.pose));
                            }
                        }
                    }
                }
            }
        }
        let (mut tasks, active) = self.tasks(t, &segments);
        self.keep_grown(&mut tasks, &segments);
        self.make_way(&mut tasks, &segments, &active);
        let speed = self.cfg.dock.speed;
        self.driving = tasks
            .iter()
            .filter_map(|k| match k.role {
                Role::Dock { v, .. } if v.abs() >= 0.5 * speed => Some((k.robot, v)),
                _ => None,
            })
            .collect();
        let maintain = self
            .pairs
            .iter()
            .enumerate()
            .filter(|(i, p)| p.status == PairStatus::Connected && !self.released.contains(i))
            .filter(|(i, _)| match &self.mode {
                Mode::Decouple { pairs, .. } => !pairs.contains(i),
                _ => true,
            })
            .map(|(_, p)| MaintainPair {
                a: p.pair.a,
                point_a: p.pair.point_a,
                head_a: p.head_a(&self.geometry),
                b: p.pair.b,
                point_b: p.pair.point_b,
                kind: p.pair.kind,
            })
            .collect();
        Tick {
            t,
            tasks,
            maintain,
            active,
            complete,
            events: std::mem::take(&mut self.pending),
        }
    }
}
