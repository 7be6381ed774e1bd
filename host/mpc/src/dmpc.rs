//! The distributed tick: one problem per robot, solved in parallel (THESIS Algorithm 9).

use crate::problem::{CouplingInstance, PointTerm, ProblemInstance, Role, VelocityTerm};
use crate::robot::RobotController;
use crate::types::*;
use crate::MpcError;
use rayon::prelude::*;
use std::collections::HashMap;

/// Distributed MPC for a fleet: keeps every robot's plan and solver between ticks.
pub struct DistributedMpc {
    config: MpcConfig,
    memory: HashMap<RobotId, RobotController>,
    pool: Option<rayon::ThreadPool>,
}

impl std::fmt::Debug for DistributedMpc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DistributedMpc")
            .field("config", &self.config)
            .field("robots", &self.memory.len())
            .finish()
    }
}

impl DistributedMpc {
    /// A controller using rayon's global thread pool.
    pub fn new(config: MpcConfig) -> Result<Self, MpcError> {
        config.validate()?;
        Ok(DistributedMpc {
            config,
            memory: HashMap::new(),
            pool: None,
        })
    }

    /// A controller solving on its own pool of `threads` threads (1: sequential).
    pub fn with_threads(config: MpcConfig, threads: usize) -> Result<Self, MpcError> {
        let mut s = Self::new(config)?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .build()
            .map_err(|e| MpcError::InvalidConfig {
                field: "threads",
                reason: e.to_string(),
            })?;
        s.pool = Some(pool);
        Ok(s)
    }

    /// The configuration.
    pub fn config(&self) -> &MpcConfig {
        &self.config
    }

    /// Switches the hard coupling constraints ([`MpcConfig::hard_couplings`]) from the next
    /// tick on.
    pub fn set_hard_couplings(&mut self, hard: bool) {
        self.config.hard_couplings = hard;
    }

    /// Sets the heading weight of the pairs' maintenance cost
    /// ([`MpcConfig::maintain_heading`]) from the next tick on; it must be finite and ≥ 0.
    pub fn set_maintain_heading(&mut self, w: f64) -> Result<(), MpcError> {
        if !(w.is_finite() && w >= 0.0) {
            return Err(MpcError::InvalidConfig {
                field: "maintain_heading",
                reason: format!("must be finite and ≥ 0 (got {w})"),
            });
        }
        self.config.maintain_heading = w;
        Ok(())
    }

    /// Forgets a robot's plan and solver (e.g. after it was moved by hand).
    pub fn reset_robot(&mut self, id: RobotId) {
        self.memory.remove(&id);
    }

    /// The last plan of a robot, if any.
    pub fn plan(&self, id: RobotId) -> Option<&[Command]> {
        self.memory.get(&id).map(|m| m.plan.as_slice())
    }

    /// One tick: every robot's problem built from the current poses, its tasks and the
    /// established `pairs`, solved in parallel; returns every robot's checked first input.
    /// Robots absent from `robots` are forgotten.
    pub fn tick(
        &mut self,
        robots: &[RobotInput],
        pairs: &[CoupledPair],
    ) -> Result<TickOutput, MpcError> {
        let instances = self.instances(robots, pairs)?;
        let cfg = &self.config;
        let mut mems: Vec<RobotController> = robots
            .iter()
            .map(|r| self.memory.remove(&r.id).unwrap_or_default())
            .collect();
        self.memory.clear();
        let mut instances = instances;
        let mems_ref = &mut mems;
        let inst_ref = &mut instances;
        let mut work = move || {
            mems_ref
                .par_iter_mut()
                .zip(inst_ref.par_iter_mut())
                .zip(robots.par_iter())
                .map(|((mem, inst), r)| mem.step(cfg, inst, r.id))
                .collect::<Vec<_>>()
        };
        let outputs = match &self.pool {
            Some(pool) => pool.install(work),
            None => work(),
        };
        for (r, m) in robots.iter().zip(mems) {
            self.memory.insert(r.id, m);
        }
        Ok(TickOutput { robots: outputs })
    }

