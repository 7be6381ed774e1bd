//! The host control loop: a swappable [`Controller`] produces a (v, ω) per robot at its
//! own rate (10 Hz for the MPC, 30 Hz for simple behaviours); the loop runs at the command
//! rate (30 Hz, THESIS 4.4.3), estimates each robot's instant velocity from poses, runs the
//! [`Stabiliser`] and streams wheel-speed targets over the [`FleetLink`]. Robots without a
//! fresh pose, or offline, are stopped. Everything is recorded into a [`RunFolder`].
//!
//! Also here: reference trajectories (line, circle) and a trajectory-following
//! controller (the demo's behaviour until assemblies land; THESIS 5.26 is the MPC version).

mod command_delay;
mod tracker;
mod trajectory;

use std::collections::BTreeMap;
use std::time::Duration;

use puzzlebot_params::{RobotKind, RobotParams};
use puzzlebot_protocol::{messages::RobotId, HostMsg};
use serde::Serialize;

use crate::drive::{DriveMap, PoseSample, Stabiliser, StabiliserGains, Twist, VelocityEstimator};
use crate::link::FleetLink;
use crate::pose::PoseTable;
use crate::report::RunFolder;

pub use command_delay::CommandDelay;
pub use tracker::{track, TrackerGains, TrajectoryFollower};
pub use trajectory::{Path, RefState, Trajectory};

/// What a controller sees of one robot.
#[derive(Debug, Clone, Copy)]
pub struct RobotView {
    /// Robot id.
    pub id: RobotId,
    /// Kind (from its announce).
    pub kind: RobotKind,
    /// Fresh pose, if any.
    pub pose: Option<PoseSample>,
    /// Velocity estimated from poses, if any.
    pub velocity: Option<Twist>,
}

/// What a controller sees of the fleet at one tick.
#[derive(Debug, Clone)]
pub struct FleetView {
    /// Host time (s).
    pub t: f64,
    /// Online robots with proven sessions.
    pub robots: Vec<RobotView>,
    /// How long after this tick the controller's commands are measured to take effect (s):
    /// on a real fleet the controller's own measured update time (its commands leave after
    /// it) plus half the link's smoothed round trip, in lockstep the measured delay of
    /// applied commands. Controllers predict poses this far ahead.
    pub latency_s: f64,
}

/// A source of per-robot (v, ω) commands: trajectory following now; MPC and assembly
/// behaviours plug in here.
pub trait Controller: Send {
    /// Short name (run folder, logs).
    fn name(&self) -> &str;
    /// How often [`Controller::update`] is called (Hz); commands are held in between.
    fn rate_hz(&self) -> f64 {
        30.0
    }
    /// Commands for some robots; robots left out are stopped.
    fn update(&mut self, view: &FleetView) -> BTreeMap<RobotId, Twist>;
    /// Where robot `id` should be at time `t` (s since the controller started), for
    /// error metrics and plots.
    fn reference(&self, _id: RobotId, _t: f64) -> Option<[f64; 2]> {
        None
    }
    /// True when the behaviour has finished at time `t` (s since it started).
    fn done(&self, t: f64) -> bool;
    /// Whether the host's velocity stabiliser may correct robot `id`'s commands from its
    /// measured motion. False for a robot coupled to others: its motion is the assembly's,
    /// so the measured-vs-commanded error is coupling force, not calibration error, and
    /// integrating it winds the robot up against its partners.
    fn stabilise(&self, _id: RobotId) -> bool {
        true
    }
    /// What the controller needs a person to do since the last call (e.g. lift knob pairs
    /// apart): the run logs it, and a simulated fleet's hand does it.
    fn hand_requests(&mut self) -> Vec<HandRequest> {
        Vec::new()
    }
    /// How long robot `id` keeps driving its latest command if no further one arrives (ms,
    /// capped by its firmware's `max_hold_ms`): sent as [`HostMsg::WheelSpeedHold`]. 0 (the
    /// default): the firmware's failsafe stops it after its timeout.
    fn hold_ms(&self, _id: RobotId) -> u16 {
        0
    }
    /// Where the run is (scenario step, pairs coupled), for the progress line on the terminal.
    fn progress(&self) -> Option<crate::replay::Progress> {
        None
    }
}

/// Work for a person's hands (THESIS 5.5.3: knob pairs hold until lifted apart).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub enum HandRequest {
    /// Lift the knob pairs among these robots apart and set the groups still joined by
    /// anchors (the rows) down a few centimetres apart.
    LiftKnobs {
        /// The robots.
        robots: Vec<RobotId>,
    },
}

/// A simulated fleet's hand: does a [`HandRequest`] in the simulator.
pub type Hand = Box<dyn FnMut(&HandRequest) + Send>;

