//! The 3-D crossing world: a formed assembly (robot poses and couplings of a [`Scenario`]) on
//! platforms with heights, gaps and steps, every robot running `firmware/core` and driven
//! through its motors (torque from the motor model, never a commanded velocity), in fixed
//! steps of simulated time. Same scenario, same seed: bit-identical runs.

use super::body::{self, RobotBodies};
use super::config::{Config3d, Strength};
use super::coupling::{self, Joint3d};
use super::motor::SideMotor;
use super::onboard::Onboard;
use super::terrain;
use crate::drive::{Bridge, DriveModel, G};
use crate::math::Pose;
use crate::mechanics::LinkKind;
use crate::scenario::Scenario;
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{RobotKind, RobotParams};
use puzzlebot_protocol::{FleetKey, RobotId};
use rapier3d_f64::prelude::*;

/// Something that happened in the 3-D world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event3d {
    /// A coupling exceeded its connector's limits and opened.
    Broke {
        /// Simulation time (µs).
        t_us: u64,
        /// Anchor or knob.
        kind: LinkKind,
        /// Robot id with the anchor / knob.
        a: RobotId,
        /// Robot id with the opening / hole.
        b: RobotId,
        /// Largest force component at the break (N).
        force: f64,
        /// Largest moment component at the break (N·m).
        moment: f64,
    },
    /// A corner of a robot's underside sank below every platform top: it fell into a gap
    /// (or tipped into it and is wedged there).
    Fell {
        /// Simulation time (µs).
        t_us: u64,
        /// Robot id.
        id: RobotId,
    },
}

/// State of one robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotState3d {
    /// Robot id.
    pub id: RobotId,
    /// Pilot or non-pilot.
    pub kind: RobotKind,
    /// Body-frame origin (on the ground plane under the body centre), world (m).
    pub position: [f64; 3],
    /// Roll, pitch, yaw (rad).
    pub rpy: [f64; 3],
    /// Forward speed (m/s).
    pub speed: f64,
    /// Turn rate about the world's vertical (rad/s).
    pub yaw_rate: f64,
    /// Wheel speeds left, right (RPM, motor-averaged).
    pub wheel_rpm: [f64; 2],
    /// Battery terminal voltage (V).
    pub battery_v: f64,
    /// The host's session with the firmware is proven.
    pub linked: bool,
    /// Fell into a gap.
    pub fallen: bool,
    /// Height of its underside's lowest corner (world z, m): the fall check's measure.
    pub underside_z: f64,
}

#[derive(Debug)]
struct Robot3d {
    id: RobotId,
    kind: RobotKind,
    model: DriveModel,
    bodies: RobotBodies,
    motors: [SideMotor; 2],
    angle: [f64; 2],
    onboard: Onboard,
    soc: f64,
    battery_v: f64,
    fallen: bool,
    /// Corners of the chassis underside in the body frame (m).
    underside: [Point<f64>; 4],
}

/// Why a 3-D world cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum World3dError {
    /// The scenario, terrain or settings are invalid.
    #[error("{0}")]
    Invalid(String),
}

/// The lockstep 3-D world (see the module documentation).
pub struct World3d {
    cfg: Config3d,
    time_us: u64,
    step_us: u64,
    params: IntegrationParameters,
    pipeline: PhysicsPipeline,
    islands: IslandManager,
    broad: DefaultBroadPhase,
    narrow: NarrowPhase,
    bodies: RigidBodySet,
    colliders: ColliderSet,
    joints: ImpulseJointSet,
    multibody: MultibodyJointSet,
    ccd: CCDSolver,
    robots: Vec<Robot3d>,
    couplings: Vec<Joint3d>,
    events: Vec<Event3d>,
    fall_below: f64,
    blocks: Vec<RigidBodyHandle>,
}

impl std::fmt::Debug for World3d {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World3d")
            .field("time_us", &self.time_us)
            .field("robots", &self.robots.len())
            .field("couplings", &self.couplings.len())
            .finish()
    }
}

/// Length scale of the world for the engine's tolerances (m): a robot body.
const LENGTH_UNIT: f64 = 0.05;

