//! Run one [`Episode`] in lockstep and judge it against the simulator's ground truth.
//!
//! Success: every step finished; every planned pair coupled in the ground truth from
//! formation complete until the dissolve step starts (no pair ever came apart in between, and
//! no coupling the plan does not have); nobody fell; every dispersing robot at its goal (the
//! disperse step finishes only then).
//!
//! A failed episode gets one [`Failure`] class, the first that applies:
//! robot fell → MPC infeasible (≥ 20 % of the controller's ticks had a failed solve) →
//! unplanned coupling (in the ground truth at formation complete, or still held when
//! formation failed) → pair popped (a planned pair came apart after formation complete, in
//! the ground truth or, failing the move, in the host's view) →
//! by the step that failed: the dissolve or disperse steps → dissolve time-out; formation →
//! pilot off its lane (the lane pilot more than twice the lane tolerance off the front pilot's
//! axis, uncoupled), docking oscillation (the pair statuses changed ≥ 12 times in the last
//! 60 s), deadlock (no robot moved 2 cm in the last 30 s), approach blocked (a robot still
//! uncoupled moved but stayed within 1.5 body lengths of a robot it was not planned to couple
//! to); a plan refused at the start → refused; anything else → other.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::time::Instant;

use puzzlebot_assembly::assign::LANE_TOLERANCE;
use puzzlebot_assembly::{EventKind, RunState};
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::RobotId;
use puzzlebot_sim::{EventKind as SimEventKind, World};
use serde::Serialize;

use crate::assemble::{AssemblyController, GateConfig, TruthRecord};
use crate::control::{Controller, FleetView, HandRequest};
use crate::drive::Twist;
use crate::lockstep::Lockstep;
use crate::report::RunFolder;

use super::episode::Episode;

/// Why an episode failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Failure {
    /// A robot still trying to dock stayed boxed in by robots it was not docking with.
    ApproachBlocked,
    /// Pairs kept changing status without settling.
    DockingOscillation,
    /// Nobody moved: robots waiting for each other.
    Deadlock,
    /// Two robots coupled where the plan has no pair.
    UnplannedCoupling,
    /// A planned pair came apart after formation complete, before the dissolve.
    PairPopped,
    /// The lane pilot left its lane and cannot turn back onto it.
    PilotOffLane,
    /// Dissolving or dispersing did not finish.
    DissolveTimeout,
    /// A robot fell (off a platform or over).
    RobotFell,
    /// The MPC failed to solve for a large part of the run.
    MpcInfeasible,
    /// The request was refused before any robot moved.
    Refused,
    /// None of the above.
    Other,
}

impl Failure {
    /// Every class, in the order of the taxonomy table.
    pub const ALL: [Failure; 11] = [
        Failure::ApproachBlocked,
        Failure::DockingOscillation,
        Failure::Deadlock,
        Failure::UnplannedCoupling,
        Failure::PairPopped,
        Failure::PilotOffLane,
        Failure::DissolveTimeout,
        Failure::RobotFell,
        Failure::MpcInfeasible,
        Failure::Refused,
        Failure::Other,
    ];

    /// Its name in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Failure::ApproachBlocked => "approach_blocked",
            Failure::DockingOscillation => "docking_oscillation",
            Failure::Deadlock => "deadlock",
            Failure::UnplannedCoupling => "unplanned_coupling",
            Failure::PairPopped => "pair_popped",
            Failure::PilotOffLane => "pilot_off_lane",
            Failure::DissolveTimeout => "dissolve_timeout",
            Failure::RobotFell => "robot_fell",
            Failure::MpcInfeasible => "mpc_infeasible",
            Failure::Refused => "refused",
            Failure::Other => "other",
        }
    }
}

