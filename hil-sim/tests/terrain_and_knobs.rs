//! Terrain support (gaps, steps, bridging assemblies) and rigid side knobs.

mod common;

use common::{connect, drive, key, speed, MiniHost};
use puzzlebot_params::terrain::{Platform, Terrain};
use puzzlebot_protocol::HostMsg;
use puzzlebot_sim::{CouplingSpec, EventKind, LinkKind, Pose, RobotSpec, Scenario, World};

fn robot(id: u16, x: f64, y: f64) -> RobotSpec {
    RobotSpec {
        id,
        kind: puzzlebot_protocol::RobotKind::NonPilot,
        pose: [x, y, 0.0],
        impairments: None,
        offline: false,
        mismatch: puzzlebot_sim::PlantMismatch::NONE,
    }
}

/// Robot `a`'s anchor in robot `b`'s opening.
fn anchor(a: u16, b: u16) -> CouplingSpec {
    CouplingSpec {
        kind: LinkKind::Anchor,
        a,
        b,
    }
}

/// Robot `a`'s left knob in robot `b`'s right hole.
fn knob(a: u16, b: u16) -> CouplingSpec {
    CouplingSpec {
        kind: LinkKind::Knob,
        a,
        b,
    }
}

#[test]
fn a_robot_driving_over_a_gap_falls_and_it_is_reported() {
    let mut s = Scenario::grid(0, 1);
    s.terrain = Terrain::gap(0.0, 0.06, 1.0, 1.0, 0.05);
    s.robots = vec![robot(1, -0.2, 0.0)];
    let mut w = World::new(&s, &key()).expect("world");
    let mut host = MiniHost::new(key());
    connect(&mut w, &mut host, 2.0);
    drive(&mut w, &mut host, 3.0, |_, _| Some(speed(100.0, 100.0)));
    let t = w.ground_truth();
    let r = t.robot(1).unwrap();
    assert!(r.fallen, "{r:?}");
    assert!(t.events.iter().any(|e| e.kind == EventKind::Fell { id: 1 }));
    // It fell at the edge, not beyond the gap.
    assert!(r.pose.x > -0.01 && r.pose.x < 0.06, "{:?}", r.pose);
}

#[test]
fn a_coupled_pair_bridges_a_gap_that_drops_a_lone_robot() {
    let gap = Terrain::gap(0.0, 0.03, 1.0, 1.0, 0.05);
    // The lead robot's centre and wheels over the 30 mm gap, its casters on both sides.
    let mut s = Scenario::grid(0, 1);
    s.terrain = gap.clone();
    s.robots = vec![robot(1, -0.035, 0.0), robot(2, 0.015, 0.0)];
    s.couplings = vec![CouplingSpec {
        kind: LinkKind::Anchor,
        a: 2,
        b: 1,
    }];
    let mut w = World::new(&s, &key()).expect("world");
    w.run_for(200_000);
    let t = w.ground_truth();
    assert!(t.robots.iter().all(|r| !r.fallen), "{:?}", t.events);
    // Alone, the same robot at the same place falls.
    let mut s = Scenario::grid(0, 1);
    s.terrain = gap;
    s.robots = vec![robot(2, 0.015, 0.0)];
    let mut w = World::new(&s, &key()).expect("world");
    w.run_for(10_000);
    assert!(w.ground_truth().robot(2).unwrap().fallen);
}

#[test]
fn steps_block_going_up_and_drop_going_down() {
    let mut s = Scenario::grid(0, 1);
    s.terrain = Terrain {
        platforms: vec![
            Platform::rect("low", [-1.0, -1.0], [0.0, 1.0], 0.0),
            Platform::rect("high", [0.0, -1.0], [1.0, 1.0], 0.02),
        ],
    };
    s.robots = vec![robot(1, -0.1, 0.0), robot(2, 0.1, 0.3)];
    let mut w = World::new(&s, &key()).expect("world");
    let mut host = MiniHost::new(key());
    connect(&mut w, &mut host, 2.0);
    // Robot 1 drives up against the 20 mm step; robot 2 drives down from the high side.
    drive(&mut w, &mut host, 2.0, |_, id| {
        Some(if id == 1 {
            speed(100.0, 100.0)
        } else {
            speed(-100.0, -100.0)
        })
    });
    let t = w.ground_truth();
    let (r1, r2) = (t.robot(1).unwrap(), t.robot(2).unwrap());
    assert!(r1.pose.x < 0.001 && r1.z == 0.0, "{r1:?}");
    assert!(t
        .events
        .iter()
        .any(|e| e.kind == EventKind::Blocked { id: 1 }));
    assert!(r2.pose.x < -0.05 && r2.z == 0.0, "{r2:?}");
    assert!(t.events.iter().any(
        |e| matches!(e.kind, EventKind::Dropped { id: 2, height } if (height - 0.02).abs() < 1e-9)
    ));
}

fn knob_pair(dx: f64) -> World {
    let mut s = Scenario::grid(0, 1);
    // Robot 2 on robot 1's left, sides touching, shifted by dx along x.
    s.robots = vec![robot(1, 0.0, 0.0), robot(2, dx, 0.0505)];
    let mut w = World::new(&s, &key()).expect("world");
    // Pressed together by hand (robots cannot drive sideways).
    w.place(2, Pose::new(dx, 0.0499, 0.0));
    w.run_for(50_000);
    w
}

