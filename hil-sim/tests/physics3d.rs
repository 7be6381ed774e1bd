//! The 3-D crossing world: determinism, friction, falling into a gap, climbing, a mesh
//! crossing (THESIS 3.5.2) and a cantilever's root knob breaking where statics says.

use puzzlebot_params::terrain::{Platform, Terrain};
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_sim::physics3d::assembly::{self, Formation, Shape};
use puzzlebot_sim::physics3d::{Config3d, Event3d, World3d};
use puzzlebot_sim::{LinkKind, RobotSpec, Scenario};

/// Near platform up to x = 0, the far one from x = `gap`, heights `near` and `far` (m).
fn gap_terrain(gap: f64, near: f64, far: f64) -> Terrain {
    Terrain {
        platforms: vec![
            Platform::rect("near", [-1.0, -0.5], [0.0, 0.5], near),
            Platform::rect("far", [gap, -0.5], [gap + 1.0, 0.5], far),
        ],
    }
}

fn lone(kind: RobotKind, x: f64, terrain: Terrain) -> Scenario {
    Scenario {
        robots: vec![RobotSpec {
            id: 1,
            kind,
            pose: [x, 0.0, 0.0],
            impairments: None,
            offline: false,
            mismatch: Default::default(),
        }],
        terrain,
        ..Scenario::default()
    }
}

fn fell(w: &World3d) -> Vec<u16> {
    w.events()
        .iter()
        .filter_map(|e| match e {
            Event3d::Fell { id, .. } => Some(*id),
            _ => None,
        })
        .collect()
}

fn broke(w: &World3d) -> usize {
    w.events()
        .iter()
        .filter(|e| matches!(e, Event3d::Broke { .. }))
        .count()
}

#[test]
fn same_seed_same_run_other_seed_other_start() {
    let run = |seed: u64| {
        let f = Formation {
            shape: Shape::Mesh {
                rows: 2,
                per_row: 2,
            },
            pilots: vec![0],
            front: [-0.05, 0.0, 0.3],
        };
        let mut s = assembly::scenario(
            &f,
            gap_terrain(0.04, 0.0, 0.0),
            FleetParams::default(),
            seed,
        );
        assembly::jitter(&mut s, 0.005, 0.05);
        let mut w = World3d::new(&s, Config3d::default()).expect("world");
        w.command_all(Some([200.0, 200.0]));
        w.run_for(1_500_000);
        w.states()
            .iter()
            .map(|r| (r.position, r.rpy))
            .collect::<Vec<_>>()
    };
    let a = run(3);
    assert_eq!(a, run(3), "same seed must give a bit-identical run");
    assert_ne!(a, run(4), "another seed starts elsewhere");
}

#[test]
fn a_block_slides_once_the_slope_passes_the_friction_angle() {
    let mu: f64 = 0.6; // the platform's friction (params::terrain default)
    let angle = mu.atan();
    let slide = |slope: f64| {
        let cfg = Config3d {
            slope,
            ..Config3d::default()
        };
        let t = Terrain {
            platforms: vec![Platform::rect("slope", [-1.0, -1.0], [1.0, 1.0], 0.0)],
        };
        let mut w = World3d::new(
            &Scenario {
                terrain: t,
                ..Scenario::default()
            },
            cfg,
        )
        .unwrap();
        let b = w.add_block([0.02, 0.02, 0.01], 0.1, 1.0, [0.0, 0.0, 0.01]);
        w.run_for(1_000_000);
        w.block_position(b).unwrap()[0]
    };
    let below = slide(angle - 0.03);
    let above = slide(angle + 0.03);
    assert!(
        below.abs() < 0.001,
        "held at {:.1}°: moved {below} m",
        (angle - 0.03).to_degrees()
    );
    assert!(
        above > 0.05,
        "must slide at {:.1}°: moved {above} m",
        (angle + 0.03).to_degrees()
    );
}

#[test]
fn a_lone_non_pilot_falls_into_a_40_mm_gap() {
    let s = lone(RobotKind::NonPilot, -0.08, gap_terrain(0.04, 0.0, 0.0));
    let cfg = Config3d::default();
    let mut w = World3d::new(&s, cfg).unwrap();
    // Standing, its underside is the chassis clearance above the platform (the wheels and
    // casters sink a little into the engine's soft contacts).
    w.run_for(500_000);
    let z = w.states()[0].underside_z;
    assert!(
        (z - cfg.chassis_clearance).abs() < 1.5e-3,
        "underside at {z} m"
    );
    w.command_all(Some([150.0, 150.0]));
    w.run_for(3_000_000);
    assert_eq!(fell(&w), vec![1], "{:?}", w.states());
    assert!(w.states()[0].underside_z < -cfg.fall_depth);
}

#[test]
fn a_pilot_climbs_a_5_mm_step_a_non_pilot_does_not() {
    let climb = |kind| {
        let s = lone(kind, -0.06, gap_terrain(0.0005, 0.0, 0.005));
        let mut w = World3d::new(&s, Config3d::default()).unwrap();
        w.command_all(Some([200.0, 200.0]));
        w.run_for(3_000_000);
        w.states()[0]
    };
    let p = climb(RobotKind::Pilot);
    assert!(
        p.position[0] > 0.05 && (p.position[2] - 0.005).abs() < 0.002,
        "{p:?}"
    );
    let n = climb(RobotKind::NonPilot);
    assert!(n.position[0] < 0.01, "non-pilot got onto the step: {n:?}");
}

