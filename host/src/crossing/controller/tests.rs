//! Tests of the crossing controller.

use super::*;
use crate::control::RobotView;
use crate::drive::PoseSample;
use puzzlebot_params::formation::{self, Shape};
use puzzlebot_params::RobotKind;
use puzzlebot_stability::crossing::plan_formed;

/// Robots 1 (pilot) and 2 in a line of two, coupled by an anchor, and its plan over a
/// 40 mm gap at 0° (crossing or not: the drive is what is tested).
fn line_of_two() -> (CrossingController, Terrain, Candidate) {
    let p = FleetParams::default();
    let terrain = Terrain {
        platforms: vec![
            puzzlebot_params::terrain::Platform::rect("near", [-1.0, -0.5], [0.0, 0.5], 0.0),
            puzzlebot_params::terrain::Platform::rect("far", [0.04, -0.5], [1.0, 0.5], 0.0),
        ],
    };
    let s = CrossSettings::default();
    let opt = CrossingOptions {
        headings: vec![0.0],
        ..crossing_options(&s, &p)
    };
    let links = formation::layout(Shape::Line(2), &p.non_pilot.geometry).1;
    let plan = plan_formed(&terrain, &p, Shape::Line(2), &[0], &links, &opt).unwrap()[0].clone();
    let c = CrossingController::new(
        plan.clone(),
        terrain.clone(),
        p,
        s,
        vec![1, 2],
        vec![(LinkKind::Anchor, 1, 2)],
    );
    (c, terrain, plan)
}

fn view(t: f64, robots: &[(RobotId, RobotKind, Option<[f64; 3]>)]) -> FleetView {
    FleetView {
        t,
        robots: robots
            .iter()
            .map(|&(id, kind, p)| RobotView {
                id,
                kind,
                pose: p.map(|[x, y, theta]| PoseSample { t, x, y, theta }),
                velocity: None,
            })
            .collect(),
        latency_s: 0.0,
    }
}

#[test]
fn pilots_drive_straight_non_pilots_steer_back_and_bystanders_stand() {
    let (mut c, _, plan) = line_of_two();
    let (x1, x2) = (plan.start[0], plan.start[0] - 0.05);
    let at = |t: f64, dx: f64| {
        view(
            t,
            &[
                (1, RobotKind::Pilot, Some([x1 + dx, 0.0, 0.1])),
                (2, RobotKind::NonPilot, Some([x2 + dx, 0.0, 0.1])),
                (9, RobotKind::NonPilot, Some([-0.5, 0.3, 0.0])),
            ],
        )
    };
    let first = c.update(&at(0.0, 0.0));
    let speed = CrossSettings::default().speed;
    assert_eq!(first[&1], Twist::new(speed, 0.0));
    assert_eq!(first[&2], Twist::new(speed, 0.0));
    let next = c.update(&at(0.5, 0.002));
    assert!((c.progress().advance - 0.002).abs() < 1e-12);
    assert_eq!(next[&1].omega, 0.0, "a pilot drives straight only");
    assert!(next[&2].omega < 0.0, "turns back to 0°: {:?}", next[&2]);
    assert_eq!(next[&9], Twist::new(0.0, 0.0), "not in the assembly");
    assert!(!c.stopped());
}

#[test]
fn a_robot_without_a_pose_stops_the_crossing() {
    let (mut c, _, plan) = line_of_two();
    let x = plan.start[0];
    c.update(&view(
        0.0,
        &[
            (1, RobotKind::Pilot, Some([x, 0.0, 0.0])),
            (2, RobotKind::NonPilot, Some([x - 0.05, 0.0, 0.0])),
        ],
    ));
    let out = c.update(&view(
        0.1,
        &[
            (1, RobotKind::Pilot, Some([x, 0.0, 0.0])),
            (2, RobotKind::NonPilot, None),
        ],
    ));
    assert!(matches!(
        c.progress().stopped,
        Some((_, _, CrossStop::PoseLost(2)))
    ));
    assert!(out.values().all(|t| *t == Twist::new(0.0, 0.0)));
    assert!(c.done(0.1));
}

