//! Moving an assembly: the velocity reference, the segment's leader, and how every member
//! follows it (rigid part, trains hanging at anchors).

use super::*;

/// Ramp of a velocity behaviour's reference (s): it accelerates uniformly over this time, so
/// every member of an assembly starts together (a step left the slowest behind, straining
/// and popping anchors). A velocity behaviour that follows another one directly ramps from
/// the previous (v, ω) instead of from rest, so chained moves do not stop in between.
pub const VELOCITY_RAMP_S: f64 = 2.0;

/// Integration step of the ramp's reference (s).
const RAMP_STEP_S: f64 = 0.005;

/// Where a velocity behaviour's reference starts: the segment leader's pose, the time, and
/// the (v, ω) it ramps from (rest, or the previous velocity behaviour's command).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct MotionStart {
    /// Origin of the reference.
    pub pose: Pose2,
    /// Time of the origin (s).
    pub t0: f64,
    /// (v, ω) at the origin.
    pub from: [f64; 2],
}

/// Pose after moving from `start` for `t` s at constant (v, ω) (unicycle arc, THESIS (2.1)).
pub(super) fn arc(start: &Pose2, v: f64, w: f64, t: f64) -> Pose2 {
    let t = t.max(0.0);
    let (dx, dy) = if w.abs() < 1e-9 {
        (v * t, 0.0)
    } else {
        let r = v / w;
        (r * (w * t).sin(), r * (1.0 - (w * t).cos()))
    };
    start.compose(&Pose2::new(dx, dy, w * t))
}

/// (v, ω) of the reference `t` s after `m`'s origin (see [`ramp_pose`]).
pub(super) fn ramp_velocity(m: &MotionStart, to: [f64; 2], t: f64) -> [f64; 2] {
    let s = (t / VELOCITY_RAMP_S).clamp(0.0, 1.0);
    [
        m.from[0] + (to[0] - m.from[0]) * s,
        m.from[1] + (to[1] - m.from[1]) * s,
    ]
}

/// Pose `t` s after `m`'s origin of a reference whose (v, ω) goes linearly from `m.from` to
/// `to` over [`VELOCITY_RAMP_S`] and stays at `to` (unicycle (2.1); the ramp is integrated
/// with the midpoint rule, the rest is an exact arc).
pub(super) fn ramp_pose(m: &MotionStart, to: [f64; 2], t: f64) -> Pose2 {
    let r = VELOCITY_RAMP_S;
    let t = t.max(0.0);
    let in_ramp = t.min(r);
    let n = (in_ramp / RAMP_STEP_S).ceil().max(1.0) as usize;
    let h = in_ramp / n as f64;
    let (mut x, mut y, mut th) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let s = (i as f64 + 0.5) * h / r;
        let v = m.from[0] + (to[0] - m.from[0]) * s;
        let w = m.from[1] + (to[1] - m.from[1]) * s;
        let mid = th + 0.5 * h * w;
        x += h * v * mid.cos();
        y += h * v * mid.sin();
        th += h * w;
    }
    let end = m.pose.compose(&Pose2::new(x, y, th));
    arc(&end, to[0], to[1], t - in_ramp)
}

impl Coordinator {
    /// Connected, unreleased pairs between two of `members`.
    pub(super) fn live_pairs(&self, members: &[RobotId]) -> Vec<usize> {
        (0..self.pairs.len())
            .filter(|i| {
                let p = &self.pairs[*i];
                p.status == PairStatus::Connected
                    && !self.released.contains(i)
                    && members.contains(&p.pair.a)
                    && members.contains(&p.pair.b)
            })
            .collect()
    }

    /// For moving a segment from `leader`: the members knob-locked to the leader (its rigid
    /// part), and for every other member the connected pair and neighbour that link it
    /// towards the leader (breadth-first over connected pairs).
    #[allow(clippy::type_complexity)]
    pub(super) fn links_towards(
        &self,
        members: &[RobotId],
        leader: RobotId,
    ) -> (BTreeSet<RobotId>, BTreeMap<RobotId, (usize, RobotId)>) {
        let live = self.live_pairs(members);
        let bfs = |knobs_only: bool| {
            let mut via = BTreeMap::new();
            let mut queue = std::collections::VecDeque::from([leader]);
            let mut seen = BTreeSet::from([leader]);
            while let Some(r) = queue.pop_front() {
                for &i in &live {
                    let p = &self.pairs[i].pair;
                    if knobs_only && p.kind != PairType::KnobHole {
                        continue;
                    }
                    let other = if p.a == r {
                        p.b
                    } else if p.b == r {
                        p.a
                    } else {
                        continue;
                    };
                    if seen.insert(other) {
                        via.insert(other, (i, r));
                        queue.push_back(other);
                    }
                }
            }
            (seen, via)
        };
        let (rigid, _) = bfs(true);
        let (_, via) = bfs(false);
        (rigid, via)
    }

