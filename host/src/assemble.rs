//! The assembly controller: the assembly [`Coordinator`] (through a [`ScenarioRunner`])
//! assigns each robot a task every 10 Hz tick, each task becomes cost terms of that robot's
//! MPC problem ([`DistributedMpc`], THESIS Algorithm 9, 5.19–5.26), and coupled pairs become
//! the MPC's coupling constraints. Over terrain, the stability gate bounds every coupled
//! assembly's advance along its heading ([`puzzlebot_stability::max_safe_advance`], SOCP
//! paper §4, DESIGN.md §7): the host never commands an assembly past the safe distance; it
//! stops the assembly and records why.
//!
//! Also: `puzzlebot run SCENARIO.toml` ([`run_scenario`]) and `puzzlebot shape info`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;
use puzzlebot_assembly::{
    shape_info, Behaviour, Coordinator, CoordinatorConfig, Event, EventKind, MaintainPair, Mode,
    PairStatus, PairTolerances, PairType, Pose2, RobotState, Role, RunState,
    Scenario as AsmScenario, ScenarioRunner, Shape,
};
use puzzlebot_mpc::{
    Command, ConnectionPoint, CostTerm, CoupledPair, DistributedMpc, Limits, MpcConfig, Pose,
    RobotInput, SolveStatus, StageWeights,
};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::messages::RobotId;
use puzzlebot_stability::puzzlebot::{Pair, PairKind, PuzzleAssembly, RobotPose};
use puzzlebot_stability::{max_safe_advance, LimitedBy};
use serde::Serialize;

use crate::control::{Controller, FleetView, HandRequest, RunSummary};
use crate::drive::{DriveMap, Twist};
use crate::report::RunFolder;
use crate::simulated::SimHarness;

/// `puzzlebot shape info`: the text (or JSON) of [`shape_info`] for `line`, `mesh` or a file.
pub fn shape_info_text(
    shape: &str,
    robots: usize,
    rows: usize,
    json: bool,
) -> anyhow::Result<String> {
    let g = FleetParams::default().non_pilot.geometry;
    let s = match shape {
        "line" => Shape::line(robots, &g)?,
        "mesh" => Shape::mesh(robots, rows, &g)?,
        file => Shape::from_file(Path::new(file), &g)?,
    };
    let info = shape_info(&s, &g);
    Ok(if json {
        format!("{}\n", serde_json::to_string_pretty(&info)?)
    } else {
        info.to_string()
    })
}

/// One stop (or limit) decided by the stability gate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GateStop {
    /// Controller time (s since start).
    pub t: f64,
    /// Robots of the assembly.
    pub robots: Vec<RobotId>,
    /// Heading of the requested advance (rad).
    pub heading: f64,
    /// Safe advance left along it (m).
    pub safe_advance: f64,
    /// What limits it.
    pub limited_by: LimitedBy,
    /// Centre of the assembly when it was stopped (m).
    pub centre: [f64; 2],
}

/// The slowest speed (m/s) every kind of robot drives steadily: both wheels at the start-up
/// dead-band M_min (THESIS 3.4), through the drive map the host commands with.
pub fn slowest_steady_speed(params: &FleetParams) -> f64 {
    [RobotKind::NonPilot, RobotKind::Pilot]
        .into_iter()
        .map(|k| {
            let map = DriveMap::from_params_or_geometric(params.robot(k));
            map.k_v * map.m_min
        })
        .fold(0.0, f64::max)
}

/// Warnings for velocity steps of `scenario` whose speed is not zero but below
/// [`slowest_steady_speed`]: each wheel can only be stopped or at M_min, so the robots
/// stick-slip, which jerks a train at its anchors (measured: a 4-robot line at 0.03 m/s
/// surged between 0 and 0.08 m/s).
pub fn slow_step_warnings(scenario: &AsmScenario, params: &FleetParams) -> Vec<String> {
    let slowest = slowest_steady_speed(params);
    scenario
        .steps
        .iter()
        .enumerate()
        .filter_map(|(i, step)| match step.behaviour {
            Behaviour::Velocity { v, .. } if v != 0.0 && v.abs() < slowest => Some(format!(
                "step {} '{}' (line {}): velocity {v} m/s is below the slowest steady speed \
                 {slowest:.3} m/s (drive.min_rpm); the robots will stick-slip and jerk \
                 their anchors",
                i + 1,
                step.label,
                step.line
            )),
            _ => None,
        })
        .collect()
}

/// Heading weight of the anchors' maintenance cost (THESIS 4.8; relative to its position
/// weight W_c = 1000, see `MpcConfig::maintain_heading`) while a shape forms: keeps coupled
/// joints straight while their robots align with others. Measured 2026-12-01 in lockstep
/// (seeds 1–24 at 0 and 20 ms): the driving line passes 46 of 48 (32 with the hard
/// constraints and their infeasible retries, the previous behaviour), the 2×2 mesh 48 of 48
/// (41), the lost-robot line 21 of 24 at 30 ms (24; 24 again once an assembly holds while a
/// lone robot joins it, see `Coordinator::tasks`); 0.006 gave 37 / 48 / 23, 0.012
/// 41 / 46 / 19, 0.03 fewer (the joints too stiff to let a segment meet its partner).
pub const MAINTAIN_HEADING_FORM: f64 = 0.008;
/// Heading weight of the anchors' maintenance cost while assemblies move (a train must bend
/// in a turn: ≈ 0.2 rad at a 0.3 m radius); the line passed the same from 1e-4 to 0.003.
pub const MAINTAIN_HEADING_MOVE: f64 = 0.003;

