//! Tests of `motion`.

use super::*;
use crate::coordinator::fixtures::*;

#[test]
fn assembly_moves_with_one_leader_and_decouples() {
    // Formation completes as soon as the pair connects (no settling), so the move starts.
    let (mut c, goal) = formed_pair();
    c.set_mode(0.5, Mode::Velocity { v: 0.02, w: 0.0 });
    let tick = c.tick(0.6, &goal);
    let leaders: BTreeSet<_> = tick.tasks.iter().map(|t| t.leader).collect();
    assert_eq!(leaders.len(), 1, "one segment, one leader");
    // The head of the line leads (the robot whose opening is free).
    let lead = leaders.into_iter().next().flatten().expect("a leader");
    let head = c.pairs()[0].pair.a;
    assert_eq!(lead, head, "the anchor robot stands ahead and leads");
    let follower = c.pairs()[0].pair.b;
    // The velocity becomes a reference: the leader's pose integrated at 0.02 m/s from
    // where it stood, ramped up over `VELOCITY_RAMP_S`; the robot behind it follows its
    // path ([`super::train`]).
    let Role::Track { reference: r1 } = role_of(&tick, lead) else {
        panic!("{:?}", role_of(&tick, lead));
    };
    let l = goal.iter().find(|r| r.id == lead).unwrap().pose;
    let ramp = |t: f64| t * t / (2.0 * VELOCITY_RAMP_S);
    assert!(
        (r1[1].x - (l.x + 0.02 * ramp(0.1))).abs() < 1e-9,
        "{:?}",
        r1[1]
    );
    let last = r1.len() - 1;
    assert!(r1[last].x > r1[1].x, "it accelerates: {r1:?}");
    assert!(
        matches!(role_of(&tick, follower), Role::Track { .. }),
        "{:?}",
        role_of(&tick, follower)
    );
    assert_eq!(tick.maintain.len(), 1);
    // Decouple: the anchor robot wiggles; once apart the pair is released.
    let pair = c.coupled_pairs();
    c.set_mode(
        1.0,
        Mode::Decouple {
            pairs: pair.clone(),
            wiggle: Wiggle::default(),
            start: 1.0,
        },
    );
    let a = c.pairs()[pair[0]].pair.a;
    let tick = c.tick(1.1, &goal);
    assert!(matches!(role_of(&tick, a), Role::Velocity { .. }));
    assert!(
        tick.maintain.is_empty(),
        "a pair being released is not maintained"
    );
    let apart: Vec<RobotState> = goal
        .iter()
        .map(|r| {
            if r.id == a {
                RobotState {
                    pose: Pose2::new(r.pose.x + 0.05, r.pose.y, 0.0),
                    ..*r
                }
            } else {
                *r
            }
        })
        .collect();
    let tick = c.tick(2.0, &apart);
    assert!(tick
        .events
        .iter()
        .any(|e| matches!(e.kind, EventKind::PairReleased { .. })));
    let segs: BTreeSet<_> = tick.tasks.iter().map(|t| t.segment).collect();
    assert_eq!(segs.len(), 2);
}