    /// Members of each segment, by id.
    pub(super) fn members(segments: &BTreeMap<RobotId, usize>) -> BTreeMap<usize, Vec<RobotId>> {
        let mut m: BTreeMap<usize, Vec<RobotId>> = BTreeMap::new();
        for (&id, &s) in segments {
            m.entry(s).or_default().push(id);
        }
        m
    }

    /// Leader of a segment for assembly motion: of a chain of anchors (a train) the end
    /// that leads in the direction of travel ([`Self::train_leader`]);
    /// of a rigid assembly the non-pilot heading closest to the members' mean
    /// heading (a robot hanging askew at an anchor would lead the rigid rest sideways);
    /// without non-pilots the lowest id. A member that already leads this motion (its start
    /// is recorded) keeps leading: chosen afresh each tick, the lead flipped between robots
    /// of a rigid mesh whose headings agree to noise, and each new leader restarted the
    /// reference from rest where the mesh then was.
    pub(super) fn motion_leader(&self, members: &[RobotId]) -> RobotId {
        if let Some(&id) = members.iter().find(|id| self.motion_start.contains_key(id)) {
            return id;
        }
        let live = self.live_pairs(members);
        if live
            .iter()
            .all(|&i| self.pairs[i].pair.kind == PairType::AnchorOpening)
        {
            // A chain of anchors (THESIS 5.2.2 "line") moves as a train behind its head.
            return self.train_leader(members, &live);
        }
        let poses: Vec<Pose2> = members
            .iter()
            .filter_map(|id| self.robots.get(id).map(|k| k.pose))
            .collect();
        let mean = crate::assign::mean_heading(&poses);
        members
            .iter()
            .copied()
            .filter(|&id| self.kind_of(id) == RobotKind::NonPilot)
            .min_by(|&a, &b| {
                let off = |id: RobotId| {
                    self.robots
                        .get(&id)
                        .map_or(f64::INFINITY, |k| wrap_angle(k.pose.yaw - mean).abs())
                };
                off(a).total_cmp(&off(b))
            })
            .unwrap_or(members[0])
    }

    /// Leader of a train (a chain of anchor pairs `live` among `members`): the end that
    /// leads in the direction of travel (the head, whose opening is free, when driving
    /// forwards; the tail, whose anchor is free, when backing), pilot or not. Every other
    /// member follows it along its path ([`super::train`]) and nobody is pushed: a member
    /// pushed from behind buckles the chain at its anchors (a pushed pilot, which turns no
    /// tighter than its butterfly allows, jackknifes until the anchor's yaw range pops a
    /// leg, THESIS 4.2.2), while a towed chain straightens behind its head.
    fn train_leader(&self, members: &[RobotId], live: &[usize]) -> RobotId {
        let backwards = match &self.mode {
            Mode::Velocity { v, .. } => *v < 0.0,
            _ => false,
        };
        // The leading end: nobody ahead of it in the direction of travel (the anchor robot
        // of a pair stands ahead of the opening robot).
        members
            .iter()
            .copied()
            .find(|&r| {
                !live.iter().any(|&i| {
                    let p = &self.pairs[i].pair;
                    if backwards {
                        p.a == r
                    } else {
                        p.b == r
                    }
                })
            })
            // A closed loop of anchors has no end: its lowest-id non-pilot leads.
            .unwrap_or_else(|| {
                members
                    .iter()
                    .copied()
                    .find(|&id| self.kind_of(id) == RobotKind::NonPilot)
                    .unwrap_or(members[0])
            })
    }

    /// Pose of `member` in `leader`'s body frame: planned when both are in the plan.
    pub(super) fn follow_offset(&self, member: RobotId, leader: RobotId) -> Pose2 {
        if let Some(plan) = &self.plan {
            if let (Some(m), Some(l)) = (plan.slot_of(member), plan.slot_of(leader)) {
                return plan.shape.slots[l].pose.relative(&plan.shape.slots[m].pose);
            }
        }
        match (self.robots.get(&leader), self.robots.get(&member)) {
            (Some(l), Some(m)) => l.pose.relative(&m.pose),
            _ => Pose2::default(),
        }
    }

    /// Goal of a segment leader when the shape centre should be at `goal`: its slot placed at
    /// the goal (or the goal itself without a plan).
    pub(super) fn leader_goal(&self, leader: RobotId, goal: &Pose2) -> Pose2 {
        match &self.plan {
            Some(plan) => match plan.slot_of(leader) {
                Some(s) => goal.compose(&plan.shape.slots[s].pose),
                None => *goal,
            },
            None => *goal,
        }
    }
}

