//! The candidate assemblies: a shape's distinct pilot placements and its formed assembly at a
//! pose.

use super::PilotPlace;
use crate::puzzlebot::{Pair, PairKind, PuzzleAssembly, RobotPose};
use puzzlebot_params::formation::{self, Link, Shape};
use puzzlebot_params::{FleetParams, RobotKind};

/// Pilot index sets of `shape` for `pilots` pilots, one per distinct placement.
pub fn pilot_sets(shape: Shape, pilots: usize) -> Vec<(PilotPlace, Vec<usize>)> {
    if pilots == 0 {
        return vec![(PilotPlace::None, vec![])];
    }
    let sizes = shape.row_sizes();
    let starts: Vec<usize> = sizes
        .iter()
        .scan(0, |at, &n| {
            let s = *at;
            *at += n;
            Some(s)
        })
        .collect();
    let fronts: Vec<usize> = starts.clone();
    let backs: Vec<usize> = starts.iter().zip(&sizes).map(|(s, n)| s + n - 1).collect();
    let pick = |order: Vec<usize>| {
        let mut s: Vec<usize> = Vec::new();
        for k in order.into_iter().chain(0..shape.count()) {
            if s.len() == pilots {
                break;
            }
            if !s.contains(&k) {
                s.push(k);
            }
        }
        s.sort_unstable();
        s
    };
    let alternate: Vec<usize> = fronts
        .iter()
        .zip(&backs)
        .flat_map(|(&f, &b)| [f, b])
        .collect();
    let mut out: Vec<(PilotPlace, Vec<usize>)> = Vec::new();
    for (place, order) in [
        (PilotPlace::Front, [fronts.clone(), backs.clone()].concat()),
        (PilotPlace::Back, [backs.clone(), fronts.clone()].concat()),
        (PilotPlace::FrontBack, alternate),
    ] {
        if place == PilotPlace::FrontBack && pilots < 2 {
            continue;
        }
        let set = pick(order);
        if !out.iter().any(|(_, s)| *s == set) {
            out.push((place, set));
        }
    }
    out
}

/// The formed assembly of `shape` with pilots `pilots`, its front robot at `front` heading
/// `yaw`, held by every coupling of its layout ([`formation::layout`]).
pub fn formed(
    shape: Shape,
    pilots: &[usize],
    params: &FleetParams,
    front: [f64; 2],
    yaw: f64,
) -> PuzzleAssembly {
    let links = formation::layout(shape, &params.non_pilot.geometry).1;
    formed_with(shape, pilots, &links, params, front, yaw)
}

/// [`formed`] held by the couplings `links` only (row-major robot indices, as the layout's):
/// an assembly as a formation left it, which may have closed fewer knobs than the layout has.
pub fn formed_with(
    shape: Shape,
    pilots: &[usize],
    links: &[(Link, usize, usize)],
    params: &FleetParams,
    front: [f64; 2],
    yaw: f64,
) -> PuzzleAssembly {
    let g = &params.non_pilot.geometry;
    let at = formation::layout(shape, g).0;
    let (s, c) = yaw.sin_cos();
    let robots: Vec<RobotPose> = at
        .iter()
        .enumerate()
        .map(|(k, o)| RobotPose {
            kind: if pilots.contains(&k) {
                RobotKind::Pilot
            } else {
                RobotKind::NonPilot
            },
            x: front[0] + c * o[0] - s * o[1],
            y: front[1] + s * o[0] + c * o[1],
            yaw,
        })
        .collect();
    let side = f64::from(g.side_point_x);
    let half_w = 0.5 * f64::from(g.width);
    let pairs = links
        .iter()
        .map(|&(l, a, b)| match l {
            Link::Anchor => Pair {
                a,
                b,
                kind: PairKind::Anchor,
                point: None,
            },
            Link::Knob => Pair {
                a,
                b,
                kind: PairKind::Knob,
                // The side point of `a` nearest `b` (rows offset by half a body).
                point: Some([(at[b][0] - at[a][0]).clamp(-side, side), half_w]),
            },
        })
        .collect();
    PuzzleAssembly { robots, pairs }
}

/// Where `pilots` sit in `shape`.
pub(super) fn place_of(shape: Shape, pilots: &[usize]) -> PilotPlace {
    let sizes = shape.row_sizes();
    let at = |k: usize| shape.place_in_row(k).map(|(r, i)| (i, sizes[r]));
    let front = pilots.iter().any(|&k| at(k).is_some_and(|(i, _)| i == 0));
    let back = pilots
        .iter()
        .any(|&k| at(k).is_some_and(|(i, n)| n > 1 && i == n - 1));
    let (_, longest) = shape.rows();
    match (pilots.is_empty(), front, back) {
        (true, _, _) => PilotPlace::None,
        (_, true, true) if longest > 1 => PilotPlace::FrontBack,
        (_, true, _) => PilotPlace::Front,
        _ => PilotPlace::Back,
    }
}
