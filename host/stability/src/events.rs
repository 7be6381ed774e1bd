//! Support events: the advances at which a wheel or caster of a moving assembly crosses a
//! platform edge, where the support topology (and the gate's model of a rigid translation)
//! changes and the loads jump.

use crate::puzzlebot::{body_corners, contact_points, world, PuzzleAssembly};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::FleetParams;

/// Advances in (0, `horizon`] (m) at which a contact point of some robot of `assembly`,
/// moving along `heading` (rad), crosses a platform edge of `terrain`: the wheel and caster
/// positions of [`contact_points`] against every polygon side, ascending. Between two of them
/// the support topology, and with it the gate's model of a rigid translation, stays the same;
/// the loads jump at them.
pub fn support_events(
    assembly: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    heading: f64,
    horizon: f64,
) -> Vec<f64> {
    let points = assembly.robots.iter().flat_map(|r| {
        contact_points(r.kind, params)
            .into_iter()
            .map(move |(b, _)| world(r, b))
    });
    crossings(points, terrain, heading, horizon)
}

/// Advances in (0, `horizon`] (m) at which a front corner or the front middle of some robot's
/// body crosses a platform edge of `terrain`, moving along `heading` (rad), ascending: where
/// a hanging robot's body may reach the platform ahead ([`crate::sag::edge_stall`]).
pub fn front_events(
    assembly: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    heading: f64,
    horizon: f64,
) -> Vec<f64> {
    let points = assembly.robots.iter().flat_map(|r| {
        let [hl, hw] = params.robot(r.kind).geometry.half_extents();
        let (hl, hw) = (f64::from(hl), f64::from(hw));
        [[hl, hw], [hl, -hw], [hl, 0.0]].map(|b| world(r, b))
    });
    crossings(points, terrain, heading, horizon)
}

/// Advances in (0, `horizon`] (m) at which a corner of some robot's underside crosses a
/// platform edge of `terrain`, moving along `heading` (rad), ascending: where the platform a
/// robot may come to rest on changes ([`crate::sag::resting_bodies`]).
pub fn body_events(
    assembly: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    heading: f64,
    horizon: f64,
) -> Vec<f64> {
    let points = assembly
        .robots
        .iter()
        .flat_map(|r| body_corners(r.kind, params).map(|b| world(r, b)));
    crossings(points, terrain, heading, horizon)
}

/// Advances in (0, `horizon`] at which one of `points` crosses a platform edge, ascending.
fn crossings(
    points: impl Iterator<Item = [f64; 2]>,
    terrain: &Terrain,
    heading: f64,
    horizon: f64,
) -> Vec<f64> {
    let dir = [heading.cos(), heading.sin()];
    let mut out = Vec::new();
    for p in points {
        {
            for pl in &terrain.platforms {
                let n = pl.polygon.len();
                for k in 0..n {
                    let (a, e) = (pl.polygon[k], pl.polygon[(k + 1) % n]);
                    if let Some(d) = ray_crosses(p, dir, a, e) {
                        if d > 0.0 && d <= horizon {
                            out.push(d);
                        }
                    }
                }
            }
        }
    }
    out.sort_by(f64::total_cmp);
    out.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    out
}

/// Distance along the ray `p + d·dir` at which it crosses the segment `a`–`b` (None: parallel
/// or missing it).
fn ray_crosses(p: [f64; 2], dir: [f64; 2], a: [f64; 2], b: [f64; 2]) -> Option<f64> {
    let s = [b[0] - a[0], b[1] - a[1]];
    let den = dir[0] * s[1] - dir[1] * s[0];
    if den.abs() < 1e-12 {
        return None;
    }
    let q = [a[0] - p[0], a[1] - p[1]];
    let d = (q[0] * s[1] - q[1] * s[0]) / den;
    let t = (q[0] * dir[1] - q[1] * dir[0]) / den;
    (-1e-12..=1.0 + 1e-12).contains(&t).then_some(d)
}
