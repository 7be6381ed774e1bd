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
mod tests;
