//! Unit tests of pair finding, matching and planning.

use super::*;
use crate::shape::SlotKind;

fn g() -> Geometry {
    Geometry::default()
}

fn robot(id: RobotId, x: f64, y: f64) -> RobotState {
    RobotState {
        id,
        kind: RobotKind::NonPilot,
        pose: Pose::new(x, y, 0.0),
    }
}

#[test]
fn line_pairs_are_anchor_front_back() {
    let s = Shape::line(4, &g()).unwrap();
    let p = s.pairs(&g());
    assert_eq!(p.len(), 3);
    for gp in &p {
        assert_eq!(gp.kind, PairType::AnchorOpening);
        assert_eq!(gp.point_a, ConnPoint::Back);
        assert_eq!(gp.point_b, ConnPoint::Front);
        // The anchor robot is the one in front.
        assert!(s.slots[gp.a].pose.x > s.slots[gp.b].pose.x);
        assert!(gp.residual < 1e-9);
    }
}

#[test]
fn mesh_2x2_pairs_rows_first_then_one_knob() {
    let s = Shape::mesh(4, 2, &g()).unwrap();
    let p = s.pairs(&g());
    assert_eq!(p.len(), 3);
    assert_eq!(p[0].kind, PairType::AnchorOpening);
    assert_eq!(p[1].kind, PairType::AnchorOpening);
    assert_eq!(p[2].kind, PairType::KnobHole);
    let k = p[2];
    assert!(matches!(
        k.point_a,
        ConnPoint::LeftFront | ConnPoint::LeftBack
    ));
    assert!(matches!(
        k.point_b,
        ConnPoint::RightFront | ConnPoint::RightBack
    ));
    // Knob robot is in the first row (y lower), hole robot in the second.
    assert!(s.slots[k.a].pose.y < s.slots[k.b].pose.y);
    assert!(p[0].centre_distance < p[2].centre_distance);
}

fn brute_force(goal: &[Pose], robots: &[RobotState]) -> f64 {
    fn rec(
        i: usize,
        goal: &[Pose],
        robots: &[RobotState],
        used: &mut Vec<bool>,
        acc: f64,
        best: &mut f64,
    ) {
        if i == goal.len() {
            *best = best.min(acc);
            return;
        }
        for r in 0..robots.len() {
            if !used[r] {
                used[r] = true;
                let d2 =
                    (goal[i].x - robots[r].pose.x).powi(2) + (goal[i].y - robots[r].pose.y).powi(2);
                rec(i + 1, goal, robots, used, acc + d2, best);
                used[r] = false;
            }
        }
    }
    let mut best = f64::INFINITY;
    rec(
        0,
        goal,
        robots,
        &mut vec![false; robots.len()],
        0.0,
        &mut best,
    );
    best
}

#[test]
fn hungarian_matches_brute_force() {
    // Deterministic pseudo-random cases (LCG), 2..=6 slots, up to 7 robots.
    let mut seed: u64 = 0x1234_5678;
    let mut rnd = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 33) as f64 / (1u64 << 31) as f64) - 0.5
    };
    for case in 0..60 {
        let n = 2 + case % 5;
        let m = n + case % 2;
        let goal: Vec<Pose> = (0..n).map(|_| Pose::new(rnd(), rnd(), 0.0)).collect();
        let robots: Vec<RobotState> = (0..m).map(|i| robot(i as RobotId, rnd(), rnd())).collect();
        let kinds = vec![SlotKind::Any; n];
        let (assign, total) = hungarian(&goal, &kinds, &robots).unwrap();
        let mut sorted = assign.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), n, "assignment must be injective");
        let best = brute_force(&goal, &robots);
        assert!(
            (total - best).abs() < 1e-6 * n as f64,
            "case {case}: {total} vs {best}"
        );
    }
}

#[test]
fn hungarian_respects_slot_kinds() {
    let goal = vec![Pose::new(0.0, 0.0, 0.0), Pose::new(1.0, 0.0, 0.0)];
    let mut robots = vec![robot(1, 0.0, 0.0), robot(2, 1.0, 0.0)];
    robots[1].kind = RobotKind::Pilot;
    let (a, _) = hungarian(&goal, &[SlotKind::Pilot, SlotKind::Any], &robots).unwrap();
    assert_eq!(a, vec![1, 0]);
    let err = hungarian(&goal, &[SlotKind::Pilot, SlotKind::Pilot], &robots);
    assert!(matches!(err, Err(PlanError::KindsUnsatisfiable)));
}

#[test]
fn align_center_moves_centroid() {
    let goal = vec![Pose::new(0.0, 0.0, 0.0), Pose::new(2.0, 0.0, 0.0)];
    let robots = vec![Pose::new(5.0, 5.0, 0.0), Pose::new(7.0, 7.0, 0.0)];
    let a = align_center(&goal, &robots);
    assert!((a[0].x - 5.0).abs() < 1e-12 && (a[0].y - 6.0).abs() < 1e-12);
    assert!((a[1].x - 7.0).abs() < 1e-12);
}

#[test]
fn a_shape_grown_around_a_robot_is_placed_on_it() {
    // The seed stands askew away from the others; its slot is its own pose, the shape's
    // heading its heading, and the others fill the remaining slots.
    let mut robots = vec![
        robot(1, 0.0, 0.0),
        robot(2, 0.3, 0.1),
        robot(3, -0.2, 0.25),
        robot(4, 0.1, -0.3),
    ];
    robots[2].pose.yaw = 0.7;
    let plan = assign_around(&ShapeSpec::Mesh { rows: 2 }, &robots, 3, &g()).unwrap();
    let slot = plan.slot_of(3).unwrap();
    let at = plan.goal_poses[slot];
    assert!(
        (at.x + 0.2).abs() < 1e-9 && (at.y - 0.25).abs() < 1e-9,
        "{at:?}"
    );
    assert!((at.yaw - 0.7).abs() < 1e-9 && (plan.heading - 0.7).abs() < 1e-9);
    let mut ids = plan.slot_robot.clone();
    ids.sort_unstable();
    assert_eq!(ids, vec![1, 2, 3, 4]);
    assert!(matches!(
        assign_around(&ShapeSpec::Line, &robots, 9, &g()),
        Err(PlanError::UnknownSeed(9))
    ));
}

#[test]
fn plan_maps_pairs_to_nearest_robots() {
    // Robots already roughly in a line, scrambled ids: the plan must pair neighbours.
    let robots = vec![robot(7, 0.10, 0.0), robot(3, 0.0, 0.0), robot(9, 0.05, 0.0)];
    let plan = assign_connection_pairs(&ShapeSpec::Line, &robots, Some(0.0), &g()).unwrap();
    assert_eq!(plan.pairs.len(), 2);
    let mut keys: Vec<_> = plan.pairs.iter().map(|p| (p.a, p.b)).collect();
    keys.sort();
    // The robot in front carries the anchor into the opening of the one behind.
    assert_eq!(keys, vec![(7, 9), (9, 3)]);
    assert!(plan.matching_cost < 1e-9);
}

#[test]
fn duplicate_and_missing_robots_are_errors() {
    let robots = vec![robot(1, 0.0, 0.0), robot(1, 0.1, 0.0)];
    assert!(matches!(
        assign_connection_pairs(&ShapeSpec::Line, &robots, None, &g()),
        Err(PlanError::DuplicateRobot(1))
    ));
    let mut r = robot(2, 0.0, 0.0);
    r.pose.x = f64::NAN;
    assert!(matches!(
        assign_connection_pairs(&ShapeSpec::Line, &[r], None, &g()),
        Err(PlanError::BadPose(2))
    ));
}