#[test]
fn an_assembly_turned_past_an_anchors_yaw_range_stops() {
    // The line of two with its front robot at `x`, both at `yaw`.
    let two = |t: f64, x: f64, yaw: f64| {
        view(
            t,
            &[
                (1, RobotKind::Pilot, Some([x, 0.0, yaw])),
                (2, RobotKind::NonPilot, Some([x - 0.05, 0.0, yaw])),
            ],
        )
    };
    let (mut c, _, plan) = line_of_two();
    // 0.1 m back from where the plan starts: wholly on the start platform.
    let x = plan.start[0] - 0.1;
    c.update(&two(0.0, x, 0.0));
    // 0.4 rad off (within the 0.5 rad range): steered, not stopped.
    c.update(&two(0.1, x, 0.4));
    assert!(!c.stopped());
    // 0.6 rad off: the plan no longer describes the motion.
    let out = c.update(&two(0.2, x, -0.6));
    match c.progress().stopped {
        Some((_, _, CrossStop::OffHeading(err))) => assert!((err + 0.6).abs() < 1e-9),
        ref other => panic!("{other:?}"),
    }
    assert!(out.values().all(|t| *t == Twist::new(0.0, 0.0)));
    let why =
        crate::assemble::cross_step::result(&CrossStop::OffHeading(-0.6), 0.004, None).unwrap_err();
    assert!(why.contains("turned -34° off the heading"), "{why}");
    // Bridging the edge (its front robot at the plan's start, over the edge), it drives
    // on: stopping astride is worse.
    let (mut c, _, plan) = line_of_two();
    c.update(&two(0.0, plan.start[0], 0.0));
    c.update(&two(0.1, plan.start[0], -0.6));
    assert!(!c.stopped(), "{:?}", c.progress().stopped);
}

#[test]
fn the_gate_stops_an_assembly_it_cannot_prove_and_a_bridged_stretch_is_held() {
    let (mut c, _, mut plan) = line_of_two();
    let x = plan.start[0];
    let two = |t: f64, dx: f64| {
        view(
            t,
            &[
                (1, RobotKind::Pilot, Some([x + dx, 0.0, 0.0])),
                (2, RobotKind::NonPilot, Some([x - 0.05 + dx, 0.0, 0.0])),
            ],
        )
    };
    // Set down with the back robot's centre over the gap: no support holds it.
    c.update(&two(0.0, 0.0));
    c.update(&two(0.1, 0.1));
    match &c.progress().stopped {
        Some((_, _, CrossStop::Gate(_))) => {}
        other => panic!("{other:?}"),
    }
    // It backs off over the advances checked on the way in, to the start.
    assert!(!c.done(0.1) && c.backing());
    let back = c.update(&two(0.2, 0.05));
    assert!(back[&1].v < 0.0 && back[&1].omega == 0.0, "{back:?}");
    assert!(back[&2].v < 0.0);
    let end = c.update(&two(0.3, -0.001));
    assert!(end.values().all(|t| t.v == 0.0));
    assert!(c.done(0.3));
    let to = c.progress().backed_off_to.expect("backed off");
    assert!((to + 0.001).abs() < 1e-12, "{to}");
    // A stretch proven only at speed: no check stops the drive there, and the robots are
    // asked to keep driving through it if the link falls silent.
    plan.advance.bridged = vec![[0.0, 0.2]];
    let mut c = CrossingController::new(
        plan,
        line_of_two().1,
        FleetParams::default(),
        CrossSettings::default(),
        vec![1, 2],
        vec![(LinkKind::Anchor, 1, 2)],
    );
    c.update(&two(0.0, 0.0));
    c.update(&two(0.1, 0.1));
    assert!(!c.stopped(), "{:?}", c.progress());
    assert!(c.hold_ms(1) > 0);
}