#[test]
fn side_knobs_need_sub_millimetre_alignment_and_are_rigid_once_in() {
    assert!(
        !knob_pair(0.002).ground_truth().are_coupled(1, 2),
        "2 mm off must not couple"
    );
    let mut w = knob_pair(0.0005);
    assert!(w.ground_truth().are_coupled(1, 2), "{:?}", w.links());
    assert!(w.events().iter().any(|e| e.kind
        == EventKind::Coupled {
            kind: LinkKind::Knob,
            a: 1,
            b: 2
        }));
    // Robot 1 drives, robot 2 brakes: the pair moves as one rigid body.
    let mut host = MiniHost::new(key());
    connect(&mut w, &mut host, 2.0);
    drive(&mut w, &mut host, 2.0, |_, id| {
        Some(if id == 1 {
            speed(150.0, 150.0)
        } else {
            HostMsg::Stop
        })
    });
    let t = w.ground_truth();
    let (p1, p2) = (t.robot(1).unwrap().pose, t.robot(2).unwrap().pose);
    let rel = p1.inverse_transform(p2.xy());
    assert!(p1.x.hypot(p1.y) > 0.05, "the pair moved: {p1:?}");
    assert!(
        (rel[0] - 0.0).abs() < 1e-3 && (rel[1] - 0.05).abs() < 1e-3,
        "{rel:?}"
    );
    assert!((p1.yaw - p2.yaw).abs() < 1e-3);
}

#[test]
fn lifting_a_mesh_by_hand_frees_its_knobs_and_keeps_its_rows() {
    // Two rows of two: 2 in front of 1 and 4 in front of 3 (anchors), row 3–4 on the left
    // of row 1–2, offset by half a body (THESIS 5.2.2), knobs coupled where they meet.
    let mut s = Scenario::grid(0, 1);
    s.robots = vec![
        robot(1, 0.0, 0.0),
        robot(2, 0.057, 0.0),
        robot(3, 0.0285, 0.05),
        robot(4, 0.0855, 0.05),
    ];
    s.couplings = vec![
        anchor(2, 1),
        anchor(4, 3),
        knob(1, 3),
        knob(2, 3),
        knob(2, 4),
    ];
    let mut w = World::new(&s, &key()).expect("world");
    w.run_for(50_000);
    let before = w.ground_truth();
    assert!(
        before.are_coupled(2, 3) && before.are_coupled(2, 1),
        "{:?}",
        w.links()
    );
    // Only the listed robots' knobs: none between 1 and 2 alone.
    assert!(w.lift_knobs(&[1, 2]).is_empty());
    let mut lifted = w.lift_knobs(&[1, 2, 3, 4]);
    lifted.sort_unstable();
    assert_eq!(lifted, vec![(1, 3), (2, 3), (2, 4)]);
    w.run_for(50_000);
    let t = w.ground_truth();
    for (a, b) in [(1, 3), (2, 3), (2, 4)] {
        assert!(
            !t.are_coupled(a, b),
            "{a}-{b} still coupled: {:?}",
            w.links()
        );
        assert!(t.events.iter().any(|e| e.kind
            == EventKind::Decoupled {
                kind: LinkKind::Knob,
                a,
                b
            }));
    }
    assert!(t.are_coupled(2, 1) && t.are_coupled(4, 3), "rows kept");
    // The left row was set down further left, unturned; the right row stayed.
    let (p1, p3) = (t.robot(1).unwrap().pose, t.robot(3).unwrap().pose);
    assert!((p1.y - 0.0).abs() < 1e-4, "{p1:?}");
    assert!(
        (p3.y - 0.05 - puzzlebot_sim::LIFT_APART).abs() < 2e-3,
        "{p3:?}"
    );
    assert!(p3.yaw.abs() < 1e-3, "{p3:?}");
}

#[test]
fn shipped_scenario_files_parse_and_build() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).expect("scenarios dir") {
        let path = entry.expect("entry").path();
        if path.extension().is_some_and(|e| e == "toml") {
            let s = Scenario::from_file(&path).unwrap_or_else(|e| panic!("{e}"));
            let mut w = World::new(&s, &key()).expect("world");
            w.run_for(100_000);
            assert!(
                w.ground_truth().robots.iter().all(|r| !r.fallen),
                "{}",
                path.display()
            );
            n += 1;
        }
    }
    assert!(n >= 3);
}

#[test]
fn a_lone_robot_clicked_in_beside_a_row_is_lifted_off_it_not_the_row_off_it() {
    // A row of two (2 in front of 1, anchored) and a lone robot 3 on its right, 3's knob in
    // 2's hole: the person lifts the lone robot away and the row stays where it is (before,
    // the knob robot's group always stayed: here the lone robot, and the row was moved).
    let mut s = Scenario::grid(0, 1);
    s.robots = vec![
        robot(1, 0.0, 0.0),
        robot(2, 0.057, 0.0),
        robot(3, 0.0855, -0.05),
    ];
    s.couplings = vec![anchor(2, 1), knob(3, 2)];
    let mut w = World::new(&s, &key()).expect("world");
    w.run_for(50_000);
    let before = w.ground_truth();
    assert!(before.are_coupled(3, 2), "{:?}", w.links());
    assert_eq!(w.lift_knobs(&[1, 2, 3]), vec![(3, 2)]);
    w.run_for(50_000);
    let t = w.ground_truth();
    assert!(
        !t.are_coupled(3, 2) && t.are_coupled(2, 1),
        "{:?}",
        w.links()
    );
    let y = |t: &puzzlebot_sim::GroundTruth, id| t.robot(id).unwrap().pose.y;
    for id in [1, 2] {
        assert!(
            (y(&t, id) - y(&before, id)).abs() < 1e-3,
            "robot {id} was moved across: {} -> {}",
            y(&before, id),
            y(&t, id)
        );
    }
    assert!(
        y(&before, 3) - y(&t, 3) > 0.01,
        "the lone robot was set down further right: {} -> {}",
        y(&before, 3),
        y(&t, 3)
    );
}
