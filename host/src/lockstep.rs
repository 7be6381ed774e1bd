//! The host's control stack driving the simulator's lockstep [`World`] (no sockets, no wall
//! clock): the same [`Controller`], drive mapping and stabiliser as the real-time loop
//! ([`crate::control::ControlLoop`]), and the same sealed protocol frames, but stepped with
//! the simulated clock. Runs are deterministic from the simulator's seed and run as fast as
//! the CPU allows, so assembly behaviours are tested and measured here (the coupling
//! experiment, THESIS 5.2.3) while the loopback end-to-end tests cover the real link.
//!
//! Poses come from the simulator's virtual motion capture (100 Hz, sub-millimetre noise, as
//! the real pose stream; [`Lockstep::exact_poses`] switches to ground truth); as on the real
//! link, the controller sees only robots heard from within `offline_after_ms` whose pose is
//! tracked.

use std::collections::BTreeMap;

use puzzlebot_params::RobotKind;
use puzzlebot_protocol::pose::BodyPose;
use puzzlebot_protocol::{FleetKey, HostMsg, HostReceived, HostSession, RobotId, MAX_DATAGRAM};
use puzzlebot_sim::{RobotTruth, Scenario, SimEvent, World};

use crate::control::{CommandDelay, Controller, FleetView, HandRequest, LoopOptions, RobotView};
use crate::drive::{DriveMap, PoseSample, Stabiliser, Twist, VelocityEstimator};

/// Mixed into the scenario's seed for the command jitter's generator (the simulator draws
/// its own noise from the seed itself).
pub(crate) const JITTER_SEED: u64 = 0x6a09_e667_f3bc_c909;

/// Weight of the newest measured command delay in its running average.
const LATENCY_SMOOTHING: f64 = 0.2;

/// The host side of every robot's session, in process.
struct Host {
    key: FleetKey,
    sessions: BTreeMap<RobotId, HostSession>,
    nonce: u64,
    /// Simulated time of the last frame each robot's session accepted (µs).
    heard: BTreeMap<RobotId, u64>,
}

impl Host {
    fn receive(&mut self, id: RobotId, frame: &[u8], now_us: u64) -> Option<Vec<u8>> {
        let key = self.key.robot_key(id);
        let s = self
            .sessions
            .entry(id)
            .or_insert_with(|| HostSession::new(id, key));
        // Host nonces: a counter is unique per run, which is all a simulated run needs.
        self.nonce += 1;
        let n = self.nonce;
        let mut out = [0u8; MAX_DATAGRAM];
        let got = s.receive(
            frame,
            || {
                let mut b = [0u8; 16];
                b[..8].copy_from_slice(&n.to_le_bytes());
                b
            },
            &mut out,
        );
        if got.is_ok() {
            self.heard.insert(id, now_us);
        }
        match got {
            Ok(HostReceived::Announce { welcome_len, .. }) => Some(out[..welcome_len].to_vec()),
            _ => None,
        }
    }

    fn established(&self, id: RobotId) -> bool {
        self.sessions
            .get(&id)
            .is_some_and(HostSession::is_established)
    }

    fn seal(&mut self, id: RobotId, msg: &HostMsg) -> Option<Vec<u8>> {
        let s = self.sessions.get_mut(&id)?;
        let mut out = [0u8; MAX_DATAGRAM];
        let n = s.send(msg, &mut out).ok()?;
        Some(out[..n].to_vec())
    }

    /// Established and heard from within `offline_us` (the real link's online test).
    fn online(&self, id: RobotId, now_us: u64, offline_us: u64) -> bool {
        self.established(id)
            && self
                .heard
                .get(&id)
                .is_some_and(|&t| now_us.saturating_sub(t) <= offline_us)
    }

    fn pump(&mut self, w: &mut World) {
        let now = w.time_us();
        for (id, frame) in w.take_from_robots() {
            if let Some(reply) = self.receive(id, &frame, now) {
                w.send_to_robot(id, &reply);
            }
        }
    }
}

/// How a lockstep run ended.
#[derive(Debug, Clone)]
pub struct LockstepRun {
    /// Controller time when the run ended (s).
    pub t_end: f64,
    /// The controller said it was done (false: the time limit ended the run).
    pub done: bool,
    /// Every simulator event (couplings, drops, failsafes) with its time.
    pub sim_events: Vec<SimEvent>,
    /// Simulated time when the controller started (µs): subtract from event times.
    pub start_us: u64,
}