#[test]
fn a_velocity_behaviour_after_another_goes_on_without_stopping() {
    let (mut c, goal) = formed_pair();
    let head = c.pairs()[0].pair.a;
    let reference = |tick: &Tick| match role_of(tick, head) {
        Role::Track { reference } => reference.clone(),
        other => panic!("{other:?}"),
    };
    let dt = c.cfg.dt;
    let l = goal.iter().find(|r| r.id == head).unwrap().pose;
    c.set_mode(0.5, Mode::Velocity { v: 0.04, w: 0.0 });
    c.tick(0.5, &goal);
    // After the ramp (2 s) the reference runs at 0.04 m/s: 0.04 · (t − 0.5 − 1) from l.
    let r = reference(&c.tick(4.5, &goal));
    assert!((r[0].x - (l.x + 0.04 * 3.0)).abs() < 1e-9, "{:?}", r[0]);
    // The next velocity behaviour starts where that reference is, at its speed: the
    // first step of the new reference is a full 0.04 · dt, and it turns gradually.
    c.set_mode(4.5, Mode::Velocity { v: 0.04, w: 0.2 });
    let r = reference(&c.tick(4.5, &goal));
    assert!((r[0].x - (l.x + 0.12)).abs() < 1e-9, "{:?}", r[0]);
    let step = (r[1].x - r[0].x).hypot(r[1].y - r[0].y);
    assert!((step - 0.04 * dt).abs() < 1e-6, "step {step}");
    assert!(r[1].yaw.abs() < 0.2 * dt, "ω ramps up: {:?}", r[1]);
    let r = reference(&c.tick(4.5 + VELOCITY_RAMP_S + 1.0, &goal));
    let turn = wrap_angle(r[1].yaw - r[0].yaw);
    assert!(
        (turn - 0.2 * dt).abs() < 1e-6,
        "full ω after the ramp: {turn}"
    );
    // After a hold, a velocity behaviour starts from rest again.
    c.set_mode(8.0, Mode::Hold);
    c.set_mode(8.0, Mode::Velocity { v: 0.04, w: 0.0 });
    let r = reference(&c.tick(8.0, &goal));
    let step = (r[1].x - r[0].x).hypot(r[1].y - r[0].y);
    assert!(step < 0.04 * dt * 0.1, "from rest: step {step}");
}

#[test]
fn a_moving_mesh_keeps_its_leader_when_another_robot_heads_nearer_the_mean() {
    let mut c = coordinator();
    c.cfg.form_settle_s = 0.0;
    let robots = four_apart();
    let kinds: BTreeMap<_, _> = robots.iter().map(|r| (r.id, r.kind)).collect();
    c.form(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, Some(0.0))
        .unwrap();
    let goal = at_goals(&c, &kinds);
    let mut t = 1.0;
    while !c.tick(t, &goal).complete {
        t += 0.1;
        assert!(t < 10.0, "the mesh formed");
    }
    // Headings within noise of each other: robot `id` is the one nearest the mean.
    let tilted = |id: RobotId| -> Vec<RobotState> {
        goal.iter()
            .map(|r| {
                let mut r = *r;
                r.pose.yaw += if r.id == id {
                    0.0
                } else {
                    0.002 * f64::from(r.id)
                };
                r
            })
            .collect()
    };
    let leaders = |tick: &Tick| -> BTreeSet<Option<RobotId>> {
        tick.tasks.iter().map(|k| k.leader).collect()
    };
    c.set_mode(t, Mode::Velocity { v: 0.04, w: 0.0 });
    let first = leaders(&c.tick(t + 0.1, &tilted(1)));
    assert_eq!(first.len(), 1, "one leader: {first:?}");
    let reference = |tick: &Tick, id: RobotId| match role_of(tick, id) {
        Role::Track { reference } => reference[0],
        other => panic!("{other:?}"),
    };
    let lead = first.iter().next().copied().flatten().expect("a leader");
    let before = reference(&c.tick(t + 1.0, &tilted(1)), lead);
    // Another robot now heads nearest the mean: the lead (and the reference, which
    // a new leader restarted from rest where the mesh then stood) stays.
    for (k, id) in [4, 2, 3].into_iter().enumerate() {
        let tick = c.tick(t + 1.1 + 0.1 * k as f64, &tilted(id));
        assert_eq!(
            leaders(&tick),
            first,
            "leader with robot {id} nearest the mean"
        );
    }
    let after = reference(&c.tick(t + 2.0, &tilted(3)), lead);
    assert!(
        after.x - before.x > 0.5 * 0.04 * 0.5,
        "the reference went on: {before:?} → {after:?}"
    );
}