/// Settings of one run of the control loop.
#[derive(Debug, Clone)]
pub struct LoopOptions {
    /// Stop after this long even if the controller is not done (s).
    pub max_duration: f64,
    /// Stabiliser gains.
    pub gains: StabiliserGains,
    /// Window of the velocity estimator (s).
    pub velocity_window: f64,
    /// Use the stabiliser's feedback (false: feed-forward mapping only).
    pub stabilise: bool,
}

impl Default for LoopOptions {
    fn default() -> Self {
        LoopOptions {
            max_duration: 60.0,
            gains: StabiliserGains::default(),
            velocity_window: 0.12,
            stabilise: true,
        }
    }
}

/// Per-robot tracking error statistics.
#[derive(Debug, Clone, Default, Serialize)]
pub struct TrackingStats {
    /// Samples.
    pub samples: u64,
    /// Mean distance to the time-indexed reference (m).
    pub mean_error: f64,
    /// Largest distance (m).
    pub max_error: f64,
    /// Ticks the robot was stopped for lack of a fresh pose.
    pub pose_stops: u64,
}

/// Result of a run of the control loop.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RunSummary {
    /// Controller name.
    pub controller: String,
    /// Duration (s).
    pub duration: f64,
    /// Control ticks.
    pub ticks: u64,
    /// Tracking error per robot (only robots with a reference).
    pub tracking: BTreeMap<RobotId, TrackingStats>,
    /// Link statistics per robot at the end.
    pub link: BTreeMap<RobotId, crate::link::LinkStats>,
    /// Mean time of one [`Controller::update`] (ms): part of the command latency.
    pub update_ms_mean: f64,
    /// Longest [`Controller::update`] (ms).
    pub update_ms_max: f64,
    /// Command periods that passed without a tick (the loop ran late: a loaded machine).
    pub missed_ticks: u64,
}

impl RunSummary {
    /// Mean of the robots' mean tracking errors (m).
    pub fn mean_tracking_error(&self) -> f64 {
        let n = self.tracking.len().max(1) as f64;
        self.tracking.values().map(|s| s.mean_error).sum::<f64>() / n
    }
}

/// One telemetry record per robot per tick.
#[derive(Debug, Serialize)]
struct TickRecord<'a> {
    t: f64,
    robot: RobotId,
    pose: Option<[f64; 3]>,
    truth: Option<[f64; 3]>,
    reference: Option<[f64; 2]>,
    desired: Option<Twist>,
    measured: Option<Twist>,
    wheel_target_rpm: Option<[f64; 2]>,
    telemetry: Option<&'a puzzlebot_protocol::messages::Telemetry>,
}

/// Weight of each new update time in the smoothed one (as the lockstep loop smooths its
/// measured command delay).
const UPDATE_SMOOTHING: f64 = 0.2;

/// Optional source of ground-truth positions (simulation): id → [x, y, θ].
pub type TruthProbe = Box<dyn Fn() -> BTreeMap<RobotId, [f64; 3]> + Send>;

/// The 30 Hz control loop over a link and a pose table.
pub struct ControlLoop {
    link: FleetLink,
    poses: PoseTable,
    params: Box<dyn Fn(RobotId, RobotKind) -> RobotParams + Send>,
    /// Options.
    pub options: LoopOptions,
    /// Ground truth for error metrics (simulation); poses are used otherwise.
    pub truth: Option<TruthProbe>,
    /// A simulated fleet's hand for the controller's [`HandRequest`]s (none: a person's).
    pub hand: Option<Hand>,
}

struct PerRobot {
    stab: Stabiliser,
    est: VelocityEstimator,
    last_pose_t: f64,
    stats: TrackingStats,
    err_sum: f64,
    pose_lost: bool,
}

impl ControlLoop {
    /// A loop driving the robots of `link` with poses from `poses`; `params` gives each
    /// robot's parameter set (calibrated file or kind defaults).
    pub fn new(
        link: FleetLink,
        poses: PoseTable,
        params: impl Fn(RobotId, RobotKind) -> RobotParams + Send + 'static,
    ) -> Self {
        ControlLoop {
            link,
            poses,
            params: Box::new(params),
            options: LoopOptions::default(),
            truth: None,
            hand: None,
        }
    }