#[test]
fn a_four_robot_mesh_with_a_pilot_crosses_40_mm_and_5_mm() {
    // THESIS 3.5.2: three non-pilots and a pilot, a 40 mm gap, 5 mm height difference.
    let f = Formation {
        shape: Shape::Mesh {
            rows: 2,
            per_row: 2,
        },
        pilots: vec![0],
        front: [-0.03, -0.025, 0.0],
    };
    let s = assembly::scenario(&f, gap_terrain(0.04, 0.005, 0.0), FleetParams::default(), 1);
    let mut w = World3d::new(&s, Config3d::default()).unwrap();
    w.command_all(Some([200.0, 200.0]));
    w.run_for(1_500_000);
    let st = w.states();
    assert!(
        fell(&w).is_empty(),
        "fell: {:?}\n{:?}",
        fell(&w),
        w.events()
    );
    assert_eq!(broke(&w), 0, "{:?}", w.events());
    for r in &st {
        assert!(r.position[0] > 0.07, "robot {} did not cross: {r:?}", r.id);
        assert!(
            r.position[2].abs() < 0.002,
            "robot {} not on the far side: {r:?}",
            r.id
        );
    }
}

/// Robots side by side, each one's left knob in the next one's right hole; the first one
/// pinned: the rest is a cantilever.
fn cantilever(n: usize, hold: f32) -> World3d {
    let mut params = FleetParams::default();
    params.non_pilot.coupling.knob_hold_force = hold;
    // Knobs without play: the load comes on without an impact at the hooks.
    params.non_pilot.coupling.knob_play = 0.0;
    let robots = (0..n)
        .map(|k| RobotSpec {
            id: k as u16 + 1,
            kind: RobotKind::NonPilot,
            pose: [0.0, 0.05 * k as f64, 0.0],
            impairments: None,
            offline: false,
            mismatch: Default::default(),
        })
        .collect();
    let couplings = (1..n)
        .map(|k| puzzlebot_sim::CouplingSpec {
            kind: LinkKind::Knob,
            a: k as u16,
            b: k as u16 + 1,
        })
        .collect();
    let s = Scenario {
        robots,
        couplings,
        terrain: Terrain {
            platforms: vec![Platform::rect("root", [-0.1, -0.1], [0.1, 0.0], 0.0)],
        },
        params,
        ..Scenario::default()
    };
    let mut w = World3d::new(&s, Config3d::default()).unwrap();
    w.pin(1);
    w.run_for(800_000);
    w
}

#[test]
fn a_cantilevered_chain_breaks_its_root_knob_where_statics_says() {
    let p = FleetParams::default();
    let weight = f64::from(p.non_pilot.mass.mass) * 9.81;
    let w = f64::from(p.non_pilot.geometry.width);
    let lever = 0.5 * f64::from(p.non_pilot.geometry.height);
    // Root moment of k robots hanging out: Σ W (j − ½) w = W w k² / 2; shear k W.
    let moment = |k: usize| weight * w * (k * k) as f64 * 0.5;
    // The root carries what statics says (within 10 %) when nothing breaks.
    let world = cantilever(3, 100.0);
    let (f, m) = world.coupling_loads()[0].expect("holds");
    let (fz, mx) = (f[2].abs(), m[0].abs());
    assert!((fz / (2.0 * weight) - 1.0).abs() < 0.1, "shear {fz} N");
    assert!(
        (mx / moment(2) - 1.0).abs() < 0.1,
        "moment {mx} N·m vs {}",
        moment(2)
    );
    // Knob strengths whose break lengths statics puts ≥ 20 % clear of the limit.
    for hold in [3.2f32, 6.0, 12.0] {
        let cap = f64::from(hold) * lever;
        let holds = |k: usize| moment(k) <= cap && k as f64 * weight <= f64::from(hold);
        let predicted = (1..10).find(|&k| !holds(k)).unwrap();
        let root_broke = |k: usize| {
            cantilever(k + 1, hold)
                .events()
                .iter()
                .any(|e| matches!(e, Event3d::Broke { a: 1, b: 2, .. }))
        };
        let out = predicted - 1;
        assert!(!root_broke(out), "hold {hold} N: {out} out must hold");
        assert!(
            root_broke(predicted),
            "hold {hold} N: {predicted} out must break"
        );
    }
}

#[test]
fn a_negative_knob_play_is_refused_by_name() {
    let mut s = lone(RobotKind::NonPilot, -0.1, gap_terrain(0.04, 0.0, 0.0));
    s.params.non_pilot.coupling.knob_play = -0.001;
    let Err(e) = World3d::new(&s, Config3d::default()) else {
        panic!("a negative knob play was accepted");
    };
    let e = e.to_string();
    assert!(e.contains("coupling.knob_play"), "{e}");
}
