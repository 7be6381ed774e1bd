//! Forming a shape tick by tick: the order of the pairs, the staged approaches and docking.

use super::approach::DockFrame;
use super::fixtures::*;
use super::*;

#[test]
fn mesh_2x2_rows_first_then_side_then_complete() {
    let (mut c, robots, kinds) = mesh_2x2_of_four_apart();
    let tick = c.tick(0.0, &robots);
    // One row first: forming the other row too would leave the side pair between two
    // assemblies, which cannot move sideways; its robots wait.
    assert_eq!(tick.active.len(), 1, "one row pair");
    for &i in &tick.active {
        assert_eq!(c.pairs()[i].pair.kind, PairType::AnchorOpening);
    }
    // Decoupled anchor robots aim their anchor head (THESIS Algorithm 7).
    let i = tick.active[0];
    let a = c.pairs()[i].pair.a;
    match role_of(&tick, a) {
        Role::Align { own_point, .. } => assert!((own_point[0] + 0.032).abs() < 1e-6),
        other => panic!("{other:?}"),
    }
    // Everyone on the goal: pairs pass to inserted, then connected after confirmation.
    let goal = at_goals(&c, &kinds);
    // Ticks at 10 Hz until complete: complete only once every pair has been connected for
    // form_settle_s.
    let mut all_connected = None;
    let mut t2 = c.tick(1.0, &goal);
    assert!(!t2.complete);
    for k in 1..=40 {
        let t = 1.0 + 0.1 * f64::from(k);
        t2 = c.tick(t, &goal);
        if t2.maintain.len() == 3 && all_connected.is_none() {
            all_connected = Some(t);
        }
        if all_connected == Some(t) {
            assert!(!t2.complete, "all connected, not yet settled");
        }
        if t2.complete {
            break;
        }
    }
    assert!(t2.complete, "connected for form_settle_s");
    let since = all_connected.expect("every pair connected");
    let settled = t2.t - since;
    assert!(
        (c.cfg.form_settle_s - 1e-9..c.cfg.form_settle_s + 0.15).contains(&settled),
        "complete {settled:.2} s after every pair connected"
    );
    assert!(t2
        .events
        .iter()
        .any(|e| e.kind == EventKind::FormationComplete));
    assert_eq!(t2.maintain.len(), 3);
    // Every pair's history is decoupled → aligned → inserted → connected, with times.
    for i in 0..3 {
        let steps: Vec<(f64, PairStatus)> = c
            .events()
            .iter()
            .filter_map(|e| match e.kind {
                EventKind::PairStatus { pair, to, .. } if pair == i => Some((e.t, to)),
                _ => None,
            })
            .collect();
        assert_eq!(
            steps.iter().map(|s| s.1).collect::<Vec<_>>(),
            vec![
                PairStatus::HeadAligned,
                PairStatus::HeadInserted,
                PairStatus::Connected
            ]
        );
        assert_eq!(steps[2].0, 1.5);
    }
    let json = serde_json::to_string(&c.events()[0]).unwrap();
    assert!(json.contains("\"event\":\"planned\""), "{json}");
}

/// A 2×2 mesh whose first row pair is connected, ticked until its side pair is active:
/// the coordinator, the robots, the tick, the row pair, the side pair's index and the
/// robot outside the row that joins by it.
fn row_formed_side_next() -> (
    Coordinator,
    Vec<RobotState>,
    Tick,
    PlannedPair,
    usize,
    RobotId,
) {
    let mut c = coordinator();
    let robots = four_apart();
    let kinds: BTreeMap<_, _> = robots.iter().map(|r| (r.id, r.kind)).collect();
    c.form(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, Some(0.0))
        .unwrap();
    // Connect the row pair that goes first; leave the others where they are.
    let first_tick = c.tick(0.0, &robots);
    let first = c.pairs()[first_tick.active[0]].pair;
    let goal = at_goals(&c, &kinds);
    let mixed: Vec<RobotState> = robots
        .iter()
        .map(|r| {
            if r.id == first.a || r.id == first.b {
                *goal.iter().find(|g| g.id == r.id).unwrap()
            } else {
                *r
            }
        })
        .collect();
    c.tick(0.1, &mixed);
    c.tick(0.2, &mixed);
    let tick = c.tick(1.0, &mixed);
    assert_eq!(tick.active.len(), 1, "{:?}", tick.active);
    let side = tick.active[0];
    let sp = c.pairs()[side].pair;
    let lone = if sp.a == first.a || sp.a == first.b {
        sp.b
    } else {
        sp.a
    };
    (c, mixed, tick, first, side, lone)
}