/// Heading weight (relative to position) of a robot hanging at a connected anchor while its
/// assembly moves (its role aligns it with its partner, see `Coordinator::tasks`) when that
/// assembly is a mesh (a connected knob pair makes it rigid in part): keeps it steering in
/// line like a knob pair does. A robot pushed along at an anchor (a pilot at the front of a
/// driving mesh) swings into the anchor's play and turns the mesh after it. A train keeps the
/// anchors' weak heading term: it bends in turns.
pub const HANG_HEADING: f64 = 0.1;

/// Heading weight (relative to position) of a held member of a grown assembly keeping its
/// pose (`Role::Keep`): it turns back when a robot docking at its side turns it about its
/// anchor. Only the held robots of a grown assembly keep their poses: in an assembly formed
/// in parallel the held robots turning back strain the couplings already made.
pub const KEEP_HEADING: f64 = 0.01;

/// Gate settings.
#[derive(Debug, Clone, PartialEq)]
pub struct GateConfig {
    /// Terrain the assembly moves over (no platforms: endless floor, gate idle).
    pub terrain: Terrain,
    /// Scan step of the contact-state search (m).
    pub step: f64,
    /// Distance kept back from the safe limit (m): covers latency (about two control
    /// periods at cruise speed) and pose noise.
    pub margin: f64,
}

impl Default for GateConfig {
    fn default() -> Self {
        GateConfig {
            terrain: Terrain::flat(),
            step: 0.005,
            margin: 0.004,
        }
    }
}

/// Assembly scenario → tasks → distributed MPC → (v, ω), with the stability gate.
pub struct AssemblyController {
    runner: ScenarioRunner,
    mpc: DistributedMpc,
    params: FleetParams,
    gate: GateConfig,
    t0: Option<f64>,
    last_t: f64,
    /// Every coordinator event (pair status changes, steps), in order.
    pub events: Vec<Event>,
    /// Every gate stop (one per change of the stop state of an assembly).
    pub gate_stops: Vec<GateStop>,
    gated: BTreeSet<Vec<RobotId>>,
    /// MPC ticks whose solve failed for some robot (fallback/stop).
    pub mpc_failures: u64,
    /// Robots ever seen.
    seen: BTreeSet<RobotId>,
    /// Failed solves by reason.
    pub mpc_failure_reasons: BTreeMap<String, u64>,
    /// Give coupled anchor pairs to the MPC as hard coupling constraints (THESIS 5.23–5.24)
    /// besides their soft maintenance cost (4.8). Off by default: a seated anchor's faces
    /// touch, so the cutting planes (5.17–5.18), which ask for `constraint_margin` between
    /// them, make the QPs primal infeasible (measured: 456 of 456 solves in the gap run, 143
    /// of ≈ 150 ticks with pairs in the lockstep line). When on, such ticks are solved again
    /// with the soft cost only (counted in `constraint_retries`).
    pub coupling_constraints: bool,
    /// Ticks re-solved without the hard coupling constraints.
    pub constraint_retries: u64,
    /// Extra seconds after the scenario ends before [`Controller::done`].
    pub settle: f64,
    /// Log milestones (steps, couplings, formation, lost robots) on the console (default on;
    /// off for batch runs such as the coupling experiment).
    pub log_milestones: bool,
    /// Longest a pose is predicted ahead from its measured velocity (s): its age plus the
    /// command latency, capped here (the velocity estimate is a short window's mean).
    pub max_prediction_s: f64,
    /// Longest the first plan waits for every online robot's first pose (s).
    pub fleet_wait_s: f64,
    /// The scenario has had its first tick.
    runner_started: bool,
    /// Every robot's last pose and velocity (kind, pose, velocity), for
    /// [`AssemblyController::max_prediction_s`].
    last_seen: BTreeMap<RobotId, (RobotKind, crate::drive::PoseSample, Option<Twist>)>,
    /// Robots in an inserted or connected pair (no velocity stabiliser feedback).
    coupled: BTreeSet<RobotId>,
    finished_at: Option<f64>,
    /// Hand requests not yet taken by the run ([`Controller::hand_requests`]).
    hand: Vec<HandRequest>,
}

impl AssemblyController {
    /// A controller running `scenario` with the fleet parameters `params`.
    pub fn new(
        scenario: AsmScenario,
        params: FleetParams,
        gate: GateConfig,
    ) -> anyhow::Result<Self> {
        let g = params.non_pilot.geometry;
        let cfg = CoordinatorConfig {
            tolerances: PairTolerances::from_params(&g, &params.non_pilot.coupling),
            dt: 1.0 / f64::from(params.rates.mpc_hz).max(1e-3),
            ..CoordinatorConfig::default()
        };
        for w in slow_step_warnings(&scenario, &params) {
            tracing::warn!("{w}");
        }
        let coordinator = Coordinator::new(g, cfg);
        let cfg = MpcConfig {
            geometry: puzzlebot_mpc::GeometryF64::from(&params.non_pilot.geometry),
            hard_couplings: false,
            maintain_heading: MAINTAIN_HEADING_FORM,
            ..MpcConfig::default()
        };
        let mpc = DistributedMpc::with_threads(cfg, 1)?;
        Ok(AssemblyController {
            runner: ScenarioRunner::new(scenario, coordinator),
            mpc,
            params,
            gate,
            t0: None,
            last_t: 0.0,
            events: Vec::new(),
            gate_stops: Vec::new(),
            gated: BTreeSet::new(),
            mpc_failures: 0,
            seen: BTreeSet::new(),
            mpc_failure_reasons: BTreeMap::new(),
            coupling_constraints: false,
            constraint_retries: 0,
            settle: 0.5,
            log_milestones: true,
            max_prediction_s: MAX_PREDICTION_S,
            last_seen: BTreeMap::new(),
            fleet_wait_s: FLEET_WAIT_S,
            runner_started: false,
            coupled: BTreeSet::new(),
            finished_at: None,
            hand: Vec::new(),
        })
    }

