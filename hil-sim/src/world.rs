//! The lockstep world: every robot's plant, its firmware (`puzzlebot_firmware_core::Robot`,
//! unchanged), contacts and couplings, terrain, the virtual radio and motion capture,
//! advanced in fixed steps of simulated time. No sockets and no wall clock: the same
//! scenario and seed give bit-identical runs.
//!
//! Per step (1 ms by default): drive plant of every robot → encoder edges into the
//! firmware's decoders with their exact timestamps → body poses → contacts and
//! couplings → terrain support → datagrams due from the radio into the firmware → at
//! each firmware period (50 Hz) `Robot::tick` with the sensors, then `poll_transmit`
//! into the radio → motion-capture frames at their rate.

use crate::drive::{self, Bridge, DriveModel, DriveState};
use crate::encoder::QuadEncoder;
use crate::math::{add, in_convex_hull, Pose, V2};
use crate::mechanics::{Body, Link, LinkEvent, LinkKind, Mechanics};
use crate::mocap::{Mocap, MocapFrame};
use crate::ota::SimOta;
use crate::radio::{Channel, Impairments};
use crate::rng::Rng;
use crate::scenario::Scenario;
use crate::watchdog::Supervision;
use puzzlebot_firmware_core::{
    DriveMode, Encoder, HBridge, MotorOutputs, NonceSource, Robot, Sensors, Status,
};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{RobotKind, RobotParams};
use puzzlebot_protocol::{FirmwareVersion, FleetKey, Nonce, ResetReason, RobotId, MAX_DATAGRAM};
use std::collections::{BTreeMap, VecDeque};

/// Firmware version the simulated robots announce.
pub const SIM_FIRMWARE_VERSION: FirmwareVersion = FirmwareVersion {
    major: 0,
    minor: 1,
    patch: 0,
};

/// Default physics step (µs): 1 kHz.
pub const DEFAULT_STEP_US: u64 = 1000;

/// A robot's support drops by more than this: it is reported as a drop (m).
pub const DROP_REPORT: f64 = 0.005;

/// Most motion-capture frames kept for [`World::take_mocap`].
pub const MOCAP_BACKLOG: usize = 256;

mod feedback;
mod operator;
mod terrain;

use terrain::support_points;

/// Boot nonces from the robot's own seeded stream (the ESP32-C3 uses its hardware RNG).
#[derive(Debug, Clone)]
pub struct SimNonces(pub(crate) Rng);

impl NonceSource for SimNonces {
    fn fresh_nonce(&mut self) -> Nonce {
        self.0.bytes16()
    }
}

/// Something that happened in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EventKind {
    /// Two robots coupled (anchor: `a`'s anchor in `b`'s opening; knob: `a`'s knob in `b`).
    Coupled {
        /// Coupling kind.
        kind: LinkKind,
        /// Robot id with the anchor / knob.
        a: RobotId,
        /// Robot id with the opening / hole.
        b: RobotId,
    },
    /// A coupling opened.
    Decoupled {
        /// Coupling kind.
        kind: LinkKind,
        /// Robot id with the anchor / knob.
        a: RobotId,
        /// Robot id with the opening / hole.
        b: RobotId,
    },
    /// Failure: the robot lost its support (over a gap, not held by its assembly) and fell.
    Fell {
        /// Robot id.
        id: RobotId,
    },
    /// The robot's support dropped to a lower platform (a step down).
    Dropped {
        /// Robot id.
        id: RobotId,
        /// Height fallen (m).
        height: f64,
    },
    /// The robot stopped at a step too high to climb.
    Blocked {
        /// Robot id.
        id: RobotId,
    },
    /// The robot was switched off.
    Offline {
        /// Robot id.
        id: RobotId,
    },
    /// The robot booted (`boot` counts boots, 1 = first).
    Booted {
        /// Robot id.
        id: RobotId,
        /// Boot number.
        boot: u32,
    },
}

/// A timestamped event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimEvent {
    /// Simulation time (µs).
    pub t_us: u64,
    /// What happened.
    pub kind: EventKind,
}

