//! Moving a train (a chain of anchor pairs, THESIS 5.2.2 "line") along its leader's path.
//!
//! Every member tracks its own pose on one path: the chain as it stood when the motion
//! started, continued by the leader's velocity reference. A member `s` metres behind the
//! leader along the chain is, at every instant, `s` metres behind the leader's reference
//! along that path, heading along it. The references are absolute: a member corrects its own
//! error against its own reference and passes nothing on to the next. Driving each member's
//! connection point after its neighbour's instead (a trailer behind its hitch) hands every
//! yaw disturbance down the chain enlarged by the ratio of the anchor's lever behind the
//! neighbour's axle to the opening's ahead of the member's own (32 mm / 18 mm for the default
//! geometry), so a line of ten amplifies a tracking error of its head a hundredfold and pops
//! its anchors under latency and model mismatch.

use super::*;

/// Integration step of the leader's reference along the path (s).
const PATH_STEP_S: f64 = 0.01;

/// How far behind its place on the path a lagging member is looked for (m): beyond that it
/// has lost the train (a popped anchor, re-coupled by the formation step).
const LAG_SEARCH: f64 = 0.5;

/// The path of one train (`samples` in increasing arc length σ; σ = 0 at the leader's
/// start) and where each member sits on it.
#[derive(Debug, Clone)]
pub(super) struct TrainPath {
    /// (σ (m), pose) along the path.
    samples: Vec<(f64, Pose2)>,
    /// The leader's reference: (time after the start (s), σ (m)), from the first sample at
    /// or after σ = 0.
    times: Vec<(f64, f64)>,
    /// Each member's σ at the start: its arc length behind the leader, negative.
    place: BTreeMap<RobotId, f64>,
    /// The leader's reference: origin, target (v, ω), integrated state (x, y, yaw, t).
    start: MotionStart,
    to: [f64; 2],
    state: [f64; 4],
}

impl TrainPath {
    /// The path of a train whose members stand at `chain` (ordered along the chain, either
    /// way), led by `leader` at one of its ends, whose velocity reference starts at `start`
    /// and ramps to `to`. `None` when the leader is not an end of the chain (every member
    /// must follow it), or when the reference does not advance along one direction (turning
    /// on the spot, or reversing during the ramp): such a motion is not a path.
    pub fn new(
        chain: &[(RobotId, Pose2)],
        leader: RobotId,
        start: MotionStart,
        to: [f64; 2],
    ) -> Option<TrainPath> {
        if to[0].abs() < 1e-3 || start.from[0] * to[0] < 0.0 {
            return None;
        }
        // From the leader back along the chain: each member's arc length behind it.
        let mut order: Vec<(RobotId, Pose2)> = chain.to_vec();
        if order.last().is_some_and(|(id, _)| *id == leader) {
            order.reverse();
        }
        if order.first().is_none_or(|(id, _)| *id != leader) {
            return None;
        }
        let mut place = BTreeMap::new();
        let mut samples = Vec::with_capacity(order.len());
        let mut s = 0.0;
        for (k, (id, p)) in order.iter().enumerate() {
            if k > 0 {
                let q = order[k - 1].1;
                s -= (p.x - q.x).hypot(p.y - q.y);
            }
            place.insert(*id, s);
            samples.push((s, if k == 0 { start.pose } else { *p }));
        }
        samples.reverse();
        Some(TrainPath {
            samples,
            times: vec![(0.0, 0.0)],
            place,
            start,
            to,
            state: [0.0; 4],
        })
    }

    /// Integrates the leader's reference on to time `t` after the start (the midpoint rule
    /// of [`ramp_pose`], continued).
    fn extend_to(&mut self, t: f64) {
        let r = VELOCITY_RAMP_S;
        let (m, to) = (self.start, self.to);
        while self.state[3] < t {
            let h = PATH_STEP_S;
            let tm = self.state[3] + 0.5 * h;
            let s = (tm / r).clamp(0.0, 1.0);
            let v = m.from[0] + (to[0] - m.from[0]) * s;
            let w = m.from[1] + (to[1] - m.from[1]) * s;
            let mid = self.state[2] + 0.5 * h * w;
            self.state[0] += h * v * mid.cos();
            self.state[1] += h * v * mid.sin();
            self.state[2] += h * w;
            self.state[3] += h;
            let pose = m
                .pose
                .compose(&Pose2::new(self.state[0], self.state[1], self.state[2]));
            let last = self.samples[self.samples.len() - 1];
            let sigma = last.0 + (pose.x - last.1.x).hypot(pose.y - last.1.y);
            self.samples.push((sigma, pose));
            self.times.push((self.state[3], sigma));
        }
    }