#[test]
fn the_drive_ends_at_the_proven_advance_reached_only_when_every_robot_is_across() {
    let (c, terrain, plan) = line_of_two();
    let settings = CrossSettings {
        live_gate: false,
        ..CrossSettings::default()
    };
    let links = vec![(LinkKind::Anchor, 1, 2)];
    let x = plan.start[0];
    let two = |t: f64, d1: f64, d2: f64| {
        view(
            t,
            &[
                (1, RobotKind::Pilot, Some([x + d1, 0.0, 0.0])),
                (2, RobotKind::NonPilot, Some([x - 0.05 + d2, 0.0, 0.0])),
            ],
        )
    };
    let fresh = |terrain: &Terrain| {
        CrossingController::new(
            plan.clone(),
            terrain.clone(),
            c.params.clone(),
            settings,
            vec![1, 2],
            links.clone(),
        )
    };
    // The mean advance reached, the back robot still on the near platform: it drives on,
    // as far as the gate proves from where the robots stand takes the back one across.
    let mut short = fresh(&terrain);
    let goal = short.goal();
    short.update(&two(0.0, 0.0, 0.0));
    let out = short.update(&two(1.0, goal + 0.04, goal - 0.04));
    assert!(!short.stopped(), "{:?}", short.progress());
    assert!(out.values().all(|t| t.v > 0.0), "{out:?}");
    // The back robot stands 40 mm short of where the plan puts it at the goal, whose
    // overshoot covers 25 of them: 15 mm more, and the overshoot past that.
    let further = short.goal();
    let want = goal + 0.015 + settings.overshoot;
    assert!((further - want).abs() < 1.5e-3, "{further} vs {want}");
    // Still not across at the end of that: it stops, once and for all.
    let out = short.update(&two(2.0, further + 0.1, further - 0.1));
    assert!(
        matches!(short.progress().stopped, Some((_, _, CrossStop::Short))),
        "{:?}",
        short.progress()
    );
    assert!(out.values().all(|t| t.v == 0.0), "{out:?}");
    assert!(!short.backing(), "no way back over the gap");
    // Where the far platform ends just past the front robot, no further advance is proven:
    // it stops at once.
    let mut end = terrain.clone();
    let far_end = x + goal + 0.04 + 0.03;
    end.platforms[1] =
        puzzlebot_params::terrain::Platform::rect("far", [0.04, -0.5], [far_end, 0.5], 0.0);
    let mut edge = fresh(&end);
    edge.update(&two(0.0, 0.0, 0.0));
    edge.update(&two(1.0, goal + 0.04, goal - 0.04));
    assert!(
        matches!(edge.progress().stopped, Some((_, _, CrossStop::Short))),
        "{:?}",
        edge.progress()
    );
    // Both across: reached.
    let mut across = fresh(&terrain);
    across.update(&two(0.0, 0.0, 0.0));
    across.update(&two(1.0, goal, goal));
    assert!(
        matches!(across.progress().stopped, Some((_, _, CrossStop::Reached))),
        "{:?}",
        across.progress()
    );
}

#[test]
fn a_lasting_heading_error_is_steered_out_by_the_integral() {
    let (mut c, _, plan) = line_of_two();
    let (x1, x2) = (plan.start[0], plan.start[0] - 0.05);
    // Held 0.1 rad off the heading (a pilot pulling to one side) over five seconds of
    // small advances.
    let at = |t: f64| {
        let dx = 1e-4 * t;
        view(
            t,
            &[
                (1, RobotKind::Pilot, Some([x1 + dx, 0.0, 0.1])),
                (2, RobotKind::NonPilot, Some([x2 + dx, 0.0, 0.1])),
            ],
        )
    };
    c.update(&at(0.0));
    let kp = c.settings.heading_gain;
    let first = c.update(&at(0.01))[&2].omega;
    assert!((first + kp * 0.1).abs() < 0.01 * kp, "{first}");
    let mut last = first;
    for i in 2..500 {
        last = c.update(&at(0.01 * f64::from(i)))[&2].omega;
    }
    assert!(!c.stopped(), "{:?}", c.progress());
    // Turning back harder than the proportional part alone, within its bound.
    assert!(last < 1.5 * first, "{first} -> {last}");
    assert!(last >= -kp * 1.1 - 1e-9, "{last}");
}

