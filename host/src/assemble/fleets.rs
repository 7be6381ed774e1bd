//! Simulated fleets for assembly scenarios: robots scattered deterministically from a seed,
//! pilots set down in one lane, and the demos' fleets and scenarios.

use puzzlebot_params::RobotKind;
use puzzlebot_protocol::messages::RobotId;

/// A simulated fleet for an assembly scenario without a simulator file: `n` non-pilot robots
/// (the first `pilots` ids are pilots) scattered deterministically from `seed` in a 0.6 m
/// square around the origin ([`scattered_fleet_in`]).
pub fn scattered_fleet(n: usize, pilots: usize, seed: u64) -> puzzlebot_sim::Scenario {
    scattered_fleet_in(n, pilots, seed, 0.3).expect("up to a dozen robots fit 0.6 m x 0.6 m")
}

/// `n` robots (the first `pilots` ids pilots) scattered deterministically from `seed` in the
/// square of half side `half_side` (m) around the origin, centres at least
/// [`MIN_START_SPACING`] apart. Pilots after the first are set down as a lab would, in its
/// lane: [`LANE_GAP`] apart behind it, facing the same way, a few millimetres and hundredths
/// of a radian off (a lone pilot is not driven and moves straight only, THESIS 3.5.2 and
/// 5.4.1; growing a shape takes two pilots so). An error, before any robot exists, when the
/// robots cannot all be placed so.
pub fn scattered_fleet_in(
    n: usize,
    pilots: usize,
    seed: u64,
    half_side: f64,
) -> anyhow::Result<puzzlebot_sim::Scenario> {
    use rand::{Rng, SeedableRng};
    if !(half_side.is_finite() && half_side > 0.0) {
        anyhow::bail!("start area: half side must be a positive number of metres, got {half_side}");
    }
    if pilots > n {
        anyhow::bail!("{pilots} pilots among {n} robots");
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut poses: Vec<[f64; 3]> = Vec::new();
    // Rejection sampling: a bounded number of draws per robot, then the area is too small.
    let tries = 10_000 * n.max(1);
    for _ in 0..tries {
        if poses.len() == n {
            break;
        }
        let p = match poses.first() {
            Some(q) if poses.len() < pilots => {
                let back = LANE_GAP * poses.len() as f64;
                let side = rng.random_range(-0.003..0.003);
                let (s, c) = q[2].sin_cos();
                [
                    q[0] - back * c - side * s,
                    q[1] - back * s + side * c,
                    q[2] + rng.random_range(-0.02..0.02),
                ]
            }
            _ => [
                rng.random_range(-half_side..half_side),
                rng.random_range(-half_side..half_side),
                rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
            ],
        };
        if poses
            .iter()
            .all(|q| (q[0] - p[0]).hypot(q[1] - p[1]) > MIN_START_SPACING)
        {
            poses.push(p);
        }
    }
    if poses.len() < n {
        anyhow::bail!(
            "{n} robots do not fit a {:.2} m square {MIN_START_SPACING} m apart (placed {})",
            2.0 * half_side,
            poses.len()
        );
    }
    let robots = poses
        .into_iter()
        .enumerate()
        .map(|(i, pose)| puzzlebot_sim::RobotSpec {
            id: (i + 1) as RobotId,
            kind: if i < pilots {
                RobotKind::Pilot
            } else {
                RobotKind::NonPilot
            },
            pose,
            impairments: None,
            offline: false,
            mismatch: puzzlebot_sim::PlantMismatch::NONE,
        })
        .collect();
    Ok(puzzlebot_sim::Scenario {
        seed,
        robots,
        ..puzzlebot_sim::Scenario::default()
    })
}

/// Least distance between robot centres at the start of a scattered fleet (m).
pub const MIN_START_SPACING: f64 = 0.12;

/// Distance between pilots set down in one lane by [`scattered_fleet`] (m): room for a
/// non-pilot's staged approach to the back one's front (its place, stand-off and route
/// clearance) with the front one still ahead.
pub const LANE_GAP: f64 = 0.4;

/// Issue 7's demo scenario (host/assembly/data/scenarios/demo.toml, embedded so the binary
/// runs from any directory), what `puzzlebot demo` runs on [`demo_fleet`]: a 2-row mesh grown
/// around the front of two pilots, driven 0.5 m, dissolved, every robot sent to its own goal.
pub const DEMO_SCENARIO: &str = include_str!("../../assembly/data/scenarios/demo.toml");

/// The fleet of `puzzlebot demo`: six robots, two pilots set down in one lane, the others
/// scattered over 0.6 m × 0.6 m ([`scattered_fleet`]). Over seeds 1–24, 21 run the whole
/// demo in lockstep (README, Status); this is seed 2.
pub fn demo_fleet() -> puzzlebot_sim::Scenario {
    scattered_fleet(6, 2, 2)
}

/// A 2-row mesh grown around the pilot of [`grow_demo_fleet`], driven 0.5 m, dissolved and
/// dispersed (host/assembly/data/scenarios/grow_mesh.toml): the one-pilot demo.
pub const GROW_DEMO_SCENARIO: &str = include_str!("../../assembly/data/scenarios/grow_mesh.toml");

/// Six robots, one pilot, scattered over 0.6 m × 0.6 m. Seed 5 is a start the mesh grows
/// from and drives intact; over seeds 1–12, 10 grow it and drive it intact (README, Status).
pub fn grow_demo_fleet() -> puzzlebot_sim::Scenario {
    scattered_fleet(6, 1, 5)
}