    /// The leader's σ at time `t` after the start.
    fn sigma_at(&self, t: f64) -> f64 {
        let i = self.times.partition_point(|(tt, _)| *tt <= t);
        if i == 0 {
            return 0.0;
        }
        if i >= self.times.len() {
            return self.times[self.times.len() - 1].1;
        }
        let (t0, s0) = self.times[i - 1];
        let (t1, s1) = self.times[i];
        s0 + (s1 - s0) * ((t - t0) / (t1 - t0).max(1e-12))
    }

    /// The pose at arc length `sigma` (clamped to the path; interpolated between samples).
    fn pose_at(&self, sigma: f64) -> Pose2 {
        let i = self.samples.partition_point(|(s, _)| *s <= sigma);
        if i == 0 {
            return self.samples[0].1;
        }
        if i >= self.samples.len() {
            return self.samples[self.samples.len() - 1].1;
        }
        let (s0, p0) = self.samples[i - 1];
        let (s1, p1) = self.samples[i];
        let f = ((sigma - s0) / (s1 - s0).max(1e-12)).clamp(0.0, 1.0);
        Pose2::new(
            p0.x + (p1.x - p0.x) * f,
            p0.y + (p1.y - p0.y) * f,
            p0.yaw + wrap_angle(p1.yaw - p0.yaw) * f,
        )
    }