    /// The scenario runner (state, coordinator, pairs).
    pub fn runner(&self) -> &ScenarioRunner {
        &self.runner
    }

    /// Where the scenario stands.
    pub fn state(&self) -> &RunState {
        self.runner.state()
    }

    fn limits(&self, kind: RobotKind) -> Limits {
        Limits::from_drive(&self.params.robot(kind).drive)
    }

    /// THESIS (4.5)–(4.7), (5.25), (5.26): a task's cost terms; `in_mesh`: the robot's
    /// assembly has a connected knob pair.
    fn costs(role: &Role, in_mesh: bool) -> Vec<CostTerm> {
        let lead = StageWeights {
            stage: 1.0e3,
            terminal: 1.0e4,
        };
        let follow = StageWeights {
            stage: 1.0e2,
            terminal: 1.0e3,
        };
        let p = |q: &Pose2| Pose::new(q.x, q.y, q.yaw);
        match role {
            Role::Hold | Role::Wait => Vec::new(),
            Role::Keep { pose } => vec![CostTerm::FollowTrajectory {
                reference: vec![p(pose)],
                weights: lead,
                heading: KEEP_HEADING,
            }],
            Role::Align {
                partner,
                own_point,
                partner_point,
                relative_yaw,
                kind,
                phase,
                ..
            } => vec![CostTerm::AlignPair {
                partner: *partner,
                own: ConnectionPoint {
                    pos: *own_point,
                    angle: 0.0,
                },
                partner_point: ConnectionPoint {
                    pos: *partner_point,
                    angle: *relative_yaw,
                },
                weights: lead,
                // A knob fits only within atan(1/25) ≈ 0.04 rad (THESIS 5.2.3): its pair
                // needs the heading as much as the position.
                heading: match kind {
                    PairType::KnobHole => 1.0e-1,
                    PairType::AnchorOpening if in_mesh && *phase == PairStatus::Connected => {
                        HANG_HEADING
                    }
                    PairType::AnchorOpening => 1.0e-3,
                },
            }],
            Role::Follow { leader, offset } => vec![CostTerm::FollowLeader {
                leader: *leader,
                offset: p(offset),
                weights: follow,
                heading: 1.0e-3,
            }],
            // A hitched train member drives its command directly; its MPC fits the same
            // twist so the plan its neighbours see is the one it drives.
            Role::Velocity { v, w } | Role::Hitch { v, w, .. } => vec![CostTerm::FitVelocity {
                target: Command { v: *v, omega: *w },
                w_v: 1.0e3,
                w_omega: 1.0e2,
            }],
            Role::GoTo { goal, use_yaw } => {
                if *use_yaw {
                    vec![CostTerm::FollowTrajectory {
                        reference: vec![p(goal)],
                        weights: lead,
                        heading: 1.0e-2,
                    }]
                } else {
                    vec![CostTerm::GoToGoal {
                        goal: [goal.x, goal.y],
                        point: [0.0, 0.0],
                        weights: lead,
                    }]
                }
            }
            Role::Track { reference } => vec![CostTerm::FollowTrajectory {
                reference: reference.iter().map(p).collect(),
                weights: lead,
                heading: 1.0e-3,
            }],
            // Docking drives directly (see `Role::Dock`).
            Role::Dock { .. } => Vec::new(),
        }
    }

    /// The stability gate: for every coupled assembly that is commanded to
    /// move, limit its advance along its heading to the proven-safe distance; stop it there.
    fn gate(
        &mut self,
        t: f64,
        states: &[RobotState],
        maintain: &[MaintainPair],
        segments: &BTreeMap<usize, Vec<RobotId>>,
        out: &mut BTreeMap<RobotId, Twist>,
    ) {
        if self.gate.terrain.platforms.is_empty() {
            return;
        }
        let dt = 1.0 / self.rate_hz();
        let geometry = self.params.non_pilot.geometry;
        for members in segments.values() {
            let idx: BTreeMap<RobotId, usize> =
                members.iter().enumerate().map(|(i, id)| (*id, i)).collect();
            let robots: Vec<RobotPose> = members
                .iter()
                .filter_map(|id| states.iter().find(|s| s.id == *id))
                .map(|s| RobotPose {
                    kind: s.kind,
                    x: s.pose.x,
                    y: s.pose.y,
                    yaw: s.pose.yaw,
                })
                .collect();
            if robots.len() != members.len() {
                continue;
            }
            let pairs: Vec<Pair> = maintain
                .iter()
                .filter_map(|m| {
                    let (a, b) = (*idx.get(&m.a)?, *idx.get(&m.b)?);
                    Some(match m.kind {
                        PairType::AnchorOpening => Pair {
                            a,
                            b,
                            kind: PairKind::Anchor,
                            point: None,
                        },
                        PairType::KnobHole => Pair {
                            a,
                            b,
                            kind: PairKind::Knob,
                            point: Some(m.point_a.position(&geometry)),
                        },
                    })
                })
                .collect();
            // Requested motion of the assembly: mean commanded speed along the mean heading.
            let n = robots.len() as f64;
            let (mut vx, mut vy) = (0.0, 0.0);
            for (r, id) in robots.iter().zip(members) {
                if let Some(tw) = out.get(id) {
                    vx += tw.v * r.yaw.cos() / n;
                    vy += tw.v * r.yaw.sin() / n;
                }
            }
            let speed = vx.hypot(vy);
            let key = members.clone();
            if speed < 1e-4 {
                continue;
            }
            let heading = vy.atan2(vx);
            let asm = PuzzleAssembly {
                robots: robots.clone(),
                pairs,
            };
            let centre = [
                robots.iter().map(|r| r.x).sum::<f64>() / n,
                robots.iter().map(|r| r.y).sum::<f64>() / n,
            ];
            let (safe, why) = match max_safe_advance(
                &asm,
                &self.params,
                &self.gate.terrain,
                heading,
                self.gate.step,
            ) {
                Ok(a) => (a.distance, a.limited_by),
                Err(e) => (
                    0.0,
                    LimitedBy::NotProven {
                        reason: e.to_string(),
                    },
                ),
            };
            let room = safe - self.gate.margin;
            // Never command past the limit: the advance over the next two control periods
            // (latency) must stay inside the room left.
            if room <= speed * 2.0 * dt {
                for id in members {
                    out.insert(*id, Twist::new(0.0, 0.0));
                }
                if self.gated.insert(key) {
                    tracing::warn!(
                        "stability gate: assembly {members:?} stopped, safe advance {safe:.4} m ({why:?})"
                    );
                    self.gate_stops.push(GateStop {
                        t,
                        robots: members.clone(),
                        heading,
                        safe_advance: safe,
                        limited_by: why,
                        centre,
                    });
                }
            } else {
                self.gated.remove(&key);
            }
        }
    }
}