#[test]
fn a_train_on_a_trajectory_tows_its_members_as_trailers_and_a_mesh_keeps_its_alignment() {
    let robots = line_of_three();
    let (c0, goal) = formed(ShapeSpec::Line, &robots);
    let pose = |id: RobotId| goal.iter().find(|r| r.id == id).unwrap().pose;
    // Robot 1 (the leader) is the line's head: along +x the others are towed.
    assert!(pose(1).x > pose(2).x && pose(2).x > pose(3).x, "{goal:?}");
    let g = c0.geometry;
    // World velocity of a body point of a robot driving at (v, ω).
    let point_velocity = |p: &Pose2, v: f64, w: f64, b: [f64; 2]| {
        let (s, c) = p.yaw.sin_cos();
        let (bx, by) = (v - w * b[1], w * b[0]);
        [c * bx - s * by, s * bx + c * by]
    };
    let mut c = c0.clone();
    // A trajectory of the shape's centre (the middle robot) that turns left at about
    // 0.3 rad/s and 0.05 m/s.
    let centre = Pose2::new(-0.1, 0.0, 0.0);
    let along = |sign: f64| Mode::Track {
        trajectory: Trajectory {
            waypoints: vec![
                (0.0, centre),
                (
                    10.0,
                    centre.compose(&Pose2::new(sign * 0.5 * 0.95, 0.5 * 0.3, sign * 3.0)),
                ),
            ],
        },
        start: 1.0,
    };
    c.set_mode(1.0, along(1.0));
    c.tick(1.0, &goal);
    let tick = c.tick(2.0, &goal);
    let Role::Track { reference } = role_of(&tick, 1) else {
        panic!("{:?}", role_of(&tick, 1));
    };
    let step = reference[0].relative(&reference[1]);
    let mut twist = BTreeMap::from([(1, (step.x / c.cfg.dt, step.yaw / c.cfg.dt))]);
    assert!(twist[&1].0 > 0.01 && twist[&1].1 > 0.05, "{twist:?}");
    // Each member moves its connection point exactly as its neighbour towards the head
    // moves the point it hangs at (the robots stand seated: no gap to close).
    for (me, next) in [(2, 1), (3, 2)] {
        let Role::Hitch { pair, v, w } = *role_of(&tick, me) else {
            panic!("robot {me}: {:?}", role_of(&tick, me));
        };
        let p = c.pairs()[pair].pair;
        let (own, theirs) = if p.a == me {
            (p.point_a, p.point_b)
        } else {
            (p.point_b, p.point_a)
        };
        assert_eq!(
            if p.a == me { p.b } else { p.a },
            next,
            "robot {me} hangs at {next}"
        );
        let (vn, wn) = twist[&next];
        let want = point_velocity(&pose(next), vn, wn, theirs.position(&g));
        let got = point_velocity(&pose(me), v, w, own.position(&g));
        assert!(
            (want[0] - got[0]).abs() < 1e-9 && (want[1] - got[1]).abs() < 1e-9,
            "robot {me}: {got:?} for {want:?}"
        );
        twist.insert(me, (v, w));
    }
    // The head turning left swings its back (and robot 2's front) to the right first.
    assert!(twist[&2].1 < 0.0 && twist[&3].1 > 0.0, "{twist:?}");
    // Driven backwards the members would jackknife as trailers: they keep the MPC's
    // alignment of their pairs.
    let mut c = c0.clone();
    c.set_mode(1.0, along(-1.0));
    let tick = c.tick(2.0, &goal);
    for me in [2, 3] {
        assert!(
            matches!(role_of(&tick, me), Role::Align { .. }),
            "robot {me}: {:?}",
            role_of(&tick, me)
        );
    }
    // A mesh's members hanging at anchors stand beside others: no trailers there.
    let (mut c, goal) = formed(
        ShapeSpec::Mesh { rows: 2 },
        &[
            np(1, 0.0, 0.0, 0.0),
            np(2, -0.1, 0.0, 0.0),
            np(3, 0.0, 0.1, 0.0),
            np(4, -0.1, 0.1, 0.0),
        ],
    );
    c.set_mode(1.0, Mode::Velocity { v: 0.05, w: 0.3 });
    let tick = c.tick(2.0, &goal);
    assert!(
        tick.tasks
            .iter()
            .all(|t| !matches!(t.role, Role::Hitch { .. })),
        "{:?}",
        tick.tasks
    );
}