/// Ground truth of one robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotTruth {
    /// Robot id.
    pub id: RobotId,
    /// Kind.
    pub kind: RobotKind,
    /// Pose (m, rad).
    pub pose: Pose,
    /// Height of the body's support (m).
    pub z: f64,
    /// Forward speed (m/s).
    pub v: f64,
    /// Yaw rate (rad/s).
    pub omega: f64,
    /// Wheel speeds left, right (RPM).
    pub wheel_rpm: [f64; 2],
    /// Signed duties applied (per-mille; 0 for coast / brake).
    pub duty: [i16; 2],
    /// DRV8833 inputs applied, left and right.
    pub bridge: [HBridge; 2],
    /// Battery terminal voltage (V).
    pub battery_v: f64,
    /// Encoder edges counted by the plant (signed), left and right.
    pub encoder_edges: [i64; 2],
    /// Firmware running.
    pub online: bool,
    /// Fell off the terrain.
    pub fallen: bool,
    /// Firmware status (None when offline).
    pub firmware: Option<Status>,
    /// Datagrams the firmware rejected since boot, per `Rejection` reason
    /// (indexed by `reason as usize`).
    pub rejected: [u32; puzzlebot_protocol::Rejection::ALL.len()],
    /// Authenticated frames the firmware accepted since boot.
    pub accepted: u32,
}

/// Ground truth of the whole world.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GroundTruth {
    /// Simulation time (µs).
    pub time_us: u64,
    /// Every robot.
    pub robots: Vec<RobotTruth>,
    /// Coupled pairs (a, b, kind) by robot id.
    pub coupled: Vec<(RobotId, RobotId, LinkKind)>,
    /// Every event so far.
    pub events: Vec<SimEvent>,
}

impl GroundTruth {
    /// The robot with `id`.
    pub fn robot(&self, id: RobotId) -> Option<&RobotTruth> {
        self.robots.iter().find(|r| r.id == id)
    }

    /// True when `a` and `b` are coupled (either way round, any kind).
    pub fn are_coupled(&self, a: RobotId, b: RobotId) -> bool {
        self.coupled
            .iter()
            .any(|&(x, y, _)| (x == a && y == b) || (x == b && y == a))
    }
}

/// Why a world cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    /// The scenario is invalid.
    #[error("scenario: {0}")]
    Scenario(String),
    /// The firmware refused its parameters.
    #[error("robot {id}: firmware parameters: {reason}")]
    Firmware {
        /// Robot id.
        id: RobotId,
        /// Why.
        reason: String,
    },
}

/// One simulated robot.
#[derive(Debug, Clone)]
struct SimRobot {
    id: RobotId,
    kind: RobotKind,
    params: RobotParams,
    model: DriveModel,
    drive: DriveState,
    pose: Pose,
    z: f64,
    quad: [QuadEncoder; 2],
    enc: [Encoder; 2],
    /// Boxed: the firmware is touched at 50 Hz, the rest of the robot at 1 kHz (keeps the
    /// per-step working set small).
    fw: Option<Box<Robot<SimNonces>>>,
    outputs: MotorOutputs,
    nonces: Rng,
    boots: u32,
    down: Channel,
    up: Channel,
    impairments: Impairments,
    fallen: bool,
    next_tick_us: u64,
    /// Control-task health: stall switch, tick supervisor, watchdog.
    supervision: Supervision,
    support_points: Vec<V2>,
    /// sin, cos of `pose.yaw`, advanced incrementally (exactly refreshed when the yaw
    /// jumps and every [`TRIG_REFRESH`] steps).
    trig: [f64; 2],
    trig_age: u32,
    /// Update slot, installed version and trial (kept across reboots, like flash).
    ota: SimOta,
}

/// Steps between exact refreshes of a robot's cached heading sine and cosine.
const TRIG_REFRESH: u32 = 1024;
/// Largest velocity change (m/s) the contact and coupling projection feeds back into a
/// robot in one step: a backstop beside the energy bound of `world/feedback.rs`, so that even
/// a momentum exchange in a badly closed loop of couplings is a jolt, not a flight.
const MAX_FEEDBACK_SPEED: f64 = 2.0;
/// The same for the yaw rate (rad/s).
const MAX_FEEDBACK_TURN: f64 = 40.0;

fn trig_of(yaw: f64) -> [f64; 2] {
    let (s, c) = yaw.sin_cos();
    [s, c]
}

/// How far a person sets the rows of a lifted mesh apart (m): clear of the 3 mm knobs (the
/// host measures them released) and of the rows' wiggles (a robot turning 0.35 rad about its
/// anchor sweeps its front corners about 1 cm sideways).
pub const LIFT_APART: f64 = 0.03;