impl World3d {
    /// Build the world of `scenario`: its robots at their poses, standing on the platform
    /// under each, its couplings as joints, its terrain as platforms.
    pub fn new(scenario: &Scenario, cfg: Config3d) -> Result<World3d, World3dError> {
        let inv = World3dError::Invalid;
        scenario
            .validate()
            .map_err(|e| inv(format!("scenario: {e}")))?;
        scenario
            .terrain
            .validate_solid()
            .map_err(|e| inv(format!("terrain: {e}")))?;
        cfg.validate().map_err(inv)?;
        scenario
            .params
            .check()
            .map_err(|e| inv(format!("params {e}")))?;
        let mut params = IntegrationParameters {
            length_unit: LENGTH_UNIT,
            num_solver_iterations: cfg.solver_iterations,
            ..IntegrationParameters::default()
        };
        params.dt = cfg.dt;
        params.contact_softness.natural_frequency = cfg.contact_frequency;
        let mut bodies = RigidBodySet::new();
        let mut colliders = ColliderSet::new();
        let mut joints = ImpulseJointSet::new();
        terrain::build(&scenario.terrain, cfg.catch_depth, &mut colliders);
        let mut key = [0u8; 32];
        key[..8].copy_from_slice(&scenario.seed.to_le_bytes());
        let key = FleetKey(key);
        let mut robots = Vec::with_capacity(scenario.robots.len());
        let mut poses = Vec::with_capacity(scenario.robots.len());
        for spec in &scenario.robots {
            let p: RobotParams = spec.mismatch.apply(scenario.params.robot(spec.kind));
            let pose = Scenario::pose_of(spec);
            let z0 = ground_under(&scenario.terrain, &p, pose);
            let rb = body::build(&p, &cfg, pose, z0, &mut bodies, &mut colliders, &mut joints);
            let model = DriveModel::new(spec.kind, &p.plant, &p.mass, &p.geometry);
            let soc = f64::from(p.plant.battery_initial_soc).clamp(0.0, 1.0);
            let onboard =
                Onboard::boot(spec.id, spec.kind, &p, &key, scenario.seed).map_err(inv)?;
            robots.push(Robot3d {
                id: spec.id,
                kind: spec.kind,
                battery_v: model.battery.open_circuit(soc),
                model,
                bodies: rb,
                motors: [SideMotor::default(); 2],
                angle: [0.0; 2],
                onboard,
                soc,
                fallen: false,
                underside: underside(&p, &cfg),
            });
            poses.push((pose, p));
        }
        let mut couplings = Vec::with_capacity(scenario.couplings.len());
        for c in &scenario.couplings {
            let find = |id: u16| {
                robots
                    .iter()
                    .position(|r| r.id == id)
                    .ok_or_else(|| inv(format!("couplings: no robot {id}")))
            };
            let (a, b) = (find(c.a)?, find(c.b)?);
            let pa = &poses[a].1;
            let (geom, strength) = match c.kind {
                LinkKind::Anchor => (coupling::anchor(pa, &cfg), Strength::anchor(pa)),
                LinkKind::Knob => (
                    coupling::knob(pa, &cfg, poses[a].0, poses[b].0),
                    Strength::knob(pa),
                ),
            };
            // Body 1 carries the opening / hole, body 2 the anchor / knob.
            let (ca, cb) = (robots[a].bodies.chassis, robots[b].bodies.chassis);
            let handle = joints.insert(cb, ca, geom.joint(), true);
            couplings.push(Joint3d {
                kind: c.kind,
                a,
                b,
                handle: Some(handle),
                geom,
                strength,
                peak_force: 0.0,
                peak_moment: 0.0,
                over_for: 0.0,
            });
        }
        Ok(World3d {
            fall_below: terrain::lowest_top(&scenario.terrain) - cfg.fall_depth,
            step_us: (cfg.dt * 1e6).round() as u64,
            cfg,
            time_us: 0,
            params,
            pipeline: PhysicsPipeline::new(),
            islands: IslandManager::new(),
            broad: DefaultBroadPhase::new(),
            narrow: NarrowPhase::new(),
            bodies,
            colliders,
            joints,
            multibody: MultibodyJointSet::new(),
            ccd: CCDSolver::new(),
            robots,
            couplings,
            events: Vec::new(),
            blocks: Vec::new(),
        })
    }