impl Controller for AssemblyController {
    fn name(&self) -> &str {
        "assembly"
    }

    fn rate_hz(&self) -> f64 {
        1.0 / self.mpc.config().dt
    }

    fn update(&mut self, view: &FleetView) -> BTreeMap<RobotId, Twist> {
        let t0 = *self.t0.get_or_insert(view.t);
        let t = view.t - t0;
        self.last_t = t;
        // Every pose brought to this tick's time (motion capture delivers them at different
        // ages: a dropout leaves one robot's pose older than its partner's, and the pair
        // measure would mix two instants), and, for the MPC's initial states, on to when the
        // commands of this tick act (the measured latency).
        // A robot missing from this view (a motion-capture dropout) keeps its last pose and
        // velocity for up to the prediction horizon; without either, the coordinator would
        // pair its stale pose with its partners' fresh ones.
        let horizon = self.max_prediction_s;
        for r in &view.robots {
            if let Some(p) = r.pose {
                let last = self.last_seen.get(&r.id).and_then(|l| l.2);
                self.last_seen
                    .insert(r.id, (r.kind, p, r.velocity.or(last)));
            }
        }
        self.last_seen
            .retain(|_, (_, p, _)| view.t - p.t <= horizon);
        let states_at = |ahead: f64| -> Vec<RobotState> {
            self.last_seen
                .iter()
                .map(|(&id, &(kind, p, w))| {
                    let dt = ((view.t - p.t).max(0.0) + ahead).min(horizon);
                    let pose = Pose2::new(p.x, p.y, p.theta);
                    RobotState {
                        id,
                        kind,
                        pose: w.map_or(pose, |w| predict(pose, w, dt)),
                    }
                })
                .collect()
        };
        // Before the first plan, every online robot must have been seen: a robot whose first
        // pose has not arrived would be left out of the plan (its shape then has a slot too
        // many). Everyone holds meanwhile, for at most `fleet_wait_s`.
        if !self.runner_started {
            let unseen = view
                .robots
                .iter()
                .any(|r| !self.last_seen.contains_key(&r.id));
            if unseen && t < self.fleet_wait_s {
                return BTreeMap::new();
            }
            self.runner_started = true;
        }
        let states = states_at(0.0);
        let predicted = states_at(view.latency_s.max(0.0));
        self.seen.extend(states.iter().map(|s| s.id));
        let tick = self.runner.tick(t, &states);
        if tracing::enabled!(target: "puzzlebot::roles", tracing::Level::TRACE) {
            for task in &tick.tasks {
                tracing::trace!(target: "puzzlebot::roles", t = format!("{t:.1}"), ?task, active = ?tick.active);
            }
        }
        // Progress on the console: steps, couplings, formation, lost robots.
        for e in &tick.events {
            let milestone = match &e.kind {
                EventKind::PairStatus { to, .. } => *to == PairStatus::Connected,
                EventKind::StepStarted { .. }
                | EventKind::StepFinished { .. }
                | EventKind::StepFailed { .. }
                | EventKind::FormationComplete
                | EventKind::LiftKnobs { .. }
                | EventKind::RobotLost { .. }
                | EventKind::Recoupling { .. }
                | EventKind::Recoupled { .. }
                | EventKind::Replanned { .. } => true,
                _ => false,
            };
            if milestone && self.log_milestones {
                tracing::info!(t = format!("{:.1}", e.t), event = %serde_json::to_string(&e.kind).unwrap_or_default(), "assembly");
            }
        }
        for e in &tick.events {
            if let EventKind::LiftKnobs { robots, pairs } = &e.kind {
                if self.log_milestones {
                    tracing::warn!(
                        "lift the knob pairs {pairs:?} among robots {robots:?} apart by hand and \
                     set the rows down a few centimetres apart (knobs hold more than the \
                     robots can pull, THESIS 5.5.3); the anchors are wiggled open after"
                    );
                }
                self.hand.push(HandRequest::LiftKnobs {
                    robots: robots.clone(),
                });
            }
        }
        self.events.extend(tick.events.iter().cloned());
        if !matches!(self.runner.state(), RunState::Running { .. }) && self.finished_at.is_none() {
            self.finished_at = Some(t);
        }
        let by_id: BTreeMap<RobotId, &RobotState> = predicted.iter().map(|s| (s.id, s)).collect();
        let mut inputs = Vec::new();
        let mut straight = BTreeSet::new();
        let mut wait = BTreeSet::new();
        let mut segments: BTreeMap<usize, Vec<RobotId>> = BTreeMap::new();
        // Assemblies with a connected knob pair: rigid in part (a mesh), not a train.
        let segment_of: BTreeMap<RobotId, usize> =
            tick.tasks.iter().map(|t| (t.robot, t.segment)).collect();
        let meshes: BTreeSet<usize> = self
            .runner
            .coordinator()
            .pairs()
            .iter()
            .filter(|p| p.status == PairStatus::Connected && p.pair.kind == PairType::KnobHole)
            .filter_map(|p| segment_of.get(&p.pair.a).copied())
            .collect();
        for task in &tick.tasks {
            let Some(s) = by_id.get(&task.robot) else {
                continue;
            };
            segments.entry(task.segment).or_default().push(task.robot);
            if task.straight_only {
                straight.insert(task.robot);
            }
            // Waiting robots are not driven (THESIS 3.5.2); holding robots stand still (with
            // no target the MPC's smoothness term would carry on their last command).
            if matches!(task.role, Role::Wait | Role::Hold) {
                wait.insert(task.robot);
            }
            inputs.push(RobotInput {
                id: task.robot,
                pose: Pose::new(s.pose.x, s.pose.y, s.pose.yaw),
                limits: self.limits(s.kind),
                costs: Self::costs(&task.role, meshes.contains(&task.segment)),
            });
        }
        // Partners/leaders that are not in this tick's inputs would be rejected by the MPC.
        let present: BTreeSet<RobotId> = inputs.iter().map(|r| r.id).collect();
        for r in &mut inputs {
            r.costs.retain(|c| match c {
                CostTerm::AlignPair { partner, .. } => present.contains(partner),
                CostTerm::FollowLeader { leader, .. } => present.contains(leader),
                _ => true,
            });
        }
        let pairs: Vec<CoupledPair> = tick
            .maintain
            .iter()
            .filter(|m| m.kind == PairType::AnchorOpening)
            .filter(|m| present.contains(&m.a) && present.contains(&m.b))
            .map(|m| CoupledPair {
                anchor_robot: m.a,
                opening_robot: m.b,
            })
            .collect();
        let mut out = BTreeMap::new();
        // The wiggle (THESIS 5.7) is an open-loop command: the MPC's smoothing would filter
        // out its square wave, so wiggling robots get it directly.
        let mut direct: BTreeMap<RobotId, Twist> = BTreeMap::new();
        if matches!(self.runner.coordinator().mode(), Mode::Decouple { .. }) {
            for task in &tick.tasks {
                if let Role::Velocity { v, w } = task.role {
                    direct.insert(task.robot, Twist::new(v, w));
                }
            }
        }
        for task in &tick.tasks {
            if let Role::Dock { v, w, .. } | Role::Hitch { v, w, .. } = task.role {
                direct.insert(task.robot, Twist::new(v, w));
            }
        }
        // Joints held straight while forming, freer while an assembly moves (a train bends
        // in turns).
        let heading = if matches!(self.runner.coordinator().mode(), Mode::Form) {
            MAINTAIN_HEADING_FORM
        } else {
            MAINTAIN_HEADING_MOVE
        };
        // Both constants are finite and ≥ 0: the setter cannot refuse them.
        let _ = self.mpc.set_maintain_heading(heading);
        self.mpc.set_hard_couplings(self.coupling_constraints);
        let mut result = self.mpc.tick(&inputs, &pairs);
        // See `coupling_constraints`: when the hard-constrained QPs are infeasible, solve
        // again with the soft maintenance cost only.
        if self.coupling_constraints
            && !pairs.is_empty()
            && result
                .as_ref()
                .is_ok_and(|o| o.robots.iter().any(|r| !r.status.is_solved()))
        {
            self.constraint_retries += 1;
            self.mpc.set_hard_couplings(false);
            result = self.mpc.tick(&inputs, &pairs);
        }
        match result {
            Ok(o) => {
                for r in o.robots {
                    if !r.status.is_solved() {
                        self.mpc_failures += 1;
                        let reason = match &r.status {
                            SolveStatus::Fallback { reason, .. }
                            | SolveStatus::Stopped { reason } => reason.clone(),
                            SolveStatus::Solved { .. } => String::new(),
                        };
                        *self.mpc_failure_reasons.entry(reason).or_insert(0) += 1;
                    }
                    let mut w = r.command.omega;
                    // Pilots move straight only (THESIS 5.4.1); waiting robots are not driven
                    // (THESIS 3.5.2).
                    if straight.contains(&r.id) {
                        w = 0.0;
                    }
                    let tw = if wait.contains(&r.id) {
                        Twist::new(0.0, 0.0)
                    } else {
                        Twist::new(r.command.v, w)
                    };
                    out.insert(r.id, tw);
                }
            }
            Err(e) => {
                self.mpc_failures += 1;
                tracing::warn!("assembly MPC input rejected: {e}");
            }
        }
        out.extend(direct);
        let segs: BTreeMap<usize, Vec<RobotId>> =
            segments.into_iter().filter(|(_, m)| m.len() > 1).collect();
        // Robots in a pair that is inserted or connected move with their partners.
        self.coupled = self
            .runner
            .coordinator()
            .pairs()
            .iter()
            .filter(|p| matches!(p.status, PairStatus::HeadInserted | PairStatus::Connected))
            .flat_map(|p| [p.pair.a, p.pair.b])
            .collect();
        let maintain = tick.maintain.clone();
        self.gate(t, &states, &maintain, &segs, &mut out);
        out
    }

