//! The per-tick coordinator: given measured poses it updates every pair's status machine
//! (THESIS Algorithm 8), picks non-conflicting active pairs (Algorithm 3 lines 6–11, Algorithm 6
//! line 4), elects segment leaders (THESIS 5.5.9) and returns one task per robot for the
//! distributed MPC. It records every status change with its time, and re-plans without a robot
//! that is lost (THESIS Algorithm 2 on the remaining fleet).

mod approach;
mod decouple;
mod motion;
mod order;
mod retarget;
mod tasks;
mod tug;

pub use motion::VELOCITY_RAMP_S;
use motion::{ramp_pose, ramp_velocity, MotionStart};

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

/// What one robot should do this tick.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "role")]
pub enum Role {
    /// Stand still (no task; keep existing couplings).
    Hold,
    /// Stand still at `pose`, turning back to it when pushed (an MPC pose goal): a member
    /// of the assembly being grown while a robot joins it ([`Coordinator::keep_grown`]).
    Keep {
        /// Where the robot was when it was first held.
        pose: Pose2,
    },
    /// Not driven: a pilot that is not yet part of an assembly with a non-pilot (THESIS 3.5.2),
    /// or a robot whose pair must wait (convex-first).
    Wait,
    /// Segment leader aligning a connection pair (THESIS (4.5), (5.19)): bring `own_point`
    /// (body frame) onto the partner's `partner_point` (its body frame), with own yaw minus
    /// partner yaw → `relative_yaw`. For `puzzlebot_mpc::CostTerm::AlignPair`: own point
    /// angle 0, partner point angle `relative_yaw`.
    Align {
        /// Index of the pair in [`Coordinator::pairs`].
        pair: usize,
        /// The other robot.
        partner: RobotId,
        /// Point on this robot (m, body frame): the augmented head while decoupled.
        own_point: [f64; 2],
        /// Point on the partner (m, its body frame).
        partner_point: [f64; 2],
        /// Target own yaw − partner yaw (rad).
        relative_yaw: f64,
        /// Anchor–opening or knob–hole.
        kind: PairType,
        /// Current status of the pair (the phase).
        phase: PairStatus,
    },
    /// Follow the segment leader (THESIS (5.25)): stay at `offset` in the leader's body frame
    /// (`puzzlebot_mpc::CostTerm::FollowLeader`), with a smaller weight than the leader's.
    Follow {
        /// Leader of this robot's segment.
        leader: RobotId,
        /// This robot's pose in the leader's body frame: from the planned shape when both are
        /// in the plan, else as measured.
        offset: Pose2,
    },
    /// Fit a velocity command (THESIS (4.7)).
    Velocity {
        /// Linear velocity (m/s).
        v: f64,
        /// Angular velocity (rad/s).
        w: f64,
    },
    /// Go to a goal pose (THESIS (4.6)); `yaw` matters only when `use_yaw`.
    GoTo {
        /// Goal.
        goal: Pose2,
        /// Whether the heading is part of the goal.
        use_yaw: bool,
    },
    /// Track a reference trajectory (THESIS (5.26)): reference poses at t, t + dt, ….
    Track {
        /// Reference samples over the MPC horizon.
        reference: Vec<Pose2>,
    },
    /// Dock a side (knob–hole) connection (THESIS (3.2) θ_bias, 5.2.2): a lone robot on the
    /// approach line beside an assembly drives `(v, w)` directly (a geometric line follower;
    /// the MPC's pose tracking leaves millimetres of lateral error where the knob needs
    /// less than one). It converges on the partner's side at a shallow angle, presses its
    /// corner on it and straightens into the 0.04 rad fit while sliding onto the hole.
    /// Also the last stage of an anchor pair with a waiting pilot (it cannot make room):
    /// the robot turns on the spot to the pilot's axis, then drives straight in along it.
    Dock {
        /// Index of the pair in [`Coordinator::pairs`].
        pair: usize,
        /// Linear velocity (m/s).
        v: f64,
        /// Angular velocity (rad/s).
        w: f64,
    },
    /// A member hanging at an anchor while its train follows a reference: it drives `(v, w)`
    /// directly so that its connection point moves with its neighbour's, as a trailer behind
    /// its hitch ([`Coordinator::hitch_commands`]; with the MPC's pair alignment and its weak
    /// heading term the followers overshot their leader's yaw in turns under late ticks).
    Hitch {
        /// Index of the pair in [`Coordinator::pairs`] that holds it to its neighbour.
        pair: usize,
        /// Linear velocity (m/s).
        v: f64,
        /// Angular velocity (rad/s).
        w: f64,
    },
}

/// Staged approach of a side connection (see [`Role::Dock`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DockConfig {
    /// Length of the approach (m).
    pub run_in: f64,
    /// How far outside the final place the approach starts (m); the line follower then
    /// holds a smaller distance off the side until just before the place, past the wrong
    /// hole 25 mm before it (`approach::DOCK_HOLD`).
    pub offset: f64,
    /// Approach speed (m/s): above the wheels' start-up dead-band (20 RPM ≈ 0.036 m/s).
    pub speed: f64,
    /// Position tolerance of the approach's start (m).
    pub capture: f64,
    /// Heading per metre of lateral distance (rad/m): below 1 / (half a body length).
    pub k_lat: f64,
    /// Aim this far inside the partner's side (m), so the sides end up pressed together.
    pub press: f64,
    /// Largest heading towards the partner (rad).
    pub max_heading: f64,
    /// Heading gain: ω = −k_θ · heading error (1/s).
    pub k_theta: f64,
    /// An assembly bent more than this at an anchor (rad) straightens before a robot docks
    /// at its side.
    pub max_bend: f64,
    /// The docking robot reverses after passing its place by this much (m): less than the
    /// 25 mm to the next hole.
    pub overshoot: f64,
    /// A bent assembly straightens only while the docking robot is at least this far from
    /// its side (m); nearer, the moving holes could catch its knobs at the wrong place.
    pub clearance: f64,
    /// Stand-off of an anchor approach to a waiting pilot, on its axis (m).
    pub standoff: f64,
    /// Slowest turn on the spot (rad/s): both wheels above the dead-band.
    pub min_turn: f64,
    /// An anchor pair whose head stays inside the opening's guide, moving less than the
    /// anchor's travel, for this long (s) while one of its robots drives away from the other
    /// at the approach speed is coupled ([`tug`]): an uncoupled head would have left the
    /// guide within (travel + seat) / speed ≈ 0.12 s; this is ten times that plus the harsh
    /// profile's worst controller latency.
    pub tug_s: f64,
}

impl Default for DockConfig {
    fn default() -> Self {
        DockConfig {
            run_in: 0.10,
            offset: 0.006,
            speed: 0.05,
            capture: 0.012,
            k_lat: 20.0,
            press: 0.0003,
            max_heading: 0.2,
            k_theta: 4.0,
            max_bend: 0.04,
            overshoot: 0.012,
            clearance: 0.003,
            standoff: 0.06,
            min_turn: 0.9,
            tug_s: 1.5,
        }
    }
}

/// Growing: how far an assembly may drive ahead to straighten before a robot docks at its side
/// (m, per pair).
const GROW_STRAIGHTEN: f64 = 0.1;

/// A docking robot relative to its final pose (see [`Role::Dock`]).
struct DockFrame {
    /// Final pose: the two connection points on each other.
    fin: Pose2,
    /// The robot's position in the final pose's frame (m).
    here: [f64; 2],
    /// Unit normal of its connection point, own frame (x, y).
    normal: (f64, f64),
    /// Outward distance from the final line (the partner's side, extended) (m).
    lat: f64,
}

/// Where a robot's direct-drive manoeuvre for a pair stands (kept between ticks, per pair).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Manoeuvre {
    /// Side docking: sweeping along the side in this direction (±1).
    Sweep(f64),
    /// Anchor approach: at the stand-off, turning onto the axis.
    Turning,
    /// Anchor approach: driving along the axis (`dir` ±1: forwards / backwards), in or
    /// backing off; going in, the nearest it got (`best`, m out) and since when (s).
    In {
        /// ±1.
        dir: f64,
        /// Smallest distance out so far.
        best: f64,
        /// Time of the last progress.
        since: f64,
    },
}

/// One robot's task.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotTask {
    /// Robot.
    pub robot: RobotId,
    /// What to do.
    pub role: Role,
    /// Only straight motion allowed (a lone pilot, THESIS 5.4.1): the MPC must keep ω = 0.
    pub straight_only: bool,
    /// Leader of this robot's segment (itself when leading; `None` when alone and idle).
    pub leader: Option<RobotId>,
    /// Segment (connected assembly) index this tick.
    pub segment: usize,
}

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

/// Something that happened, with its time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "event")]
pub enum EventKind {
    /// A plan was made (Algorithm 2).
    Planned {
        /// Robots in the plan.
        robots: Vec<RobotId>,
        /// Number of pairs.
        pairs: usize,
    },
    /// A pair changed status.
    PairStatus {
        /// Pair index.
        pair: usize,
        /// Anchor / knob robot.
        a: RobotId,
        /// Opening / hole robot.
        b: RobotId,
        /// Pair type.
        kind: PairType,
        /// Before.
        from: PairStatus,
        /// After.
        to: PairStatus,
    },
    /// A side pair was re-targeted: the docking robot's knob / hole clicked in with a
    /// neighbour of its planned partner at the same place in the shape (a mesh side has a
    /// hole every half body; the anchors' play decides which lines up first).
    PairRetargeted {
        /// Pair index.
        pair: usize,
        /// Planned knob robot and hole robot.
        from: (RobotId, RobotId),
        /// Knob robot and hole robot now.
        to: (RobotId, RobotId),
    },
    /// Two robots coupled by an anchor the plan does not have (e.g. the wrong way round):
    /// they wiggle apart (THESIS 5.7) before formation goes on.
    UnplannedCoupling {
        /// Robot whose anchor is in.
        anchor: RobotId,
        /// Robot whose opening holds it.
        opening: RobotId,
    },
    /// An unplanned coupling came apart.
    UnplannedReleased {
        /// Robot whose anchor was in.
        anchor: RobotId,
        /// Robot whose opening held it.
        opening: RobotId,
    },
    /// A decouple behaviour has knob pairs: robots cannot pull a knob out of its hole
    /// (THESIS 5.5.3), so a person lifts them apart; the anchor pairs wiggle once every
    /// knob pair is measured out of its hole.
    LiftKnobs {
        /// Robots of the pairs being decoupled (lift the knob pairs among them).
        robots: Vec<RobotId>,
        /// The tracked knob pairs (knob robot, hole robot).
        pairs: Vec<(RobotId, RobotId)>,
    },
    /// A robot was declared lost.
    RobotLost {
        /// The robot.
        robot: RobotId,
    },
    /// The plan was recomputed without lost robots.
    Replanned {
        /// Robots in the new plan.
        robots: Vec<RobotId>,
    },
    /// Re-planning failed; the coordinator holds everyone.
    ReplanFailed {
        /// Why.
        reason: String,
    },
    /// Every pair of the plan is connected.
    FormationComplete,
    /// A behaviour started.
    BehaviourStarted {
        /// Its name.
        name: String,
    },
    /// A scenario step started.
    StepStarted {
        /// Step index (0-based).
        index: usize,
        /// Its label or behaviour name.
        label: String,
    },
    /// A scenario step finished.
    StepFinished {
        /// Step index.
        index: usize,
    },
    /// A scenario step failed (timeout or planning error); the scenario stops.
    StepFailed {
        /// Step index.
        index: usize,
        /// Why.
        reason: String,
    },
    /// A pair came apart while its assembly moved: the move stops and the pair is coupled
    /// again (the plan's formation) before the move goes on.
    Recoupling {
        /// Anchor / knob robot.
        a: RobotId,
        /// Opening / hole robot.
        b: RobotId,
        /// The move step.
        index: usize,
    },
    /// Every pair is coupled again after [`EventKind::Recoupling`]; the move goes on.
    Recoupled {
        /// Anchor / knob robot.
        a: RobotId,
        /// Opening / hole robot.
        b: RobotId,
    },
    /// A pair was released after decoupling and is no longer tracked.
    PairReleased {
        /// Anchor / knob robot.
        a: RobotId,
        /// Opening / hole robot.
        b: RobotId,
    },
}