    /// Simulation time (µs).
    pub fn time_us(&self) -> u64 {
        self.time_us
    }

    /// Stream the wheel-speed command (RPM, left and right) to robot `id` through its host
    /// session at 30 Hz; `None` stops streaming (the firmware's failsafe then stops it).
    pub fn command(&mut self, id: RobotId, rpm: Option<[f32; 2]>) -> bool {
        match self.robots.iter_mut().find(|r| r.id == id) {
            Some(r) => {
                r.onboard.command = rpm;
                true
            }
            None => false,
        }
    }

    /// The same command to every robot.
    pub fn command_all(&mut self, rpm: Option<[f32; 2]>) {
        for r in &mut self.robots {
            r.onboard.command = rpm;
        }
    }

    /// Every robot's commands from now on ask it to keep driving `hold_ms` through link
    /// silence (0: the plain failsafe).
    pub fn hold_all(&mut self, hold_ms: u16) {
        for r in &mut self.robots {
            r.onboard.hold_ms = hold_ms;
        }
    }

    /// Advance one step.
    pub fn step(&mut self) {
        let dt = self.cfg.dt;
        let t0 = self.time_us;
        let t1 = t0 + self.step_us;
        // 1. Firmware, motors, battery.
        for r in &mut self.robots {
            let out = r.onboard.step(t0, r.battery_v);
            let omega = side_speeds(&self.bodies, &r.bodies);
            let cmds = [
                Bridge {
                    in1: out.left.in1,
                    in2: out.left.in2,
                },
                Bridge {
                    in1: out.right.in1,
                    in2: out.right.in2,
                },
            ];
            let mut drives = [None; 2];
            for s in 0..2 {
                drives[s] = Some(r.motors[s].joint_drive(
                    &r.model,
                    cmds[s],
                    r.battery_v,
                    omega[s],
                    self.cfg.wheel_rest_speed,
                    r.bodies.wheels_per_side,
                ));
            }
            for w in &r.bodies.wheels {
                let (Some(d), Some(j)) = (drives[w.side], self.joints.get_mut(w.joint, false))
                else {
                    continue;
                };
                j.data
                    .set_motor(JointAxis::AngX, 0.0, d.target_vel, 0.0, d.damping);
                j.data.set_motor_max_force(JointAxis::AngX, d.max_torque);
            }
            let b = &r.model.battery;
            let i_total = b.idle + r.motors[0].current.abs() + r.motors[1].current.abs();
            r.soc = (r.soc - i_total * dt * b.inv_capacity).max(0.0);
            r.battery_v = (b.open_circuit(r.soc) - i_total * b.resistance).max(0.0);
        }
        // Coupling springs engage outside their free ranges.
        for c in &self.couplings {
            let Some(h) = c.handle else { continue };
            let q = self.coupling_coords(c);
            if let Some(j) = self.joints.get_mut(h, false) {
                c.geom.drive(&mut j.data, &q);
            }
        }
        // 2. Physics.
        let (sn, cs) = self.cfg.slope.sin_cos();
        let ramp = if self.cfg.settle_time > 0.0 {
            (t1 as f64 * 1e-6 / self.cfg.settle_time).min(1.0)
        } else {
            1.0
        };
        let gravity = vector![G * sn, 0.0, -G * cs] * ramp;
        self.pipeline.step(
            &gravity,
            &self.params,
            &mut self.islands,
            &mut self.broad,
            &mut self.narrow,
            &mut self.bodies,
            &mut self.colliders,
            &mut self.joints,
            &mut self.multibody,
            &mut self.ccd,
            &(),
            &(),
        );
        // 3. Encoders and falls.
        for r in &mut self.robots {
            let omega = side_speeds(&self.bodies, &r.bodies);
            let a0 = r.angle;
            for (a, w) in r.angle.iter_mut().zip(omega) {
                *a += w * dt;
            }
            r.onboard.encoders(a0, r.angle, t0, t1);
            let z = underside_z(r, &self.bodies);
            if !r.fallen && z < self.fall_below {
                r.fallen = true;
                self.events.push(Event3d::Fell { t_us: t1, id: r.id });
            }
        }
        // 4. Connector strength.
        for k in 0..self.couplings.len() {
            let c = &self.couplings[k];
            let Some(h) = c.handle else { continue };
            let q = self.coupling_coords(c);
            let c = &mut self.couplings[k];
            if c.load(&q, dt, self.cfg.break_after) {
                self.joints.remove(h, true);
                c.handle = None;
                self.events.push(Event3d::Broke {
                    t_us: t1,
                    kind: c.kind,
                    a: self.robots[c.a].id,
                    b: self.robots[c.b].id,
                    force: c.peak_force,
                    moment: c.peak_moment,
                });
            }
        }
        self.time_us = t1;
    }

