//! Formed assemblies as THESIS's crossing experiments start them (THESIS 3.5.3, 5.2.4):
//! a line (robots front to back on soft anchors) or a mesh (rows of lines offset by half a
//! body, the rows held by side knobs), at a heading, with seeded jitter of the start pose.

use crate::mechanics::LinkKind;
use crate::rng::Rng;
use crate::scenario::{CouplingSpec, RobotSpec, Scenario};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};

/// Shape of a formed assembly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// One row of `n` robots on soft anchors.
    Line(usize),
    /// `rows` rows of `per_row` robots, each row offset by half a body from the previous.
    Mesh {
        /// Rows.
        rows: usize,
        /// Robots per row.
        per_row: usize,
    },
}

/// Where the assembly starts and which robots are pilots.
#[derive(Debug, Clone, PartialEq)]
pub struct Formation {
    /// Shape.
    pub shape: Shape,
    /// Indices (row-major, front first) of pilot robots.
    pub pilots: Vec<usize>,
    /// Front-centre point of the first row's front robot (m) and the heading (rad).
    pub front: [f64; 3],
}

/// A coupling of a layout: kind, robot with the anchor / knob, robot with the opening / hole.
pub type LayoutLink = (LinkKind, usize, usize);

/// Body-centre offsets (forward, left) of every robot, row-major with the front robot of each
/// row first, and the couplings (indices) that hold them: anchors within a row (the robot in
/// front carries the anchor), knobs between rows (the right-hand robot carries the knob).
pub fn layout(shape: Shape, p: &FleetParams) -> (Vec<[f64; 2]>, Vec<LayoutLink>) {
    let g = &p.non_pilot.geometry;
    let seat =
        f64::from(g.anchor_opening[0]) - puzzlebot_params::coupling::Coupling::anchor_depth(g);
    let pitch = seat - f64::from(g.anchor_head[0]);
    let width = f64::from(g.width);
    let (rows, per_row) = match shape {
        Shape::Line(n) => (1, n),
        Shape::Mesh { rows, per_row } => (rows, per_row),
    };
    let mut at = Vec::with_capacity(rows * per_row);
    let mut links = Vec::new();
    for r in 0..rows {
        // Odd rows sit half a body forward (THESIS 5.2.2), each row to the left of the last.
        let shift = if r % 2 == 1 { 0.5 * pitch } else { 0.0 };
        for i in 0..per_row {
            at.push([shift - pitch * i as f64, width * r as f64]);
            let k = r * per_row + i;
            if i > 0 {
                links.push((LinkKind::Anchor, k - 1, k));
            }
        }
    }
    for r in 1..rows {
        for i in 0..per_row {
            for j in 0..per_row {
                let (a, b) = ((r - 1) * per_row + i, r * per_row + j);
                if (at[a][0] - at[b][0]).abs() < 0.75 * pitch {
                    links.push((LinkKind::Knob, a, b));
                }
            }
        }
    }
    (at, links)
}

/// The scenario of a formed assembly on `terrain` (robot ids from 1, row-major).
pub fn scenario(f: &Formation, terrain: Terrain, params: FleetParams, seed: u64) -> Scenario {
    let (at, links) = layout(f.shape, &params);
    let [fx, fy, yaw] = f.front;
    let (s, c) = yaw.sin_cos();
    let robots = at
        .iter()
        .enumerate()
        .map(|(k, o)| RobotSpec {
            id: k as u16 + 1,
            kind: if f.pilots.contains(&k) {
                RobotKind::Pilot
            } else {
                RobotKind::NonPilot
            },
            pose: [fx + c * o[0] - s * o[1], fy + s * o[0] + c * o[1], yaw],
            impairments: None,
            offline: false,
            mismatch: Default::default(),
        })
        .collect();
    let couplings = links
        .iter()
        .map(|&(kind, a, b)| CouplingSpec {
            kind,
            a: a as u16 + 1,
            b: b as u16 + 1,
        })
        .collect();
    Scenario {
        seed,
        robots,
        couplings,
        terrain,
        params,
        ..Scenario::default()
    }
}

/// Move the whole assembly by a seeded random offset (uniform within ±`pos` m along each
/// axis, ±`yaw` rad about its front robot): the start-pose jitter of repeated runs.
pub fn jitter(s: &mut Scenario, pos: f64, yaw: f64) {
    let mut rng = Rng::new(s.seed, 0x717);
    let mut u = || 2.0 * rng.uniform() - 1.0;
    let (dx, dy, dyaw) = (pos * u(), pos * u(), yaw * u());
    let Some(front) = s.robots.first().map(|r| r.pose) else {
        return;
    };
    let (sn, cs) = dyaw.sin_cos();
    for r in &mut s.robots {
        let (ox, oy) = (r.pose[0] - front[0], r.pose[1] - front[1]);
        r.pose = [
            front[0] + cs * ox - sn * oy + dx,
            front[1] + sn * ox + cs * oy + dy,
            r.pose[2] + dyaw,
        ];
    }
}