    /// The arc length of the path point nearest `p`, searched from `back` behind `guess` to
    /// `ahead` beyond it (a path that turns full circle passes the same place again).
    fn project(&self, p: [f64; 2], guess: f64, back: f64, ahead: f64) -> f64 {
        let lo = self.samples.partition_point(|(s, _)| *s < guess - back);
        let hi = self.samples.partition_point(|(s, _)| *s <= guess + ahead);
        let mut best = (f64::INFINITY, guess);
        for k in lo.max(1)..hi.min(self.samples.len()) {
            let ((s0, p0), (s1, p1)) = (self.samples[k - 1], self.samples[k]);
            let (dx, dy) = (p1.x - p0.x, p1.y - p0.y);
            let len2 = dx * dx + dy * dy;
            let f = if len2 > 0.0 {
                (((p[0] - p0.x) * dx + (p[1] - p0.y) * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let d = (p0.x + f * dx - p[0]).hypot(p0.y + f * dy - p[1]);
            if d < best.0 {
                best = (d, s0 + f * (s1 - s0));
            }
        }
        best.1
    }

    /// The member ahead of `member` in the direction of travel and its distance along the
    /// chain (m), or `None` for the leader.
    fn predecessor(&self, member: RobotId) -> Option<(RobotId, f64)> {
        let own = *self.place.get(&member)?;
        self.place
            .iter()
            .filter(|(_, &s)| s > own + 1e-9)
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(&id, &s)| (id, s - own))
    }

    /// `member`'s reference at the times `t + k · dt` after the start (k = 0 … `steps`), or
    /// `None` for a robot that is not in the train. A member behind another keeps its
    /// distance along the path to where that one is measured (`ahead`: its pose), advancing
    /// with the leader's reference speed over the horizon: a member that lags (slower motors
    /// than the host believes, a dead-band) is not pushed by the ones behind it, and its
    /// lag reaches them only as a position along the path, never as a turn.
    pub fn reference(
        &mut self,
        member: RobotId,
        ahead: Option<Pose2>,
        t: f64,
        dt: f64,
        steps: usize,
    ) -> Option<Vec<Pose2>> {
        let place = *self.place.get(&member)?;
        self.extend_to(t + steps as f64 * dt + PATH_STEP_S);
        let now = self.sigma_at(t);
        let from = match (self.predecessor(member), ahead) {
            (Some((_, gap)), Some(p)) => {
                let theirs = self.project(p.xy(), now + place + gap, LAG_SEARCH, 2.0 * gap);
                (theirs - gap).min(now + place)
            }
            _ => now + place,
        };
        Some(
            (0..=steps)
                .map(|k| self.pose_at(from + self.sigma_at(t + k as f64 * dt) - now))
                .collect(),
        )
    }
}

impl Coordinator {
    /// The (v, ω) a velocity behaviour asks of the segment `members`, its turn widened to a
    /// pilot's smallest radius when the segment is a train with a pilot: every member of a
    /// train follows the same path, and a pilot turns no tighter than
    /// [`CoordinatorConfig::pilot_turn_radius`] (THESIS 3.5.1, 5.4.1).
    pub(super) fn feasible_twist(&self, members: &[RobotId], [v, w]: [f64; 2]) -> [f64; 2] {
        let pilot = members.iter().any(|&m| self.kind_of(m) == RobotKind::Pilot);
        if !pilot || members.len() < 2 || self.chain_order(members).is_none() {
            return [v, w];
        }
        let max = v.abs() / self.cfg.pilot_turn_radius.max(1e-6);
        [v, w.clamp(-max, max)]
    }

    /// The members of a train (live anchor pairs among `members`) in order along the chain,
    /// from the robot whose opening is free; `None` unless the pairs form one open chain
    /// through every member.
    pub(super) fn chain_order(&self, members: &[RobotId]) -> Option<Vec<RobotId>> {
        let live = self.live_pairs(members);
        if live
            .iter()
            .any(|&i| self.pairs[i].pair.kind != PairType::AnchorOpening)
        {
            return None;
        }
        let head = members
            .iter()
            .copied()
            .find(|&r| !live.iter().any(|&i| self.pairs[i].pair.b == r))?;
        let mut order = vec![head];
        while let Some(next) = live.iter().find_map(|&i| {
            let p = &self.pairs[i].pair;
            (p.a == *order.last()?).then_some(p.b)
        }) {
            if order.contains(&next) {
                return None;
            }
            order.push(next);
        }
        (order.len() == members.len()).then_some(order)
    }

    /// References of every member of the train led by `leader` in a velocity behaviour
    /// (see the module documentation), or `None` when this motion is not one along a path
    /// (then the members are towed as trailers, [`Self::hitch_commands`]).
    pub(super) fn train_references(
        &self,
        members: &[RobotId],
        leader: RobotId,
        t: f64,
    ) -> Option<BTreeMap<RobotId, Vec<Pose2>>> {
        let Mode::Velocity { v, w } = self.mode else {
            return None;
        };
        let start = *self.motion_start.get(&leader)?;
        let mut trains = self.trains.borrow_mut();
        let path = match trains.entry(leader) {
            std::collections::btree_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::btree_map::Entry::Vacant(e) => {
                let order = self.chain_order(members)?;
                let chain: Vec<(RobotId, Pose2)> = order
                    .iter()
                    .map(|id| self.robots.get(id).map(|k| (*id, k.pose)))
                    .collect::<Option<_>>()?;
                let to = self.feasible_twist(members, [v, w]);
                e.insert(TrainPath::new(&chain, leader, start, to)?)
            }
        };
        let (dt, steps) = (self.cfg.dt, self.cfg.horizon_steps);
        members
            .iter()
            .map(|&m| {
                let ahead = path
                    .predecessor(m)
                    .and_then(|(id, _)| self.robots.get(&id))
                    .map(|k| k.pose);
                Some((m, path.reference(m, ahead, t - start.t0, dt, steps)?))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coordinator::fixtures::*;

    fn reference_of(tick: &Tick, id: RobotId) -> Vec<Pose2> {
        match role_of(tick, id) {
            Role::Track { reference } => reference.clone(),
            other => panic!("robot {id}: {other:?}"),
        }
    }

    /// Ticks from `t0` to `t1` (s) with every robot measured on its own reference of the
    /// tick before (perfect tracking), except those in `stuck`, which stay where they are.
    fn drive(
        c: &mut Coordinator,
        robots: &mut [RobotState],
        t0: f64,
        t1: f64,
        stuck: &[RobotId],
    ) -> Tick {
        let mut t = t0;
        let mut tick = c.tick(t, robots);
        while t < t1 - 1e-9 {
            for r in robots.iter_mut() {
                if let Role::Track { reference } = role_of(&tick, r.id) {
                    if !stuck.contains(&r.id) {
                        r.pose = reference[1];
                    }
                }
            }
            t += c.cfg.dt;
            tick = c.tick(t, robots);
        }
        tick
    }

    #[test]
    fn a_train_with_a_pilot_turns_no_tighter_than_the_pilot_can() {
        let mut robots = line_of_three();
        robots[2].kind = RobotKind::Pilot;
        let (c, _) = formed(ShapeSpec::Line, &robots);
        let members = [1, 2, 3];
        let widest = 0.05 / c.cfg.pilot_turn_radius;
        assert!(widest < 0.3, "the pilot's limit binds: {widest}");
        assert_eq!(c.feasible_twist(&members, [0.05, 0.3]), [0.05, widest]);
        assert_eq!(c.feasible_twist(&members, [0.05, -0.3]), [0.05, -widest]);
        assert_eq!(c.feasible_twist(&members, [0.05, 0.01]), [0.05, 0.01]);
        // Without a pilot the requested turn stands.
        let (c, _) = formed(ShapeSpec::Line, &line_of_three());
        assert_eq!(c.feasible_twist(&members, [0.05, 0.3]), [0.05, 0.3]);
    }

    #[test]
    fn a_train_in_a_velocity_behaviour_follows_its_leaders_path() {
        let robots = line_of_three();
        let (mut c, goal) = formed(ShapeSpec::Line, &robots);
        let start = |id: RobotId| goal.iter().find(|r| r.id == id).unwrap().pose;
        let (v, w) = (0.05, 0.3);
        c.set_mode(1.0, Mode::Velocity { v, w });
        let mut now = goal.clone();
        // Early on, the members behind the head advance along the chain as it stood.
        let tick = drive(&mut c, &mut now, 1.0, 1.5, &[]);
        let lead = reference_of(&tick, 1)[0];
        let advanced = (lead.x - start(1).x).hypot(lead.y - start(1).y);
        assert!(advanced > 1e-4, "the head's reference moved: {lead:?}");
        for id in [2, 3] {
            let r = reference_of(&tick, id)[0];
            assert!(
                (r.x - (start(id).x + advanced)).abs() < 1e-3 && r.y.abs() < 1e-9,
                "robot {id} on the chain behind the head: {r:?}"
            );
        }
        // Later, every member is on the head's circle (radius v / ω after the ramp), its arc
        // distance from the head's reference the one it had along the chain.
        let tick = drive(&mut c, &mut now, 1.5, 1.0 + VELOCITY_RAMP_S + 6.0, &[]);
        let head = reference_of(&tick, 1);
        let radius = v / w;
        let centre = head[0].compose(&Pose2::new(0.0, radius, 0.0));
        for (id, behind) in [(2, 0.05), (3, 0.1)] {
            let r = reference_of(&tick, id);
            assert_eq!(r.len(), head.len(), "a reference over the whole horizon");
            let off = (r[0].x - centre.x).hypot(r[0].y - centre.y) - radius;
            assert!(
                off.abs() < 2e-3,
                "robot {id} {off} off the circle: {:?}",
                r[0]
            );
            let arc = wrap_angle(head[0].yaw - r[0].yaw) * radius;
            assert!(
                (arc - behind).abs() < 5e-3,
                "robot {id}: arc {arc} behind the head"
            );
        }
        // A member that lags holds the ones behind it back: they keep their distance along
        // the path to where it is, not to where it should be.
        let mut c3 = formed(ShapeSpec::Line, &robots).0;
        c3.set_mode(1.0, Mode::Velocity { v, w });
        let mut lagging = goal.clone();
        let tick = drive(&mut c3, &mut lagging, 1.0, 6.0, &[2]);
        let r3 = reference_of(&tick, 3)[0];
        let gap = (r3.x - start(2).x).hypot(r3.y - start(2).y);
        assert!(
            (gap - 0.05).abs() < 3e-3,
            "robot 3 waits 0.05 m behind the stuck robot 2: {gap}, {r3:?}"
        );
        // Backing, the tail leads and the others follow its path the other way.
        let mut c2 = formed(ShapeSpec::Line, &robots).0;
        c2.set_mode(1.0, Mode::Velocity { v: -v, w });
        let mut back = goal.clone();
        let tick = drive(&mut c2, &mut back, 1.0, 1.0 + VELOCITY_RAMP_S + 6.0, &[]);
        let leaders: BTreeSet<_> = tick.tasks.iter().map(|t| t.leader).collect();
        assert_eq!(
            leaders,
            BTreeSet::from([Some(3)]),
            "the tail leads backwards"
        );
        let tail = reference_of(&tick, 3)[0];
        for (id, ahead) in [(2, 0.05), (1, 0.1)] {
            let r = reference_of(&tick, id)[0];
            let gap = (r.x - tail.x).hypot(r.y - tail.y);
            assert!(
                gap > 0.9 * ahead && gap <= ahead + 1e-3,
                "robot {id}: {gap} from the tail"
            );
        }
    }
}