    /// Run `controller` until it is done (or the time limit), recording into `folder`.
    /// Every robot is stopped at the end.
    pub async fn run(
        &mut self,
        controller: &mut dyn Controller,
        mut folder: Option<&mut RunFolder>,
        progress: Option<&indicatif::ProgressBar>,
    ) -> RunSummary {
        let rates = self.link.rates();
        let hz = f64::from(rates.command_hz).clamp(1.0, 1000.0);
        let dt = 1.0 / hz;
        let stale = Duration::from_millis(u64::from(rates.pose_stale_after_ms));
        let ctrl_period = 1.0 / controller.rate_hz().clamp(0.1, hz);
        let mut tick = tokio::time::interval(Duration::from_secs_f64(dt));
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let start = self.link.now();
        let mut next_ctrl = start;
        let mut desired: BTreeMap<RobotId, Twist> = BTreeMap::new();
        let mut robots: BTreeMap<RobotId, PerRobot> = BTreeMap::new();
        let mut summary = RunSummary {
            controller: controller.name().to_string(),
            ..RunSummary::default()
        };
        // The controller's update time, smoothed (s): its commands leave that much after the
        // poses of its view were taken, so it is part of the latency it has to predict over.
        let mut update_s: Option<f64> = None;
        let (mut updates, mut update_sum) = (0u64, 0.0);
        let mut last_tick: Option<f64> = None;
        loop {
            tick.tick().await;
            let now = self.link.now();
            let t = now - start;
            if controller.done(t) || t > self.options.max_duration {
                break;
            }
            summary.ticks += 1;
            if let Some(last) = last_tick {
                summary.missed_ticks += ((now - last) / dt - 0.5).max(0.0) as u64;
            }
            last_tick = Some(now);
            if let Some(pb) = progress {
                pb.set_position((t * 10.0) as u64);
            }
            crate::replay::progress::observe(t, || controller.progress());
            let statuses = self.link.statuses();
            let online: Vec<_> = statuses
                .iter()
                .filter(|s| s.online && s.established)
                .collect();
            // One-way command latency: half the median smoothed round trip of the robots.
            let mut rtts: Vec<f64> = online.iter().filter_map(|s| s.stats.rtt_avg_ms).collect();
            rtts.sort_by(f64::total_cmp);
            let mut view = FleetView {
                t: now,
                robots: Vec::new(),
                latency_s: rtts.get(rtts.len() / 2).map_or(0.0, |ms| 0.5e-3 * ms)
                    + update_s.unwrap_or(0.0),
            };
            for s in &online {
                let kind = s.kind.unwrap_or(RobotKind::NonPilot);
                let r = robots.entry(s.id).or_insert_with(|| {
                    let p = (self.params)(s.id, kind);
                    PerRobot {
                        stab: Stabiliser::new(
                            DriveMap::from_params_or_geometric(&p),
                            self.options.gains,
                        ),
                        est: VelocityEstimator::new(self.options.velocity_window),
                        last_pose_t: f64::NEG_INFINITY,
                        stats: TrackingStats::default(),
                        err_sum: 0.0,
                        pose_lost: false,
                    }
                });
                let pose = self.poses.fresh(s.id, stale);
                if let Some(p) = pose {
                    if p.t > r.last_pose_t {
                        r.est.push(p);
                        r.last_pose_t = p.t;
                    }
                } else {
                    r.est.clear();
                }
                view.robots.push(RobotView {
                    id: s.id,
                    kind,
                    pose,
                    velocity: r.est.estimate(),
                });
            }
            if now >= next_ctrl {
                desired = controller.update(&view);
                let took = (self.link.now() - now).max(0.0);
                update_s = Some(update_s.map_or(took, |u| u + UPDATE_SMOOTHING * (took - u)));
                updates += 1;
                update_sum += took;
                summary.update_ms_max = summary.update_ms_max.max(took * 1e3);
                for r in controller.hand_requests() {
                    if let Some(hand) = self.hand.as_mut() {
                        hand(&r);
                    }
                }
                next_ctrl += ctrl_period;
                if next_ctrl < now {
                    next_ctrl = now + ctrl_period;
                }
            }
            let truth = self.truth.as_ref().map(|f| f());
            crate::live::observe(
                t,
                || match &truth {
                    Some(m) => m.clone(),
                    None => view
                        .robots
                        .iter()
                        .filter_map(|r| r.pose.map(|p| (r.id, [p.x, p.y, p.theta])))
                        .collect(),
                },
                || controller.progress(),
            );
            for rv in &view.robots {
                let Some(r) = robots.get_mut(&rv.id) else {
                    continue;
                };
                let status = online.iter().find(|s| s.id == rv.id);
                let want = desired.get(&rv.id).copied();
                let mut wheels = None;
                match (rv.pose, want) {
                    (None, _) => {
                        // Stale or missing pose: this robot stops (DESIGN.md §7).
                        if !r.pose_lost {
                            tracing::warn!(robot = rv.id, "pose stale or missing: stopping robot");
                            if let Some(f) = folder.as_deref_mut() {
                                let _ = f.event(&serde_json::json!({"t": now, "robot": rv.id, "event": "pose_lost"}));
                            }
                        }
                        r.pose_lost = true;
                        r.stats.pose_stops += 1;
                        r.stab.reset();
                        self.link.command(rv.id, HostMsg::Stop).await;
                    }
                    (Some(_), None) => {
                        r.stab.reset();
                        self.link.command(rv.id, HostMsg::Stop).await;
                    }
                    (Some(_), Some(w)) => {
                        if r.pose_lost {
                            r.pose_lost = false;
                            if let Some(f) = folder.as_deref_mut() {
                                let _ = f.event(&serde_json::json!({"t": now, "robot": rv.id, "event": "pose_back"}));
                            }
                        }
                        let measured = if self.options.stabilise && controller.stabilise(rv.id) {
                            rv.velocity
                        } else {
                            r.stab.forget_feedback();
                            None
                        };
                        let wt = r.stab.step(w, measured, dt);
                        wheels = Some([wt.left_rpm, wt.right_rpm]);
                        self.link
                            .command(rv.id, wheel_msg(wt, controller.hold_ms(rv.id)))
                            .await;
                    }
                }
                let reference = controller.reference(rv.id, t);
                let tru = truth.as_ref().and_then(|m| m.get(&rv.id).copied());
                let actual = tru.or(rv.pose.map(|p| [p.x, p.y, p.theta]));
                if let (Some(rf), Some(a)) = (reference, actual) {
                    let e = ((rf[0] - a[0]).powi(2) + (rf[1] - a[1]).powi(2)).sqrt();
                    r.stats.samples += 1;
                    r.err_sum += e;
                    r.stats.max_error = r.stats.max_error.max(e);
                }
                let telemetry = status.and_then(|s| s.telemetry.as_ref());
                if let Some(f) = folder.as_deref_mut() {
                    let _ = f.telemetry(&TickRecord {
                        t: now,
                        robot: rv.id,
                        pose: rv.pose.map(|p| [p.x, p.y, p.theta]),
                        truth: tru,
                        reference,
                        desired: want,
                        measured: rv.velocity,
                        wheel_target_rpm: wheels,
                        telemetry,
                    });
                    let tr = f.traces.entry(rv.id).or_default();
                    if let Some(a) = actual {
                        tr.actual.push((t, a[0], a[1]));
                    }
                    if let Some(rf) = reference {
                        tr.reference.push((t, rf[0], rf[1]));
                    }
                    if let Some(tm) = telemetry {
                        tr.wheels.push((
                            t,
                            f64::from(tm.target_rpm[0]),
                            f64::from(tm.target_rpm[1]),
                            f64::from(tm.measured_rpm[0]),
                            f64::from(tm.measured_rpm[1]),
                        ));
                    }
                }
            }
            if let Some(f) = folder.as_deref_mut() {
                for e in self.link.drain_events() {
                    let _ = f.event(&e);
                }
            }
        }
        self.link.stop_all().await;
        summary.duration = self.link.now() - start;
        if updates > 0 {
            summary.update_ms_mean = update_sum / updates as f64 * 1e3;
        }
        for (id, r) in robots {
            let mut s = r.stats;
            if s.samples > 0 {
                s.mean_error = r.err_sum / s.samples as f64;
                summary.tracking.insert(id, s);
            }
        }
        for s in self.link.statuses() {
            summary.link.insert(s.id, s.stats);
        }
        summary
    }
}