#[test]
fn a_lone_robot_docks_at_a_row_instead_of_joining_two_rows_sideways() {
    let (c, _, tick, first, side, lone) = row_formed_side_next();
    // Next: the side (knob) pair, not the other row's anchor pair.
    assert_eq!(c.pairs()[side].pair.kind, PairType::KnobHole);
    // Its robot outside the row docks (drives directly or goes to the approach's start);
    // the row holds still.
    assert!(
        matches!(role_of(&tick, lone), Role::Dock { .. } | Role::GoTo { .. }),
        "{:?}",
        role_of(&tick, lone)
    );
    for id in [first.a, first.b] {
        assert_eq!(role_of(&tick, id), &Role::Hold, "row robot {id}");
    }
}

#[test]
fn a_docking_robot_stays_off_the_side_until_it_has_passed_the_wrong_hole() {
    let (mut c, mixed, _, _, i, lone) = row_formed_side_next();
    let frame = c.dock_frame(i, lone).unwrap();
    let (_, ny) = frame.normal;
    // (v, turn towards the side) on the approach line, 3 mm out, `before` short of the
    // place and `yaw` towards the side.
    let mut drive_at = |t: f64, before: f64, yaw: f64| {
        let pose = frame
            .fin
            .compose(&Pose2::new(-before, -0.003 * ny, yaw * ny.signum()));
        let robots: Vec<RobotState> = mixed
            .iter()
            .map(|r| {
                if r.id == lone {
                    RobotState { pose, ..*r }
                } else {
                    *r
                }
            })
            .collect();
        match role_of(&c.tick(t, &robots), lone) {
            Role::Dock { v, w, .. } => (*v, w * ny.signum()),
            other => panic!("{before} m before its place: {other:?}"),
        }
    };
    // 25 mm before the place its knob passes the wrong hole: still parallel, off the side
    // (closing in all the way, it would click in there).
    let (v, far) = drive_at(1.1, 0.03, 0.0);
    assert!(
        v > 0.0 && far.abs() < 0.05,
        "turns {far} rad/s 30 mm before its place"
    );
    // Heading for the side there (its turn onto the line went on too far): it turns away
    // on the spot before it drives on.
    let (v, w) = drive_at(1.2, 0.03, 0.3);
    assert!(v == 0.0 && w < -0.5, "v {v}, turns {w} rad/s");
    // Past the wrong hole, it closes in.
    let (v, near) = drive_at(1.3, 0.01, 0.0);
    assert!(
        v > 0.0 && near > 0.2,
        "turns {near} rad/s 10 mm before its place"
    );
}