/// A timed event.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// Time (s).
    pub t: f64,
    /// What happened.
    #[serde(flatten)]
    pub kind: EventKind,
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

/// The behaviour the coordinator is executing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Stand still, keep couplings.
    Hold,
    /// Form the planned shape (pairs from [`Coordinator::form`]).
    Form,
    /// Assemblies follow a velocity (leader fits it, others follow).
    Velocity {
        /// m/s.
        v: f64,
        /// rad/s.
        w: f64,
    },
    /// Each assembly moves so that the plan's shape centre reaches `goal` (leaders go to their
    /// slot placed at the goal; others follow).
    GoTo {
        /// Goal of the shape centre and heading.
        goal: Pose2,
    },
    /// Leaders track a trajectory of the shape centre (started at `start`).
    Track {
        /// The trajectory (times relative to `start`).
        trajectory: Trajectory,
        /// Start time (s).
        start: f64,
    },
    /// Rendezvous (THESIS (2.3)) or anti-rendezvous ((2.4)) of the given robots.
    Rendezvous {
        /// Robots taking part (others hold).
        robots: Vec<RobotId>,
        /// Gain on the consensus velocity (1/s).
        gain: f64,
        /// Anti-rendezvous.
        anti: bool,
        /// Anti-rendezvous: a robot whose nearest neighbour is this far (m) stops (THESIS
        /// (2.4) grows every distance exponentially: left to run, a robot that had already
        /// separated drove on, one pilot 3 m, while another was still close to its neighbour).
        #[serde(default)]
        until: Option<f64>,
    },
    /// The anchor robots of the given pairs wiggle (THESIS (5.7)) until decoupled.
    Decouple {
        /// Pairs (by index) to release.
        pairs: Vec<usize>,
        /// Wiggle profile.
        wiggle: Wiggle,
        /// Start time (s).
        start: f64,
    },
    /// Every listed robot goes to its own goal (THESIS (4.6)).
    Disperse {
        /// Goals.
        goals: BTreeMap<RobotId, Pose2>,
    },
}

/// Coordinator settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CoordinatorConfig {
    /// Status machine tolerances.
    pub tolerances: PairTolerances,
    /// A planned robot unseen for this long is lost and the plan is recomputed (s).
    pub lost_after_s: f64,
    /// A pair starts only when every pair of a shorter centre distance is connected
    /// (strict convex-first, THESIS 5.2.2: rows before the side joins).
    pub strict_convex_first: bool,
    /// MPC horizon samples for trajectory references.
    pub horizon_steps: usize,
    /// MPC step (s).
    pub dt: f64,
    /// Heading gain of the THESIS (3.2) point controller used by rendezvous.
    pub heading_gain: f64,
    /// Staged approach of side connections.
    pub dock: DockConfig,
    /// A formation counts as complete once every planned pair has stayed connected this long
    /// (s): the last join can knock an earlier pair loose (measured in lockstep: a pair came
    /// apart 0.1 s after the last one connected, and the run ended with it apart).
    pub form_settle_s: f64,
    /// Smallest turning radius of a pilot (m,
    /// [`puzzlebot_params::drive::Drive::min_turn_radius`]).
    pub pilot_turn_radius: f64,
}

