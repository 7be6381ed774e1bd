//! Tests of the decouple behaviour.

use super::*;
use crate::coordinator::fixtures::*;

/// `robots` with the robots `ids` moved by (dx, dy).
fn moved(robots: &[RobotState], ids: &[RobotId], dx: f64, dy: f64) -> Vec<RobotState> {
    robots
        .iter()
        .map(|r| {
            let mut r = *r;
            if ids.contains(&r.id) {
                r.pose.x += dx;
                r.pose.y += dy;
            }
            r
        })
        .collect()
}

/// `robots` formed into `spec`, then decoupling every pair from t = 5 s: (coordinator,
/// poses, the pairs).
fn decoupling(
    spec: ShapeSpec,
    robots: &[RobotState],
) -> (Coordinator, Vec<RobotState>, Vec<usize>) {
    let (mut c, goal) = formed(spec, robots);
    let pairs = c.coupled_pairs();
    c.set_mode(
        5.0,
        Mode::Decouple {
            pairs: pairs.clone(),
            wiggle: Wiggle::default(),
            start: 5.0,
        },
    );
    (c, goal, pairs)
}

fn wiggling(tick: &Tick) -> Vec<(RobotId, f64)> {
    tick.tasks
        .iter()
        .filter_map(|t| match t.role {
            Role::Velocity { w, .. } => Some((t.robot, w)),
            _ => None,
        })
        .collect()
}

#[test]
fn a_knob_clicked_in_where_the_plan_has_none_is_lifted_by_hand() {
    let (mut c, _, kinds) = mesh_2x2_of_four_apart();
    let lifts = |tick: &Tick| -> Vec<Vec<(RobotId, RobotId)>> {
        tick.events
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::LiftKnobs { pairs, .. } => Some(pairs.clone()),
                _ => None,
            })
            .collect()
    };
    // The finished mesh: its rows' knobs sit in each other's holes where the shape has
    // them side by side (more than the one planned knob pair): none is lifted.
    let mut robots = at_goals(&c, &kinds);
    let tick = c.tick(0.1, &robots);
    assert!(lifts(&tick).is_empty(), "{:?}", tick.events);
    // The back robot of the second row (slot 2, at (−12.5, 25) mm) one hole (25 mm)
    // further back, beside the first row's back robot: its holes take that robot's
    // knobs, at a place the plan does not have.
    let plan = c.plan().unwrap().clone();
    let moved = plan.slot_robot[2];
    for r in robots.iter_mut().filter(|r| r.id == moved) {
        r.pose = r.pose.compose(&Pose2::new(-0.025, 0.0, 0.0));
    }
    let tick = c.tick(0.2, &robots);
    let asked = lifts(&tick);
    assert!(
        asked.len() == 1 && asked[0].iter().all(|&(a, b)| a == moved || b == moved),
        "{asked:?}"
    );
    // Asked once, not again every tick.
    let tick = c.tick(0.3, &robots);
    assert!(lifts(&tick).is_empty());
}

#[test]
fn a_released_anchor_whose_head_stays_in_is_wiggled_again() {
    let (mut c, goal, pairs) = decoupling(
        ShapeSpec::Line,
        &[np(1, 0.0, 0.0, 0.0), np(2, 0.2, 0.0, 0.0)],
    );
    let i = pairs[0];
    let (a, b) = (c.pairs()[i].pair.a, c.pairs()[i].pair.b);
    let pose = |rs: &[RobotState], id| rs.iter().find(|r| r.id == id).unwrap().pose;
    let with = |p: Pose2| -> Vec<RobotState> {
        goal.iter()
            .map(|r| {
                if r.id == a {
                    RobotState { pose: p, ..*r }
                } else {
                    *r
                }
            })
            .collect()
    };
    let seated = pose(&goal, a);
    // The anchor robot swung past the anchor's yaw range: measured apart, released.
    let swung = with(Pose2::new(seated.x, seated.y, seated.yaw + 1.2));
    let tick = c.tick(5.1, &swung);
    assert!(tick
        .events
        .iter()
        .any(|e| matches!(e.kind, EventKind::PairReleased { a: x, b: y } if (x, y) == (a, b))));
    // It swung back, its head 3 mm out of its seat (within the anchor's travel: still
    // held), and stays there: not apart, and after the clearing time wiggled again.
    let (s, co) = seated.yaw.sin_cos();
    let held = with(Pose2::new(
        seated.x + 0.003 * co,
        seated.y + 0.003 * s,
        seated.yaw,
    ));
    let mut again = false;
    let mut t = 5.2;
    while t < 12.0 && !again {
        again |=
            c.tick(t, &held).events.iter().any(
                |e| matches!(e.kind, EventKind::PairRecoupled { a: x, b: y } if (x, y) == (a, b)),
            );
        assert!(!c.decouple_done(), "t = {t}: done with the head in");
        t += 0.1;
    }
    assert!(again, "never wiggled again");
    assert!(wiggling(&c.tick(t, &held)).iter().any(|&(id, _)| id == a));
    // Driven 5 cm clear: released, and the behaviour is done.
    let clear = with(Pose2::new(
        seated.x + 0.05 * co,
        seated.y + 0.05 * s,
        seated.yaw,
    ));
    for k in 1..=5 {
        c.tick(t + 0.1 * f64::from(k), &clear);
    }
    assert!(c.decouple_done(), "{:?}", c.pairs()[i].status);
}