/// What one episode did.
#[derive(Debug, Clone, Serialize)]
pub struct Outcome {
    /// The episode.
    pub episode: Episode,
    /// Every criterion met.
    pub success: bool,
    /// The failure class (none on success).
    pub failure: Option<Failure>,
    /// What exactly went wrong, for a person.
    pub detail: String,
    /// Simulated time from the start of the formation step to formation complete (s).
    pub formation_s: Option<f64>,
    /// Planned anchor pairs that came apart in the ground truth between formation complete
    /// and the dissolve (each time counted; the host couples them again while it can).
    pub pops: usize,
    /// Simulated time of the whole run (s).
    pub sim_s: f64,
    /// Wall-clock time the episode took (s).
    pub wall_s: f64,
}

/// Share of the controller's ticks with a failed MPC solve above which a failure is the
/// MPC's.
const MPC_FAILURE_SHARE: f64 = 0.2;
/// Status changes in the last [`OSCILLATION_WINDOW_S`] that make a formation failure an
/// oscillation.
const OSCILLATION_CHANGES: usize = 12;
/// Window of the oscillation count (s).
const OSCILLATION_WINDOW_S: f64 = 60.0;
/// Window of the deadlock and blocked-approach checks (s).
const STILL_WINDOW_S: f64 = 30.0;
/// A robot that moved less than this over [`STILL_WINDOW_S`] stood still (m).
const STILL_DISTANCE_M: f64 = 0.02;
/// Period of the ground-truth samples the classification looks at (s).
const SAMPLE_PERIOD_S: f64 = 0.5;

/// The assembly controller, watched: remembers the planned pairs when formation completes.
struct Watched {
    inner: AssemblyController,
    /// (anchor/knob robot, opening/hole robot) of every pair at formation complete.
    planned: Option<(f64, Vec<(RobotId, RobotId)>)>,
    /// Robots whose slots touch in the shape, at formation complete: a coupling between them
    /// that the plan's spanning tree left out (a mesh robot's second knob pair) is part of
    /// the shape, not an unplanned coupling.
    neighbours: BTreeSet<(RobotId, RobotId)>,
    seen_events: usize,
}

impl Controller for Watched {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn rate_hz(&self) -> f64 {
        self.inner.rate_hz()
    }
    fn update(&mut self, view: &FleetView) -> BTreeMap<RobotId, Twist> {
        let out = self.inner.update(view);
        if self.planned.is_none() {
            let new = &self.inner.events[self.seen_events.min(self.inner.events.len())..];
            if let Some(e) = new
                .iter()
                .find(|e| matches!(e.kind, EventKind::FormationComplete))
            {
                let pairs = self
                    .inner
                    .runner()
                    .coordinator()
                    .pairs()
                    .iter()
                    .map(|p| (p.pair.a, p.pair.b))
                    .collect();
                self.planned = Some((e.t, pairs));
                if let Some(plan) = self.inner.runner().coordinator().plan() {
                    self.neighbours = slot_neighbours(plan);
                }
            }
            self.seen_events = self.inner.events.len();
        }
        out
    }
    fn done(&self, t: f64) -> bool {
        self.inner.done(t)
    }
    fn stabilise(&self, id: RobotId) -> bool {
        self.inner.stabilise(id)
    }
    fn hand_requests(&mut self) -> Vec<HandRequest> {
        self.inner.hand_requests()
    }
}

/// Pairs of robots whose slots in `plan`'s shape are side by side or end to end: centres no
/// farther apart than a knob pair's (one width across, up to half a length along) allows.
fn slot_neighbours(plan: &puzzlebot_assembly::Plan) -> BTreeSet<(RobotId, RobotId)> {
    let g = FleetParams::default().non_pilot.geometry;
    let (l, w) = (f64::from(g.length), f64::from(g.width));
    let reach = 1.05 * w.hypot(0.5 * l).max(l);
    let slots = &plan.shape.slots;
    let mut out = BTreeSet::new();
    for (i, a) in slots.iter().enumerate() {
        for (j, b) in slots.iter().enumerate().skip(i + 1) {
            let d = (a.pose.x - b.pose.x).hypot(a.pose.y - b.pose.y);
            if let (Some(&ra), Some(&rb)) = (plan.slot_robot.get(i), plan.slot_robot.get(j)) {
                if d <= reach {
                    out.insert(unordered(ra, rb));
                }
            }
        }
    }
    out
}