    fn done(&self, t: f64) -> bool {
        self.finished_at.is_some_and(|f| t >= f + self.settle)
    }

    fn stabilise(&self, id: RobotId) -> bool {
        !self.coupled.contains(&id)
    }

    fn hand_requests(&mut self) -> Vec<HandRequest> {
        std::mem::take(&mut self.hand)
    }
}

/// Default [`AssemblyController::max_prediction_s`] (s): the harsh profile's worst latency
/// (130 ms) plus a pose period.
pub const MAX_PREDICTION_S: f64 = 0.15;

/// Default [`AssemblyController::fleet_wait_s`] (s): a hundred frames of the 100 Hz motion
/// capture, where a first pose lost to a dropout arrives in the next.
pub const FLEET_WAIT_S: f64 = 1.0;

/// `pose` moved on for `dt` seconds at the constant twist `w` (exact unicycle arc).
pub fn predict(pose: Pose2, w: Twist, dt: f64) -> Pose2 {
    if dt <= 0.0 {
        return pose;
    }
    let th = pose.yaw + w.omega * dt;
    let (dx, dy) = if w.omega.abs() < 1e-6 {
        (w.v * dt * pose.yaw.cos(), w.v * dt * pose.yaw.sin())
    } else {
        let r = w.v / w.omega;
        (
            r * (th.sin() - pose.yaw.sin()),
            -r * (th.cos() - pose.yaw.cos()),
        )
    };
    Pose2::new(
        pose.x + dx,
        pose.y + dy,
        puzzlebot_assembly::geom::wrap_angle(th),
    )
}

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
    pub kind: puzzlebot_sim::LinkKind,
    /// Robot with the anchor / knob.
    pub a: RobotId,
    /// Robot with the opening / hole.
    pub b: RobotId,
}

