//! Reproducible benchmark and peer-comparison scenarios (lines of coupled robots).

use crate::problem::ProblemInstance;
use crate::types::*;
use crate::{DistributedMpc, RobotController};
use puzzlebot_params::{drive::Drive, RobotKind};

/// Spacing of coupled robots along a line (m): body length + 4 mm gap, anchor head inside
/// the opening's polygon.
pub const LINE_SPACING: f64 = 0.054;

/// A fleet of `n` non-pilot robots in lines of `per_line` coupled robots (anchor robot in
/// front), lines 0.3 m apart. The front robot of a line follows a gentle arc (THESIS 5.26),
/// the others follow it (5.25). Returns the inputs and the established pairs.
pub fn coupled_lines(
    n: usize,
    per_line: usize,
    horizon: usize,
    dt: f64,
) -> (Vec<RobotInput>, Vec<CoupledPair>) {
    let limits = Limits::from_drive(&Drive::for_kind(RobotKind::NonPilot));
    let per_line = per_line.max(1);
    let mut robots = Vec::with_capacity(n);
    let mut pairs = Vec::new();
    for i in 0..n {
        let line = i / per_line;
        let pos = i % per_line;
        let id = i as RobotId;
        let leader = (line * per_line) as RobotId;
        let y0 = 0.3 * line as f64;
        let x = -LINE_SPACING * pos as f64;
        let pose = Pose::new(x, y0, 0.0);
        let costs = if pos == 0 {
            let (r, v) = (0.6, 0.04);
            let reference = (0..=horizon)
                .map(|k| {
                    let a = v * dt * k as f64 / r;
                    Pose::new(r * a.sin(), y0 + r * (1.0 - a.cos()), a)
                })
                .collect();
            vec![CostTerm::FollowTrajectory {
                reference,
                weights: StageWeights {
                    stage: 1.0e3,
                    terminal: 1.0e4,
                },
                heading: 1.0e-3,
            }]
        } else {
            pairs.push(CoupledPair {
                anchor_robot: id - 1,
                opening_robot: id,
            });
            vec![CostTerm::FollowLeader {
                leader,
                offset: Pose::new(-LINE_SPACING * pos as f64, 0.0, 0.0),
                weights: StageWeights {
                    stage: 1.0e2,
                    terminal: 1.0e3,
                },
                heading: 1.0e-3,
            }]
        };
        robots.push(RobotInput {
            id,
            pose,
            limits,
            costs,
        });
    }
    (robots, pairs)
}

/// A warmed-up problem of one robot with `couplings` (0, 1 or 2) established pairs, taken
/// from [`coupled_lines`] after five ticks, with its butterfly wings selected.
pub fn robot_instance(
    couplings: usize,
    cfg: &MpcConfig,
) -> Result<ProblemInstance, crate::MpcError> {
    let (n, idx) = match couplings {
        0 => (1, 0),
        1 => (3, 0),
        _ => (3, 1),
    };
    let (robots, pairs) = coupled_lines(n, 3, cfg.horizon, cfg.dt);
    let mut mpc = DistributedMpc::with_threads(cfg.clone(), 1)?;
    for _ in 0..5 {
        mpc.tick(&robots, &pairs)?;
    }
    let mut inst = mpc.instances(&robots, &pairs)?.swap_remove(idx);
    RobotController::new().step(cfg, &mut inst, robots[idx].id);
    Ok(inst)
}
