//! Formed assemblies as THESIS's crossing experiments start them (THESIS 3.5.3, 5.2.4):
//! a line (robots front to back on soft anchors) or a mesh (rows of lines offset by half a
//! body, the rows held by side knobs), at a heading, with seeded jitter of the start pose.

use crate::mechanics::LinkKind;
use crate::rng::Rng;
use crate::scenario::{CouplingSpec, RobotSpec, Scenario};
use puzzlebot_params::formation;
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};

pub use puzzlebot_params::formation::Shape;

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

/// Body-centre offsets (forward, left; m) and couplings of `shape`
/// ([`puzzlebot_params::formation::layout`]) with the simulator's coupling kinds.
pub fn layout(shape: Shape, p: &FleetParams) -> (formation::Offsets, Vec<LayoutLink>) {
    let (at, links) = formation::layout(shape, &p.non_pilot.geometry);
    let links = links
        .into_iter()
        .map(|(l, a, b)| (LinkKind::from(l), a, b))
        .collect();
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