/// Optional hook called every 100 ms of a simulated run with the harness and the time (s):
/// tests use it to switch robots off mid-run.
pub type RunHook = Box<dyn FnMut(&SimHarness, f64) + Send>;

/// Run an assembly scenario against an in-process simulated fleet `sim` (loopback), recording
/// into a new run folder under `runs_dir`: `events.jsonl` gets every pair status change and
/// gate stop with its time, `assembly_events.jsonl` the coordinator events alone, plus the
/// trajectory plots.
pub async fn run_scenario(
    scenario: AsmScenario,
    sim: puzzlebot_sim::Scenario,
    runs_dir: &Path,
    max_duration: f64,
    mut hook: Option<RunHook>,
) -> anyhow::Result<AssemblyReport> {
    let n = sim.robots.iter().filter(|r| !r.offline).count();
    let gate = GateConfig {
        terrain: sim.terrain.clone(),
        ..GateConfig::default()
    };
    let params = sim.params.clone();
    let name = format!("assembly-{}", scenario.name);
    let h = SimHarness::start(sim).await?;
    h.wait_ready(n, Duration::from_secs(5)).await?;
    let mut ctl = AssemblyController::new(scenario, params, gate)?;
    let mut folder = RunFolder::create(runs_dir, &name)?;
    let mut lp = h.control_loop();
    lp.options.max_duration = max_duration;
    let summary = if let Some(hook) = hook.as_mut() {
        let start = tokio::time::Instant::now();
        let run = lp.run(&mut ctl, Some(&mut folder), None);
        tokio::pin!(run);
        let mut iv = tokio::time::interval(Duration::from_millis(100));
        loop {
            tokio::select! {
                s = &mut run => break s,
                _ = iv.tick() => hook(&h, start.elapsed().as_secs_f64()),
            }
        }
    } else {
        lp.run(&mut ctl, Some(&mut folder), None).await
    };
    write_events(&mut folder, &ctl)?;
    folder.finish()?;
    folder.write_json("summary.json", &summary)?;
    let report = report_of(&folder, &ctl, summary, &h.fleet.ground_truth());
    folder.write_json("assembly_report.json", &report)?;
    h.shutdown().await;
    Ok(report)
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
    /// Motor duty (per mille).
    pub duty: [i16; 2],
}

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
            duty: r.duty,
        }
    }
}

/// [`run_scenario`] with the host's controller stepped in lockstep with the simulator
/// ([`crate::lockstep`]: no sockets, no wall clock, the simulated motion capture as pose
/// input): deterministic, faster than real time. The run folder gets the same event files, the
/// trajectory plot and `telemetry.jsonl` with every robot's ground truth at 10 Hz (there is
/// no link telemetry).
pub fn run_scenario_lockstep(
    scenario: AsmScenario,
    sim: puzzlebot_sim::Scenario,
    runs_dir: &Path,
    max_duration: f64,
) -> anyhow::Result<AssemblyReport> {
    let gate = GateConfig {
        terrain: sim.terrain.clone(),
        ..GateConfig::default()
    };
    let params = sim.params.clone();
    let name = format!("assembly-{}", scenario.name);
    let mut ls = crate::lockstep::Lockstep::new(&sim)?;
    let mut ctl = AssemblyController::new(scenario, params, gate)?;
    let mut folder = RunFolder::create(runs_dir, &name)?;
    // The simulator's ground-truth paths for the run folder's trajectory plot, at 10 Hz.
    let mut next = 0.0;
    let mut written = Ok(());
    ls.run(&mut ctl, max_duration, |w, t| {
        if t >= next {
            next = t + 0.1;
            for r in w.ground_truth().robots {
                let tr = folder.traces.entry(r.id).or_default();
                tr.actual.push((t, r.pose.x, r.pose.y));
                if written.is_ok() {
                    written = folder.telemetry(&TruthRecord::of(t, &r));
                }
            }
        }
    });
    written.context("writing telemetry.jsonl")?;
    write_events(&mut folder, &ctl)?;
    folder.finish()?;
    let report = report_of(
        &folder,
        &ctl,
        RunSummary::default(),
        &ls.world.ground_truth(),
    );
    folder.write_json("assembly_report.json", &report)?;
    Ok(report)
}