/// A simulated fleet in lockstep with a host controller.
pub struct Lockstep {
    /// The simulated world (tests may reach in: switch robots off, place them).
    pub world: World,
    host: Host,
    kinds: BTreeMap<RobotId, RobotKind>,
    stabilisers: BTreeMap<RobotId, (Stabiliser, VelocityEstimator)>,
    options: LoopOptions,
    command_period_us: u64,
    offline_us: u64,
    /// Latest tracked motion-capture pose of each robot (capture time µs, pose): a frame
    /// that lost the body leaves it, as [`crate::pose::PoseTable`] does; `None` = exact.
    mocap: Option<BTreeMap<RobotId, (u64, BodyPose)>>,
    /// A pose older than this is stale and its robot is stopped (µs; `pose_stale_after_ms`).
    stale_us: u64,
    /// Capture time of the last pose given to each robot's velocity estimator (µs).
    estimated: BTreeMap<RobotId, u64>,
    /// Simulated controller latency, its jitter seeded from the scenario's seed so that runs
    /// stay reproducible.
    delay: CommandDelay<BTreeMap<RobotId, Twist>>,
}

impl Lockstep {
    /// Build the world of `scenario` and open every online robot's session (≤ 3 s simulated).
    pub fn new(scenario: &Scenario) -> anyhow::Result<Lockstep> {
        let key = FleetKey([0x5a; 32]);
        let mut world = World::new(scenario, &key)?;
        let mut host = Host {
            key,
            sessions: BTreeMap::new(),
            nonce: 0,
            heard: BTreeMap::new(),
        };
        let online: Vec<RobotId> = scenario
            .robots
            .iter()
            .filter(|r| !r.offline)
            .map(|r| r.id)
            .collect();
        let connect_end = world.time_us() + 3_000_000;
        while !online.iter().all(|&id| host.established(id)) {
            if world.time_us() > connect_end {
                anyhow::bail!("simulated robots did not open sessions within 3 s");
            }
            world.step();
            host.pump(&mut world);
        }
        let options = LoopOptions::default();
        let stabilisers = scenario
            .robots
            .iter()
            .map(|r| {
                let map = DriveMap::from_params_or_geometric(scenario.params.robot(r.kind));
                (
                    r.id,
                    (
                        Stabiliser::new(map, options.gains),
                        VelocityEstimator::new(options.velocity_window),
                    ),
                )
            })
            .collect();
        let hz = f64::from(scenario.params.rates.command_hz).clamp(1.0, 1000.0);
        Ok(Lockstep {
            world,
            host,
            kinds: scenario.robots.iter().map(|r| (r.id, r.kind)).collect(),
            stabilisers,
            options,
            command_period_us: (1e6 / hz) as u64,
            offline_us: u64::from(scenario.params.rates.offline_after_ms) * 1000,
            mocap: Some(BTreeMap::new()),
            stale_us: u64::from(scenario.params.rates.pose_stale_after_ms) * 1000,
            estimated: BTreeMap::new(),
            delay: CommandDelay::new(scenario.seed ^ JITTER_SEED),
        })
    }

    /// The controller's commands take effect `ms` after its tick, as on a real host where
    /// the solve takes time while the fleet moves on (default 0). Delayed commands are picked
    /// up at the next 30 Hz command period, so the effective delay is rounded up to whole
    /// periods: 1–33 ms all act as one period (measured: 10, 20 and 30 ms gave identical runs).
    pub fn command_delay(mut self, ms: f64) -> Self {
        self.delay.set_delay_ms(ms);
        self
    }

    /// Every tick's commands take effect a further random delay in [0, `ms`) later (uniform,
    /// drawn from the scenario's seed: the same scenario gives the same run), as on a real
    /// host whose solve times vary under load. Commands keep their order. Default 0.
    pub fn command_jitter(mut self, ms: f64) -> Self {
        self.delay.set_jitter_ms(ms);
        self
    }

    /// The controller sees exact ground-truth poses instead of motion capture.
    pub fn exact_poses(mut self) -> Self {
        self.mocap = None;
        self
    }

    /// The pose the host sees of a robot whose ground truth is `truth`: (capture time µs,
    /// x, y, yaw), or `None` when it is not tracked or stale.
    fn observed(&self, truth: &RobotTruth, now_us: u64) -> Option<(u64, f64, f64, f64)> {
        match &self.mocap {
            None => Some((now_us, truth.pose.x, truth.pose.y, truth.pose.yaw)),
            Some(latest) => latest
                .get(&truth.id)
                .filter(|(at, _)| now_us.saturating_sub(*at) <= self.stale_us)
                .map(|(at, b)| (*at, f64::from(b.x), f64::from(b.y), f64::from(b.yaw))),
        }
    }

    fn take_mocap(&mut self) {
        let frames = self.world.take_mocap();
        if let Some(latest) = &mut self.mocap {
            for f in frames {
                for b in f.bodies.into_iter().filter(|b| b.tracked) {
                    latest.insert(b.robot_id, (f.time_us, b));
                }
            }
        }
    }