impl Default for CoordinatorConfig {
    fn default() -> Self {
        CoordinatorConfig {
            tolerances: PairTolerances::default(),
            lost_after_s: 1.0,
            strict_convex_first: true,
            horizon_steps: 10,
            form_settle_s: 1.0,
            dt: 0.1,
            heading_gain: 1.0,
            dock: DockConfig::default(),
            pilot_turn_radius: puzzlebot_params::drive::Drive::for_kind(RobotKind::Pilot)
                .min_turn_radius(),
        }
    }
}

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
    released: BTreeSet<usize>,
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
            released: BTreeSet::new(),
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
            unplanned: BTreeMap::new(),
            knob_lifts: BTreeMap::new(),
            grow: None,
            grow_lane: None,
            straighten_from: Default::default(),
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

    /// All events so far.
    pub fn events(&self) -> &[Event] {
        &self.events
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

    /// Record an event (e.g. from a scenario runner); it is returned with the next tick.
    pub fn record(&mut self, t: f64, kind: EventKind) {
        self.push(t, kind);
    }

    /// Ids of known robots that are not lost.
    pub fn robot_ids(&self) -> Vec<RobotId> {
        self.robots
            .keys()
            .copied()
            .filter(|id| !self.lost.contains(id))
            .collect()
    }

    /// Events recorded since the last tick (drained).
    pub fn tick_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.pending)
    }

    fn push(&mut self, t: f64, kind: EventKind) {
        let e = Event { t, kind };
        self.events.push(e.clone());
        self.pending.push(e);
    }

    /// Record pair `i`'s status changes as events.
    fn push_transitions(&mut self, i: usize, transitions: Vec<crate::pair::Transition>) {
        let Some(p) = self.pairs.get(i).map(|tp| tp.pair) else {
            return;
        };
        for x in transitions {
            self.push(
                x.t,
                EventKind::PairStatus {
                    pair: i,
                    a: p.a,
                    b: p.b,
                    kind: p.kind,
                    from: x.from,
                    to: x.to,
                },
            );
        }
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

    /// Start forming `spec` with every known robot plus `robots` (THESIS Algorithms 2 and 7).
    /// Pairs that already exist with the same robots and points keep their status.
    pub fn form(
        &mut self,
        t: f64,
        spec: ShapeSpec,
        robots: &[RobotState],
        heading: Option<f64>,
    ) -> Result<&Plan, PlanError> {
        self.observe(t, robots);
        let states = self.states();
        let plan = assign_connection_pairs(&spec, &states, heading, &self.geometry)?;
        self.grow_lane = None;
        Ok(self.start_form(t, plan, heading, None))
    }

    /// Install `plan` and switch to forming it.
    fn start_form(
        &mut self,
        t: f64,
        plan: Plan,
        heading: Option<f64>,
        grow: Option<RobotId>,
    ) -> &Plan {
        self.heading = heading;
        self.grow = grow;
        self.install(t, plan, false);
        self.mode = Mode::Form;
        self.push(
            t,
            EventKind::BehaviourStarted {
                name: "form".into(),
            },
        );
        self.plan.as_ref().expect("just installed")
    }

    /// Start forming `spec` grown around one robot (`seed`; default: the pilot, else the
    /// robot nearest the fleet's centre), which stays where it is: the shape is placed on it
    /// ([`crate::assign::assign_around`]) and the other robots join its assembly one at a time, each alone,
    /// by the staged approaches (stand off, turn, drive in), while the assembly holds still.
    /// Slower than forming in parallel, but it needs no train to manoeuvre, so it works from
    /// scattered starts. A lone pilot is not driven (THESIS 3.5.2) and moves straight only
    /// (5.4.1), so with two pilots they must stand in one lane (the second behind the first,
    /// facing the same way): the front one is the seed, a non-pilot couples to the other,
    /// and the two drive straight up to the seed before the rest joins
    /// ([`assign_around_lane`]). More pilots, or two out of lane, are an error.
    pub fn form_grown(
        &mut self,
        t: f64,
        spec: ShapeSpec,
        robots: &[RobotState],
        seed: Option<RobotId>,
    ) -> Result<&Plan, PlanError> {
        self.observe(t, robots);
        let states = self.states();
        let (seed, lane) = self.grow_seed(&states, seed)?;
        let plan = assign_around_lane(&spec, &states, seed, lane, &self.geometry)?;
        let heading = Some(plan.heading);
        self.grow_lane = lane;
        Ok(self.start_form(t, plan, heading, Some(seed)))
    }

    /// The seed of a grown shape and the pilot in its lane, if any ([`Coordinator::form_grown`]).
    fn grow_seed(
        &self,
        states: &[RobotState],
        seed: Option<RobotId>,
    ) -> Result<(RobotId, Option<RobotId>), PlanError> {
        let pilots: Vec<&RobotState> = states
            .iter()
            .filter(|r| r.kind == RobotKind::Pilot)
            .collect();
        let too_many = PlanError::GrowPilots {
            pilots: pilots.len().max(2),
            radius: self.cfg.pilot_turn_radius,
        };
        match pilots[..] {
            [] => {
                let s = match seed {
                    Some(s) => s,
                    None => Self::central(states).ok_or(PlanError::NotEnoughRobots {
                        needed: 1,
                        available: 0,
                    })?,
                };
                Ok((s, None))
            }
            [p] => match seed {
                Some(s) if s != p.id => Err(too_many),
                _ => Ok((p.id, None)),
            },
            [a, b] => {
                // The front one (further along the pair's mean heading) is the seed.
                let h = wrap_angle(b.pose.yaw - a.pose.yaw) / 2.0 + a.pose.yaw;
                let along = |r: &RobotState| r.pose.x * h.cos() + r.pose.y * h.sin();
                let (front, back) = if along(a) >= along(b) { (a, b) } else { (b, a) };
                if seed.is_some_and(|s| s != front.id) {
                    return Err(too_many);
                }
                let d = front.pose.inverse_transform(back.pose.xy());
                let yaw = wrap_angle(back.pose.yaw - front.pose.yaw);
                let (max_lateral, max_yaw) = crate::assign::LANE_TOLERANCE;
                if d[1].abs() > max_lateral || yaw.abs() > max_yaw {
                    return Err(PlanError::PilotsNotInLane {
                        seed: front.id,
                        pilot: back.id,
                        lateral: d[1].abs(),
                        yaw,
                        max_lateral,
                        max_yaw,
                    });
                }
                Ok((front.id, Some(back.id)))
            }
            _ => Err(too_many),
        }
    }

    /// The robot nearest the centre of `states`.
    fn central(states: &[RobotState]) -> Option<RobotId> {
        let poses: Vec<Pose2> = states.iter().map(|r| r.pose).collect();
        let [cx, cy] = crate::assign::mean_position(&poses);
        states
            .iter()
            .min_by(|a, b| {
                let da = (a.pose.x - cx).hypot(a.pose.y - cy);
                let db = (b.pose.x - cx).hypot(b.pose.y - cy);
                da.total_cmp(&db)
            })
            .map(|r| r.id)
    }

    fn install(&mut self, t: f64, plan: Plan, replanned: bool) {
        let old: BTreeMap<_, _> = self
            .pairs
            .iter()
            .map(|p| (p.pair.key(), (p.status, p.since, p.last)))
            .collect();
        // Docking directions are per pair index: a new plan starts afresh.
        self.dock_dir.get_mut().clear();
        self.straighten_from.get_mut().clear();
        self.pairs = plan
            .pairs
            .iter()
            .map(|&pp| {
                let mut tp = TrackedPair::new(pp, t);
                if let Some(&(status, since, last)) = old.get(&pp.key()) {
                    tp.status = status;
                    tp.since = since;
                    tp.last = last;
                }
                tp
            })
            .collect();
        self.released.clear();
        self.complete_reported = false;
        self.complete_since = None;
        let robots = plan.slot_robot.clone();
        let n = plan.pairs.len();
        self.plan = Some(plan);
        if replanned {
            self.push(t, EventKind::Replanned { robots });
        } else {
            self.push(t, EventKind::Planned { robots, pairs: n });
        }
    }

    /// Declare `robot` lost and, when it was part of the plan, recompute the plan without it.
    pub fn mark_lost(&mut self, t: f64, robot: RobotId) {
        if !self.lost.insert(robot) {
            return;
        }
        self.push(t, EventKind::RobotLost { robot });
        let Some(plan) = self.plan.clone() else {
            return;
        };
        let Some(slot) = plan.slot_of(robot) else {
            return;
        };
        let spec = match &plan.spec {
            ShapeSpec::Fixed(shape) => match shape.without_slot(slot, &self.geometry) {
                Ok(s) => ShapeSpec::Fixed(s),
                Err(e) => {
                    self.fail_replan(t, e.to_string());
                    return;
                }
            },
            other => other.clone(),
        };
        let states: Vec<RobotState> = self
            .states()
            .into_iter()
            .filter(|r| plan.slot_of(r.id).is_some())
            .collect();
        let replan = match self.grow {
            // Grown around a seed that is still there: around it again, else the most
            // central robot.
            Some(seed) => {
                let seed = if seed == robot || self.grow_lane == Some(robot) {
                    self.grow_seed(&states, None).map(|(s, l)| {
                        self.grow_lane = l;
                        s
                    })
                } else {
                    Ok(seed)
                };
                self.grow = seed.as_ref().ok().copied();
                seed.and_then(|s| {
                    assign_around_lane(&spec, &states, s, self.grow_lane, &self.geometry)
                })
            }
            None => assign_connection_pairs(&spec, &states, Some(plan.heading), &self.geometry),
        };
        match replan {
            Ok(p) => self.install(t, p, true),
            Err(e) => self.fail_replan(t, e.to_string()),
        }
    }

    /// Let a robot declared lost take part again (it joins the next `form`); returns whether
    /// it was lost.
    pub fn readmit(&mut self, robot: RobotId) -> bool {
        let was = self.lost.remove(&robot);
        if was {
            // Its old pose is stale; wait for a fresh measurement.
            self.robots.remove(&robot);
        }
        was
    }

    fn fail_replan(&mut self, t: f64, reason: String) {
        self.plan = None;
        self.pairs.clear();
        self.dock_dir.get_mut().clear();
        self.mode = Mode::Hold;
        self.push(t, EventKind::ReplanFailed { reason });
    }

    /// Switch behaviour (formation is started with [`Coordinator::form`]).
    pub fn set_mode(&mut self, t: f64, mode: Mode) {
        let name = match &mode {
            Mode::Hold => "hold",
            Mode::Form => "form",
            Mode::Velocity { .. } => "velocity",
            Mode::GoTo { .. } => "go_to",
            Mode::Track { .. } => "trajectory",
            Mode::Rendezvous { anti: false, .. } => "rendezvous",
            Mode::Rendezvous { anti: true, .. } => "anti_rendezvous",
            Mode::Decouple { .. } => "decouple",
            Mode::Disperse { .. } => "disperse",
        };
        match (&self.mode, &mode) {
            // A velocity behaviour right after another: each reference goes on from where
            // the previous one is now, at its (v, ω), so the assembly does not stop between
            // the steps (and the members keep their offsets).
            (Mode::Velocity { v, w }, Mode::Velocity { .. }) => {
                let to = [*v, *w];
                for m in self.motion_start.values_mut() {
                    *m = MotionStart {
                        pose: ramp_pose(m, to, t - m.t0),
                        t0: t,
                        from: ramp_velocity(m, to, t - m.t0),
                    };
                }
            }
            _ => {
                self.motion_start.clear();
                self.motion_offsets.clear();
            }
        }
        self.mode = mode;
        self.push(t, EventKind::BehaviourStarted { name: name.into() });
        if let Mode::Decouple { pairs, .. } = &self.mode {
            let knobs: Vec<(RobotId, RobotId)> = pairs
                .iter()
                .filter_map(|&i| self.pairs.get(i))
                .filter(|p| p.pair.kind == PairType::KnobHole)
                .map(|p| (p.pair.a, p.pair.b))
                .collect();
            if !knobs.is_empty() {
                let mut robots: Vec<RobotId> = pairs
                    .iter()
                    .filter_map(|&i| self.pairs.get(i))
                    .flat_map(|p| [p.pair.a, p.pair.b])
                    .collect();
                robots.sort_unstable();
                robots.dedup();
                self.push(
                    t,
                    EventKind::LiftKnobs {
                        robots,
                        pairs: knobs,
                    },
                );
            }
        }
    }

    /// Robots seen and not lost, by id.
    fn live_ids(&self) -> Vec<RobotId> {
        self.robots
            .keys()
            .copied()
            .filter(|id| !self.lost.contains(id))
            .collect()
    }

    /// Segments (connected assemblies) from the connected, unreleased pairs: robot → segment.
    pub fn segments(&self) -> BTreeMap<RobotId, usize> {
        let ids = self.live_ids();
        let index: BTreeMap<RobotId, usize> =
            ids.iter().enumerate().map(|(i, &id)| (id, i)).collect();
        let mut groups = petgraph::unionfind::UnionFind::<usize>::new(ids.len());
        for (i, tp) in self.pairs.iter().enumerate() {
            if tp.status != PairStatus::Connected || self.released.contains(&i) {
                continue;
            }
            if let (Some(&a), Some(&b)) = (index.get(&tp.pair.a), index.get(&tp.pair.b)) {
                groups.union(a, b);
            }
        }
        // Renumber roots densely in id order.
        let mut dense = BTreeMap::new();
        let mut out = BTreeMap::new();
        for (i, &id) in ids.iter().enumerate() {
            let r = groups.find_mut(i);
            let n = dense.len();
            let s = *dense.entry(r).or_insert(n);
            out.insert(id, s);
        }
        out
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
        // Release decoupled pairs of a decouple behaviour.
        if let Mode::Decouple { pairs, .. } = &self.mode {
            let done: Vec<usize> = pairs
                .iter()
                .copied()
                .filter(|&i| {
                    !self.released.contains(&i)
                        && self
                            .pairs
                            .get(i)
                            .is_some_and(|p| p.status == PairStatus::Decoupled)
                })
                .collect();
            for i in done {
                self.released.insert(i);
                let p = self.pairs[i].pair;
                self.push(t, EventKind::PairReleased { a: p.a, b: p.b });
            }
        }
        self.confirm_by_tug(t);
        self.update_wiggles(t);
        self.complete_since = if self.is_complete() {
            Some(self.complete_since.unwrap_or(t))
        } else {
            None
        };
        let complete = self
            .complete_since
            .is_some_and(|since| t - since >= self.cfg.form_settle_s - 1e-9);
        if complete && !self.complete_reported && self.mode == Mode::Form {
            self.complete_reported = true;
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

    /// Growing: the held members of the grown assembly keep where they were first held
    /// ([`Role::Keep`]). A robot docking at its side turned its end robot about its anchor
    /// (rubbing along it, and steering by that robot's pose), and held at zero speed, the
    /// row stayed bent to the anchors' play, its corner in the docking lane.
    fn keep_grown(&mut self, tasks: &mut [RobotTask], segments: &BTreeMap<RobotId, usize>) {
        let home = match (&self.mode, self.grow) {
            (Mode::Form, Some(seed)) => segments.get(&seed).copied(),
            _ => None,
        };
        let size = home.map_or(0, |h| segments.values().filter(|&&s| s == h).count());
        let mut kept = BTreeMap::new();
        for task in tasks.iter_mut() {
            if task.role != Role::Hold || Some(task.segment) != home || size < 2 {
                continue;
            }
            // The lane pilot hangs at an anchor and turns no tighter than its butterfly:
            // driven back to where it was first held after a joining robot knocked the
            // assembly round, it lagged the others until its anchor popped (seed 1 of the
            // demo fleet: 0.5 rad knocked, 0.4 rad bend, popped). It holds where it is.
            if Some(task.robot) == self.grow_lane {
                continue;
            }
            let Some(now) = self.robots.get(&task.robot).map(|k| k.pose) else {
                continue;
            };
            let pose = self.kept_at.get(&task.robot).copied().unwrap_or(now);
            kept.insert(task.robot, pose);
            task.role = Role::Keep { pose };
        }
        self.kept_at = kept;
    }

    /// Forming: a lone non-pilot that waits in the corridor of an active pair's staged
    /// approach ([`Coordinator::approach_blockers`]) steps out of it. The approach chooser
    /// skips blocked pairs, but growing often has only one pair to choose (measured, seed 39
    /// of the demo's scattered start: a robot docking at the lone pilot pushed for 240 s
    /// against one waiting in its lane).
    fn make_way(
        &self,
        tasks: &mut [RobotTask],
        segments: &BTreeMap<RobotId, usize>,
        active: &[usize],
    ) {
        if self.mode != Mode::Form {
            return;
        }
        for &i in active {
            if !matches!(
                self.pairs.get(i).map(|p| p.status),
                Some(PairStatus::Decoupled | PairStatus::HeadAligned)
            ) {
                continue;
            }
            for (id, goal, _) in self.approach_blockers(i, segments) {
                if let Some(task) = tasks.iter_mut().find(|t| {
                    t.robot == id
                        && self.lone_non_pilot(id, segments)
                        && matches!(t.role, Role::Hold | Role::Wait)
                }) {
                    task.role = Role::GoTo {
                        goal,
                        use_yaw: false,
                    };
                    task.leader = Some(id);
                }
            }
        }
    }

    /// Robot `id`'s kind as last seen (a robot never seen counts as a non-pilot).
    pub fn kind_of(&self, id: RobotId) -> RobotKind {
        self.robots.get(&id).map_or(RobotKind::NonPilot, |k| k.kind)
    }

    /// Largest relative yaw over the connected anchor pairs inside `members` (rad).
    fn chain_bend(&self, members: &[RobotId]) -> f64 {
        self.live_pairs(members)
            .into_iter()
            .map(|i| &self.pairs[i])
            .filter(|p| p.pair.kind == PairType::AnchorOpening)
            .filter_map(|p| {
                let (a, b) = (self.robots.get(&p.pair.a)?, self.robots.get(&p.pair.b)?);
                Some(wrap_angle(a.pose.yaw - b.pose.yaw - p.pair.relative_yaw).abs())
            })
            .fold(0.0, f64::max)
    }

    /// Indices of connected pairs that involve `robot` (for decoupling it).
    pub fn connected_pairs_of(&self, robot: RobotId) -> Vec<usize> {
        self.pairs
            .iter()
            .enumerate()
            .filter(|(i, p)| {
                p.pair.involves(robot)
                    && !self.released.contains(i)
                    && p.status != PairStatus::Decoupled
            })
            .map(|(i, _)| i)
            .collect()
    }

    /// Indices of all tracked, unreleased pairs that are not decoupled.
    pub fn coupled_pairs(&self) -> Vec<usize> {
        self.pairs
            .iter()
            .enumerate()
            .filter(|(i, p)| !self.released.contains(i) && p.status != PairStatus::Decoupled)
            .map(|(i, _)| i)
            .collect()
    }

    /// Last known pose of a robot.
    pub fn pose(&self, robot: RobotId) -> Option<Pose2> {
        self.robots.get(&robot).map(|k| k.pose)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn np(id: RobotId, x: f64, y: f64, yaw: f64) -> RobotState {
        RobotState {
            id,
            kind: RobotKind::NonPilot,
            pose: Pose2::new(x, y, yaw),
        }
    }

    /// Four robots 0.3 m apart on a square, all facing +x.
    fn four_apart() -> Vec<RobotState> {
        vec![
            np(1, 0.0, 0.0, 0.0),
            np(2, 0.3, 0.0, 0.0),
            np(3, 0.0, 0.3, 0.0),
            np(4, 0.3, 0.3, 0.0),
        ]
    }

    fn coordinator() -> Coordinator {
        Coordinator::from_params(&FleetParams::default())
    }

    #[test]
    fn spreading_out_a_robot_already_clear_of_the_others_stops_while_close_ones_go_on() {
        // THESIS (2.4) pushes every robot away from the centre, faster the further it is:
        // with `until_distance` a robot whose nearest neighbour is that far stops.
        let robots = vec![
            np(1, 0.0, 0.0, 0.0),
            np(2, 0.03, 0.0, 0.0),
            np(3, 0.5, 0.0, 0.0),
        ];
        for until in [Some(0.1), None] {
            let mut c = coordinator();
            c.set_mode(
                0.0,
                Mode::Rendezvous {
                    robots: vec![1, 2, 3],
                    gain: 0.5,
                    anti: true,
                    until,
                },
            );
            let tick = c.tick(0.0, &robots);
            for id in [1, 2] {
                assert!(
                    matches!(role_of(&tick, id), Role::Velocity { v, .. } if v.abs() > 1e-3),
                    "robot {id} moves away: {:?}",
                    role_of(&tick, id)
                );
            }
            match until {
                Some(_) => assert_eq!(role_of(&tick, 3), &Role::Hold),
                None => assert!(
                    matches!(role_of(&tick, 3), Role::Velocity { v, .. } if *v > 0.1),
                    "{:?}",
                    role_of(&tick, 3)
                ),
            }
        }
    }

    #[test]
    fn dispersing_robots_that_must_pass_each_other_drive_round_not_through() {
        // Robot 1's goal lies beyond robot 2 and robot 2's beyond robot 1 (the MPC has no
        // obstacle terms: straight at their goals they pushed head-on until the step timed
        // out); a robot with a free way heads straight for its goal.
        let mut c = coordinator();
        let robots = vec![
            np(1, 0.0, 0.0, 0.0),
            np(2, 0.08, 0.0, std::f64::consts::PI),
            np(3, 0.0, 0.5, 0.0),
        ];
        let goals: BTreeMap<RobotId, Pose2> = [
            (1, Pose2::new(0.2, 0.0, 0.0)),
            (2, Pose2::new(-0.12, 0.0, 0.0)),
            (3, Pose2::new(0.2, 0.5, 0.0)),
        ]
        .into();
        c.set_mode(0.0, Mode::Disperse { goals });
        let tick = c.tick(0.0, &robots);
        let target = |id| match &role_of(&tick, id) {
            Role::GoTo { goal, .. } => *goal,
            other => panic!("robot {id}: {other:?}"),
        };
        for id in [1, 2] {
            let g = target(id);
            assert!(
                g.y.abs() > 0.02,
                "robot {id} heads off the line between them: {g:?}"
            );
        }
        let g3 = target(3);
        assert!(
            (g3.x - 0.2).abs() < 1e-12 && (g3.y - 0.5).abs() < 1e-12,
            "{g3:?}"
        );
    }

    /// Robots standing exactly on their plan's goal poses.
    fn at_goals(c: &Coordinator, kinds: &BTreeMap<RobotId, RobotKind>) -> Vec<RobotState> {
        let plan = c.plan().unwrap();
        plan.slot_robot
            .iter()
            .zip(&plan.goal_poses)
            .map(|(&id, &pose)| RobotState {
                id,
                kind: kinds[&id],
                pose,
            })
            .collect()
    }

    /// [`four_apart`] forming a 2×2 mesh heading along +x: the coordinator, the robots and
    /// their kinds.
    fn mesh_2x2_of_four_apart() -> (Coordinator, Vec<RobotState>, BTreeMap<RobotId, RobotKind>) {
        let mut c = coordinator();
        let robots = four_apart();
        let kinds = robots.iter().map(|r| (r.id, r.kind)).collect();
        c.form(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, Some(0.0))
            .unwrap();
        (c, robots, kinds)
    }

    fn role_of(tick: &Tick, id: RobotId) -> &Role {
        &tick.tasks.iter().find(|t| t.robot == id).unwrap().role
    }

    #[test]
    fn a_knob_clicked_in_where_the_plan_has_none_is_lifted_by_hand() {
        let (mut c, _, kinds) = mesh_2x2_of_four_apart();
        let lifts = |tick: &Tick| -> Vec<Vec<(RobotId, RobotId)>> {
            tick.events
                .iter()
                .filter_map(|e| match &e.kind {
                    EventKind::LiftKnobs { pairs, .. } => Some(pairs.clone()),
                    _ => None,
                })
                .collect()
        };
        // The finished mesh: its rows' knobs sit in each other's holes where the shape has
        // them side by side (more than the one planned knob pair): none is lifted.
        let mut robots = at_goals(&c, &kinds);
        let tick = c.tick(0.1, &robots);
        assert!(lifts(&tick).is_empty(), "{:?}", tick.events);
        // The back robot of the second row (slot 2, at (−12.5, 25) mm) one hole (25 mm)
        // further back, beside the first row's back robot: its holes take that robot's
        // knobs, at a place the plan does not have.
        let plan = c.plan().unwrap().clone();
        let moved = plan.slot_robot[2];
        for r in robots.iter_mut().filter(|r| r.id == moved) {
            r.pose = r.pose.compose(&Pose2::new(-0.025, 0.0, 0.0));
        }
        let tick = c.tick(0.2, &robots);
        let asked = lifts(&tick);
        assert!(
            asked.len() == 1 && asked[0].iter().all(|&(a, b)| a == moved || b == moved),
            "{asked:?}"
        );
        // Asked once, not again every tick.
        let tick = c.tick(0.3, &robots);
        assert!(lifts(&tick).is_empty());
    }

    #[test]
    fn mesh_2x2_rows_first_then_side_then_complete() {
        let (mut c, robots, kinds) = mesh_2x2_of_four_apart();
        let tick = c.tick(0.0, &robots);
        // One row first: forming the other row too would leave the side pair between two
        // assemblies, which cannot move sideways; its robots wait.
        assert_eq!(tick.active.len(), 1, "one row pair");
        for &i in &tick.active {
            assert_eq!(c.pairs()[i].pair.kind, PairType::AnchorOpening);
        }
        // Decoupled anchor robots aim their anchor head (THESIS Algorithm 7).
        let i = tick.active[0];
        let a = c.pairs()[i].pair.a;
        match role_of(&tick, a) {
            Role::Align { own_point, .. } => assert!((own_point[0] + 0.032).abs() < 1e-6),
            other => panic!("{other:?}"),
        }
        // Everyone on the goal: pairs pass to inserted, then connected after confirmation.
        let goal = at_goals(&c, &kinds);
        // Ticks at 10 Hz until complete: complete only once every pair has been connected for
        // form_settle_s.
        let mut all_connected = None;
        let mut t2 = c.tick(1.0, &goal);
        assert!(!t2.complete);
        for k in 1..=40 {
            let t = 1.0 + 0.1 * f64::from(k);
            t2 = c.tick(t, &goal);
            if t2.maintain.len() == 3 && all_connected.is_none() {
                all_connected = Some(t);
            }
            if all_connected == Some(t) {
                assert!(!t2.complete, "all connected, not yet settled");
            }
            if t2.complete {
                break;
            }
        }
        assert!(t2.complete, "connected for form_settle_s");
        let since = all_connected.expect("every pair connected");
        let settled = t2.t - since;
        assert!(
            (c.cfg.form_settle_s - 1e-9..c.cfg.form_settle_s + 0.15).contains(&settled),
            "complete {settled:.2} s after every pair connected"
        );
        assert!(t2
            .events
            .iter()
            .any(|e| e.kind == EventKind::FormationComplete));
        assert_eq!(t2.maintain.len(), 3);
        // Every pair's history is decoupled → aligned → inserted → connected, with times.
        for i in 0..3 {
            let steps: Vec<(f64, PairStatus)> = c
                .events()
                .iter()
                .filter_map(|e| match e.kind {
                    EventKind::PairStatus { pair, to, .. } if pair == i => Some((e.t, to)),
                    _ => None,
                })
                .collect();
            assert_eq!(
                steps.iter().map(|s| s.1).collect::<Vec<_>>(),
                vec![
                    PairStatus::HeadAligned,
                    PairStatus::HeadInserted,
                    PairStatus::Connected
                ]
            );
            assert_eq!(steps[2].0, 1.5);
        }
        let json = serde_json::to_string(&c.events()[0]).unwrap();
        assert!(json.contains("\"event\":\"planned\""), "{json}");
    }

    /// A 2×2 mesh whose first row pair is connected, ticked until its side pair is active:
    /// the coordinator, the robots, the tick, the row pair, the side pair's index and the
    /// robot outside the row that joins by it.
    fn row_formed_side_next() -> (
        Coordinator,
        Vec<RobotState>,
        Tick,
        PlannedPair,
        usize,
        RobotId,
    ) {
        let mut c = coordinator();
        let robots = four_apart();
        let kinds: BTreeMap<_, _> = robots.iter().map(|r| (r.id, r.kind)).collect();
        c.form(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, Some(0.0))
            .unwrap();
        // Connect the row pair that goes first; leave the others where they are.
        let first_tick = c.tick(0.0, &robots);
        let first = c.pairs()[first_tick.active[0]].pair;
        let goal = at_goals(&c, &kinds);
        let mixed: Vec<RobotState> = robots
            .iter()
            .map(|r| {
                if r.id == first.a || r.id == first.b {
                    *goal.iter().find(|g| g.id == r.id).unwrap()
                } else {
                    *r
                }
            })
            .collect();
        c.tick(0.1, &mixed);
        c.tick(0.2, &mixed);
        let tick = c.tick(1.0, &mixed);
        assert_eq!(tick.active.len(), 1, "{:?}", tick.active);
        let side = tick.active[0];
        let sp = c.pairs()[side].pair;
        let lone = if sp.a == first.a || sp.a == first.b {
            sp.b
        } else {
            sp.a
        };
        (c, mixed, tick, first, side, lone)
    }

    #[test]
    fn a_lone_robot_docks_at_a_row_instead_of_joining_two_rows_sideways() {
        let (c, _, tick, first, side, lone) = row_formed_side_next();
        // Next: the side (knob) pair, not the other row's anchor pair.
        assert_eq!(c.pairs()[side].pair.kind, PairType::KnobHole);
        // Its robot outside the row docks (drives directly or goes to the approach's start);
        // the row holds still.
        assert!(
            matches!(role_of(&tick, lone), Role::Dock { .. } | Role::GoTo { .. }),
            "{:?}",
            role_of(&tick, lone)
        );
        for id in [first.a, first.b] {
            assert_eq!(role_of(&tick, id), &Role::Hold, "row robot {id}");
        }
    }

    #[test]
    fn a_docking_robot_stays_off_the_side_until_it_has_passed_the_wrong_hole() {
        let (mut c, mixed, _, _, i, lone) = row_formed_side_next();
        let frame = c.dock_frame(i, lone).unwrap();
        let (_, ny) = frame.normal;
        // (v, turn towards the side) on the approach line, 3 mm out, `before` short of the
        // place and `yaw` towards the side.
        let mut drive_at = |t: f64, before: f64, yaw: f64| {
            let pose = frame
                .fin
                .compose(&Pose2::new(-before, -0.003 * ny, yaw * ny.signum()));
            let robots: Vec<RobotState> = mixed
                .iter()
                .map(|r| {
                    if r.id == lone {
                        RobotState { pose, ..*r }
                    } else {
                        *r
                    }
                })
                .collect();
            match role_of(&c.tick(t, &robots), lone) {
                Role::Dock { v, w, .. } => (*v, w * ny.signum()),
                other => panic!("{before} m before its place: {other:?}"),
            }
        };
        // 25 mm before the place its knob passes the wrong hole: still parallel, off the side
        // (it used to close in all the way and click in there).
        let (v, far) = drive_at(1.1, 0.03, 0.0);
        assert!(
            v > 0.0 && far.abs() < 0.05,
            "turns {far} rad/s 30 mm before its place"
        );
        // Heading for the side there (its turn onto the line went on too far): it turns away
        // on the spot before it drives on.
        let (v, w) = drive_at(1.2, 0.03, 0.3);
        assert!(v == 0.0 && w < -0.5, "v {v}, turns {w} rad/s");
        // Past the wrong hole, it closes in.
        let (v, near) = drive_at(1.3, 0.01, 0.0);
        assert!(
            v > 0.0 && near > 0.2,
            "turns {near} rad/s 10 mm before its place"
        );
    }

    /// [`row_formed_side_next`] with every robot at its goal, and the other row's anchor pair
    /// `j`: its robot in the side pair is in place, the other one (`me`) comes in along the
    /// axis, which runs beside the first row.
    struct OtherRow {
        c: Coordinator,
        goal: Vec<RobotState>,
        first: PlannedPair,
        j: usize,
        me: RobotId,
        /// `me`'s place (its partner in place).
        frame: DockFrame,
        /// Side of `me`'s connection point (+1: front).
        s: f64,
        /// Side of the axis the first row stands on (±1).
        row_side: f64,
    }

    fn other_row_approach() -> OtherRow {
        let (mut c, mixed, _, first, side, _) = row_formed_side_next();
        let kinds: BTreeMap<_, _> = mixed.iter().map(|r| (r.id, r.kind)).collect();
        let goal = at_goals(&c, &kinds);
        let sp = c.pairs()[side].pair;
        let j = (0..c.pairs().len())
            .find(|&k| k != side && c.pairs()[k].pair != first)
            .unwrap();
        let p = c.pairs()[j].pair;
        let me = if [sp.a, sp.b].contains(&p.a) {
            p.b
        } else {
            p.a
        };
        c.tick(1.5, &goal);
        let frame = c.dock_frame(j, me).unwrap();
        let s = frame.normal.0.signum();
        let row_side = frame
            .fin
            .inverse_transform(goal.iter().find(|r| r.id == first.a).unwrap().pose.xy())[1]
            .signum();
        OtherRow {
            c,
            goal,
            first,
            j,
            me,
            frame,
            s,
            row_side,
        }
    }

    #[test]
    fn an_anchor_approach_beside_a_row_keeps_off_the_robots_where_they_are() {
        let OtherRow {
            mut c,
            goal,
            first,
            j,
            me,
            frame,
            s,
            row_side,
        } = other_row_approach();
        let p = c.pairs()[j].pair;
        // The first row stands 3 mm nearer the axis than planned (a bent or skewed row).
        let (sn, cs) = frame.fin.yaw.sin_cos();
        let shift = -row_side * 0.003;
        let robots: Vec<RobotState> = goal
            .iter()
            .map(|r| {
                let mut r = *r;
                if r.id == first.a || r.id == first.b {
                    r.pose.x -= sn * shift;
                    r.pose.y += cs * shift;
                } else if r.id == me {
                    // 60 mm out on the axis, 4 mm off it away from the row, parallel.
                    r.pose = frame
                        .fin
                        .compose(&Pose2::new(-s * 0.06, -row_side * 0.004, 0.0));
                }
                r
            })
            .collect();
        c.tick(2.0, &robots);
        c.dock_dir.borrow_mut().insert(
            j,
            Manoeuvre::In {
                dir: s,
                best: 0.06,
                since: 2.0,
            },
        );
        let role = c.anchor_approach_role(j, me);
        let Some(Role::Dock { v, w, .. }) = role else {
            panic!(
                "{role:?} me {me} pair {p:?} {:?} {:?}",
                c.robots.get(&me),
                frame.fin
            );
        };
        assert!(v * s > 0.0, "going in: v {v}");
        // 4 mm off the axis is 1 mm off the row's side: it steers away from the row (it
        // used to hold 4 mm off the axis and slid flush along the row's side).
        let away = w * -row_side * s;
        assert!(away > 0.1, "turns {w} rad/s (away from the row: {away})");
    }

    #[test]
    fn an_anchor_approach_shortens_its_run_in_to_keep_clear_of_a_waiting_robot() {
        use approach::{FLUSH_RUN_IN, ROUTE_CLEARANCE};
        let OtherRow {
            mut c,
            goal,
            j,
            me,
            frame,
            s,
            row_side,
            ..
        } = other_row_approach();
        // The robot starts 0.4 m out and 0.3 m to the side away from the row.
        let start = frame
            .fin
            .compose(&Pose2::new(-s * 0.4, -row_side * 0.3, 0.0));
        // Another robot stands 5 cm beside the axis at the usual stand-off (as a row would).
        let beside = frame
            .fin
            .compose(&Pose2::new(-s * c.cfg.dock.standoff, row_side * 0.05, 0.0));
        let mut robots: Vec<RobotState> = goal
            .iter()
            .map(|r| {
                let mut r = *r;
                if r.id == me {
                    r.pose = start;
                }
                r
            })
            .collect();
        robots.push(np(8, beside.x, beside.y, 0.0));
        c.tick(2.0, &robots);
        // The stand-off moves out past it, plus the line follower's run-in.
        let full = c.approach_standoff(&frame.fin, s, me);
        assert!(
            full >= c.cfg.dock.standoff + FLUSH_RUN_IN - 1e-9,
            "stand-off {full}"
        );
        // A robot waits 4 cm beside that stand-off, on the side away from the row.
        let waiting = frame
            .fin
            .compose(&Pose2::new(-s * full, -row_side * 0.04, 0.0));
        let mut with = robots.clone();
        with.push(np(9, waiting.x, waiting.y, 0.0));
        c.tick(2.1, &with);
        let short = c.approach_standoff(&frame.fin, s, me);
        let pre = frame.fin.compose(&Pose2::new(-s * short, 0.0, 0.0));
        assert!(
            short < full && short >= full - FLUSH_RUN_IN - 1e-9,
            "stand-off {short} (without the waiting robot {full})"
        );
        let gap = (pre.x - waiting.x).hypot(pre.y - waiting.y);
        assert!(gap >= ROUTE_CLEARANCE, "{gap} from the waiting robot");
        // So the robot drives to it (a stand-off beside the waiting robot had no route: it
        // held until the step timed out).
        let role = c.anchor_approach_role(j, me);
        assert!(
            matches!(role, Some(Role::Dock { .. } | Role::GoTo { .. })),
            "{role:?}"
        );
    }

    #[test]
    fn lost_robot_triggers_replan_without_it() {
        let mut c = coordinator();
        let robots: Vec<RobotState> = (1..=4)
            .map(|i| np(i, 0.1 * f64::from(i), 0.2, 0.0))
            .collect();
        c.form(0.0, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
        assert_eq!(c.plan().unwrap().pairs.len(), 3);
        c.tick(0.0, &robots);
        let without: Vec<RobotState> = robots.iter().copied().filter(|r| r.id != 3).collect();
        c.tick(0.5, &without);
        assert_eq!(c.plan().unwrap().slot_robot.len(), 4, "not lost yet");
        let tick = c.tick(1.2, &without);
        assert!(tick
            .events
            .iter()
            .any(|e| e.kind == EventKind::RobotLost { robot: 3 }));
        assert!(tick
            .events
            .iter()
            .any(|e| matches!(e.kind, EventKind::Replanned { .. })));
        let plan = c.plan().unwrap();
        assert_eq!(plan.slot_robot.len(), 3);
        assert!(!plan.slot_robot.contains(&3));
        assert_eq!(plan.pairs.len(), 2);
        assert!(plan.pairs.iter().all(|p| !p.involves(3)));
        assert!(tick.tasks.iter().all(|t| t.robot != 3));
        // If it shows up again it stays out of the plan until readmitted and re-formed.
        c.tick(1.3, &robots);
        assert!(!c.plan().unwrap().slot_robot.contains(&3));
        assert!(c.readmit(3));
        c.tick(1.4, &robots);
        c.form(1.4, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
        assert_eq!(c.plan().unwrap().slot_robot.len(), 4);
    }

    #[test]
    fn explicit_loss_of_a_fixed_shape_middle_slot_fails_cleanly() {
        let g = Geometry::default();
        let shape = crate::shape::Shape::line(3, &g).unwrap();
        let mut c = coordinator();
        let robots: Vec<RobotState> = (1..=3)
            .map(|i| np(i, 0.1 * f64::from(i), 0.0, 0.0))
            .collect();
        c.form(0.0, ShapeSpec::Fixed(shape), &robots, Some(0.0))
            .unwrap();
        let middle = c.plan().unwrap().slot_robot[1];
        c.mark_lost(0.1, middle);
        assert!(c.plan().is_none());
        assert!(c
            .events()
            .iter()
            .any(|e| matches!(e.kind, EventKind::ReplanFailed { .. })));
    }

    #[test]
    fn growing_takes_one_pilot_as_its_seed_and_holds_the_assembly_still() {
        let mut c = coordinator();
        let mut robots = vec![
            np(1, 0.0, 0.0, 0.0),
            np(2, 0.3, 0.2, 1.0),
            np(3, -0.3, 0.1, 2.0),
        ];
        robots[0].kind = RobotKind::Pilot;
        robots[2].kind = RobotKind::Pilot;
        // Two pilots out of lane: the error gives the numbers.
        let err = c
            .form_grown(0.0, ShapeSpec::Line, &robots, None)
            .unwrap_err();
        assert!(
            matches!(
                err,
                PlanError::PilotsNotInLane {
                    seed: 1,
                    pilot: 3,
                    ..
                }
            ),
            "{err}"
        );
        assert!(
            err.to_string().contains("0.100 m off pilot 1's axis"),
            "{err}"
        );
        // Three pilots: no lane takes them.
        robots[1].kind = RobotKind::Pilot;
        let err = c
            .form_grown(0.0, ShapeSpec::Line, &robots, None)
            .unwrap_err();
        assert!(
            matches!(err, PlanError::GrowPilots { pilots: 3, .. }),
            "{err}"
        );
        assert!(err.to_string().contains("0.61 m"), "{err}");
        robots[1].kind = RobotKind::NonPilot;
        robots[2].kind = RobotKind::NonPilot;
        let plan = c.form_grown(0.0, ShapeSpec::Line, &robots, None).unwrap();
        // Built on the pilot, where it stands.
        let at = plan.goal_poses[plan.slot_of(1).unwrap()];
        assert!(at.x.abs() < 1e-9 && at.y.abs() < 1e-9 && at.yaw.abs() < 1e-9);
        let tick = c.tick(0.0, &robots);
        // One robot at a time joins the pilot; the pilot is not driven, the other waits.
        assert_eq!(tick.active.len(), 1);
        assert!(matches!(role_of(&tick, 1), Role::Hold | Role::Wait));
        let moving: Vec<RobotId> = [2, 3]
            .into_iter()
            .filter(|&id| matches!(role_of(&tick, id), Role::Dock { .. } | Role::GoTo { .. }))
            .collect();
        assert_eq!(moving.len(), 1, "{:?}", tick.tasks);
    }

    #[test]
    fn a_second_pilot_in_the_lane_is_linked_to_the_seed_first() {
        // Pilot 2 set down 0.4 m behind pilot 1, facing the same way (a little off by hand);
        // four non-pilots scattered. THESIS 5.4.1: pilots move straight only.
        let mut c = coordinator();
        let mut robots = vec![
            np(1, 0.1, 0.05, 0.3),
            np(
                2,
                0.1 - 0.4 * 0.3f64.cos(),
                0.05 - 0.4 * 0.3f64.sin() + 0.004,
                0.32,
            ),
            np(3, 0.3, -0.25, 1.0),
            np(4, -0.3, 0.3, 2.0),
            np(5, 0.35, 0.3, -1.0),
            np(6, -0.1, -0.3, 0.5),
        ];
        robots[0].kind = RobotKind::Pilot;
        robots[1].kind = RobotKind::Pilot;
        // The seed given as the back pilot is refused (only the front one stays put).
        assert!(matches!(
            c.form_grown(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, Some(2)),
            Err(PlanError::GrowPilots { .. })
        ));
        let plan = c
            .form_grown(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, None)
            .unwrap()
            .clone();
        // Built on pilot 1 where it stands; pilot 2's place ahead of it on its own axis.
        let at = plan.goal_of(1).unwrap();
        assert!((at.x - 0.1).abs() < 1e-9 && (at.y - 0.05).abs() < 1e-9);
        let p2 = robots[1].pose;
        let d = p2.inverse_transform(plan.goal_of(2).unwrap().xy());
        assert!(d[0] > 0.2 && d[1].abs() < 0.012, "pilot 2's place {d:?}");
        // The robot between them: anchor pairs to both pilots.
        let link = |a: RobotId| {
            plan.pairs
                .iter()
                .filter(|p| p.kind == PairType::AnchorOpening && (p.a == a || p.b == a))
                .map(|p| if p.a == a { p.b } else { p.a })
                .collect::<Vec<_>>()
        };
        let middle = link(2)[0];
        assert!(link(1).contains(&middle), "{:?}", plan.pairs);
        // First a non-pilot couples to pilot 2 where it waits; everyone else waits.
        let tick = c.tick(0.0, &robots);
        assert_eq!(tick.active.len(), 1);
        let p = c.pairs()[tick.active[0]].pair;
        assert!([p.a, p.b].contains(&2) && [p.a, p.b].contains(&middle));
        assert!(matches!(role_of(&tick, 2), Role::Wait));
        assert!(matches!(role_of(&tick, 1), Role::Hold | Role::Wait));
        // Coupled (pose at its place in front of pilot 2): the two join pilot 1 next.
        let place = p2.compose(
            &plan
                .goal_of(2)
                .unwrap()
                .inverse()
                .compose(&plan.goal_of(middle).unwrap()),
        );
        for r in robots.iter_mut().filter(|r| r.id == middle) {
            r.pose = place;
        }
        let mut t = 0.0;
        while c.pairs()[tick.active[0]].status != PairStatus::Connected && t < 3.0 {
            t += 0.1;
            c.tick(t, &robots);
        }
        assert_eq!(c.pairs()[tick.active[0]].status, PairStatus::Connected);
        let tick = c.tick(t + 0.1, &robots);
        assert_eq!(tick.active.len(), 1);
        let q = c.pairs()[tick.active[0]].pair;
        assert!(
            [q.a, q.b].contains(&1) && [q.a, q.b].contains(&middle),
            "{q:?}"
        );
        // Pilot 2 is driven with its partner now, straight up the lane, the partner in
        // front pulling it; pilot 1 holds.
        match (role_of(&tick, middle), role_of(&tick, 2)) {
            (Role::Dock { v: v1, .. }, Role::Dock { v: v2, w: w2, .. }) => {
                assert!(
                    *v1 > 0.0 && *v2 > 0.0 && v2 < v1 && *w2 == 0.0,
                    "{v1} {v2} {w2}"
                );
            }
            other => panic!("train roles {other:?}"),
        }
        assert!(matches!(role_of(&tick, 1), Role::Hold | Role::Wait));
        // A robot waiting in the lane ahead of the train: the train stops and it steps aside.
        let ahead = place.compose(&Pose2::new(0.1, 0.01, 0.5));
        let other = [3, 4, 5, 6]
            .into_iter()
            .find(|&id| id != middle)
            .expect("another robot");
        for r in robots.iter_mut().filter(|r| r.id == other) {
            r.pose = ahead;
        }
        let tick = c.tick(t + 0.2, &robots);
        for id in [middle, 2] {
            assert!(
                matches!(role_of(&tick, id), Role::Dock { v, w, .. } if *v == 0.0 && *w == 0.0),
                "robot {id}: {:?}",
                role_of(&tick, id)
            );
        }
        match role_of(&tick, other) {
            Role::GoTo { goal, .. } => {
                let o = ahead.inverse_transform(goal.xy());
                assert!(o[1].abs() > 0.05, "aside: {o:?}");
            }
            r => panic!("robot {other} does not make way: {r:?}"),
        }
    }

    /// Pilot 1 and three non-pilots scattered round it, growing a line round the pilot: the
    /// coordinator, the robots, their kinds and the line's robots in slot order.
    #[allow(clippy::type_complexity)]
    fn line_grown_round_pilot_1() -> (
        Coordinator,
        Vec<RobotState>,
        BTreeMap<RobotId, RobotKind>,
        Vec<RobotId>,
    ) {
        let mut c = coordinator();
        let mut robots = vec![
            np(1, 0.0, 0.0, 0.0),
            np(2, 0.3, 0.2, 1.0),
            np(3, -0.3, 0.3, 2.0),
            np(4, 0.2, -0.3, -1.0),
        ];
        robots[0].kind = RobotKind::Pilot;
        let kinds = robots.iter().map(|r| (r.id, r.kind)).collect();
        let slots = c
            .form_grown(0.0, ShapeSpec::Line, &robots, None)
            .unwrap()
            .slot_robot
            .clone();
        (c, robots, kinds, slots)
    }

    #[test]
    fn a_robot_waiting_in_a_docking_lane_makes_way() {
        let (mut c, mut robots, _, _) = line_grown_round_pilot_1();
        let tick = c.tick(0.0, &robots);
        let i = tick.active[0];
        let p = c.pairs()[i].pair;
        let mover = if p.a == 1 { p.b } else { p.a };
        let waiting = [2, 3, 4]
            .into_iter()
            .find(|&id| id != mover)
            .expect("a waiting robot");
        // Put the waiting robot on the approach axis, between the stand-off and the place.
        let f = c.dock_frame(i, mover).expect("dock frame");
        let s = f.normal.0.signum();
        let at = f.fin.transform([-s * 0.06, 0.01]);
        for r in robots.iter_mut().filter(|r| r.id == waiting) {
            r.pose = Pose2::new(at[0], at[1], 0.3);
        }
        let tick = c.tick(0.1, &robots);
        assert_eq!(tick.active, vec![i], "the same pair goes on");
        match role_of(&tick, waiting) {
            Role::GoTo { goal, .. } => {
                let o = f.fin.inverse_transform(goal.xy());
                // Its body (half a width) outside the 35 mm corridor.
                assert!(
                    o[1] > 0.035 + 0.025 && (o[0] + s * 0.06).abs() < 1e-9,
                    "beside the corridor, on its own side: {o:?}"
                );
            }
            r => panic!("robot {waiting} does not make way: {r:?}"),
        }
        // Beside the corridor but where the approaching robot must stand off (the route
        // there keeps its clearance): it steps further out.
        let near = f.fin.transform([-s * 0.06, 0.05]);
        for r in robots.iter_mut().filter(|r| r.id == waiting) {
            r.pose = Pose2::new(near[0], near[1], 0.3);
        }
        let tick = c.tick(0.15, &robots);
        match role_of(&tick, waiting) {
            Role::GoTo { goal, .. } => {
                let o = f.fin.inverse_transform(goal.xy());
                assert!(
                    o[1] > approach::ROUTE_CLEARANCE,
                    "clear of the stand-off: {o:?}"
                );
            }
            r => panic!("robot {waiting} does not make way at the stand-off: {r:?}"),
        }
        // Out of the corridor and clear of the stand-off it waits again.
        let out = f.fin.transform([-s * 0.06, 0.09]);
        for r in robots.iter_mut().filter(|r| r.id == waiting) {
            r.pose = Pose2::new(out[0], out[1], 0.3);
        }
        let tick = c.tick(0.2, &robots);
        assert!(
            matches!(role_of(&tick, waiting), Role::Hold | Role::Wait),
            "{:?}",
            role_of(&tick, waiting)
        );
    }

    #[test]
    fn a_grown_row_pushed_while_a_robot_joins_it_turns_back_to_where_it_was_held() {
        let (mut c, robots, kinds, _) = line_grown_round_pilot_1();
        // The first robot to join the pilot is coupled to it, where the plan puts it.
        let active = c.tick(0.0, &robots).active[0];
        let first = c.pairs()[active].pair;
        let joined = if first.a == 1 { first.b } else { first.a };
        let goal = at_goals(&c, &kinds);
        let mut now: Vec<RobotState> = robots
            .iter()
            .map(|r| match r.id {
                id if id == joined => *goal.iter().find(|g| g.id == id).unwrap(),
                _ => *r,
            })
            .collect();
        for k in 1..=10 {
            c.tick(0.1 * k as f64, &now);
        }
        assert!(c
            .pairs()
            .iter()
            .any(|p| p.pair == first && p.status == PairStatus::Connected));
        c.tick(1.1, &now);
        let tick = c.tick(1.2, &now);
        let held = |tick: &Tick, id| match role_of(tick, id) {
            Role::Keep { pose } => *pose,
            r => panic!("robot {id}: {r:?}"),
        };
        let at = held(&tick, joined);
        assert_eq!(at, now.iter().find(|r| r.id == joined).unwrap().pose);
        held(&tick, 1);
        // Pushed (turned about its anchor by the next robot docking): it keeps the pose
        // where it was first held, to turn back to.
        for r in now.iter_mut().filter(|r| r.id == joined) {
            r.pose.yaw += 0.1;
        }
        let tick = c.tick(1.3, &now);
        assert_eq!(held(&tick, joined), at);
        // The robot that joins next is not held.
        assert!(tick
            .tasks
            .iter()
            .filter(|t| t.robot != 1 && t.robot != joined)
            .all(|t| !matches!(t.role, Role::Keep { .. })));
    }

    #[test]
    fn growing_brings_a_coupled_group_outside_the_grown_assembly_to_it() {
        let (mut c, _, kinds, slots) = line_grown_round_pilot_1();
        // The robots on the far side of the pilot coupled to each other in their places of
        // the line, but 0.3 m to the side (their coupling out of turn, or the one to the
        // pilot's side came apart); the near side joined: no lone robot is left to join.
        let at = slots.iter().position(|&id| id == 1).unwrap();
        let far: Vec<RobotId> = if at < slots.len() / 2 {
            slots[at + 1..].to_vec()
        } else {
            slots[..at].to_vec()
        };
        assert!(far.len() >= 2, "{slots:?}");
        let off: Vec<RobotState> = at_goals(&c, &kinds)
            .into_iter()
            .map(|mut r| {
                if far.contains(&r.id) {
                    r.pose.y += 0.3;
                }
                r
            })
            .collect();
        for k in 0..=10 {
            c.tick(0.1 * k as f64, &off);
        }
        let segments = c.segments();
        assert!(
            far.iter().all(|id| segments[id] == segments[&far[0]])
                && slots
                    .iter()
                    .all(|id| far.contains(id) || segments[id] == segments[&1]),
            "{segments:?}"
        );
        // The group is brought to the grown assembly by their anchor pair; it does not wait.
        let tick = c.tick(1.1, &off);
        assert_eq!(tick.active.len(), 1, "{:?}", tick.tasks);
        let p = c.pairs()[tick.active[0]].pair;
        assert!(far.contains(&p.a) != far.contains(&p.b), "{p:?}");
        assert!(tick.tasks.iter().any(|t| far.contains(&t.robot)
            && !matches!(t.role, Role::Wait | Role::Hold | Role::Keep { .. })));
    }

    #[test]
    fn lone_pilot_waits_and_non_pilot_approaches_on_its_axis() {
        let mut c = coordinator();
        let mut robots = vec![np(1, 0.0, 0.0, 0.0), np(2, 0.2, 0.0, 0.0)];
        robots[1].kind = RobotKind::Pilot;
        c.form(0.0, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
        let tick = c.tick(0.0, &robots);
        assert_eq!(role_of(&tick, 2), &Role::Wait);
        // The staged approach (to the stand-off on the pilot's axis; near it, by the point
        // law), not the MPC's pair alignment, which pushes a robot that cannot move away.
        assert!(
            matches!(
                role_of(&tick, 1),
                Role::GoTo { .. } | Role::Dock { pair: 0, .. }
            ),
            "robot 1: {:?}",
            role_of(&tick, 1)
        );
        assert!(
            tick.tasks
                .iter()
                .find(|t| t.robot == 2)
                .unwrap()
                .straight_only
        );
    }

    /// Two robots that formed a line by t = 0.5 s (no settling), standing at their goals.
    fn formed_pair() -> (Coordinator, Vec<RobotState>) {
        formed(
            ShapeSpec::Line,
            &[np(1, 0.0, 0.0, 0.0), np(2, 0.2, 0.0, 0.0)],
        )
    }

    /// `robots` formed into `spec` (every robot on its goal, every pair connected).
    fn formed(spec: ShapeSpec, robots: &[RobotState]) -> (Coordinator, Vec<RobotState>) {
        let mut c = coordinator();
        c.cfg.form_settle_s = 0.0;
        let kinds: BTreeMap<_, _> = robots.iter().map(|r| (r.id, r.kind)).collect();
        c.form(0.0, spec, robots, Some(0.0)).unwrap();
        let goal = at_goals(&c, &kinds);
        let mut t = 0.0;
        while !c.tick(t, &goal).complete {
            t += 0.1;
            assert!(t < 5.0, "formed: {:?}", c.pairs());
        }
        (c, goal)
    }

    /// `robots` with the robots `ids` moved by (dx, dy).
    fn moved(robots: &[RobotState], ids: &[RobotId], dx: f64, dy: f64) -> Vec<RobotState> {
        robots
            .iter()
            .map(|r| {
                let mut r = *r;
                if ids.contains(&r.id) {
                    r.pose.x += dx;
                    r.pose.y += dy;
                }
                r
            })
            .collect()
    }

    /// `robots` formed into `spec`, then decoupling every pair from t = 5 s: (coordinator,
    /// poses, the pairs).
    fn decoupling(
        spec: ShapeSpec,
        robots: &[RobotState],
    ) -> (Coordinator, Vec<RobotState>, Vec<usize>) {
        let (mut c, goal) = formed(spec, robots);
        let pairs = c.coupled_pairs();
        c.set_mode(
            5.0,
            Mode::Decouple {
                pairs: pairs.clone(),
                wiggle: Wiggle::default(),
                start: 5.0,
            },
        );
        (c, goal, pairs)
    }

    fn wiggling(tick: &Tick) -> Vec<(RobotId, f64)> {
        tick.tasks
            .iter()
            .filter_map(|t| match t.role {
                Role::Velocity { w, .. } => Some((t.robot, w)),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn a_mesh_is_dissolved_by_lifting_its_knobs_then_wiggling_its_anchors() {
        let (mut c, goal, pairs) = decoupling(ShapeSpec::Mesh { rows: 2 }, &four_apart());
        let knob = *pairs
            .iter()
            .find(|&&i| c.pairs()[i].pair.kind == PairType::KnobHole)
            .expect("a knob pair");
        // A person is asked to lift the knob pair; until it is out, nobody wiggles (a
        // knob-locked robot cannot turn).
        let tick = c.tick(5.1, &goal);
        let (ka, kb) = (c.pairs()[knob].pair.a, c.pairs()[knob].pair.b);
        assert!(
            tick.events.iter().any(|e| matches!(&e.kind,
                EventKind::LiftKnobs { robots, pairs } if robots.len() == 4 && pairs == &[(ka, kb)])),
            "{:?}",
            tick.events
        );
        assert!(wiggling(&tick).is_empty(), "{:?}", wiggling(&tick));
        // The hole robot's row set down 3 cm away: the knob pair is released and each row's
        // anchor robot wiggles.
        let row_b: Vec<RobotId> = goal
            .iter()
            .filter(|r| (r.pose.y - goal.iter().find(|q| q.id == kb).unwrap().pose.y).abs() < 0.01)
            .map(|r| r.id)
            .collect();
        let lifted = moved(&goal, &row_b, 0.0, 0.03);
        let tick = c.tick(5.2, &lifted);
        assert!(tick
            .events
            .iter()
            .any(|e| matches!(e.kind, EventKind::PairReleased { a, b } if (a, b) == (ka, kb))));
        let w = wiggling(&c.tick(5.3, &lifted));
        assert_eq!(w.len(), 2, "one anchor robot per row: {w:?}");
    }

    #[test]
    fn a_train_is_wiggled_open_one_pair_per_robot_and_a_released_pair_drives_clear() {
        let robots = [
            np(1, 0.0, 0.0, 0.0),
            np(2, 0.2, 0.0, 0.0),
            np(3, 0.4, 0.0, 0.0),
        ];
        let (mut c, goal, pairs) = decoupling(ShapeSpec::Line, &robots);
        assert_eq!(pairs.len(), 2);
        // The middle robot is in both pairs: one of them wiggles at a time.
        let tick = c.tick(5.1, &goal);
        let w = wiggling(&tick);
        assert_eq!(w.len(), 1, "{w:?}");
        let first = pairs
            .iter()
            .map(|&i| c.pairs()[i].pair)
            .find(|p| p.a == w[0].0)
            .expect("the wiggler's pair");
        // Its anchor pops 8 mm out: released, but not clear. It drives straight on and the
        // other pair waits.
        let (s, co) = goal
            .iter()
            .find(|r| r.id == first.a)
            .unwrap()
            .pose
            .yaw
            .sin_cos();
        let out = moved(&goal, &[first.a], 0.008 * co, 0.008 * s);
        c.tick(5.2, &out);
        let w = wiggling(&c.tick(5.3, &out));
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].0 == first.a && w[0].1 == 0.0, "drives clear: {w:?}");
        // Clear: the other pair wiggles.
        let clear = moved(&goal, &[first.a], 0.03 * co, 0.03 * s);
        let w = wiggling(&c.tick(5.4, &clear));
        assert!(w.len() == 1 && w[0].0 != first.a, "{w:?}");
    }

    #[test]
    fn assembly_moves_with_one_leader_and_decouples() {
        // Formation completes as soon as the pair connects (no settling), so the move starts.
        let (mut c, goal) = formed_pair();
        c.set_mode(0.5, Mode::Velocity { v: 0.02, w: 0.0 });
        let tick = c.tick(0.6, &goal);
        let leaders: BTreeSet<_> = tick.tasks.iter().map(|t| t.leader).collect();
        assert_eq!(leaders.len(), 1, "one segment, one leader");
        // The velocity becomes a reference: the leader's pose integrated at 0.02 m/s from
        // where it stood, ramped up over `VELOCITY_RAMP_S`; the anchor chain behind it moves
        // like a train, robot 2 towed at its connected pair with robot 1.
        let Role::Track { reference: r1 } = role_of(&tick, 1) else {
            panic!("{:?}", role_of(&tick, 1));
        };
        let l = goal.iter().find(|r| r.id == 1).unwrap().pose;
        let ramp = |t: f64| t * t / (2.0 * VELOCITY_RAMP_S);
        assert!(
            (r1[1].x - (l.x + 0.02 * ramp(0.1))).abs() < 1e-9,
            "{:?}",
            r1[1]
        );
        let last = r1.len() - 1;
        assert!(r1[last].x > r1[1].x, "it accelerates: {r1:?}");
        assert!(
            matches!(role_of(&tick, 2), Role::Hitch { pair: 0, .. }),
            "{:?}",
            role_of(&tick, 2)
        );
        assert_eq!(tick.maintain.len(), 1);
        // Decouple: the anchor robot wiggles; once apart the pair is released.
        let pair = c.coupled_pairs();
        c.set_mode(
            1.0,
            Mode::Decouple {
                pairs: pair.clone(),
                wiggle: Wiggle::default(),
                start: 1.0,
            },
        );
        let a = c.pairs()[pair[0]].pair.a;
        let tick = c.tick(1.1, &goal);
        assert!(matches!(role_of(&tick, a), Role::Velocity { .. }));
        assert!(
            tick.maintain.is_empty(),
            "a pair being released is not maintained"
        );
        let apart: Vec<RobotState> = goal
            .iter()
            .map(|r| {
                if r.id == a {
                    RobotState {
                        pose: Pose2::new(r.pose.x + 0.05, r.pose.y, 0.0),
                        ..*r
                    }
                } else {
                    *r
                }
            })
            .collect();
        let tick = c.tick(2.0, &apart);
        assert!(tick
            .events
            .iter()
            .any(|e| matches!(e.kind, EventKind::PairReleased { .. })));
        let segs: BTreeSet<_> = tick.tasks.iter().map(|t| t.segment).collect();
        assert_eq!(segs.len(), 2);
    }

    #[test]
    fn a_velocity_behaviour_after_another_goes_on_without_stopping() {
        let (mut c, goal) = formed_pair();
        let reference = |tick: &Tick| match role_of(tick, 1) {
            Role::Track { reference } => reference.clone(),
            other => panic!("{other:?}"),
        };
        let dt = c.cfg.dt;
        let l = goal.iter().find(|r| r.id == 1).unwrap().pose;
        c.set_mode(0.5, Mode::Velocity { v: 0.04, w: 0.0 });
        c.tick(0.5, &goal);
        // After the ramp (2 s) the reference runs at 0.04 m/s: 0.04 · (t − 0.5 − 1) from l.
        let r = reference(&c.tick(4.5, &goal));
        assert!((r[0].x - (l.x + 0.04 * 3.0)).abs() < 1e-9, "{:?}", r[0]);
        // The next velocity behaviour starts where that reference is, at its speed: the
        // first step of the new reference is a full 0.04 · dt, and it turns gradually.
        c.set_mode(4.5, Mode::Velocity { v: 0.04, w: 0.2 });
        let r = reference(&c.tick(4.5, &goal));
        assert!((r[0].x - (l.x + 0.12)).abs() < 1e-9, "{:?}", r[0]);
        let step = (r[1].x - r[0].x).hypot(r[1].y - r[0].y);
        assert!((step - 0.04 * dt).abs() < 1e-6, "step {step}");
        assert!(r[1].yaw.abs() < 0.2 * dt, "ω ramps up: {:?}", r[1]);
        let r = reference(&c.tick(4.5 + VELOCITY_RAMP_S + 1.0, &goal));
        let turn = wrap_angle(r[1].yaw - r[0].yaw);
        assert!(
            (turn - 0.2 * dt).abs() < 1e-6,
            "full ω after the ramp: {turn}"
        );
        // After a hold, a velocity behaviour starts from rest again.
        c.set_mode(8.0, Mode::Hold);
        c.set_mode(8.0, Mode::Velocity { v: 0.04, w: 0.0 });
        let r = reference(&c.tick(8.0, &goal));
        let step = (r[1].x - r[0].x).hypot(r[1].y - r[0].y);
        assert!(step < 0.04 * dt * 0.1, "from rest: step {step}");
    }

    #[test]
    fn a_moving_mesh_keeps_its_leader_when_another_robot_heads_nearer_the_mean() {
        let mut c = coordinator();
        c.cfg.form_settle_s = 0.0;
        let robots = four_apart();
        let kinds: BTreeMap<_, _> = robots.iter().map(|r| (r.id, r.kind)).collect();
        c.form(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, Some(0.0))
            .unwrap();
        let goal = at_goals(&c, &kinds);
        let mut t = 1.0;
        while !c.tick(t, &goal).complete {
            t += 0.1;
            assert!(t < 10.0, "the mesh formed");
        }
        // Headings within noise of each other: robot `id` is the one nearest the mean.
        let tilted = |id: RobotId| -> Vec<RobotState> {
            goal.iter()
                .map(|r| {
                    let mut r = *r;
                    r.pose.yaw += if r.id == id {
                        0.0
                    } else {
                        0.002 * f64::from(r.id)
                    };
                    r
                })
                .collect()
        };
        let leaders = |tick: &Tick| -> BTreeSet<Option<RobotId>> {
            tick.tasks.iter().map(|k| k.leader).collect()
        };
        c.set_mode(t, Mode::Velocity { v: 0.04, w: 0.0 });
        let first = leaders(&c.tick(t + 0.1, &tilted(1)));
        assert_eq!(first.len(), 1, "one leader: {first:?}");
        let reference = |tick: &Tick, id: RobotId| match role_of(tick, id) {
            Role::Track { reference } => reference[0],
            other => panic!("{other:?}"),
        };
        let lead = first.iter().next().copied().flatten().expect("a leader");
        let before = reference(&c.tick(t + 1.0, &tilted(1)), lead);
        // Another robot now heads nearest the mean: the lead (and the reference, which
        // a new leader restarted from rest where the mesh then stood) stays.
        for (k, id) in [4, 2, 3].into_iter().enumerate() {
            let tick = c.tick(t + 1.1 + 0.1 * k as f64, &tilted(id));
            assert_eq!(
                leaders(&tick),
                first,
                "leader with robot {id} nearest the mean"
            );
        }
        let after = reference(&c.tick(t + 2.0, &tilted(3)), lead);
        assert!(
            after.x - before.x > 0.5 * 0.04 * 0.5,
            "the reference went on: {before:?} → {after:?}"
        );
    }

    #[test]
    fn a_lone_robot_does_not_approach_through_a_robot_on_its_axis() {
        // A line of four: the rear pair is connected, the robot second from the front is
        // 30 mm off its place and the front robot stands at its own place, i.e. on the axis
        // along which the second robot would reverse its anchor into the rear pair.
        let mut c = coordinator();
        let robots: Vec<RobotState> = (0..4)
            .map(|k| np(k + 1, -0.06 * f64::from(k), 0.0, 0.0))
            .collect();
        let kinds: BTreeMap<_, _> = robots.iter().map(|r| (r.id, r.kind)).collect();
        c.form(0.0, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
        let mut poses = at_goals(&c, &kinds);
        poses.sort_by(|a, b| b.pose.x.total_cmp(&a.pose.x));
        let (front, second, third) = (poses[0].id, poses[1].id, poses[2].id);
        poses[1].pose.y += 0.03;
        for k in 0..5 {
            c.tick(0.1 * f64::from(k), &poses);
        }
        let pair = |a: RobotId, b: RobotId| {
            c.pairs()
                .iter()
                .position(|tp| (tp.pair.a, tp.pair.b) == (a, b) || (tp.pair.a, tp.pair.b) == (b, a))
                .unwrap()
        };
        let (join, ahead) = (pair(second, third), pair(front, second));
        assert_eq!(
            c.pairs()[join].pair.a,
            second,
            "the second robot's anchor: {:?}",
            c.pairs()
        );
        assert_eq!(c.pairs()[join].status, PairStatus::Decoupled);
        let segments = c.segments();
        assert!(
            c.approach_blocked(join, &segments),
            "the front robot is on the axis"
        );
        let tick = c.tick(0.5, &poses);
        assert!(
            tick.active.contains(&ahead) && !tick.active.contains(&join),
            "the pair with the front robot goes first: active {:?}",
            tick.active
        );
        // With the front robot out of the way the approach is free again.
        poses[0].pose.y += 0.1;
        c.tick(0.6, &poses);
        assert!(!c.approach_blocked(join, &c.segments()));
    }

    #[test]
    fn a_moving_train_tows_its_members_as_trailers_and_a_mesh_keeps_its_alignment() {
        let robots = [
            np(1, 0.0, 0.0, 0.0),
            np(2, -0.1, 0.0, 0.0),
            np(3, -0.2, 0.0, 0.0),
        ];
        let (c0, goal) = formed(ShapeSpec::Line, &robots);
        let pose = |id: RobotId| goal.iter().find(|r| r.id == id).unwrap().pose;
        // Robot 1 (the leader) is the line's head: along +x the others are towed.
        assert!(pose(1).x > pose(2).x && pose(2).x > pose(3).x, "{goal:?}");
        let g = c0.geometry;
        // World velocity of a body point of a robot driving at (v, ω).
        let point_velocity = |p: &Pose2, v: f64, w: f64, b: [f64; 2]| {
            let (s, c) = p.yaw.sin_cos();
            let (bx, by) = (v - w * b[1], w * b[0]);
            [c * bx - s * by, s * bx + c * by]
        };
        let mut c = c0.clone();
        c.set_mode(1.0, Mode::Velocity { v: 0.05, w: 0.3 });
        c.tick(1.0, &goal);
        let tick = c.tick(2.0, &goal);
        let Role::Track { reference } = role_of(&tick, 1) else {
            panic!("{:?}", role_of(&tick, 1));
        };
        let step = reference[0].relative(&reference[1]);
        let mut twist = BTreeMap::from([(1, (step.x / c.cfg.dt, step.yaw / c.cfg.dt))]);
        assert!(twist[&1].0 > 0.01 && twist[&1].1 > 0.05, "{twist:?}");
        // Each member moves its connection point exactly as its neighbour towards the head
        // moves the point it hangs at (the robots stand seated: no gap to close).
        for (me, next) in [(2, 1), (3, 2)] {
            let Role::Hitch { pair, v, w } = *role_of(&tick, me) else {
                panic!("robot {me}: {:?}", role_of(&tick, me));
            };
            let p = c.pairs()[pair].pair;
            let (own, theirs) = if p.a == me {
                (p.point_a, p.point_b)
            } else {
                (p.point_b, p.point_a)
            };
            assert_eq!(
                if p.a == me { p.b } else { p.a },
                next,
                "robot {me} hangs at {next}"
            );
            let (vn, wn) = twist[&next];
            let want = point_velocity(&pose(next), vn, wn, theirs.position(&g));
            let got = point_velocity(&pose(me), v, w, own.position(&g));
            assert!(
                (want[0] - got[0]).abs() < 1e-9 && (want[1] - got[1]).abs() < 1e-9,
                "robot {me}: {got:?} for {want:?}"
            );
            twist.insert(me, (v, w));
        }
        // The head turning left swings its back (and robot 2's front) to the right first.
        assert!(twist[&2].1 < 0.0 && twist[&3].1 > 0.0, "{twist:?}");
        // Driven backwards the members would jackknife as trailers: they keep the MPC's
        // alignment of their pairs.
        let mut c = c0.clone();
        c.set_mode(1.0, Mode::Velocity { v: -0.05, w: 0.3 });
        let tick = c.tick(2.0, &goal);
        for me in [2, 3] {
            assert!(
                matches!(role_of(&tick, me), Role::Align { .. }),
                "robot {me}: {:?}",
                role_of(&tick, me)
            );
        }
        // A mesh's members hanging at anchors stand beside others: no trailers there.
        let (mut c, goal) = formed(
            ShapeSpec::Mesh { rows: 2 },
            &[
                np(1, 0.0, 0.0, 0.0),
                np(2, -0.1, 0.0, 0.0),
                np(3, 0.0, 0.1, 0.0),
                np(4, -0.1, 0.1, 0.0),
            ],
        );
        c.set_mode(1.0, Mode::Velocity { v: 0.05, w: 0.3 });
        let tick = c.tick(2.0, &goal);
        assert!(
            tick.tasks
                .iter()
                .all(|t| !matches!(t.role, Role::Hitch { .. })),
            "{:?}",
            tick.tasks
        );
    }
}
