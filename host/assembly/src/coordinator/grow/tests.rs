//! Tests of `grow`.

use super::*;
use crate::coordinator::fixtures::*;

/// Pilot 1 and three non-pilots scattered round it, growing a line round the pilot: the
/// coordinator, the robots, their kinds and the line's robots in slot order.
#[allow(clippy::type_complexity)]
fn line_grown_round_pilot_1() -> (
    Coordinator,
    Vec<RobotState>,
    BTreeMap<RobotId, RobotKind>,
    Vec<RobotId>,
) {
    let mut c = coordinator();
    let robots = pilot_and_three_scattered();
    let kinds = robots.iter().map(|r| (r.id, r.kind)).collect();
    let slots = c
        .form_grown(0.0, ShapeSpec::Line, &robots, None)
        .unwrap()
        .slot_robot
        .clone();
    (c, robots, kinds, slots)
}

#[test]
fn growing_takes_one_pilot_as_its_seed_and_holds_the_assembly_still() {
    let mut c = coordinator();
    let mut robots = vec![
        np(1, 0.0, 0.0, 0.0),
        np(2, 0.3, 0.2, 1.0),
        np(3, -0.3, 0.1, 2.0),
    ];
    robots[0].kind = RobotKind::Pilot;
    robots[2].kind = RobotKind::Pilot;
    // Two pilots out of lane: the error gives the numbers.
    let err = c
        .form_grown(0.0, ShapeSpec::Line, &robots, None)
        .unwrap_err();
    assert!(
        matches!(
            err,
            PlanError::PilotsNotInLane {
                seed: 1,
                pilot: 3,
                ..
            }
        ),
        "{err}"
    );
    assert!(
        err.to_string().contains("0.100 m off pilot 1's axis"),
        "{err}"
    );
    // Three pilots: no lane takes them.
    robots[1].kind = RobotKind::Pilot;
    let err = c
        .form_grown(0.0, ShapeSpec::Line, &robots, None)
        .unwrap_err();
    assert!(
        matches!(err, PlanError::GrowPilots { pilots: 3, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("0.61 m"), "{err}");
    robots[1].kind = RobotKind::NonPilot;
    robots[2].kind = RobotKind::NonPilot;
    let plan = c.form_grown(0.0, ShapeSpec::Line, &robots, None).unwrap();
    // Built on the pilot, where it stands.
    let at = plan.goal_poses[plan.slot_of(1).unwrap()];
    assert!(at.x.abs() < 1e-9 && at.y.abs() < 1e-9 && at.yaw.abs() < 1e-9);
    let tick = c.tick(0.0, &robots);
    // One robot at a time joins the pilot; the pilot is not driven, the other drives
    // to its stand-off meanwhile (`staging`).
    assert_eq!(tick.active.len(), 1);
    assert!(matches!(role_of(&tick, 1), Role::Hold | Role::Wait));
    let moving: Vec<RobotId> = [2, 3]
        .into_iter()
        .filter(|&id| matches!(role_of(&tick, id), Role::Dock { .. } | Role::GoTo { .. }))
        .collect();
    assert_eq!(moving.len(), 2, "{:?}", tick.tasks);
}

#[test]
fn a_lane_pilot_leading_its_train_off_the_lane_backs_off_and_comes_in_again() {
    // A line on pilot 1 with pilot 2 in its lane; the seed's assembly and the train
    // behind pilot 2 formed; pilot 2 leads the train into the seed's assembly, 20 mm off
    // the lane. A pilot alone off the lane holds (it only drives straight); one leading
    // a train does not: stalled, the train backs off to come in again.
    let mut c = coordinator();
    let mut robots = vec![
        np(1, 0.0, 0.0, 0.0),
        np(2, -0.16, 0.0, 0.0),
        np(3, 0.1, 0.3, 1.0),
        np(4, -0.3, 0.3, 2.0),
        np(5, 0.2, -0.3, -1.0),
    ];
    robots[0].kind = RobotKind::Pilot;
    robots[1].kind = RobotKind::Pilot;
    c.form_grown(0.0, ShapeSpec::Line, &robots, None).unwrap();
    let kinds: BTreeMap<RobotId, RobotKind> = robots.iter().map(|r| (r.id, r.kind)).collect();
    let plan = c.plan().unwrap().clone();
    // Pilot 2's pair towards pilot 1 (the lane pair) and the robots behind it.
    let at = |id: RobotId| plan.goal_of(id).unwrap();
    let along = |id: RobotId| at(1).inverse_transform(at(id).xy())[0];
    let ahead = plan
        .pairs
        .iter()
        .find(|p| (p.a == 2 || p.b == 2) && along(if p.a == 2 { p.b } else { p.a }) > along(2))
        .map(|p| if p.a == 2 { p.b } else { p.a })
        .unwrap();
    // Everyone at its place, the train (pilot 2 and those behind it) 30 mm back and
    // 20 mm to the side.
    let shift = at(1)
        .compose(&Pose2::new(-0.03, 0.02, 0.0))
        .compose(&at(1).inverse());
    let mut placed = at_goals(&c, &kinds);
    for r in placed.iter_mut() {
        if along(r.id) <= along(2) {
            r.pose = shift.compose(&r.pose);
        }
    }
    let lane_pair = (0..c.pairs().len())
        .find(|&i| {
            let p = c.pairs()[i].pair;
            [p.a, p.b].contains(&2) && [p.a, p.b].contains(&ahead)
        })
        .unwrap();
    let mut t = 0.0;
    let mut moved = false;
    while t < 10.0 && !moved {
        t += 0.1;
        let tick = c.tick(t, &placed);
        if tick.active.contains(&lane_pair) {
            moved = matches!(role_of(&tick, 2), Role::Dock { v, .. } if *v != 0.0);
        }
    }
    assert!(moved, "the train led by pilot 2 stays held off the lane");
}

#[test]
fn a_second_pilot_in_the_lane_is_linked_to_the_seed_first() {
    // Pilot 2 set down 0.4 m behind pilot 1, facing the same way (a little off by hand);
    // four non-pilots scattered. THESIS 5.4.1: pilots move straight only.
    let mut c = coordinator();
    let mut robots = vec![
        np(1, 0.1, 0.05, 0.3),
        np(
            2,
            0.1 - 0.4 * 0.3f64.cos(),
            0.05 - 0.4 * 0.3f64.sin() + 0.004,
            0.32,
        ),
        np(3, 0.3, -0.25, 1.0),
        np(4, -0.3, 0.3, 2.0),
        np(5, 0.35, 0.3, -1.0),
        np(6, -0.1, -0.3, 0.5),
    ];
    robots[0].kind = RobotKind::Pilot;
    robots[1].kind = RobotKind::Pilot;
    // The seed given as the back pilot is refused (only the front one stays put).
    assert!(matches!(
        c.form_grown(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, Some(2)),
        Err(PlanError::GrowPilots { .. })
    ));
    let plan = c
        .form_grown(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, None)
        .unwrap()
        .clone();
    // Built on pilot 1 where it stands; pilot 2's place ahead of it on its own axis.
    let at = plan.goal_of(1).unwrap();
    assert!((at.x - 0.1).abs() < 1e-9 && (at.y - 0.05).abs() < 1e-9);
    let p2 = robots[1].pose;
    let d = p2.inverse_transform(plan.goal_of(2).unwrap().xy());
    assert!(d[0] > 0.2 && d[1].abs() < 0.012, "pilot 2's place {d:?}");
    // The robot between them: anchor pairs to both pilots.
    let link = |a: RobotId| {
        plan.pairs
            .iter()
            .filter(|p| p.kind == PairType::AnchorOpening && (p.a == a || p.b == a))
            .map(|p| if p.a == a { p.b } else { p.a })
            .collect::<Vec<_>>()
    };
    let middle = link(2)[0];
    assert!(link(1).contains(&middle), "{:?}", plan.pairs);
    // First a non-pilot couples to pilot 2 where it waits; everyone else waits.
    let tick = c.tick(0.0, &robots);
    assert_eq!(tick.active.len(), 1);
    let p = c.pairs()[tick.active[0]].pair;
    assert!([p.a, p.b].contains(&2) && [p.a, p.b].contains(&middle));
    assert!(matches!(role_of(&tick, 2), Role::Wait));
    assert!(matches!(role_of(&tick, 1), Role::Hold | Role::Wait));
    // Coupled (pose at its place in front of pilot 2): the two join pilot 1 next.
    let place = p2.compose(
        &plan
            .goal_of(2)
            .unwrap()
            .inverse()
            .compose(&plan.goal_of(middle).unwrap()),
    );
    for r in robots.iter_mut().filter(|r| r.id == middle) {
        r.pose = place;
    }
    let mut t = 0.0;
    while c.pairs()[tick.active[0]].status != PairStatus::Connected && t < 3.0 {
        t += 0.1;
        c.tick(t, &robots);
    }
    assert_eq!(c.pairs()[tick.active[0]].status, PairStatus::Connected);
    let tick = c.tick(t + 0.1, &robots);
    assert_eq!(tick.active.len(), 1);
    let q = c.pairs()[tick.active[0]].pair;
    assert!(
        [q.a, q.b].contains(&1) && [q.a, q.b].contains(&middle),
        "{q:?}"
    );
    // Pilot 2 is driven with its partner now, straight up the lane, the partner in
    // front pulling it; pilot 1 holds.
    match (role_of(&tick, middle), role_of(&tick, 2)) {
        (Role::Dock { v: v1, .. }, Role::Dock { v: v2, w: w2, .. }) => {
            assert!(
                *v1 > 0.0 && *v2 > 0.0 && v2 < v1 && *w2 == 0.0,
                "{v1} {v2} {w2}"
            );
        }
        other => panic!("train roles {other:?}"),
    }
    assert!(matches!(role_of(&tick, 1), Role::Hold | Role::Wait));
    // A robot waiting in the lane ahead of the train: the train stops and it steps aside.
    let ahead = place.compose(&Pose2::new(0.1, 0.01, 0.5));
    let other = [3, 4, 5, 6]
        .into_iter()
        .find(|&id| id != middle)
        .expect("another robot");
    for r in robots.iter_mut().filter(|r| r.id == other) {
        r.pose = ahead;
    }
    let tick = c.tick(t + 0.2, &robots);
    for id in [middle, 2] {
        assert!(
            matches!(role_of(&tick, id), Role::Dock { v, w, .. } if *v == 0.0 && *w == 0.0),
            "robot {id}: {:?}",
            role_of(&tick, id)
        );
    }
    match role_of(&tick, other) {
        Role::GoTo { goal, .. } => {
            let o = ahead.inverse_transform(goal.xy());
            assert!(o[1].abs() > 0.05, "aside: {o:?}");
        }
        r => panic!("robot {other} does not make way: {r:?}"),
    }
}

#[test]
fn a_robot_waiting_in_a_docking_lane_makes_way() {
    let (mut c, mut robots, _, _) = line_grown_round_pilot_1();
    let tick = c.tick(0.0, &robots);
    let i = tick.active[0];
    let p = c.pairs()[i].pair;
    let mover = if p.a == 1 { p.b } else { p.a };
    let waiting = [2, 3, 4]
        .into_iter()
        .find(|&id| id != mover)
        .expect("a waiting robot");
    // Put the waiting robot on the approach axis, between the stand-off and the place.
    let f = c.dock_frame(i, mover).expect("dock frame");
    let s = f.normal.0.signum();
    let at = f.fin.transform([-s * 0.06, 0.01]);
    for r in robots.iter_mut().filter(|r| r.id == waiting) {
        r.pose = Pose2::new(at[0], at[1], 0.3);
    }
    let tick = c.tick(0.1, &robots);
    assert_eq!(tick.active, vec![i], "the same pair goes on");
    match role_of(&tick, waiting) {
        Role::GoTo { goal, .. } => {
            let o = f.fin.inverse_transform(goal.xy());
            // Its body (half a width) outside the 35 mm corridor.
            assert!(
                o[1] > 0.035 + 0.025 && (o[0] + s * 0.06).abs() < 1e-9,
                "beside the corridor, on its own side: {o:?}"
            );
        }
        r => panic!("robot {waiting} does not make way: {r:?}"),
    }
    // Beside the corridor but where the approaching robot must stand off (the route
    // there keeps its clearance): it steps further out.
    let near = f.fin.transform([-s * 0.06, 0.05]);
    for r in robots.iter_mut().filter(|r| r.id == waiting) {
        r.pose = Pose2::new(near[0], near[1], 0.3);
    }
    let tick = c.tick(0.15, &robots);
    match role_of(&tick, waiting) {
        Role::GoTo { goal, .. } => {
            let o = f.fin.inverse_transform(goal.xy());
            assert!(
                o[1] > c.room().route_clearance,
                "clear of the stand-off: {o:?}"
            );
        }
        r => panic!("robot {waiting} does not make way at the stand-off: {r:?}"),
    }
    // Out of the corridor and clear of the stand-off it waits again.
    let out = f.fin.transform([-s * 0.06, 0.09]);
    for r in robots.iter_mut().filter(|r| r.id == waiting) {
        r.pose = Pose2::new(out[0], out[1], 0.3);
    }
    let tick = c.tick(0.2, &robots);
    assert!(
        matches!(role_of(&tick, waiting), Role::Hold | Role::Wait),
        "{:?}",
        role_of(&tick, waiting)
    );
}

#[test]
fn a_grown_row_is_kept_straight_at_its_planned_places_while_a_robot_joins_it() {
    let (mut c, robots, kinds, _) = line_grown_round_pilot_1();
    // The first robot to join the pilot is coupled to it at its place in the plan, but
    // bent 0.15 rad about its anchor (within the anchor's play).
    let active = c.tick(0.0, &robots).active[0];
    let first = c.pairs()[active].pair;
    let joined = if first.a == 1 { first.b } else { first.a };
    let goal = at_goals(&c, &kinds);
    let planned = goal.iter().find(|g| g.id == joined).unwrap().pose;
    // Turned about its connection point, where the two robots touch.
    let own = if joined == first.a {
        first.point_a
    } else {
        first.point_b
    };
    let w = planned.transform(own.position(&c.geometry));
    let bent = Pose2::new(w[0], w[1], 0.15).compose(&Pose2::new(
        planned.x - w[0],
        planned.y - w[1],
        planned.yaw,
    ));
    let mut now: Vec<RobotState> = robots
        .iter()
        .map(|r| match r.id {
            id if id == joined => RobotState { pose: bent, ..*r },
            _ => *r,
        })
        .collect();
    for k in 1..=10 {
        c.tick(0.1 * k as f64, &now);
    }
    assert!(c
        .pairs()
        .iter()
        .any(|p| p.pair == first && p.status == PairStatus::Connected));
    c.tick(1.1, &now);
    let tick = c.tick(1.2, &now);
    let held = |tick: &Tick, id| match role_of(tick, id) {
        Role::Keep { pose } => *pose,
        r => panic!("robot {id}: {r:?}"),
    };
    // It is kept at its planned (straight) place relative to the seed, not where it
    // stood bent: a robot docking at the side of a bent row finds no fit.
    let near = |a: Pose2, b: Pose2| a.distance(&b) < 1e-9 && wrap_angle(a.yaw - b.yaw).abs() < 1e-9;
    let at = held(&tick, joined);
    assert!(near(at, planned), "{at:?} vs {planned:?}");
    held(&tick, 1);
    // Pushed (turned about its anchor by the next robot docking): the same place.
    for r in now.iter_mut().filter(|r| r.id == joined) {
        r.pose.yaw += 0.1;
    }
    let tick = c.tick(1.3, &now);
    assert!(near(held(&tick, joined), planned));
    // The robot that joins next is not held.
    assert!(tick
        .tasks
        .iter()
        .filter(|t| t.robot != 1 && t.robot != joined)
        .all(|t| !matches!(t.role, Role::Keep { .. })));
}

#[test]
fn growing_brings_a_coupled_group_outside_the_grown_assembly_to_it() {
    let (mut c, _, kinds, slots) = line_grown_round_pilot_1();
    // The robots on the far side of the pilot coupled to each other in their places of
    // the line, but 0.3 m to the side (their coupling out of turn, or the one to the
    // pilot's side came apart); the near side joined: no lone robot is left to join.
    let at = slots.iter().position(|&id| id == 1).unwrap();
    let far: Vec<RobotId> = if at < slots.len() / 2 {
        slots[at + 1..].to_vec()
    } else {
        slots[..at].to_vec()
    };
    assert!(far.len() >= 2, "{slots:?}");
    let off: Vec<RobotState> = at_goals(&c, &kinds)
        .into_iter()
        .map(|mut r| {
            if far.contains(&r.id) {
                r.pose.y += 0.3;
            }
            r
        })
        .collect();
    for k in 0..=10 {
        c.tick(0.1 * k as f64, &off);
    }
    let segments = c.segments();
    assert!(
        far.iter().all(|id| segments[id] == segments[&far[0]])
            && slots
                .iter()
                .all(|id| far.contains(id) || segments[id] == segments[&1]),
        "{segments:?}"
    );
    // The group is brought to the grown assembly by their anchor pair; it does not wait.
    let tick = c.tick(1.1, &off);
    assert_eq!(tick.active.len(), 1, "{:?}", tick.tasks);
    let p = c.pairs()[tick.active[0]].pair;
    assert!(far.contains(&p.a) != far.contains(&p.b), "{p:?}");
    assert!(tick.tasks.iter().any(|t| far.contains(&t.robot)
        && !matches!(t.role, Role::Wait | Role::Hold | Role::Keep { .. })));
}

#[test]
fn a_grown_assembly_straightens_back_towards_where_its_formation_started() {
    let (mut c, robots, _, _) = line_grown_round_pilot_1();
    c.tick(0.0, &robots);
    let ahead = |c: &mut Coordinator, x: f64, y: f64| {
        let moved: Vec<RobotState> = robots
            .iter()
            .map(|r| match r.id {
                1 => RobotState {
                    pose: Pose2::new(x, y, 0.0),
                    ..*r
                },
                _ => *r,
            })
            .collect();
        c.tick(1.0, &moved);
    };
    // The pilot (the seed) started at the origin facing +x.
    ahead(&mut c, 0.05, 0.0);
    assert!(c.straighten_backwards(&[1, 2], 0.0));
    // Along the other heading the same place lies behind the start.
    assert!(!c.straighten_backwards(&[1, 2], std::f64::consts::PI));
    ahead(&mut c, -0.05, 0.3);
    assert!(!c.straighten_backwards(&[1, 2], 0.0));
    // An assembly without the seed straightens ahead, as it always did.
    ahead(&mut c, 0.05, 0.0);
    assert!(!c.straighten_backwards(&[2, 3], 0.0));
}