    /// Run `ctl` until it is done or `limit` s have passed; `hook(world, t)` is called at
    /// every controller tick before the controller sees the fleet.
    pub fn run(
        &mut self,
        ctl: &mut dyn Controller,
        limit: f64,
        mut hook: impl FnMut(&mut World, f64),
    ) -> LockstepRun {
        self.take_mocap();
        let start = self.world.time_us();
        let ctl_period_us = (1e6 / ctl.rate_hz().clamp(0.1, 1000.0)) as u64;
        let (mut next_cmd, mut next_ctl) = (start, start);
        let mut cmds: BTreeMap<RobotId, Twist> = BTreeMap::new();
        self.delay.clear();
        // Measured delay from a tick to its commands acting (µs, smoothed), as a real host
        // measures it from the robots' command echo.
        let mut latency_us = 0.0_f64;
        let dt = self.command_period_us as f64 * 1e-6;
        let mut done = false;
        loop {
            let now = self.world.time_us();
            let t = (now - start) as f64 * 1e-6;
            if t > limit {
                break;
            }
            if now >= next_cmd {
                next_cmd += self.command_period_us;
                let truth = self.world.ground_truth();
                let mut view = FleetView {
                    t,
                    robots: Vec::new(),
                    latency_s: latency_us * 1e-6,
                };
                // As the real link: only robots whose session is established and that were
                // heard from recently (a switched-off robot drops out and is lost).
                let (host, off) = (&self.host, self.offline_us);
                for r in truth.robots.iter().filter(|r| host.online(r.id, now, off)) {
                    let kind = self
                        .kinds
                        .get(&r.id)
                        .copied()
                        .unwrap_or(RobotKind::NonPilot);
                    let Some((at, x, y, theta)) = self.observed(r, now) else {
                        if let Some((_, est)) = self.stabilisers.get_mut(&r.id) {
                            est.clear();
                        }
                        // Online but not tracked: the controller knows it is there.
                        view.robots.push(RobotView {
                            id: r.id,
                            kind,
                            pose: None,
                            velocity: None,
                        });
                        continue;
                    };
                    let t_pose = at.saturating_sub(start) as f64 * 1e-6;
                    let pose = PoseSample {
                        t: t_pose,
                        x,
                        y,
                        theta,
                    };
                    let fresh = self.estimated.get(&r.id).is_none_or(|&last| at > last);
                    let velocity = self.stabilisers.get_mut(&r.id).and_then(|(_, est)| {
                        if fresh {
                            est.push(pose);
                        }
                        est.estimate()
                    });
                    self.estimated.insert(r.id, at);
                    view.robots.push(RobotView {
                        id: r.id,
                        kind,
                        pose: Some(pose),
                        velocity,
                    });
                }
                if now >= next_ctl {
                    next_ctl += ctl_period_us;
                    hook(&mut self.world, t);
                    let new_cmds = ctl.update(&view);
                    for r in ctl.hand_requests() {
                        match r {
                            HandRequest::LiftKnobs { robots } => {
                                self.world.lift_knobs(&robots);
                            }
                        }
                    }
                    // The controller's own latency (its solve time on a real host).
                    self.delay.push(now, new_cmds);
                    if ctl.done(t) {
                        done = true;
                        break;
                    }
                }
                while let Some((issued, c)) = self.delay.pop_due(now) {
                    latency_us += LATENCY_SMOOTHING * ((now - issued) as f64 - latency_us);
                    cmds = c;
                }
                // A robot without a fresh pose (none tracked within the stale limit) gets no
                // command this period (its firmware holds the last one until its failsafe
                // timeout).
                let mut sent = Vec::with_capacity(view.robots.len());
                for rv in view.robots.iter().filter(|rv| rv.pose.is_some()) {
                    let msg = match (cmds.get(&rv.id), self.stabilisers.get_mut(&rv.id)) {
                        (Some(&w), Some((stab, _))) => {
                            let measured = if self.options.stabilise && ctl.stabilise(rv.id) {
                                rv.velocity
                            } else {
                                stab.forget_feedback();
                                None
                            };
                            let wt = stab.step(w, measured, dt);
                            crate::control::wheel_msg(wt, ctl.hold_ms(rv.id))
                        }
                        (_, stab) => {
                            if let Some((s, _)) = stab {
                                s.reset();
                            }
                            HostMsg::Stop
                        }
                    };
                    if let Some(f) = self.host.seal(rv.id, &msg) {
                        self.world.send_to_robot(rv.id, &f);
                    }
                    sent.push((rv.id, msg));
                }
                crate::record::observe(t, &self.world, &view, &sent);
                crate::replay::progress::observe(t, || ctl.progress());
                crate::live::observe(
                    t,
                    || {
                        self.world
                            .ground_truth()
                            .robots
                            .iter()
                            .map(|r| (r.id, [r.pose.x, r.pose.y, r.pose.yaw]))
                            .collect()
                    },
                    || ctl.progress(),
                );
            }
            self.world.step();
            self.host.pump(&mut self.world);
            self.take_mocap();
        }
        LockstepRun {
            t_end: (self.world.time_us() - start) as f64 * 1e-6,
            done,
            sim_events: self.world.events().to_vec(),
            start_us: start,
        }
    }
}
