//! The assembly controller: the assembly [`Coordinator`] (through a [`ScenarioRunner`])
//! assigns each robot a task every 10 Hz tick, each task becomes cost terms of that robot's
//! MPC problem ([`DistributedMpc`], THESIS Algorithm 9, 5.19–5.26), coupled pairs become the
//! MPC's coupling constraints, and the stability gate bounds every moving assembly.

use std::collections::{BTreeMap, BTreeSet};

use puzzlebot_assembly::{
    Coordinator, Event, EventKind, Mode, PairStatus, PairType, RobotState, Role, RunState,
    Scenario as AsmScenario, ScenarioRunner, Tick,
};
use puzzlebot_mpc::{
    CostTerm, CoupledPair, DistributedMpc, Limits, MpcConfig, RobotInput, SolveStatus,
};
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::messages::RobotId;

use super::costs::{costs, MAINTAIN_HEADING_FORM, MAINTAIN_HEADING_HOLD};
use super::gate::{Gate, GateConfig, GateStop};
use super::latency::{PoseHistory, FLEET_WAIT_S, MAX_PREDICTION_S};
use super::separation::{separate_making_way, Exemptions, SeparationConfig};
use super::slow_steps::slow_step_warnings;
use crate::control::{Controller, FleetView, HandRequest};
use crate::drive::Twist;

/// Assembly scenario → tasks → distributed MPC → (v, ω), with the stability gate.
pub struct AssemblyController {
    runner: ScenarioRunner,
    mpc: DistributedMpc,
    params: FleetParams,
    gate: Gate,
    /// Keeps robots away from drops outside a cross step (`None` on the endless floor).
    edge_guard: Option<super::edge_guard::EdgeGuard>,
    t0: Option<f64>,
    last_t: f64,
    /// Every coordinator event (pair status changes, steps), in order.
    pub events: Vec<Event>,
    /// Every gate stop (one per change of the stop state of an assembly).
    pub gate_stops: Vec<GateStop>,
    /// Robots the edge guard stopped on the last tick.
    edge_stopped: BTreeSet<RobotId>,
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
    /// Longest a pose is predicted ahead (s): its age plus the command latency, capped here
    /// ([`PoseHistory::states_at`]).
    pub max_prediction_s: f64,
    /// Longest the first plan waits for every online robot's first pose (s).
    pub fleet_wait_s: f64,
    /// The scenario has had its first tick.
    runner_started: bool,
    /// Keeps robots that are not docking apart.
    separation: SeparationConfig,
    /// Every robot's last pose and velocity, for [`AssemblyController::max_prediction_s`].
    poses: PoseHistory,
    /// Robots in an inserted or connected pair (no velocity stabiliser feedback).
    coupled: BTreeSet<RobotId>,
    finished_at: Option<f64>,
    /// Hand requests not yet taken by the run ([`Controller::hand_requests`]).
    hand: Vec<HandRequest>,
    /// Terrain of every cross step, loaded before the run.
    #[cfg(feature = "sim")]
    terrains: BTreeMap<std::path::PathBuf, puzzlebot_params::terrain::Terrain>,
    /// The crossing behaviour driving the robots during a cross step.
    #[cfg(feature = "sim")]
    crossing: Option<crate::crossing::controller::CrossingController>,
    /// Where every cross step of the run ended.
    #[cfg(feature = "sim")]
    pub crossings: Vec<crate::crossing::controller::CrossProgress>,
    /// A simulated run moves the robots into the 3-D world at a cross step: the controller
    /// holds and reports done when one is due ([`AssemblyController::crossing_pending`]),
    /// and the run goes on in the 3-D world with this off.
    #[cfg(feature = "sim")]
    pub hand_over_crossings: bool,
}