#[test]
fn a_mesh_is_dissolved_by_lifting_its_knobs_then_wiggling_its_anchors() {
    let (mut c, goal, pairs) = decoupling(ShapeSpec::Mesh { rows: 2 }, &four_apart());
    let knob = *pairs
        .iter()
        .find(|&&i| c.pairs()[i].pair.kind == PairType::KnobHole)
        .expect("a knob pair");
    // A person is asked to lift the knob pair; until it is out, nobody wiggles (a
    // knob-locked robot cannot turn).
    let tick = c.tick(5.1, &goal);
    let (ka, kb) = (c.pairs()[knob].pair.a, c.pairs()[knob].pair.b);
    assert!(
        tick.events.iter().any(|e| matches!(&e.kind,
            EventKind::LiftKnobs { robots, pairs } if robots.len() == 4 && pairs == &[(ka, kb)])),
        "{:?}",
        tick.events
    );
    assert!(wiggling(&tick).is_empty(), "{:?}", wiggling(&tick));
    // The hole robot's row set down 3 cm away: the knob pair is released and each row's
    // anchor robot wiggles.
    let row_b: Vec<RobotId> = goal
        .iter()
        .filter(|r| (r.pose.y - goal.iter().find(|q| q.id == kb).unwrap().pose.y).abs() < 0.01)
        .map(|r| r.id)
        .collect();
    let lifted = moved(&goal, &row_b, 0.0, 0.03);
    let tick = c.tick(5.2, &lifted);
    assert!(tick
        .events
        .iter()
        .any(|e| matches!(e.kind, EventKind::PairReleased { a, b } if (a, b) == (ka, kb))));
    let w = wiggling(&c.tick(5.3, &lifted));
    assert_eq!(w.len(), 2, "one anchor robot per row: {w:?}");
}

#[test]
fn a_train_is_wiggled_open_one_pair_per_robot_and_a_released_pair_drives_clear() {
    let robots = [
        np(1, 0.0, 0.0, 0.0),
        np(2, 0.2, 0.0, 0.0),
        np(3, 0.4, 0.0, 0.0),
    ];
    let (mut c, goal, pairs) = decoupling(ShapeSpec::Line, &robots);
    assert_eq!(pairs.len(), 2);
    // The middle robot is in both pairs: one of them wiggles at a time.
    let tick = c.tick(5.1, &goal);
    let w = wiggling(&tick);
    assert_eq!(w.len(), 1, "{w:?}");
    let first = pairs
        .iter()
        .map(|&i| c.pairs()[i].pair)
        .find(|p| p.a == w[0].0)
        .expect("the wiggler's pair");
    // Its anchor pops 8 mm out: released, but not clear. It drives straight on, its
    // partner backs straight away from it, and the other pair waits.
    let (s, co) = goal
        .iter()
        .find(|r| r.id == first.a)
        .unwrap()
        .pose
        .yaw
        .sin_cos();
    let out = moved(&goal, &[first.a], 0.008 * co, 0.008 * s);
    c.tick(5.2, &out);
    c.tick(5.25, &out);
    let tick = c.tick(5.3, &out);
    let speed = |id: RobotId| match role_of(&tick, id) {
        Role::Velocity { v, w } => (*v, *w),
        other => panic!("robot {id}: {other:?}"),
    };
    let (va, wa) = speed(first.a);
    let (vb, wb) = speed(first.b);
    assert!(
        va > 0.0 && wa == 0.0,
        "the anchor robot drives clear: {va}, {wa}"
    );
    assert!(vb < 0.0 && wb == 0.0, "its partner backs away: {vb}, {wb}");
    assert_eq!(wiggling(&tick).len(), 2, "nobody else moves: {tick:?}");
    // Clear: the other pair wiggles.
    let clear = moved(&goal, &[first.a], 0.03 * co, 0.03 * s);
    let w = wiggling(&c.tick(5.4, &clear));
    assert!(w.len() == 1 && w[0].0 != first.a, "{w:?}");
}

#[test]
fn a_pilot_held_from_behind_is_not_made_to_pull_its_anchor_out() {
    let mut robots = [
        np(1, 0.0, 0.0, 0.0),
        np(2, 0.2, 0.0, 0.0),
        np(3, 0.4, 0.0, 0.0),
        np(4, 0.6, 0.0, 0.0),
        np(5, -0.2, 0.0, 0.0),
    ];
    robots[1].kind = RobotKind::Pilot;
    let (mut c, goal) = formed(ShapeSpec::Line, &robots);
    let pairs = c.coupled_pairs();
    let chain: BTreeSet<(RobotId, RobotId)> = pairs
        .iter()
        .map(|&i| (c.pairs()[i].pair.a, c.pairs()[i].pair.b))
        .collect();
    // Pilot 2's anchor is in robot 1's opening; robot 1's own anchor is held in robot 5
    // and robot 3's anchor is held in the pilot's opening.
    assert!(
        chain.contains(&(2, 1)) && chain.contains(&(1, 5)) && chain.contains(&(3, 2)),
        "{chain:?}"
    );
    c.set_mode(
        5.0,
        Mode::Decouple {
            pairs,
            wiggle: Wiggle::default(),
            start: 5.0,
        },
    );
    for k in 1..20 {
        let tick = c.tick(5.0 + 0.1 * f64::from(k), &goal);
        // Pulling forward, the pilot would drag robot 3 by its held anchor (it cannot be
        // pulled straight out) and nothing would come apart.
        assert!(
            !matches!(role_of(&tick, 2), Role::Velocity { v, .. } if *v > 0.0),
            "the pilot pulls: {:?}",
            role_of(&tick, 2)
        );
        assert!(!wiggling(&tick).is_empty(), "nobody wiggles");
    }
}