/// The lockstep simulation (see the module documentation).
#[derive(Debug, Clone)]
pub struct World {
    time_us: u64,
    step_us: u64,
    key: FleetKey,
    robots: Vec<SimRobot>,
    mech: Mechanics,
    bodies: Vec<Body>,
    link_events: Vec<LinkEvent>,
    terrain: Terrain,
    flat: bool,
    events: Vec<SimEvent>,
    mocap: Mocap,
    next_mocap_us: u64,
    mocap_out: VecDeque<MocapFrame>,
    outbox: Vec<(RobotId, Vec<u8>)>,
    scratch: Vec<(u16, f64, f64, f64, f64)>,
    /// Per-step scratch: wheel angles before and body velocities after each drive step.
    plant_out: Vec<([f64; 2], [f64; 3])>,
    /// Scratch: per robot velocity change (v, v_y, Ω) the projection asks for.
    feedback: Vec<[f64; 3]>,
    /// Scratch: per island the energy terms (B, C) of that velocity change.
    feedback_energy: Vec<[f64; 2]>,
}

impl World {
    /// Build the world of `scenario`; robots get keys derived from `key`.
    pub fn new(scenario: &Scenario, key: &FleetKey) -> Result<World, WorldError> {
        scenario.validate().map_err(WorldError::Scenario)?;
        let geom = scenario.params.non_pilot.geometry;
        let mut mech = Mechanics::new(&geom, &scenario.params.non_pilot.coupling);
        let mut robots = Vec::with_capacity(scenario.robots.len());
        for spec in &scenario.robots {
            let params = spec.mismatch.apply(scenario.params.robot(spec.kind));
            let model = DriveModel::new(spec.kind, &params.plant, &params.mass, &params.geometry);
            let drive = DriveState::at_rest(&model, f64::from(params.plant.battery_initial_soc));
            let tag = u64::from(spec.id) << 8;
            let pose = Scenario::pose_of(spec);
            let z = scenario
                .terrain
                .support_at([pose.x, pose.y])
                .map_or(0.0, |s| s.0);
            let edges = params.firmware.encoder_edges_per_rev;
            let mut r = SimRobot {
                id: spec.id,
                kind: spec.kind,
                support_points: support_points(&params),
                params,
                model,
                drive,
                pose,
                z,
                quad: [QuadEncoder::new(edges, 0.0), QuadEncoder::new(edges, 0.0)],
                enc: [Encoder::new(), Encoder::new()],
                fw: None,
                outputs: MotorOutputs::COAST,
                nonces: Rng::new(scenario.seed, tag | 1),
                boots: 0,
                down: Channel::new(Rng::new(scenario.seed, tag | 2)),
                up: Channel::new(Rng::new(scenario.seed, tag | 3)),
                impairments: spec.impairments.unwrap_or(scenario.impairments),
                fallen: false,
                next_tick_us: 0,
                // Set up with the loop period by `boot`.
                supervision: Supervision::new(0),
                trig: trig_of(pose.yaw),
                trig_age: 0,
                ota: SimOta::new(SIM_FIRMWARE_VERSION),
            };
            if !spec.offline {
                boot(&mut r, key, 0, ResetReason::PowerOn).map_err(|reason| {
                    WorldError::Firmware {
                        id: spec.id,
                        reason,
                    }
                })?;
            }
            robots.push(r);
        }
        let bodies = robots
            .iter()
            .map(|r| Body::new(r.pose, r.model.m, r.model.iz))
            .collect();
        for c in &scenario.couplings {
            let a = robots.iter().position(|r| r.id == c.a);
            let b = robots.iter().position(|r| r.id == c.b);
            if let (Some(a), Some(b)) = (a, b) {
                mech.attach(c.kind, a, b);
            }
        }
        let mut events = Vec::new();
        for r in &robots {
            if r.fw.is_some() {
                events.push(SimEvent {
                    t_us: 0,
                    kind: EventKind::Booted { id: r.id, boot: 1 },
                });
            }
        }
        Ok(World {
            time_us: 0,
            step_us: DEFAULT_STEP_US,
            key: key.clone(),
            robots,
            mech,
            bodies,
            link_events: Vec::new(),
            flat: scenario.terrain.platforms.is_empty(),
            terrain: scenario.terrain.clone(),
            events,
            mocap: Mocap::new(scenario.mocap, Rng::new(scenario.seed, 0xC0FFEE)),
            next_mocap_us: 0,
            mocap_out: VecDeque::new(),
            outbox: Vec::new(),
            scratch: Vec::new(),
            plant_out: Vec::new(),
            feedback: Vec::new(),
            feedback_energy: Vec::new(),
        })
    }

