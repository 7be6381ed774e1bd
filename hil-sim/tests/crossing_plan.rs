//! The gate plans, the physics drives: the crossing planner's best 2 × 2 mesh (one pilot) for
//! a 40 mm gap, level and 5 mm down (THESIS 3.5.2), formed at the planner's pose and heading in the 3-D world and driven by its
//! firmware, ends with every robot on the far platform, none fallen, no connector broken.

use puzzlebot_params::terrain::{Platform, Terrain};
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_sim::physics3d::{Config3d, Event3d, World3d};
use puzzlebot_sim::{CouplingSpec, LinkKind, RobotSpec, Scenario};
use puzzlebot_stability::crossing::{formed, plan, CrossingOptions};
use puzzlebot_stability::puzzlebot::PairKind;

#[test]
fn the_planned_mesh_crosses_in_the_physics() {
    cross_planned(0.0);
}

/// THESIS 3.5.2: the far platform 5 mm lower.
#[test]
fn the_planned_mesh_crosses_40_mm_down_5_mm() {
    cross_planned(0.005);
}

/// Plan 4 robots (one pilot) over a 40 mm gap with the near platform `drop` higher, drive
/// the best 2 x 2 mesh the planner proves at its heading, check every robot is across.
fn cross_planned(drop: f64) {
    let gap = 0.04;
    let terrain = Terrain {
        platforms: vec![
            Platform::rect("near", [-1.0, -0.5], [0.0, 0.5], drop),
            Platform::rect("far", [gap, -0.5], [gap + 1.0, 0.5], 0.0),
        ],
    };
    let params = FleetParams::default();
    let ranked = plan(&terrain, &params, 4, 1, &CrossingOptions::default()).expect("plan");
    let best = &ranked[0];
    assert!(
        best.shape == "mesh 2x2" && best.crosses(),
        "the planner's choice: {best:?}"
    );
    // The candidate's assembly where the planner starts it.
    let mesh = puzzlebot_params::formation::Shape::Mesh {
        rows: 2,
        per_row: 2,
    };
    let a = formed(
        mesh,
        &best.pilot_robots,
        &params,
        best.start,
        best.heading_deg.to_radians(),
    );
    let robots = a
        .robots
        .iter()
        .enumerate()
        .map(|(k, r)| RobotSpec {
            id: k as u16 + 1,
            kind: r.kind,
            pose: [r.x, r.y, r.yaw],
            impairments: None,
            offline: false,
            mismatch: Default::default(),
        })
        .collect::<Vec<_>>();
    assert_eq!(
        robots.iter().filter(|r| r.kind == RobotKind::Pilot).count(),
        1
    );
    let couplings = a
        .pairs
        .iter()
        .map(|p| CouplingSpec {
            kind: match p.kind {
                PairKind::Anchor => LinkKind::Anchor,
                PairKind::Knob => LinkKind::Knob,
            },
            a: p.a as u16 + 1,
            b: p.b as u16 + 1,
        })
        .collect();
    let s = Scenario {
        robots,
        couplings,
        terrain,
        params,
        ..Scenario::default()
    };
    let mut w = World3d::new(&s, Config3d::default()).expect("world");
    w.command_all(Some([150.0, 150.0]));
    // 150 RPM on 17 mm wheels: 0.27 m/s; the planner's advance plus a second to settle.
    w.run_for(((best.required / 0.25 + 1.0) * 1e6) as u64);
    let events = w.events().to_vec();
    assert!(
        !events
            .iter()
            .any(|e| matches!(e, Event3d::Fell { .. } | Event3d::Broke { .. })),
        "{events:?}"
    );
    for r in w.states() {
        assert!(
            r.position[0] > gap + 0.025 && r.position[2].abs() < 0.002,
            "robot {} is not across: {r:?} (plan: {best:?})",
            r.id
        );
    }
}