/// World velocity of the body point `p` of a robot at `pose` driving at (v, ω) (unicycle
/// (2.1) plus ω × p).
fn point_velocity(pose: &Pose2, twist: [f64; 2], p: [f64; 2]) -> [f64; 2] {
    let (s, c) = pose.yaw.sin_cos();
    let (bx, by) = (twist[0] - twist[1] * p[1], twist[1] * p[0]);
    [c * bx - s * by, s * bx + c * by]
}

/// (v, ω) that moves the body point `p` (`p[0]` ≠ 0) of a robot at `pose` at the world
/// velocity `u`: a point off the wheel axle of a unicycle is fully actuated, so the point
/// kinematics of [`point_velocity`] invert exactly.
fn drive_point(pose: &Pose2, p: [f64; 2], u: [f64; 2]) -> [f64; 2] {
    let (s, c) = pose.yaw.sin_cos();
    let (bx, by) = (c * u[0] + s * u[1], -s * u[0] + c * u[1]);
    let w = by / p[0];
    [bx + w * p[1], w]
}

impl Coordinator {
    /// Moving a train (a chain of anchors) whose `leader` tracks `reference` (samples
    /// [`CoordinatorConfig::dt`] apart): the direct (v, ω) of every member behind it, `via`
    /// naming each member's pair and neighbour towards the leader (a tractor and its
    /// trailers). Each drives its connection point with the velocity of its neighbour's (the
    /// leader's from the reference, every other's from its own command) plus
    /// [`CoordinatorConfig::hitch_gain`] times the gap between the two, and its heading follows by itself as a
    /// trailer's does behind its hitch. That is stable only while the hitch leads the
    /// member's axle in the direction of travel: a member pushed backwards, a pilot
    /// (straight only) and everything hanging behind them get no command here (they keep
    /// the MPC's pair alignment).
    pub(super) fn hitch_commands(
        &self,
        leader: RobotId,
        reference: &[Pose2],
        via: &BTreeMap<RobotId, (usize, RobotId)>,
    ) -> BTreeMap<RobotId, [f64; 2]> {
        let pose = |id: &RobotId| self.robots.get(id).map(|k| k.pose);
        let mut out = BTreeMap::new();
        let (Some(r0), Some(r1)) = (reference.first(), reference.get(1)) else {
            return out;
        };
        let step = r0.relative(r1);
        let dt = self.cfg.dt.max(1e-6);
        // Every member's (v, ω) as far as it is known.
        let mut twist = BTreeMap::from([(leader, [step.x / dt, step.yaw / dt])]);
        let mut progress = true;
        while progress {
            progress = false;
            for (&m, &(i, next)) in via {
                let p = &self.pairs[i].pair;
                if twist.contains_key(&m) || p.kind != PairType::AnchorOpening {
                    continue;
                }
                let (Some(tn), Some(pn), Some(pm)) =
                    (twist.get(&next).copied(), pose(&next), pose(&m))
                else {
                    continue;
                };
                let (own, theirs) = if m == p.a {
                    (p.point_a, p.point_b)
                } else {
                    (p.point_b, p.point_a)
                };
                let (own, theirs) = (
                    own.position(&self.geometry),
                    theirs.position(&self.geometry),
                );
                if own[0].abs() < 1e-3 {
                    continue;
                }
                let ff = point_velocity(&pn, tn, theirs);
                // Pushed backwards (the hitch trails the axle): a trailer would jackknife.
                let along = (ff[0] * pm.yaw.cos() + ff[1] * pm.yaw.sin()) * own[0].signum();
                if along < -1e-3 {
                    continue;
                }
                let [hx, hy] = pn.transform(theirs);
                let [ox, oy] = pm.transform(own);
                let u = [
                    ff[0] + self.cfg.hitch_gain * (hx - ox),
                    ff[1] + self.cfg.hitch_gain * (hy - oy),
                ];
                let [v, w] = drive_point(&pm, own, u);
                // A pilot turns no tighter than its smallest radius (THESIS 3.5.1, 5.4.1).
                let max_turn = match self.kind_of(m) {
                    RobotKind::Pilot => v.abs() / self.cfg.pilot_turn_radius.max(1e-6),
                    RobotKind::NonPilot => self.cfg.hitch_max_turn,
                };
                let w = w.clamp(-max_turn, max_turn);
                twist.insert(m, [v, w]);
                out.insert(m, [v, w]);
                progress = true;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
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
}