    /// Simulation time (µs).
    pub fn time_us(&self) -> u64 {
        self.time_us
    }

    /// Physics step (µs).
    pub fn step_us(&self) -> u64 {
        self.step_us
    }

    /// Robot ids in scenario order.
    pub fn robot_ids(&self) -> Vec<RobotId> {
        self.robots.iter().map(|r| r.id).collect()
    }

    /// Every robot's ground-truth pose, in scenario order (cheaper than
    /// [`World::ground_truth`] for frequent samples).
    pub fn poses(&self) -> impl Iterator<Item = (RobotId, Pose)> + '_ {
        self.robots.iter().map(|r| (r.id, r.pose))
    }

    fn index(&self, id: RobotId) -> Option<usize> {
        self.robots.iter().position(|r| r.id == id)
    }

    /// Advance one physics step.
    #[allow(clippy::needless_range_loop)] // per-wheel arrays indexed in parallel
    pub fn step(&mut self) {
        let dt = self.step_us as f64 * 1e-6;
        let t0 = self.time_us;
        let t1 = t0 + self.step_us;
        // 1. Plants (a tight loop of independent robots, so the CPU overlaps their
        //    dependency chains), then encoders and poses.
        let mut plant = std::mem::take(&mut self.plant_out);
        plant.clear();
        for r in self.robots.iter_mut() {
            let cmd = [
                Bridge {
                    in1: r.outputs.left.in1,
                    in2: r.outputs.left.in2,
                },
                Bridge {
                    in1: r.outputs.right.in1,
                    in2: r.outputs.right.in2,
                },
            ];
            let a0 = r.drive.angle;
            let vel = drive::step(&r.model, &mut r.drive, cmd, dt);
            plant.push((a0, vel));
        }
        for ((r, body), &(a0, [v, omega, vy])) in self
            .robots
            .iter_mut()
            .zip(self.bodies.iter_mut())
            .zip(plant.iter())
        {
            for s in 0..2 {
                let enc = &mut r.enc[s];
                let online = r.fw.is_some();
                r.quad[s].advance(a0[s], r.drive.angle[s], t0, t1, |e| {
                    if online {
                        enc.on_edge(e.a, e.b, e.t_us);
                    }
                });
            }
            if r.fallen {
                continue;
            }
            let [s, c] = r.trig;
            r.pose.x += (c * v - s * vy) * dt;
            r.pose.y += (s * v + c * vy) * dt;
            let dth = omega * dt;
            r.pose.yaw = crate::math::wrap(r.pose.yaw + dth);
            r.trig_age += 1;
            if dth.abs() > 0.02 || r.trig_age >= TRIG_REFRESH {
                r.trig = trig_of(r.pose.yaw);
                r.trig_age = 0;
            } else if dth != 0.0 {
                // Rotate (s, c) by dθ with the Taylor series (error < 1e-16 for |dθ| ≤ 0.02).
                let d2 = dth * dth;
                let sd = dth * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0));
                let cd = 1.0 - d2 / 2.0 * (1.0 - d2 / 12.0 * (1.0 - d2 / 30.0));
                r.trig = [s * cd + c * sd, c * cd - s * sd];
            }
            body.pose = r.pose;
            body.trig = r.trig;
        }
        self.plant_out = plant;
        // 2. Contacts and couplings, with the projection fed back into velocities.
        self.link_events.clear();
        self.mech.resolve(&mut self.bodies, &mut self.link_events);
        self.feed_back_projection(dt);
        for e in std::mem::take(&mut self.link_events) {
            let (kind, a, b, coupled) = match e {
                LinkEvent::Coupled(k, a, b) => (k, a, b, true),
                LinkEvent::Decoupled(k, a, b) => (k, a, b, false),
            };
            let (a, b) = (self.robots[a].id, self.robots[b].id);
            let kind = if coupled {
                EventKind::Coupled { kind, a, b }
            } else {
                EventKind::Decoupled { kind, a, b }
            };
            self.events.push(SimEvent { t_us: t1, kind });
        }
        // 3. Terrain.
        if !self.flat {
            self.terrain_step(t1);
        }
        self.time_us = t1;
        // 4. Radio in, firmware ticks, radio out.
        let mut buf = [0u8; MAX_DATAGRAM];
        for r in &mut self.robots {
            let mut restart = None;
            if let Some(fw) = r.fw.as_mut() {
                let ota = &mut r.ota;
                r.down.due(t1, |frame| {
                    // Rejections are counted by the firmware itself (LinkStats).
                    let _ = fw.on_datagram(frame, t1);
                    if let Some(report) = fw.take_update_request().and_then(|q| ota.on_request(q)) {
                        fw.report_update(report);
                    }
                });
                if t1 >= r.next_tick_us && r.supervision.is_stalled() {
                    // A stalled control task: no tick, the PWM keeps its last duties.
                    r.next_tick_us = t1 + fw.period_us();
                } else if t1 >= r.next_tick_us {
                    let sensors = Sensors {
                        battery_mv: (r.drive.battery_v * 1000.0).clamp(0.0, 65_535.0) as u16,
                        rssi_dbm: -45,
                        encoders: [r.enc[0].snapshot(), r.enc[1].snapshot()],
                    };
                    r.outputs = fw.tick(t1, &sensors);
                    r.supervision.after_tick(t1);
                    r.next_tick_us = t1 + fw.period_us();
                    while let Some(n) = fw.poll_transmit(t1, &mut buf) {
                        r.up.send(t1, &buf[..n], &r.impairments);
                    }
                    restart = r.ota.after_tick(t1, fw.is_established());
                }
            } else {
                r.down.clear();
            }
            // An installed update boots, or an unconfirmed one rolls back.
            if let Some(reason) = restart {
                r.down.clear();
                if boot(r, &self.key, t1, reason).is_ok() {
                    let kind = EventKind::Booted {
                        id: r.id,
                        boot: r.boots,
                    };
                    self.events.push(SimEvent { t_us: t1, kind });
                }
            }
            // Only a running chip has a watchdog (an offline robot is switched off).
            let running = r.fw.is_some();
            if let Some(reason) = running
                .then(|| r.supervision.check(t1, &mut r.outputs))
                .flatten()
            {
                r.down.clear();
                if boot(r, &self.key, t1, reason).is_ok() {
                    let kind = EventKind::Booted {
                        id: r.id,
                        boot: r.boots,
                    };
                    self.events.push(SimEvent { t_us: t1, kind });
                }
            }
            let id = r.id;
            let outbox = &mut self.outbox;
            r.up.due(t1, |frame| outbox.push((id, frame.to_vec())));
        }
        // 5. Motion capture.
        if t1 >= self.next_mocap_us {
            self.scratch.clear();
            for r in &self.robots {
                self.scratch
                    .push((r.id, r.pose.x, r.pose.y, r.z, r.pose.yaw));
            }
            let f = self.mocap.capture(t1, &self.scratch);
            if self.mocap_out.len() >= MOCAP_BACKLOG {
                self.mocap_out.pop_front();
            }
            self.mocap_out.push_back(f);
            self.next_mocap_us = t1 + self.mocap.period_us();
        }
    }

    /// Advance by `us` microseconds (whole steps).
    pub fn run_for(&mut self, us: u64) {
        let end = self.time_us + us;
        while self.time_us < end {
            self.step();
        }
    }
}

/// (Re)boot the firmware of `r` at `now_us` with a fresh nonce from its stream; its
/// announces carry `reason`.
fn boot(r: &mut SimRobot, key: &FleetKey, now_us: u64, reason: ResetReason) -> Result<(), String> {
    let nonces = SimNonces(Rng::new(r.nonces.next_u64(), u64::from(r.boots)));
    let mut fw = Robot::new(
        r.id,
        r.kind,
        Some(key.robot_key(r.id)),
        r.params.firmware,
        r.ota.version(),
        nonces,
    )
    .map_err(|e| e.to_string())?;
    r.ota.on_boot(now_us);
    fw.set_reset_reason(reason);
    r.supervision.rebooted(fw.period_us());
    r.boots += 1;
    r.next_tick_us = now_us + fw.period_us();
    r.fw = Some(Box::new(fw));
    r.outputs = MotorOutputs::COAST;
    // Fresh decoders that read the current levels at power-up.
    for s in 0..2 {
        let (a, b) = r.quad[s].levels();
        r.enc[s] = Encoder::new();
        r.enc[s].init_levels(a, b);
    }
    Ok(())
}