    /// Resolves every robot's problem to numbers without solving (for export and tests).
    pub fn instances(
        &self,
        robots: &[RobotInput],
        pairs: &[CoupledPair],
    ) -> Result<Vec<ProblemInstance>, MpcError> {
        let cfg = &self.config;
        let h = cfg.horizon;
        let mut index: HashMap<RobotId, usize> = HashMap::with_capacity(robots.len());
        for (i, r) in robots.iter().enumerate() {
            if index.insert(r.id, i).is_some() {
                return Err(invalid(r.id, "duplicate robot id in tick"));
            }
            if !r.pose.is_finite() {
                return Err(invalid(r.id, "pose is not finite"));
            }
            r.limits
                .validate()
                .map_err(|e| invalid(r.id, &e.to_string()))?;
        }
        for p in pairs {
            for id in [p.anchor_robot, p.opening_robot] {
                if !index.contains_key(&id) {
                    return Err(invalid(id, "coupled pair names a robot not in this tick"));
                }
            }
            if p.anchor_robot == p.opening_robot {
                return Err(invalid(p.anchor_robot, "coupled pair with itself"));
            }
        }
        // Every robot's expected trajectory k = 0 … H (neighbours' view of it).
        let predictions: Vec<Vec<Pose>> = robots
            .iter()
            .map(|r| match cfg.neighbours {
                NeighbourModel::Frozen => vec![r.pose; h + 1],
                NeighbourModel::Predicted => {
                    let u = self
                        .memory
                        .get(&r.id)
                        .map(|m| m.shifted_plan(h))
                        .unwrap_or_else(|| vec![Command::STOP; h]);
                    let mut xs = Vec::with_capacity(h + 1);
                    let mut x = r.pose;
                    xs.push(x);
                    for ui in u {
                        x = ui.drive(&x, cfg.dt);
                        xs.push(x);
                    }
                    xs
                }
            })
            .collect();
        let mut out = Vec::with_capacity(robots.len());
        for r in robots {
            let mem = self.memory.get(&r.id);
            let guess = mem
                .map(|m| m.shifted_plan(h))
                .unwrap_or_else(|| vec![Command::STOP; h]);
            let u_prev = mem.map(|m| m.last_command).unwrap_or_default();
            let traj_of = |id: RobotId, what: &str| -> Result<&Vec<Pose>, MpcError> {
                index
                    .get(&id)
                    .map(|&i| &predictions[i])
                    .ok_or_else(|| invalid(r.id, &format!("{what} {id} is not in this tick")))
            };
            let stage = |w: &StageWeights| -> Vec<f64> {
                (0..=h)
                    .map(|k| match k {
                        0 => 0.0,
                        k if k == h => w.terminal,
                        _ => w.stage,
                    })
                    .collect()
            };
            let mut points = Vec::new();
            let mut velocities = Vec::new();
            for c in &r.costs {
                match c {
                    CostTerm::AlignPair {
                        partner,
                        own,
                        partner_point,
                        weights,
                        heading,
                    } => {
                        if *partner == r.id {
                            return Err(invalid(r.id, "AlignPair with itself"));
                        }
                        let tr = traj_of(*partner, "AlignPair partner")?;
                        let off = Pose::new(
                            partner_point.pos[0],
                            partner_point.pos[1],
                            partner_point.angle,
                        );
                        points.push(PointTerm {
                            point: own.pos,
                            angle: own.angle,
                            targets: tr.iter().map(|p| p.compose_unwrapped(&off)).collect(),
                            weights: stage(weights),
                            heading: check_w(r.id, *heading)?,
                        });
                    }
                    CostTerm::GoToGoal {
                        goal,
                        point,
                        weights,
                    } => {
                        if !(goal.iter().chain(point).all(|v| v.is_finite())) {
                            return Err(invalid(r.id, "GoToGoal with non-finite goal or point"));
                        }
                        points.push(PointTerm {
                            point: *point,
                            angle: 0.0,
                            targets: vec![Pose::new(goal[0], goal[1], 0.0)],
                            weights: stage(weights),
                            heading: 0.0,
                        });
                    }
                    CostTerm::FitVelocity {
                        target,
                        w_v,
                        w_omega,
                    } => {
                        if !(target.v.is_finite() && target.omega.is_finite()) {
                            return Err(invalid(r.id, "FitVelocity target not finite"));
                        }
                        velocities.push(VelocityTerm {
                            target: *target,
                            w: [check_w(r.id, *w_v)?, check_w(r.id, *w_omega)?],
                        });
                    }
                    CostTerm::FollowTrajectory {
                        reference,
                        weights,
                        heading,
                    } => {
                        if reference.is_empty() || reference.iter().any(|p| !p.is_finite()) {
                            return Err(invalid(
                                r.id,
                                "FollowTrajectory reference empty or not finite",
                            ));
                        }
                        points.push(PointTerm {
                            point: [0.0, 0.0],
                            angle: 0.0,
                            targets: reference.clone(),
                            weights: stage(weights),
                            heading: check_w(r.id, *heading)?,
                        });
                    }
                    CostTerm::FollowLeader {
                        leader,
                        offset,
                        weights,
                        heading,
                    } => {
                        if *leader == r.id {
                            return Err(invalid(r.id, "FollowLeader of itself"));
                        }
                        if !offset.is_finite() {
                            return Err(invalid(r.id, "FollowLeader offset not finite"));
                        }
                        let tr = traj_of(*leader, "FollowLeader leader")?;
                        points.push(PointTerm {
                            point: [0.0, 0.0],
                            angle: 0.0,
                            targets: tr.iter().map(|p| p.compose_unwrapped(offset)).collect(),
                            weights: stage(weights),
                            heading: check_w(r.id, *heading)?,
                        });
                    }
                }
                if let Some(t) = points.last() {
                    if t.weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
                        return Err(invalid(r.id, "cost weights must be finite and ≥ 0"));
                    }
                }
            }
            // Established pairs: hard constraints and the soft maintenance cost W_c J_c (4.8).
            let mut couplings = Vec::new();
            let g = &cfg.geometry;
            let centre = g.polygon_centre();
            let maint_w: Vec<f64> = (0..=h)
                .map(|k| {
                    if k >= 1 && k <= cfg.constraint_horizon.max(1) {
                        cfg.w_maintain
                    } else {
                        0.0
                    }
                })
                .collect();
            for p in pairs {
                let (role, nb) = if p.anchor_robot == r.id {
                    (Role::Anchor, p.opening_robot)
                } else if p.opening_robot == r.id {
                    (Role::Opening, p.anchor_robot)
                } else {
                    continue;
                };
                let tr = &predictions[index[&nb]];
                let (own_point, target_offset) = match role {
                    Role::Anchor => (g.anchor_head, Pose::new(centre[0], centre[1], 0.0)),
                    Role::Opening => (centre, Pose::new(g.anchor_head[0], g.anchor_head[1], 0.0)),
                };
                if cfg.w_maintain > 0.0 {
                    points.push(PointTerm {
                        point: own_point,
                        angle: 0.0,
                        targets: tr
                            .iter()
                            .map(|q| q.compose_unwrapped(&target_offset))
                            .collect(),
                        weights: maint_w.clone(),
                        heading: cfg.maintain_heading,
                    });
                }
                if cfg.constraint_horizon > 0 && cfg.hard_couplings {
                    couplings.push(CouplingInstance {
                        role,
                        neighbour: nb,
                        neighbour_poses: tr[..=cfg.constraint_horizon].to_vec(),
                    });
                }
            }
            out.push(ProblemInstance {
                horizon: h,
                constraint_horizon: cfg.constraint_horizon,
                dt: cfg.dt,
                x0: r.pose,
                u_prev,
                guess,
                limits: r.limits,
                wings: Vec::new(),
                points,
                velocities,
                w_smooth: cfg.w_smooth,
                w_effort: cfg.w_effort,
                w_damping: if couplings.is_empty() {
                    cfg.w_damping
                } else {
                    [
                        cfg.w_damping[0] + cfg.w_consistency[0],
                        cfg.w_damping[1] + cfg.w_consistency[1],
                    ]
                },
                couplings,
                geometry: cfg.geometry.clone(),
                margin: cfg.constraint_margin,
            });
        }
        Ok(out)
    }
}

fn invalid(robot: RobotId, reason: &str) -> MpcError {
    MpcError::InvalidInput {
        robot,
        reason: reason.to_string(),
    }
}

fn check_w(robot: RobotId, w: f64) -> Result<f64, MpcError> {
    if w.is_finite() && w >= 0.0 {
        Ok(w)
    } else {
        Err(invalid(robot, "cost weight must be finite and ≥ 0"))
    }
}