#[test]
fn an_assembly_beside_its_path_steers_back_onto_it() {
    let (mut c, _, plan) = line_of_two();
    let (x1, x2) = (plan.start[0], plan.start[0] - 0.05);
    let at = |t: f64, dx: f64, dy: f64| {
        view(
            t,
            &[
                (1, RobotKind::Pilot, Some([x1 + dx, dy, 0.0])),
                (2, RobotKind::NonPilot, Some([x2 + dx, dy, 0.0])),
            ],
        )
    };
    c.update(&at(0.0, 0.0, 0.0));
    // On the heading, 10 mm left of the path: turns right, towards it.
    let left = c.update(&at(0.01, 0.002, 0.01));
    assert!(left[&2].omega < 0.0, "{:?}", left[&2]);
    assert_eq!(left[&1].omega, 0.0, "a pilot drives straight only");
    // Right of it: turns left.
    let (mut c, _, _) = line_of_two();
    c.update(&at(0.0, 0.0, 0.0));
    let right = c.update(&at(0.01, 0.002, -0.01));
    assert!(right[&2].omega > 0.0, "{:?}", right[&2]);
}

#[test]
fn a_turned_assembly_turns_back_as_one_body_none_slower_than_the_crossing_speed() {
    let (mut c, _, plan) = line_of_two();
    let x = plan.start[0];
    let speed = c.settings.speed;
    // Side by side across the heading, robot 1 on the left, both turned right of it.
    let at = |t: f64, dx: f64, theta: f64| {
        view(
            t,
            &[
                (1, RobotKind::Pilot, Some([x + dx, 0.03, theta])),
                (2, RobotKind::NonPilot, Some([x + dx, -0.03, theta])),
            ],
        )
    };
    c.update(&at(0.0, 0.0, -0.05));
    let small = c.update(&at(0.01, 0.0005, -0.05));
    // Turning left about robot 1, the innermost: robot 2 on the outside drives faster by
    // the body's yaw rate times their 60 mm apart.
    let kp = c.settings.heading_gain;
    assert!((small[&1].v - speed).abs() < 1e-12, "{:?}", small[&1]);
    let rate = (small[&2].v - speed) / 0.06;
    assert!(rate > 0.9 * kp * 0.05 && rate < 1.1 * kp * 0.05, "{rate}");
    assert_eq!(small[&1].omega, 0.0, "a pilot drives straight only");
    assert!(small[&2].omega > 0.0, "{:?}", small[&2]);
    // Far off, the body's turn is capped: the outer robot at most half again as fast.
    let (mut c, _, _) = line_of_two();
    c.update(&at(0.0, 0.0, -0.4));
    let far = c.update(&at(0.01, 0.0005, -0.4));
    assert!((far[&2].v - 1.5 * speed).abs() < 1e-12, "{:?}", far[&2]);
    assert!((far[&1].v - speed).abs() < 1e-12, "{:?}", far[&1]);
    // Turned the other way, robot 2 is innermost.
    let (mut c, _, _) = line_of_two();
    c.update(&at(0.0, 0.0, 0.05));
    let other = c.update(&at(0.01, 0.0005, 0.05));
    assert!((other[&2].v - speed).abs() < 1e-12, "{:?}", other[&2]);
    assert!(other[&1].v > speed, "{:?}", other[&1]);
}