fn report_of(
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
                kind,
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

fn write_events(folder: &mut RunFolder, ctl: &AssemblyController) -> anyhow::Result<()> {
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

/// A simulated fleet for an assembly scenario without a simulator file: `n` non-pilot robots
/// (the first `pilots` ids are pilots) scattered deterministically from `seed` in a 0.6 m
/// square around the origin ([`scattered_fleet_in`]).
pub fn scattered_fleet(n: usize, pilots: usize, seed: u64) -> puzzlebot_sim::Scenario {
    scattered_fleet_in(n, pilots, seed, 0.3).expect("up to a dozen robots fit 0.6 m x 0.6 m")
}

/// `n` robots (the first `pilots` ids pilots) scattered deterministically from `seed` in the
/// square of half side `half_side` (m) around the origin, centres at least
/// [`MIN_START_SPACING`] apart. Pilots after the first are set down as a lab would, in its
/// lane: [`LANE_GAP`] apart behind it, facing the same way, a few millimetres and hundredths
/// of a radian off (a lone pilot is not driven and moves straight only, THESIS 3.5.2 and
/// 5.4.1; growing a shape takes two pilots so). An error, before any robot exists, when the
/// robots cannot all be placed so.
pub fn scattered_fleet_in(
    n: usize,
    pilots: usize,
    seed: u64,
    half_side: f64,
) -> anyhow::Result<puzzlebot_sim::Scenario> {
    use rand::{Rng, SeedableRng};
    if !(half_side.is_finite() && half_side > 0.0) {
        anyhow::bail!("start area: half side must be a positive number of metres, got {half_side}");
    }
    if pilots > n {
        anyhow::bail!("{pilots} pilots among {n} robots");
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut poses: Vec<[f64; 3]> = Vec::new();
    // Rejection sampling: a bounded number of draws per robot, then the area is too small.
    let tries = 10_000 * n.max(1);
    for _ in 0..tries {
        if poses.len() == n {
            break;
        }
        let p = match poses.first() {
            Some(q) if poses.len() < pilots => {
                let back = LANE_GAP * poses.len() as f64;
                let side = rng.random_range(-0.003..0.003);
                let (s, c) = q[2].sin_cos();
                [
                    q[0] - back * c - side * s,
                    q[1] - back * s + side * c,
                    q[2] + rng.random_range(-0.02..0.02),
                ]
            }
            _ => [
                rng.random_range(-half_side..half_side),
                rng.random_range(-half_side..half_side),
                rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
            ],
        };
        if poses
            .iter()
            .all(|q| (q[0] - p[0]).hypot(q[1] - p[1]) > MIN_START_SPACING)
        {
            poses.push(p);
        }
    }
    if poses.len() < n {
        anyhow::bail!(
            "{n} robots do not fit a {:.2} m square {MIN_START_SPACING} m apart (placed {})",
            2.0 * half_side,
            poses.len()
        );
    }
    let robots = poses
        .into_iter()
        .enumerate()
        .map(|(i, pose)| puzzlebot_sim::RobotSpec {
            id: (i + 1) as RobotId,
            kind: if i < pilots {
                RobotKind::Pilot
            } else {
                RobotKind::NonPilot
            },
            pose,
            impairments: None,
            offline: false,
            mismatch: puzzlebot_sim::PlantMismatch::NONE,
        })
        .collect();
    Ok(puzzlebot_sim::Scenario {
        seed,
        robots,
        ..puzzlebot_sim::Scenario::default()
    })
}

/// Least distance between robot centres at the start of a scattered fleet (m).
pub const MIN_START_SPACING: f64 = 0.12;

/// Distance between pilots set down in one lane by [`scattered_fleet`] (m): room for a
/// non-pilot's staged approach to the back one's front (its place, stand-off and route
/// clearance) with the front one still ahead.
pub const LANE_GAP: f64 = 0.4;

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

/// Coordinator mode name (for logs).
pub fn mode_name(m: &Mode) -> &'static str {
    match m {
        Mode::Hold => "hold",
        Mode::Form => "form",
        Mode::Velocity { .. } => "velocity",
        Mode::GoTo { .. } => "go_to",
        Mode::Track { .. } => "track",
        Mode::Rendezvous { .. } => "rendezvous",
        Mode::Decouple { .. } => "decouple",
        Mode::Disperse { .. } => "disperse",
    }
}

/// Issue 7's demo scenario (host/assembly/data/scenarios/demo.toml, embedded so the binary
/// runs from any directory), what `puzzlebot demo` runs on [`demo_fleet`]: a 2-row mesh grown
/// around the front of two pilots, driven 0.5 m, dissolved, every robot sent to its own goal.
pub const DEMO_SCENARIO: &str = include_str!("../assembly/data/scenarios/demo.toml");

/// The fleet of `puzzlebot demo`: six robots, two pilots set down in one lane, the others
/// scattered over 0.6 m × 0.6 m ([`scattered_fleet`]). Over seeds 1–24, 21 run the whole
/// demo in lockstep (README, Status); this is seed 2.
pub fn demo_fleet() -> puzzlebot_sim::Scenario {
    scattered_fleet(6, 2, 2)
}

/// A 2-row mesh grown around the pilot of [`grow_demo_fleet`], driven 0.5 m, dissolved and
/// dispersed (host/assembly/data/scenarios/grow_mesh.toml): the one-pilot demo.
pub const GROW_DEMO_SCENARIO: &str = include_str!("../assembly/data/scenarios/grow_mesh.toml");

/// Six robots, one pilot, scattered over 0.6 m × 0.6 m. Seed 5 is a start the mesh grows
/// from and drives intact; over seeds 1–12, 10 grow it and drive it intact (README, Status).
pub fn grow_demo_fleet() -> puzzlebot_sim::Scenario {
    scattered_fleet(6, 1, 5)
}

/// The assembly library, for callers of this module (tests, tools).
pub use puzzlebot_assembly as assembly;

/// Parse an assembly scenario from TOML text (`name` labels errors) with the default geometry.
pub fn parse_scenario(name: &str, text: &str) -> anyhow::Result<AsmScenario> {
    let g = FleetParams::default().non_pilot.geometry;
    Ok(AsmScenario::from_toml_str(Path::new(name), text, &g)?)
}

/// An error unless the scenario of `r` finished (for the CLI's exit status).
pub fn ensure_finished(r: &AssemblyReport) -> anyhow::Result<()> {
    match &r.state {
        RunState::Finished => Ok(()),
        other => anyhow::bail!("the assembly scenario did not finish: {other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lockstep_run_records_every_robots_ground_truth_in_its_run_folder() {
        let runs = std::env::temp_dir().join(format!("pb-lockstep-{}", std::process::id()));
        let fleet = scattered_fleet(2, 0, 1);
        let text =
            "name = \"drive\"\n[[step]]\nmove = { velocity = [0.05, 0.0], duration_s = 2 }\n";
        let r = run_scenario_lockstep(parse_scenario("drive", text).unwrap(), fleet, &runs, 10.0)
            .unwrap();
        let lines: Vec<serde_json::Value> =
            std::fs::read_to_string(r.folder.join("telemetry.jsonl"))
                .unwrap()
                .lines()
                .map(|l| serde_json::from_str(l).unwrap())
                .collect();
        for id in [1, 2] {
            let mine: Vec<&serde_json::Value> = lines.iter().filter(|v| v["robot"] == id).collect();
            assert!(
                mine.len() >= 15,
                "robot {id}: {} records at 10 Hz over 2 s",
                mine.len()
            );
            // The records follow the robot: it drove forward, and the last one is where the
            // run ended.
            let end = mine.last().unwrap()["truth"].as_array().unwrap().clone();
            let end: Vec<f64> = end.iter().map(|x| x.as_f64().unwrap()).collect();
            let fin = r.final_poses[&id];
            assert!(
                (end[0] - fin[0]).hypot(end[1] - fin[1]) < 0.01,
                "{end:?} vs {fin:?}"
            );
            assert!(
                mine.iter().any(|v| v["v"].as_f64().unwrap() > 0.03),
                "robot {id} drove"
            );
        }
        let _ = std::fs::remove_dir_all(&runs);
    }

    #[test]
    fn a_velocity_step_below_the_wheels_dead_band_is_warned_about_by_step_and_line() {
        let p = FleetParams::default();
        let slowest = slowest_steady_speed(&p);
        // 20 RPM on 17-19 mm wheels: a few centimetres per second.
        assert!((0.02..0.06).contains(&slowest), "slowest {slowest}");
        let s = parse_scenario(
            "s.toml",
            &format!(
                "[[step]]\nmove = {{ velocity = [{}, 0.0], duration_s = 2 }}\n\
             [[step]]\nlabel = \"creep\"\nmove = {{ velocity = [{}, 0.1], duration_s = 2 }}\n\
             [[step]]\nmove = {{ velocity = [0.0, 0.5], duration_s = 2 }}\n\
             [[step]]\nmove = {{ velocity = [{}, 0.0], duration_s = 2 }}\n",
                slowest * 1.2,
                -slowest * 0.8,
                slowest * 0.5
            ),
        )
        .expect("scenario");
        let w = slow_step_warnings(&s, &p);
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w[0].starts_with("step 2 'creep' (line 3)"), "{}", w[0]);
        assert!(w[1].starts_with("step 4 "), "{}", w[1]);
        assert!(w[0].contains(&format!("{slowest:.3} m/s")), "{}", w[0]);
    }

    #[test]
    fn a_robot_hanging_at_an_anchor_keeps_in_line_in_a_mesh_and_bends_in_a_train() {
        let hanging = |phase| Role::Align {
            pair: 0,
            partner: 2,
            own_point: [0.04, 0.0],
            partner_point: [-0.04, 0.0],
            relative_yaw: 0.0,
            kind: PairType::AnchorOpening,
            phase,
        };
        let heading = |role: &Role, in_mesh| match AssemblyController::costs(role, in_mesh)[..] {
            [CostTerm::AlignPair { heading, .. }] => heading,
            ref c => panic!("costs {c:?}"),
        };
        let moving = hanging(PairStatus::Connected);
        assert_eq!(heading(&moving, true), HANG_HEADING);
        // A train bends in turns; an anchor being inserted is steered by its position.
        assert!(heading(&moving, false) < HANG_HEADING / 10.0);
        assert!(heading(&hanging(PairStatus::HeadAligned), true) < HANG_HEADING / 10.0);
    }

    #[test]
    fn a_kept_robot_is_driven_back_to_its_pose_and_a_held_one_is_not_driven() {
        let pose = Pose2::new(0.1, -0.2, 0.3);
        match &AssemblyController::costs(&Role::Keep { pose }, false)[..] {
            [CostTerm::FollowTrajectory {
                reference, heading, ..
            }] => {
                assert_eq!(reference, &vec![Pose::new(0.1, -0.2, 0.3)]);
                assert_eq!(*heading, KEEP_HEADING);
            }
            c => panic!("costs {c:?}"),
        }
        assert!(AssemblyController::costs(&Role::Hold, false).is_empty());
    }
}
