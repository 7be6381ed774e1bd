//! Platforms of [`Terrain`] as fixed colliders: each platform a prism from the catch floor up
//! to its height; a gap is where no platform is, with a catch floor `catch_depth` below the
//! lowest platform so that a fallen robot comes to rest. Terrains must pass
//! [`Terrain::validate_solid`].

use puzzlebot_params::terrain::{Platform, Terrain};
use rapier3d_f64::prelude::*;

/// Collision group of the terrain.
pub const TERRAIN_GROUP: Group = Group::GROUP_1;
/// Collision group of robot parts (they touch the terrain, not each other).
pub const ROBOT_GROUP: Group = Group::GROUP_2;

/// Half size of the catch floor and of the floor of a terrain without platforms (m).
const FLOOR_HALF: f64 = 50.0;

/// Height of the catch floor under `t` (m).
pub fn catch_floor(t: &Terrain, catch_depth: f64) -> f64 {
    lowest_top(t) - catch_depth
}

/// The lowest platform top (0 for the endless floor).
pub fn lowest_top(t: &Terrain) -> f64 {
    t.platforms
        .iter()
        .map(|p| p.height)
        .fold(None, |m: Option<f64>, h| Some(m.map_or(h, |m| m.min(h))))
        .unwrap_or(0.0)
}

/// Add the terrain's colliders (attached to the ground) to `colliders`.
pub fn build(t: &Terrain, catch_depth: f64, colliders: &mut ColliderSet) {
    let groups = InteractionGroups::new(TERRAIN_GROUP, ROBOT_GROUP, InteractionTestMode::And);
    let floor_top = if t.platforms.is_empty() {
        0.0
    } else {
        catch_floor(t, catch_depth)
    };
    let floor = ColliderBuilder::cuboid(FLOOR_HALF, FLOOR_HALF, 0.05)
        .translation(vector![0.0, 0.0, floor_top - 0.05])
        .friction(0.6)
        .collision_groups(groups)
        .build();
    colliders.insert(floor);
    for p in &t.platforms {
        colliders.insert(prism(p, floor_top).collision_groups(groups).build());
    }
}

fn prism(p: &Platform, bottom: f64) -> ColliderBuilder {
    let top = p.height;
    let half_h = ((top - bottom) * 0.5).max(1e-4);
    let mid = top - half_h;
    let fr = p.friction;
    if let Some((min, max)) = axis_aligned_rect(&p.polygon) {
        let half = [(max[0] - min[0]) * 0.5, (max[1] - min[1]) * 0.5];
        return ColliderBuilder::cuboid(half[0], half[1], half_h)
            .translation(vector![min[0] + half[0], min[1] + half[1], mid])
            .friction(fr);
    }
    let pts: Vec<Point<f64>> = p
        .polygon
        .iter()
        .flat_map(|v| [point![v[0], v[1], mid - half_h], point![v[0], v[1], top]])
        .collect();
    ColliderBuilder::convex_hull(&pts)
        // `validate` has made sure the polygon is convex with an area: the hull exists.
        .unwrap_or_else(|| ColliderBuilder::ball(1e-3))
        .friction(fr)
}

fn axis_aligned_rect(poly: &[[f64; 2]]) -> Option<([f64; 2], [f64; 2])> {
    if poly.len() != 4 {
        return None;
    }
    let xs: Vec<f64> = poly.iter().map(|v| v[0]).collect();
    let ys: Vec<f64> = poly.iter().map(|v| v[1]).collect();
    let min = [
        xs.iter().copied().fold(f64::MAX, f64::min),
        ys.iter().copied().fold(f64::MAX, f64::min),
    ];
    let max = [
        xs.iter().copied().fold(f64::MIN, f64::max),
        ys.iter().copied().fold(f64::MIN, f64::max),
    ];
    let corner =
        |v: &[f64; 2]| (v[0] == min[0] || v[0] == max[0]) && (v[1] == min[1] || v[1] == max[1]);
    poly.iter().all(corner).then_some((min, max))
}