/// Ground truth sampled during a run.
#[derive(Default)]
struct Samples {
    /// (controller time s, robot → (x, y, yaw)).
    poses: Vec<(f64, BTreeMap<RobotId, [f64; 3]>)>,
}

impl Samples {
    fn take(&mut self, w: &World, t: f64) {
        if self
            .poses
            .last()
            .is_some_and(|(last, _)| t - last < SAMPLE_PERIOD_S)
        {
            return;
        }
        let poses = w.poses().map(|(id, p)| (id, [p.x, p.y, p.yaw])).collect();
        self.poses.push((t, poses));
    }

    /// Each robot's travel over the window ending at `t_end` (m): the farthest it got from
    /// where it was at the window's start.
    fn travel(&self, t_end: f64, window: f64) -> BTreeMap<RobotId, f64> {
        let inside: Vec<_> = self
            .poses
            .iter()
            .filter(|(t, _)| *t >= t_end - window && *t <= t_end)
            .collect();
        let mut out = BTreeMap::new();
        if let Some((_, first)) = inside.first() {
            for (id, p0) in first {
                let d = inside
                    .iter()
                    .filter_map(|(_, m)| m.get(id))
                    .map(|p| (p[0] - p0[0]).hypot(p[1] - p0[1]))
                    .fold(0.0, f64::max);
                out.insert(*id, d);
            }
        }
        out
    }
}

/// Run `ep` and judge it. With `folder`, a run folder is written there (scenario, events,
/// ground truth, the outcome, `run.mcap`, the replay page and pictures) for `--replay`.
pub fn run_episode(ep: &Episode, folder: Option<&Path>) -> Outcome {
    let wall = Instant::now();
    let fail = |failure: Failure, detail: String| Outcome {
        episode: ep.clone(),
        success: false,
        failure: Some(failure),
        detail,
        formation_s: None,
        pops: 0,
        sim_s: 0.0,
        wall_s: wall.elapsed().as_secs_f64(),
    };
    let params = FleetParams::default();
    let sim = match ep.sim_scenario() {
        Ok(s) => s,
        Err(e) => return fail(Failure::Refused, format!("{e:#}")),
    };
    let asm = match ep.asm_scenario(&params) {
        Ok(s) => s,
        Err(e) => return fail(Failure::Refused, format!("{e:#}")),
    };
    let imp = ep.impairment();
    let mut ls = match Lockstep::new(&sim) {
        Ok(l) => l
            .command_delay(imp.delay_ms())
            .command_jitter(imp.jitter_ms()),
        Err(e) => return fail(Failure::Other, format!("simulator: {e:#}")),
    };
    let gate = GateConfig {
        terrain: sim.terrain.clone(),
        ..GateConfig::default()
    };
    let mut inner = match AssemblyController::new(asm, params, gate) {
        Ok(c) => c,
        Err(e) => return fail(Failure::Refused, format!("{e:#}")),
    };
    inner.log_milestones = false;
    let mut ctl = Watched {
        inner,
        planned: None,
        neighbours: BTreeSet::new(),
        seen_events: 0,
    };
    let mut samples = Samples::default();
    let mut traces: BTreeMap<RobotId, Vec<TruthRecord>> = BTreeMap::new();
    let record = folder.is_some();
    // A run written to a folder is also recorded (`run.mcap`, for the replay page).
    let recorder = record.then(|| crate::record::Recorder::new(&sim));
    let mut run_it = || {
        ls.run(&mut ctl, ep.run_limit_s(), |w, t| {
            samples.take(w, t);
            if record
                && traces
                    .values()
                    .next()
                    .is_none_or(|tr| tr.last().is_none_or(|l| t - l.t >= 0.1))
            {
                for r in w.ground_truth().robots {
                    traces.entry(r.id).or_default().push(TruthRecord::of(t, &r));
                }
            }
        })
    };
    let (run, recorder) = match recorder {
        Some(rec) => {
            let (run, rec) = crate::record::recording(rec, run_it);
            (run, Some(rec))
        }
        None => (run_it(), None),
    };
    let truth = ls.world.ground_truth();
    let mut out = judge(ep, &ctl, &run, &truth, &samples);
    out.wall_s = wall.elapsed().as_secs_f64();
    if let Some(base) = folder {
        if let Err(e) = write_folder(base, ep, &ctl.inner, &out, traces, recorder) {
            out.detail
                .push_str(&format!(" (run folder not written: {e:#})"));
        }
    }
    out
}