impl AssemblyController {
    /// A controller running `scenario` with the fleet parameters `params`.
    pub fn new(
        scenario: AsmScenario,
        params: FleetParams,
        gate: GateConfig,
    ) -> anyhow::Result<Self> {
        for w in slow_step_warnings(&scenario, &params) {
            tracing::warn!("{w}");
        }
        #[cfg(feature = "sim")]
        let terrains = super::cross_step::load_terrains(&scenario)?;
        #[cfg(not(feature = "sim"))]
        if scenario.steps.iter().any(|s| {
            matches!(
                s.behaviour,
                puzzlebot_assembly::scenario::Behaviour::Cross { .. }
            )
        }) {
            anyhow::bail!(
                "cross steps need the crossing planner of the default build (feature `sim`)"
            );
        }
        let coordinator = Coordinator::from_params(&params);
        let geometry = params.non_pilot.geometry;
        let cfg = MpcConfig {
            geometry: puzzlebot_mpc::GeometryF64::from(&params.non_pilot.geometry),
            hard_couplings: false,
            maintain_heading: MAINTAIN_HEADING_FORM,
            ..MpcConfig::default()
        };
        let mpc = DistributedMpc::with_threads(cfg, 1)?;
        // A fleet that crosses terrain stands on it from the start: every step's motion is
        // gated on it, not only the crossing's.
        #[cfg(feature = "sim")]
        let gate = match super::cross_step::ground_of(&scenario, &terrains) {
            Some(terrain) if gate.terrain.platforms.is_empty() => GateConfig { terrain, ..gate },
            _ => gate,
        };
        let edge_guard = gate
            .edge_guard
            .then(|| super::edge_guard::EdgeGuard::new(&gate.terrain, &params))
            .flatten();
        let gate = Gate::new(gate, params.clone());
        Ok(AssemblyController {
            runner: ScenarioRunner::new(scenario, coordinator),
            mpc,
            params,
            gate,
            edge_guard,
            t0: None,
            last_t: 0.0,
            events: Vec::new(),
            gate_stops: Vec::new(),
            edge_stopped: BTreeSet::new(),
            mpc_failures: 0,
            seen: BTreeSet::new(),
            mpc_failure_reasons: BTreeMap::new(),
            coupling_constraints: false,
            constraint_retries: 0,
            settle: 0.5,
            log_milestones: true,
            max_prediction_s: MAX_PREDICTION_S,
            poses: PoseHistory::default(),
            fleet_wait_s: FLEET_WAIT_S,
            runner_started: false,
            separation: SeparationConfig::from_geometry(&geometry),
            coupled: BTreeSet::new(),
            finished_at: None,
            hand: Vec::new(),
            #[cfg(feature = "sim")]
            terrains,
            #[cfg(feature = "sim")]
            crossing: None,
            #[cfg(feature = "sim")]
            crossings: Vec::new(),
            #[cfg(feature = "sim")]
            hand_over_crossings: false,
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

    /// The separation filter ([`separate`]) over this tick's commands: robots that drive alone
    /// keep clear of every robot they are not docking with.
    fn keep_apart(
        &self,
        tick: &Tick,
        states: &[RobotState],
        segments: &BTreeMap<usize, Vec<RobotId>>,
        wait: &BTreeSet<RobotId>,
        out: &mut BTreeMap<RobotId, Twist>,
    ) {
        // Forming brings robots into contact on purpose (docking, robots waiting beside an
        // approach): the approach planning keeps corridors free there.
        if matches!(self.runner.coordinator().mode(), Mode::Form) {
            return;
        }
        let pairs = self.runner.coordinator().pairs();
        let mut exempt = Exemptions {
            segment: tick.tasks.iter().map(|t| (t.robot, t.segment)).collect(),
            ..Exemptions::default()
        };
        let mut touch = |a: RobotId, b: RobotId| {
            if let (Some(&sa), Some(&sb)) = (exempt.segment.get(&a), exempt.segment.get(&b)) {
                exempt.allow(sa, sb);
            }
        };
        for (i, p) in pairs.iter().enumerate() {
            if p.status != PairStatus::Decoupled || tick.active.contains(&i) {
                touch(p.pair.a, p.pair.b);
            }
        }
        for task in &tick.tasks {
            let partner = match task.role {
                Role::Follow { leader, .. } => Some(leader),
                Role::Align { partner, .. } => Some(partner),
                Role::Dock { pair, .. } | Role::Hitch { pair, .. } => pairs.get(pair).map(|p| {
                    if p.pair.a == task.robot {
                        p.pair.b
                    } else {
                        p.pair.a
                    }
                }),
                _ => None,
            };
            if let Some(partner) = partner {
                touch(task.robot, partner);
            }
        }
        let lone: BTreeSet<RobotId> = segments
            .values()
            .filter(|m| m.len() == 1)
            .flatten()
            .copied()
            .collect();
        let alone: BTreeSet<RobotId> = lone.difference(wait).copied().collect();
        // Dissolving, released robots hold while their neighbours pull out of each other: the
        // ones standing in a puller's way make way for it.
        let holders: BTreeSet<RobotId> =
            if matches!(self.runner.coordinator().mode(), Mode::Decouple { .. }) {
                tick.tasks
                    .iter()
                    .filter(|t| t.role == Role::Hold && lone.contains(&t.robot))
                    .map(|t| t.robot)
                    .collect()
            } else {
                BTreeSet::new()
            };
        separate_making_way(&self.separation, states, &alone, &holders, &exempt, out);
    }

    /// During a cross step, the crossing behaviour's commands: started on the step's first
    /// tick from the measured assembly (or refused, failing the step), its result reported
    /// to the runner when it stops. `None` outside a cross step.
    #[cfg(feature = "sim")]
    fn cross(&mut self, view: &FleetView) -> Option<BTreeMap<RobotId, Twist>> {
        use super::cross_step;
        let file = self.runner.crossing_due()?.to_path_buf();
        if self.crossing.is_none() && self.hand_over_crossings {
            return Some(BTreeMap::new());
        }
        if self.crossing.is_none() {
            let links = cross_step::believed_links(self.runner.coordinator(), view, &self.params);
            let started = self
                .terrain(&file)
                .ok_or_else(|| format!("terrain {} was not loaded", file.display()))
                .and_then(|t| cross_step::start(view, &links, t, &self.params));
            match started {
                Ok(c) => {
                    if self.log_milestones {
                        tracing::info!("crossing: the gate proves it; driving across");
                    }
                    self.crossing = Some(c.with_rate(self.rate_hz()));
                }
                Err(why) => {
                    self.runner.finish_crossing(Err(why));
                    return Some(BTreeMap::new());
                }
            }
        }
        let c = self.crossing.as_mut()?;
        let out = c.update(view);
        if !c.done(view.t) {
            return Some(out);
        }
        if let Some((_, advance, stop)) = &c.progress().stopped {
            let result = cross_step::result(stop, *advance, c.progress().backed_off_to);
            self.crossings.push(c.progress().clone());
            self.crossing = None;
            self.runner.finish_crossing(result);
        }
        Some(out)
    }

    /// A cross step is due and its crossing has not started: the terrain file it names.
    #[cfg(feature = "sim")]
    pub fn crossing_pending(&self) -> Option<&std::path::Path> {
        self.runner
            .crossing_due()
            .filter(|_| self.crossing.is_none())
    }

    /// The loaded terrain of a cross step's file.
    #[cfg(feature = "sim")]
    pub fn terrain(&self, file: &std::path::Path) -> Option<&puzzlebot_params::terrain::Terrain> {
        self.terrains.get(file)
    }

    fn limits(&self, kind: RobotKind) -> Limits {
        Limits::from_drive(&self.params.robot(kind).drive)
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
        self.poses.observe(view, horizon);
        // Before the first plan, every online robot must have been seen: a robot whose first
        // pose has not arrived would be left out of the plan (its shape then has a slot too
        // many). Everyone holds meanwhile, for at most `fleet_wait_s`.
        if !self.runner_started {
            let unseen = view.robots.iter().any(|r| !self.poses.contains(r.id));
            if unseen && t < self.fleet_wait_s {
                return BTreeMap::new();
            }
            self.runner_started = true;
        }
        let latency = view.latency_s.max(0.0);
        let (poses, coupled) = (&self.poses, &self.coupled);
        let states = poses.states_at(view.t, 0.0, horizon, latency, coupled);
        let predicted = poses.states_at(view.t, latency, horizon, latency, coupled);
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
                if let Some(text) = crate::replay::words::describe_event(&e.kind) {
                    tracing::info!("{:.1} s: {text}", e.t);
                }
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
        #[cfg(feature = "sim")]
        if let Some(out) = self.cross(view) {
            self.poses.sent(view.t, &out);
            return out;
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
                pose: s.pose,
                limits: self.limits(s.kind),
                costs: costs(&task.role, meshes.contains(&task.segment)),
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
        // The anchors' maintenance cost (THESIS 4.8) pulls each robot of a pair towards its
        // partner's predicted plan. While assemblies move, every member already tracks its
        // own place (a rigid offset or its predecessor's path): the cost would only couple
        // two controllers that each see the other's noisy, latency-late prediction, and they
        // swing the joint between them until the anchor pops. So it holds while forming,
        // holding and decoupling, not while assemblies move.
        let moving = matches!(
            self.runner.coordinator().mode(),
            Mode::Velocity { .. } | Mode::GoTo { .. } | Mode::Track { .. }
        );
        let pairs: Vec<CoupledPair> = tick
            .maintain
            .iter()
            .filter(|m| m.kind == PairType::AnchorOpening && !moving)
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
            if let Role::Dock { v, w, .. } | Role::Hitch { v, w, .. } | Role::Drive { v, w } =
                task.role
            {
                direct.insert(task.robot, Twist::new(v, w));
            }
        }
        // Joints held straight while forming, freer otherwise (a train that bent in a turn
        // stays bent while it holds).
        let heading = if matches!(self.runner.coordinator().mode(), Mode::Form) {
            MAINTAIN_HEADING_FORM
        } else {
            MAINTAIN_HEADING_HOLD
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
        self.keep_apart(&tick, &predicted, &segments, &wait, &mut out);
        // Every assembly and every lone robot that moves: over terrain a lone robot driven
        // off an edge falls as surely as an assembly.
        let segs: BTreeMap<usize, Vec<RobotId>> = segments.into_iter().collect();
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
        let dt = 1.0 / self.rate_hz();
        let stops = self.gate.apply(t, dt, &states, &maintain, &segs, &mut out);
        self.gate_stops.extend(stops);
        if let Some(guard) = &self.edge_guard {
            // The commands act after the latency and hold for up to two control periods.
            let look = latency + 2.0 * dt;
            let stopped = guard.apply(&states, &segs, look, &mut out);
            if !stopped.is_empty() && self.edge_stopped.is_empty() {
                tracing::warn!("robots {stopped:?} stopped short of a drop (outside a cross step)");
            }
            self.edge_stopped = stopped;
        }
        self.poses.sent(view.t, &out);
        out
    }

    fn done(&self, t: f64) -> bool {
        #[cfg(feature = "sim")]
        if self.hand_over_crossings && self.crossing_pending().is_some() {
            return true;
        }
        self.finished_at.is_some_and(|f| t >= f + self.settle)
    }

    fn stabilise(&self, id: RobotId) -> bool {
        !self.coupled.contains(&id)
    }

    fn hand_requests(&mut self) -> Vec<HandRequest> {
        std::mem::take(&mut self.hand)
    }

    fn hold_ms(&self, _id: RobotId) -> u16 {
        #[cfg(feature = "sim")]
        if let Some(c) = &self.crossing {
            return c.hold_ms(_id);
        }
        0
    }

    fn progress(&self) -> Option<crate::replay::Progress> {
        Some(crate::replay::Progress::of_runner(&self.runner))
    }
}