#[test]
fn a_robot_that_sweeps_over_its_place_without_a_click_backs_out_clear_and_comes_in_again() {
    let (mut c, mixed, _, _, i, lone) = row_formed_side_next();
    let frame = c.dock_frame(i, lone).unwrap();
    let (fin, (nx, ny)) = (frame.fin, frame.normal);
    let d = c.cfg.dock;
    // Distance out from the side (m) of a robot at `pose`.
    let off_side = |pose: &Pose2| {
        let here = fin.inverse_transform(pose.xy());
        -(here[0] * nx + here[1] * ny)
    };
    let mut t = 1.0;
    // The robot at `pose`: its v, and where it is after `dt` at that (v, ω).
    let mut step = |pose: &mut Pose2, dt: f64| {
        t += 0.1;
        let robots: Vec<RobotState> = mixed
            .iter()
            .map(|r| {
                if r.id == lone {
                    RobotState { pose: *pose, ..*r }
                } else {
                    *r
                }
            })
            .collect();
        let (v, w) = match role_of(&c.tick(t, &robots), lone) {
            Role::Dock { v, w, .. } => (*v, *w),
            other => panic!("at {pose:?}: {other:?}"),
        };
        *pose = Pose2::new(
            pose.x + v * dt * pose.yaw.cos(),
            pose.y + v * dt * pose.yaw.sin(),
            pose.yaw + w * dt,
        );
        v
    };
    // Flush with the side, coming in from behind its place.
    assert!(step(&mut fin.compose(&Pose2::new(-0.03, 0.0, 0.0)), 0.0) > 0.0);
    // Over its place and back, `max_passes` times, without the knob clicking in.
    for k in 0..d.max_passes {
        let past = if k % 2 == 0 { 1.0 } else { -1.0 } * (d.overshoot + 0.002);
        let v = step(&mut fin.compose(&Pose2::new(past, 0.0, 0.0)), 0.0);
        if k + 1 < d.max_passes {
            assert!(v * past < 0.0, "pass {k}: v {v} at {past} m");
        } else {
            assert!(v < 0.0, "last pass: v {v} at {past} m");
        }
    }
    // It backs out the way it came, over its place without turning back, and steers off
    // the side, where the row may straighten.
    let mut pose = fin.compose(&Pose2::new(0.005, 0.0, 0.0));
    let mut widest = 0.0_f64;
    for _ in 0..40 {
        let here = fin.inverse_transform(pose.xy());
        if -here[0] >= d.run_in {
            break;
        }
        assert!(step(&mut pose, 0.1) < 0.0, "turned back at {here:?}");
        widest = widest.max(off_side(&pose));
    }
    let here = fin.inverse_transform(pose.xy());
    assert!(-here[0] >= d.run_in, "still backing out at {here:?}");
    assert!(
        widest > d.clearance,
        "kept within {widest} m of the side (the row straightens from {} m)",
        d.clearance
    );
    // Then it comes in afresh.
    assert!(step(&mut pose, 0.0) > 0.0);
}

/// [`row_formed_side_next`] with every robot at its goal, and the other row's anchor pair
/// `j`: its robot in the side pair is in place, the other one (`me`) comes in along the
/// axis, which runs beside the first row.
struct OtherRow {
    c: Coordinator,
    goal: Vec<RobotState>,
    first: PlannedPair,
    j: usize,
    me: RobotId,
    /// `me`'s place (its partner in place).
    frame: DockFrame,
    /// Side of `me`'s connection point (+1: front).
    s: f64,
    /// Side of the axis the first row stands on (±1).
    row_side: f64,
}

fn other_row_approach() -> OtherRow {
    let (mut c, mixed, _, first, side, _) = row_formed_side_next();
    let kinds: BTreeMap<_, _> = mixed.iter().map(|r| (r.id, r.kind)).collect();
    let goal = at_goals(&c, &kinds);
    let sp = c.pairs()[side].pair;
    let j = (0..c.pairs().len())
        .find(|&k| k != side && c.pairs()[k].pair != first)
        .unwrap();
    let p = c.pairs()[j].pair;
    let me = if [sp.a, sp.b].contains(&p.a) {
        p.b
    } else {
        p.a
    };
    c.tick(1.5, &goal);
    let frame = c.dock_frame(j, me).unwrap();
    let s = frame.normal.0.signum();
    let row_side = frame
        .fin
        .inverse_transform(goal.iter().find(|r| r.id == first.a).unwrap().pose.xy())[1]
        .signum();
    OtherRow {
        c,
        goal,
        first,
        j,
        me,
        frame,
        s,
        row_side,
    }
}

#[test]
fn an_anchor_approach_beside_a_row_keeps_off_the_robots_where_they_are() {
    let OtherRow {
        mut c,
        goal,
        first,
        j,
        me,
        frame,
        s,
        row_side,
    } = other_row_approach();
    let p = c.pairs()[j].pair;
    // The first row stands 3 mm nearer the axis than planned (a bent or skewed row).
    let (sn, cs) = frame.fin.yaw.sin_cos();
    let shift = -row_side * 0.003;
    let robots: Vec<RobotState> = goal
        .iter()
        .map(|r| {
            let mut r = *r;
            if r.id == first.a || r.id == first.b {
                r.pose.x -= sn * shift;
                r.pose.y += cs * shift;
            } else if r.id == me {
                // 60 mm out on the axis, 4 mm off it away from the row, parallel.
                r.pose = frame
                    .fin
                    .compose(&Pose2::new(-s * 0.06, -row_side * 0.004, 0.0));
            }
            r
        })
        .collect();
    c.tick(2.0, &robots);
    c.dock_dir.borrow_mut().insert(
        j,
        Manoeuvre::In {
            dir: s,
            best: 0.06,
            since: 2.0,
        },
    );
    let role = c.anchor_approach_role(j, me);
    let Some(Role::Dock { v, w, .. }) = role else {
        panic!(
            "{role:?} me {me} pair {p:?} {:?} {:?}",
            c.robots.get(&me),
            frame.fin
        );
    };
    assert!(v * s > 0.0, "going in: v {v}");
    // 4 mm off the axis is 1 mm off the row's side: it steers away from the row rather than
    // holding 4 mm off the axis and sliding flush along the row's side.
    let away = w * -row_side * s;
    assert!(away > 0.1, "turns {w} rad/s (away from the row: {away})");
}