fn write_folder(
    base: &Path,
    ep: &Episode,
    ctl: &AssemblyController,
    out: &Outcome,
    traces: BTreeMap<RobotId, Vec<TruthRecord>>,
    recorder: Option<crate::record::Recorder>,
) -> anyhow::Result<()> {
    let mut f = RunFolder::create(base, &format!("episode-{}-{}", ep.seed, ep.profile.name()))?;
    std::fs::write(f.dir().join("scenario.toml"), ep.scenario_text())?;
    f.write_json("simulator.json", &ep.sim_scenario()?)?;
    for e in &ctl.events {
        f.event(e)?;
    }
    for tr in traces.values() {
        for s in tr {
            f.telemetry(s)?;
        }
    }
    f.write_json("outcome.json", out)?;
    f.finish()?;
    if let Some(mut rec) = recorder {
        rec.host_events(&ctl.events, &ctl.gate_stops);
        rec.write(&f.dir().join(crate::record::RUN_MCAP))?;
    }
    let w = crate::replay::write(f.dir())?;
    eprintln!(
        "run folder: {}\nreplay: {}\npictures: {}",
        f.dir().display(),
        w.page.display(),
        w.picture.display()
    );
    Ok(())
}

/// Which planned pairs and which others were coupled in the ground truth at each moment:
/// the coupling events replayed.
fn coupled_at(run: &crate::lockstep::LockstepRun, t: f64) -> BTreeSet<(RobotId, RobotId)> {
    let until = run.start_us + (t.max(0.0) * 1e6) as u64;
    let mut held = BTreeSet::new();
    for e in run.sim_events.iter().filter(|e| e.t_us <= until) {
        match e.kind {
            SimEventKind::Coupled { a, b, .. } => {
                held.insert(unordered(a, b));
            }
            SimEventKind::Decoupled { a, b, .. } => {
                held.remove(&unordered(a, b));
            }
            _ => {}
        }
    }
    held
}

fn unordered(a: RobotId, b: RobotId) -> (RobotId, RobotId) {
    (a.min(b), a.max(b))
}