impl DriveMap {
    /// The mapping the control loop uses: calibrated gains when the robot's parameter set
    /// carries gains in wheel-RPM units that pass validation and are within a factor of
    /// two of THESIS (2.1)–(2.2); otherwise the geometric gains of (2.1)–(2.2) (the THESIS
    /// 3.5.1 defaults are in PWM units of the v2 robots, not RPM).
    pub fn from_params_or_geometric(p: &RobotParams) -> DriveMap {
        let cal = DriveMap::from_params(p);
        let geo = DriveMap::geometric(p);
        let near = |a: f64, b: f64| a > b / 2.0 && a < b * 2.0;
        if cal.validate().is_ok() && near(cal.k_v, geo.k_v) && near(cal.k_omega, geo.k_omega) {
            cal
        } else {
            geo
        }
    }
}

/// The drive command of wheel targets `wt`, kept `hold_ms` through link silence when > 0.
pub fn wheel_msg(wt: crate::drive::WheelTargets, hold_ms: u16) -> HostMsg {
    let (left_rpm, right_rpm) = (wt.left_rpm as f32, wt.right_rpm as f32);
    if hold_ms > 0 {
        HostMsg::WheelSpeedHold {
            left_rpm,
            right_rpm,
            hold_ms,
        }
    } else {
        HostMsg::WheelSpeed {
            left_rpm,
            right_rpm,
        }
    }
}

#[cfg(test)]
mod tests;