#[test]
fn an_anchor_approach_shortens_its_run_in_to_keep_clear_of_a_waiting_robot() {
    let OtherRow {
        mut c,
        goal,
        j,
        me,
        frame,
        s,
        row_side,
        ..
    } = other_row_approach();
    // The robot starts 0.4 m out and 0.3 m to the side away from the row.
    let start = frame
        .fin
        .compose(&Pose2::new(-s * 0.4, -row_side * 0.3, 0.0));
    // Another robot stands 5 cm beside the axis at the usual stand-off (as a row would).
    let beside = frame
        .fin
        .compose(&Pose2::new(-s * c.cfg.dock.standoff, row_side * 0.05, 0.0));
    let mut robots: Vec<RobotState> = goal
        .iter()
        .map(|r| {
            let mut r = *r;
            if r.id == me {
                r.pose = start;
            }
            r
        })
        .collect();
    robots.push(np(8, beside.x, beside.y, 0.0));
    c.tick(2.0, &robots);
    // The stand-off moves out past it, plus the line follower's run-in.
    let full = c.approach_standoff(&frame.fin, s, me);
    assert!(
        full >= c.cfg.dock.standoff + c.cfg.dock.flush_run_in - 1e-9,
        "stand-off {full}"
    );
    // A robot waits 4 cm beside that stand-off, on the side away from the row.
    let waiting = frame
        .fin
        .compose(&Pose2::new(-s * full, -row_side * 0.04, 0.0));
    let mut with = robots.clone();
    with.push(np(9, waiting.x, waiting.y, 0.0));
    c.tick(2.1, &with);
    let short = c.approach_standoff(&frame.fin, s, me);
    let pre = frame.fin.compose(&Pose2::new(-s * short, 0.0, 0.0));
    assert!(
        short < full && short >= full - c.cfg.dock.flush_run_in - 1e-9,
        "stand-off {short} (without the waiting robot {full})"
    );
    let gap = (pre.x - waiting.x).hypot(pre.y - waiting.y);
    assert!(
        gap >= c.room().route_clearance,
        "{gap} from the waiting robot"
    );
    // So the robot drives to it (a stand-off beside the waiting robot has no route: it
    // would hold for good).
    let role = c.anchor_approach_role(j, me);
    assert!(
        matches!(role, Some(Role::Dock { .. } | Role::GoTo { .. })),
        "{role:?}"
    );
}

#[test]
fn lone_pilot_waits_and_non_pilot_approaches_on_its_axis() {
    let mut c = coordinator();
    let mut robots = vec![np(1, 0.0, 0.0, 0.0), np(2, 0.2, 0.0, 0.0)];
    robots[1].kind = RobotKind::Pilot;
    c.form(0.0, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
    let tick = c.tick(0.0, &robots);
    assert_eq!(role_of(&tick, 2), &Role::Wait);
    // The staged approach (to the stand-off on the pilot's axis; near it, by the point
    // law), not the MPC's pair alignment, which pushes a robot that cannot move away.
    assert!(
        matches!(
            role_of(&tick, 1),
            Role::GoTo { .. } | Role::Dock { pair: 0, .. }
        ),
        "robot 1: {:?}",
        role_of(&tick, 1)
    );
    assert!(
        tick.tasks
            .iter()
            .find(|t| t.robot == 2)
            .unwrap()
            .straight_only
    );
}