fn judge(
    ep: &Episode,
    ctl: &Watched,
    run: &crate::lockstep::LockstepRun,
    truth: &puzzlebot_sim::GroundTruth,
    samples: &Samples,
) -> Outcome {
    let events = &ctl.inner.events;
    let step_start = |label: &str| {
        events.iter().find_map(|e| match &e.kind {
            EventKind::StepStarted { label: l, .. } if l == label => Some(e.t),
            _ => None,
        })
    };
    let formed_at = ctl.planned.as_ref().map(|(t, _)| *t);
    let formation_s = formed_at.map(|t| t - step_start("form").unwrap_or(0.0));
    let mut out = Outcome {
        episode: ep.clone(),
        success: false,
        failure: None,
        detail: String::new(),
        formation_s,
        pops: 0,
        sim_s: run.t_end,
        wall_s: 0.0,
    };
    let state = ctl.inner.state().clone();
    let mut verdict = |f: Failure, d: String| {
        out.failure = Some(f);
        out.detail = d;
    };
    let fallen: Vec<RobotId> = truth
        .robots
        .iter()
        .filter(|r| r.fallen)
        .map(|r| r.id)
        .collect();
    let ticks = (run.t_end * ctl.inner.rate_hz()).max(1.0);
    let failed_step = match &state {
        RunState::Failed { index, reason } => Some((*index, reason.clone())),
        RunState::Running { index } => Some((*index, "the run's time limit passed".into())),
        RunState::Finished => None,
    };
    let label_of = |index: usize| {
        ctl.inner
            .runner()
            .scenario()
            .steps
            .get(index)
            .map_or_else(|| format!("step {index}"), |s| s.label.clone())
    };
    // Planned pairs and the ground truth from formation complete to the dissolve.
    let mut popped = None;
    let mut unplanned = None;
    if let Some((t_fc, planned)) = &ctl.planned {
        let plan: BTreeSet<_> = planned.iter().map(|&(a, b)| unordered(a, b)).collect();
        let held = coupled_at(run, *t_fc);
        if let Some(x) = held.difference(&plan).find(|x| !ctl.neighbours.contains(x)) {
            unplanned = Some(format!(
                "robots {} and {} coupled at formation complete; the plan has no such pair",
                x.0, x.1
            ));
        }
        let t_dec = step_start("dissolve").unwrap_or(f64::INFINITY);
        let from = run.start_us + (t_fc * 1e6) as u64;
        let to = if t_dec.is_finite() {
            run.start_us + (t_dec * 1e6) as u64
        } else {
            u64::MAX
        };
        // Planned pairs that came apart in the ground truth between the two instants.
        let apart: Vec<(RobotId, RobotId, u64)> = run
            .sim_events
            .iter()
            .filter_map(|e| match e.kind {
                SimEventKind::Decoupled { a, b, .. }
                    if e.t_us > from && e.t_us < to && plan.contains(&unordered(a, b)) =>
                {
                    Some((a, b, e.t_us))
                }
                _ => None,
            })
            .collect();
        out.pops = apart.len();
        popped = apart.first().map(|&(a, b, t_us)| {
            format!(
                "pair {a}-{b} came apart at t = {:.1} s (formed at {t_fc:.1} s)",
                t_us.saturating_sub(run.start_us) as f64 * 1e-6
            )
        });
        if popped.is_none() {
            if let Some(x) = plan.difference(&held).next() {
                popped = Some(format!(
                    "pair {}-{} counted connected at formation complete but not coupled in the simulator",
                    x.0, x.1
                ));
            }
        }
    }
    if !fallen.is_empty() {
        verdict(Failure::RobotFell, format!("robots {fallen:?} fell"));
    } else if ctl.inner.mpc_failures as f64 > MPC_FAILURE_SHARE * ticks {
        verdict(
            Failure::MpcInfeasible,
            format!(
                "{} of ≈{ticks:.0} ticks had a failed solve: {:?}",
                ctl.inner.mpc_failures, ctl.inner.mpc_failure_reasons
            ),
        );
    } else if let Some(d) = unplanned {
        verdict(Failure::UnplannedCoupling, d);
    } else if let Some(d) = popped {
        verdict(Failure::PairPopped, d);
    } else if let Some((index, reason)) = failed_step {
        let label = label_of(index);
        let d = format!("step {index} ({label}) failed: {reason}");
        match label.as_str() {
            "dissolve" | "spread out" | "disperse" => verdict(Failure::DissolveTimeout, d),
            "form" => {
                let f = classify_formation(ep, ctl, run, truth, samples, &reason);
                verdict(f, d);
            }
            // The move stops when the host sees a pair come apart and couples it again; it
            // fails when that keeps happening (the ground truth may still hold the pair: the
            // host's view of it came apart).
            "move" if reason.contains("came apart") => verdict(Failure::PairPopped, d),
            _ => verdict(Failure::Other, d),
        }
    }
    out.success = out.failure.is_none();
    out
}