    /// Advance by `us` microseconds (whole steps).
    pub fn run_for(&mut self, us: u64) {
        let end = self.time_us + us;
        while self.time_us < end {
            self.step();
        }
    }

    /// Every robot's state, in scenario order.
    pub fn states(&self) -> Vec<RobotState3d> {
        self.robots
            .iter()
            .map(|r| {
                let b = &self.bodies[r.bodies.chassis];
                let iso = b.position();
                let (roll, pitch, yaw) = iso.rotation.euler_angles();
                let fwd = iso.rotation * Vector::x();
                let w = side_speeds(&self.bodies, &r.bodies);
                let rpm = 60.0 / std::f64::consts::TAU;
                RobotState3d {
                    id: r.id,
                    kind: r.kind,
                    position: [iso.translation.x, iso.translation.y, iso.translation.z],
                    rpy: [roll, pitch, yaw],
                    speed: b.linvel().dot(&fwd),
                    yaw_rate: b.angvel().z,
                    wheel_rpm: [w[0] * rpm, w[1] * rpm],
                    battery_v: r.battery_v,
                    linked: r.onboard.linked(),
                    fallen: r.fallen,
                    underside_z: underside_z(r, &self.bodies),
                }
            })
            .collect()
    }

    /// Everything that happened so far.
    pub fn events(&self) -> &[Event3d] {
        &self.events
    }

    /// Couplings: (kind, robot id a, robot id b, still holding, peak force N, peak moment N·m).
    pub fn couplings(&self) -> Vec<(LinkKind, RobotId, RobotId, bool, f64, f64)> {
        self.couplings
            .iter()
            .map(|c| {
                (
                    c.kind,
                    self.robots[c.a].id,
                    self.robots[c.b].id,
                    c.handle.is_some(),
                    c.peak_force,
                    c.peak_moment,
                )
            })
            .collect()
    }

    /// Add a passive box (half extents m, mass kg, friction) resting with its centre at
    /// `centre` (world, m); returns its index for [`World3d::block_position`].
    pub fn add_block(
        &mut self,
        half: [f64; 3],
        mass: f64,
        friction: f64,
        centre: [f64; 3],
    ) -> usize {
        let h = self.bodies.insert(
            RigidBodyBuilder::dynamic()
                .translation(vector![centre[0], centre[1], centre[2]])
                .can_sleep(false)
                .build(),
        );
        let vol = 8.0 * half[0] * half[1] * half[2];
        let col = ColliderBuilder::cuboid(half[0], half[1], half[2])
            .density(mass / vol.max(1e-12))
            .friction(friction)
            .friction_combine_rule(CoefficientCombineRule::Min)
            .collision_groups(InteractionGroups::new(
                terrain::ROBOT_GROUP,
                terrain::TERRAIN_GROUP,
                InteractionTestMode::And,
            ))
            .build();
        self.colliders.insert_with_parent(col, h, &mut self.bodies);
        self.blocks.push(h);
        self.blocks.len() - 1
    }

    /// Centre of block `i` (world, m).
    pub fn block_position(&self, i: usize) -> Option<[f64; 3]> {
        let b = self.bodies.get(*self.blocks.get(i)?)?;
        let t = b.translation();
        Some([t.x, t.y, t.z])
    }