/// [`slot_neighbours`] of the coordinator's current plan.
fn shape_neighbours(ctl: &Watched) -> BTreeSet<(RobotId, RobotId)> {
    ctl.inner
        .runner()
        .coordinator()
        .plan()
        .map(slot_neighbours)
        .unwrap_or_default()
}

/// The class of a formation that did not complete.
fn classify_formation(
    ep: &Episode,
    ctl: &Watched,
    run: &crate::lockstep::LockstepRun,
    truth: &puzzlebot_sim::GroundTruth,
    samples: &Samples,
    reason: &str,
) -> Failure {
    let events = &ctl.inner.events;
    let t_end = run.t_end;
    let moved = events.iter().any(|e| {
        matches!(e.kind, EventKind::PairStatus { .. })
            || matches!(e.kind, EventKind::FormationComplete)
    });
    if !moved && !reason.contains("timed out") && !reason.contains("time limit") {
        return Failure::Refused;
    }
    let plan: BTreeSet<(RobotId, RobotId)> = ctl
        .inner
        .runner()
        .coordinator()
        .pairs()
        .iter()
        .map(|p| unordered(p.pair.a, p.pair.b))
        .collect();
    let held = coupled_at(run, t_end);
    if held
        .difference(&plan)
        .any(|x| !ctl.neighbours.contains(x) && !shape_neighbours(ctl).contains(x))
    {
        return Failure::UnplannedCoupling;
    }
    // The lane pilot (id 2 of a two-pilot fleet) off the front pilot's axis and alone.
    if ep.pilots == 2 {
        if let (Some(p1), Some(p2)) = (truth.robot(1), truth.robot(2)) {
            let (s, c) = p1.pose.yaw.sin_cos();
            let lateral = (-(p2.pose.x - p1.pose.x) * s + (p2.pose.y - p1.pose.y) * c).abs();
            let alone = !held.iter().any(|&(a, b)| a == 2 || b == 2);
            if alone && lateral > 2.0 * LANE_TOLERANCE.0 && p2.kind == RobotKind::Pilot {
                return Failure::PilotOffLane;
            }
        }
    }
    let changes = events
        .iter()
        .filter(|e| e.t >= t_end - OSCILLATION_WINDOW_S)
        .filter(|e| matches!(e.kind, EventKind::PairStatus { .. }))
        .count();
    if changes >= OSCILLATION_CHANGES {
        return Failure::DockingOscillation;
    }
    let travel = samples.travel(t_end, STILL_WINDOW_S);
    if travel.values().all(|&d| d < STILL_DISTANCE_M) {
        return Failure::Deadlock;
    }
    // A robot still uncoupled that moved but stayed close to robots it was not planned to
    // couple to.
    let body = 1.5 * f64::from(FleetParams::default().non_pilot.geometry.length);
    let coupled: BTreeSet<RobotId> = held.iter().flat_map(|&(a, b)| [a, b]).collect();
    let partners = |id: RobotId| -> BTreeSet<RobotId> {
        plan.iter()
            .filter_map(|&(a, b)| match (a == id, b == id) {
                (true, _) => Some(b),
                (_, true) => Some(a),
                _ => None,
            })
            .collect()
    };
    let blocked = truth.robots.iter().any(|r| {
        if coupled.contains(&r.id) || travel.get(&r.id).is_none_or(|&d| d < STILL_DISTANCE_M) {
            return false;
        }
        let mine = partners(r.id);
        truth.robots.iter().any(|o| {
            o.id != r.id
                && !mine.contains(&o.id)
                && (o.pose.x - r.pose.x).hypot(o.pose.y - r.pose.y) < body
        })
    });
    if blocked {
        Failure::ApproachBlocked
    } else {
        Failure::Other
    }
}