    /// Wrench each coupling carries now: force (N) and moment (N·m) in the frame of the robot
    /// with the opening / hole; `None` once broken. Scenario order.
    pub fn coupling_loads(&self) -> Vec<Option<([f64; 3], [f64; 3])>> {
        self.couplings
            .iter()
            .map(|c| c.handle.map(|_| c.geom.wrench(&self.coupling_coords(c))))
            .collect()
    }

    fn coupling_coords(&self, c: &Joint3d) -> [f64; 6] {
        let b1 = self.bodies[self.robots[c.b].bodies.chassis].position();
        let b2 = self.bodies[self.robots[c.a].bodies.chassis].position();
        c.geom.coords(b1, b2)
    }

    /// Open the coupling between robots `a` and `b` (either order) by hand, as a person
    /// lifts a mesh apart (THESIS 5.5.3); false when they hold no coupling.
    pub fn release(&mut self, a: RobotId, b: RobotId) -> bool {
        let ids = |c: &Joint3d| (self.robots[c.a].id, self.robots[c.b].id);
        let Some(k) = self.couplings.iter().position(|c| {
            let (x, y) = ids(c);
            c.handle.is_some() && ((x, y) == (a, b) || (x, y) == (b, a))
        }) else {
            return false;
        };
        if let Some(h) = self.couplings[k].handle.take() {
            self.joints.remove(h, true);
        }
        true
    }

    /// Pin robot `id` to the world (a fixed body), e.g. the root of a cantilever.
    pub fn pin(&mut self, id: RobotId) -> bool {
        let Some(r) = self.robots.iter().find(|r| r.id == id) else {
            return false;
        };
        let handles: Vec<RigidBodyHandle> = std::iter::once(r.bodies.chassis)
            .chain(r.bodies.wheels.iter().map(|w| w.body))
            .collect();
        for h in handles {
            if let Some(b) = self.bodies.get_mut(h) {
                b.set_body_type(RigidBodyType::Fixed, true);
            }
        }
        true
    }
}

/// Height of the ground the robot stands on at `pose`: the highest platform under any of its
/// wheels (the floor at 0 without platforms).
fn ground_under(t: &Terrain, p: &RobotParams, pose: Pose) -> f64 {
    if t.platforms.is_empty() {
        return 0.0;
    }
    body::wheel_points(p)
        .iter()
        .chain(std::iter::once(&([0.0, 0.0], 0)))
        .filter_map(|(pt, _)| t.support_at(pose.apply(*pt)).map(|s| s.0))
        .fold(None, |m: Option<f64>, h| Some(m.map_or(h, |m| m.max(h))))
        .unwrap_or_else(|| terrain::lowest_top(t))
}

/// Height of robot `r`'s lowest underside corner (world z, m).
fn underside_z(r: &Robot3d, bodies: &RigidBodySet) -> f64 {
    let iso = bodies[r.bodies.chassis].position();
    r.underside
        .iter()
        .map(|c| (iso * c).z)
        .fold(f64::MAX, f64::min)
}

/// Corners of the chassis underside in the body frame.
fn underside(p: &RobotParams, cfg: &Config3d) -> [Point<f64>; 4] {
    let (hl, hw) = (
        0.5 * f64::from(p.geometry.length),
        0.5 * f64::from(p.geometry.width),
    );
    let z = cfg.chassis_clearance;
    [
        point![hl, hw, z],
        point![hl, -hw, z],
        point![-hl, hw, z],
        point![-hl, -hw, z],
    ]
}

/// Wheel speeds relative to the chassis about the axle (rad/s), averaged per motor side.
fn side_speeds(bodies: &RigidBodySet, rb: &RobotBodies) -> [f64; 2] {
    let ch = &bodies[rb.chassis];
    let axle = ch.position().rotation * Vector::y();
    let mut sum = [0.0; 2];
    for w in &rb.wheels {
        let rel = bodies[w.body].angvel() - ch.angvel();
        sum[w.side] += rel.dot(&axle);
    }
    let n = rb.wheels_per_side as f64;
    [sum[0] / n, sum[1] / n]
}
