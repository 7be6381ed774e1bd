//! Which pairs may start now: the formation order (a pair starts only when the rest of the plan
//! can still be done after it) and, when growing, the next robot to join.

use super::*;

impl Coordinator {
    /// Non-conflicting active pairs (one per segment; THESIS Algorithm 3 busy flags lifted to
    /// segments so that each segment has one leader, 5.5.9).
    pub(super) fn choose_active(&self, segments: &BTreeMap<RobotId, usize>) -> Vec<usize> {
        if self.grow.is_some() {
            return self
                .grow_home(segments)
                .map_or_else(Vec::new, |home| self.choose_grow(segments, home));
        }
        let drivable: BTreeSet<usize> = segments
            .iter()
            .filter(|(id, _)| self.kind_of(**id) == RobotKind::NonPilot)
            .map(|(_, &s)| s)
            .collect();
        let mut busy = BTreeSet::new();
        let mut active = Vec::new();
        // A pair starts only when it can be done now and the rest of the plan can still be
        // done after it ([`Coordinator::startable`]): a side pair needs a lone non-pilot on
        // one side (rows cannot move sideways, THESIS 5.2.2: the side join needs < 1 mm), an
        // anchor pair a non-pilot on one side (THESIS 3.5.2).
        let mut merged = segments.clone();
        let decoupled: Vec<usize> = (0..self.pairs.len())
            .filter(|&i| {
                self.pairs[i].status == PairStatus::Decoupled && !self.released.contains(&i)
            })
            .collect();
        let mut startable: BTreeSet<usize> = decoupled
            .iter()
            .copied()
            .filter(|&i| self.startable(&merged, i, true))
            .collect();
        // No order completes the plan from here (e.g. both sides of every remaining side pair
        // are already assemblies): rather than deadlock, start what can be done now.
        let fallback = startable.is_empty();
        if fallback {
            startable = decoupled
                .iter()
                .copied()
                .filter(|&i| self.startable(&merged, i, false))
                .collect();
        }
        // Smallest distance bucket that still has unconnected pairs that may start.
        let open_bucket = self
            .pairs
            .iter()
            .enumerate()
            .filter(|(i, p)| {
                p.status != PairStatus::Connected
                    && !self.released.contains(i)
                    && (p.status != PairStatus::Decoupled || startable.contains(i))
            })
            .map(|(_, p)| crate::assign::distance_bucket(p.pair.centre_distance))
            .min();
        // Pairs in progress first, then the queue order (convex-first).
        let mut order: Vec<usize> = (0..self.pairs.len()).collect();
        order.sort_by_key(|&i| {
            (
                self.pairs[i].status == PairStatus::Decoupled,
                self.pairs[i].pair.order,
            )
        });
        for i in order {
            let tp = &self.pairs[i];
            if tp.status == PairStatus::Connected || self.released.contains(&i) {
                continue;
            }
            if self.cfg.strict_convex_first
                && tp.status == PairStatus::Decoupled
                && Some(crate::assign::distance_bucket(tp.pair.centre_distance)) != open_bucket
            {
                continue;
            }
            let (Some(&sa), Some(&sb)) = (segments.get(&tp.pair.a), segments.get(&tp.pair.b))
            else {
                continue;
            };
            if busy.contains(&sa) || busy.contains(&sb) {
                continue;
            }
            if !drivable.contains(&sa) && !drivable.contains(&sb) {
                continue;
            }
            // A lone robot cannot make its staged anchor approach through a robot standing on
            // the approach axis (it would push it along, THESIS 3.3.2's conflict): another
            // pair goes first (after a popped anchor, the robot that stood coupled in front
            // sits exactly there).
            if tp.status == PairStatus::Decoupled && self.approach_blocked(i, segments) {
                continue;
            }
            // Re-checked against the pairs chosen so far; a pair not startable at the start of
            // the tick is not searched again.
            if tp.status == PairStatus::Decoupled
                && (!startable.contains(&i) || !self.startable(&merged, i, !fallback))
            {
                continue;
            }
            busy.insert(sa);
            busy.insert(sb);
            active.push(i);
            // Later choices see this pair as done.
            for seg in merged.values_mut() {
                if *seg == sb {
                    *seg = sa;
                }
            }
        }
        active
    }

    /// Robot `id` is a non-pilot alone in its segment (it can drive to a pair by itself).
    pub(super) fn lone_non_pilot(&self, id: RobotId, segments: &BTreeMap<RobotId, usize>) -> bool {
        segments
            .get(&id)
            .is_some_and(|s| segments.values().filter(|&x| x == s).count() == 1)
            && self.kind_of(id) == RobotKind::NonPilot
    }

    /// Anchor pair `i` joined by a lone non-pilot's staged approach (its partner's side holds:
    /// an assembly, or pilots alone, which are not driven until coupled): (mover, partner).
    pub(super) fn lone_approach(
        &self,
        i: usize,
        segments: &BTreeMap<RobotId, usize>,
    ) -> Option<(RobotId, RobotId)> {
        let p = &self.pairs.get(i)?.pair;
        if p.kind != PairType::AnchorOpening {
            return None;
        }
        let members = |r: RobotId| {
            let s = segments.get(&r);
            segments
                .iter()
                .filter(move |(_, x)| Some(*x) == s)
                .map(|(&m, _)| m)
        };
        let lone = |r: RobotId| self.lone_non_pilot(r, segments);
        // An assembly, a pilot, or the seed a grown assembly starts from stays where it is.
        let seed = self.grow_home(segments);
        let holds = |r: RobotId| {
            members(r).count() > 1
                || members(r).all(|m| self.kind_of(m) == RobotKind::Pilot)
                || seed == Some(r)
        };
        if lone(p.a) && holds(p.b) {
            Some((p.a, p.b))
        } else if lone(p.b) && holds(p.a) {
            Some((p.b, p.a))
        } else {
            None
        }
    }

    /// Whether anchor pair `i` would be joined by a lone robot's staged approach
    /// ([`Coordinator::lone_approach`]) while another robot stands on the approach axis
    /// (centre within a body width of it: the two bodies overlap) nearer to the final place than the
    /// stand-off plus the route clearance: the stand-off would move out past that robot and
    /// the approach run through it.
    pub(super) fn approach_blocked(&self, i: usize, segments: &BTreeMap<RobotId, usize>) -> bool {
        self.approach_blockers(i, segments)
            .iter()
            .any(|&(_, _, on_axis)| on_axis)
    }

    /// The corridor of pair `i`'s staged approach: a lone robot's, or a lane train driving
    /// up to the seed (its whole way along the lane is the corridor, and it has no
    /// stand-off); with the robots it does not count (the mover's and the partner's).
    fn approach_corridor(
        &self,
        i: usize,
        segments: &BTreeMap<RobotId, usize>,
    ) -> Option<(Corridor, RobotId, RobotId)> {
        let (mover, partner, train) = match self.lone_approach(i, segments) {
            Some((m, p)) => (m, p, false),
            None => {
                let (m, p) = self.lane_train_pair(i, segments)?;
                (m, p, true)
            }
        };
        let f = self.dock_frame(i, mover)?;
        // Own connection point at the front: the approach comes from behind the place.
        let s = f.normal.0.signum();
        let room = self.room();
        let reach = if train {
            -s * f.here[0]
        } else {
            self.cfg.dock.standoff + room.route_clearance
        };
        // A train's bodies sweep the lane: anyone whose body overlaps it blocks.
        let half = if train {
            room.lane_block_half_width
        } else {
            f64::from(self.geometry.width)
        };
        let corridor = Corridor {
            fin: f.fin,
            s,
            reach,
            half,
            train,
            standoff: self.cfg.dock.standoff,
            route_clearance: room.route_clearance,
        };
        Some((corridor, mover, partner))
    }

    /// Whether a robot standing at `p` would be in the way of pair `i`'s staged approach
    /// (as [`Coordinator::approach_blockers`] counts it).
    pub(super) fn in_approach_corridor(
        &self,
        i: usize,
        segments: &BTreeMap<RobotId, usize>,
        p: [f64; 2],
    ) -> bool {
        self.approach_corridor(i, segments)
            .is_some_and(|(c, _, _)| c.test(p).is_some())
    }

    /// The robots in the way of pair `i`'s staged approach: on its axis (flag `true`, what
    /// [`Coordinator::approach_blocked`] counts) or too near its stand-off for the route
    /// there. Each comes with a place it can stand instead: beside the axis on the side it
    /// already stands, clear of the corridor by the make-way margin and of the stand-off by
    /// the route clearance ([`super::routing::Room`]) and [`DockConfig::standoff_margin`].
    pub(super) fn approach_blockers(
        &self,
        i: usize,
        segments: &BTreeMap<RobotId, usize>,
    ) -> Vec<(RobotId, Pose2, bool)> {
        let Some((c, mover, partner)) = self.approach_corridor(i, segments) else {
            return Vec::new();
        };
        let room = self.room();
        self.robots
            .iter()
            .filter(|&(&id, _)| {
                id != mover
                    && !self.lost.contains(&id)
                    && segments.get(&id) != segments.get(&partner)
                    && segments.get(&id) != segments.get(&mover)
            })
            .filter_map(|(&id, k)| {
                let (o, dx, on_axis) = c.test(k.pose.xy())?;
                let side = if o[1] < 0.0 { -1.0 } else { 1.0 };
                let clear = room.route_clearance + self.cfg.dock.standoff_margin;
                let lat =
                    (c.half + room.make_way_margin).max((clear * clear - dx * dx).max(0.0).sqrt());
                let to = c.fin.transform([o[0], side * lat]);
                Some((id, Pose2::new(to[0], to[1], k.pose.yaw), on_axis))
            })
            .collect()
    }

    /// Growing around `seed`: the pair in progress, else the pair by which the nearest lone
    /// non-pilot joins the seed's assembly (the rest of the plan still possible after it).
    pub(super) fn choose_grow(
        &self,
        segments: &BTreeMap<RobotId, usize>,
        seed: RobotId,
    ) -> Vec<usize> {
        let Some(&home) = segments.get(&seed) else {
            return Vec::new();
        };
        let open = |i: usize| !self.released.contains(&i);
        if let Some(i) = self.lane_link(segments, home) {
            return vec![i];
        }
        let joins = |i: usize| {
            let p = &self.pairs[i].pair;
            let (sa, sb) = (segments.get(&p.a), segments.get(&p.b));
            let lone = |id| self.lone_non_pilot(id, segments);
            if sa == Some(&home) && sb != Some(&home) && lone(p.b) {
                Some(p.b)
            } else if sb == Some(&home) && sa != Some(&home) && lone(p.a) {
                Some(p.a)
            } else {
                None
            }
        };
        if let Some(i) = (0..self.pairs.len()).find(|&i| {
            open(i)
                && matches!(
                    self.pairs[i].status,
                    PairStatus::HeadAligned | PairStatus::HeadInserted
                )
                && joins(i).is_some()
        }) {
            return vec![i];
        }
        (0..self.pairs.len())
            .filter(|&i| open(i) && self.pairs[i].status == PairStatus::Decoupled)
            .filter_map(|i| joins(i).map(|me| (i, me)))
            .filter(|&(i, _)| self.startable(segments, i, true))
            .min_by(|&(i, a), &(j, b)| {
                // Convex-first (rows before the side joins, THESIS 5.2.2), then the nearest.
                let bucket =
                    |k: usize| crate::assign::distance_bucket(self.pairs[k].pair.centre_distance);
                let d = |k: usize, me: RobotId| {
                    self.dock_frame(k, me)
                        .map_or(f64::INFINITY, |f| f.here[0].hypot(f.here[1]))
                };
                bucket(i).cmp(&bucket(j)).then(d(i, a).total_cmp(&d(j, b)))
            })
            .map(|(i, _)| vec![i])
            .or_else(|| self.rejoin_grown(segments, home).map(|i| vec![i]))
            .unwrap_or_default()
    }

    /// Growing with a second pilot in the seed's lane ([`Coordinator::form_grown`]), before
    /// anyone joins the seed: first the pair by which a lone non-pilot couples to that pilot
    /// where it waits (the staged approach), then the pair by which the two join the seed's
    /// assembly (they drive straight along the lane, the pilot behind). None once the lane
    /// pilot is in the seed's assembly.
    fn lane_link(&self, segments: &BTreeMap<RobotId, usize>, home: usize) -> Option<usize> {
        let pilot = self.grow_lane?;
        let own = *segments.get(&pilot)?;
        if own == home {
            return None;
        }
        let alone = segments.values().filter(|&&s| s == own).count() == 1;
        let candidates = (0..self.pairs.len()).filter(|&i| {
            let tp = &self.pairs[i];
            if self.released.contains(&i) || tp.status == PairStatus::Connected {
                return false;
            }
            let (Some(&sa), Some(&sb)) = (segments.get(&tp.pair.a), segments.get(&tp.pair.b))
            else {
                return false;
            };
            let other = match (sa == own, sb == own) {
                (true, false) => tp.pair.b,
                (false, true) => tp.pair.a,
                _ => return false,
            };
            tp.pair.kind == PairType::AnchorOpening
                && if alone {
                    self.lone_non_pilot(other, segments)
                } else {
                    segments.get(&other) == Some(&home)
                }
        });
        let candidates: Vec<usize> = candidates.collect();
        // A pair in progress first; else the first that keeps the plan completable.
        candidates
            .iter()
            .copied()
            .find(|&i| self.pairs[i].status != PairStatus::Decoupled)
            .or_else(|| {
                candidates
                    .iter()
                    .copied()
                    .filter(|&i| self.startable(segments, i, true))
                    .min_by(|&i, &j| self.pair_span(i).total_cmp(&self.pair_span(j)))
            })
    }

    /// Growing, when no lone robot can join: a pair that joins another assembly to the grown
    /// one and keeps the plan completable ([`Coordinator::startable`]: an anchor pair, the
    /// other assembly moving), the nearest first. Such assemblies appear when a coupling of
    /// the grown one comes apart, or a planned pair between two robots outside it couples out
    /// of turn (a robot docking beside the assembly backing into one waiting nearby); without
    /// this every robot would wait for good.
    fn rejoin_grown(&self, segments: &BTreeMap<RobotId, usize>, home: usize) -> Option<usize> {
        (0..self.pairs.len())
            .filter(|&i| {
                !self.released.contains(&i) && self.pairs[i].status != PairStatus::Connected
            })
            .filter(|&i| {
                let p = &self.pairs[i].pair;
                let (sa, sb) = (segments.get(&p.a), segments.get(&p.b));
                sa.is_some() && sb.is_some() && sa != sb && (sa == Some(&home) || sb == Some(&home))
            })
            .filter(|&i| self.startable(segments, i, true))
            .min_by(|&i, &j| {
                // A pair already in progress (the anchor at the mouth) first.
                let waiting = |k: usize| self.pairs[k].status == PairStatus::Decoupled;
                waiting(i)
                    .cmp(&waiting(j))
                    .then(self.pair_span(i).total_cmp(&self.pair_span(j)))
            })
    }

    /// Distance between the centres of pair `k`'s two robots (m; infinite when one is unseen).
    fn pair_span(&self, k: usize) -> f64 {
        let p = &self.pairs[k].pair;
        match (self.robots.get(&p.a), self.robots.get(&p.b)) {
            (Some(a), Some(b)) => (a.pose.x - b.pose.x).hypot(a.pose.y - b.pose.y),
            _ => f64::INFINITY,
        }
    }

    /// Can pair `i` be connected now, given robot → segment `merged`, and every other
    /// unconnected pair after it, in some order? A merge of two segments needs a non-pilot
    /// on one side (anchor pairs: that side moves, THESIS 3.5.2) or a lone non-pilot on one
    /// side (side pairs: it docks, [`Role::Dock`]); a pair inside one segment closes a loop.
    /// Depth-first over merge orders, memoised on the partition (plans are small); when the
    /// search budget runs out the pair may start. `whole_plan` false: only "now".
    pub(super) fn startable(
        &self,
        merged: &BTreeMap<RobotId, usize>,
        i: usize,
        whole_plan: bool,
    ) -> bool {
        let pending: Vec<usize> = (0..self.pairs.len())
            .filter(|&k| {
                k != i
                    && self.pairs[k].status != PairStatus::Connected
                    && !self.released.contains(&k)
            })
            .collect();
        let mut groups: BTreeMap<usize, Vec<RobotId>> = BTreeMap::new();
        for (&id, &seg) in merged {
            groups.entry(seg).or_default().push(id);
        }
        let partition: Vec<Vec<RobotId>> = groups.into_values().collect();
        let Some(after) = self.merge_if_valid(&partition, i) else {
            return false;
        };
        if !whole_plan {
            return true;
        }
        let mut seen = BTreeSet::new();
        // Bounded so a tick stays cheap on large or infeasible plans (each node clones a
        // partition): at most a few milliseconds per pair.
        let mut budget = 2_000usize;
        self.completable(after, &pending, &mut seen, &mut budget)
    }

    /// The partition after connecting pair `k`, if that merge is allowed now.
    pub(super) fn merge_if_valid(
        &self,
        part: &[Vec<RobotId>],
        k: usize,
    ) -> Option<Vec<Vec<RobotId>>> {
        let p = &self.pairs[k].pair;
        let sa = part.iter().position(|g| g.contains(&p.a))?;
        let sb = part.iter().position(|g| g.contains(&p.b))?;
        if sa == sb {
            return Some(part.to_vec());
        }
        let drivable = |g: &Vec<RobotId>| g.iter().any(|&r| self.kind_of(r) == RobotKind::NonPilot);
        let lone = |g: &Vec<RobotId>| g.len() == 1 && drivable(g);
        let ok = match p.kind {
            PairType::AnchorOpening => drivable(&part[sa]) || drivable(&part[sb]),
            PairType::KnobHole => lone(&part[sa]) || lone(&part[sb]),
        };
        if !ok {
            return None;
        }
        let mut out: Vec<Vec<RobotId>> = part
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != sa && *j != sb)
            .map(|(_, g)| g.clone())
            .collect();
        let mut joined = [part[sa].clone(), part[sb].clone()].concat();
        joined.sort_unstable();
        out.push(joined);
        out.sort();
        Some(out)
    }

    pub(super) fn completable(
        &self,
        part: Vec<Vec<RobotId>>,
        pending: &[usize],
        seen: &mut BTreeSet<(Vec<Vec<RobotId>>, Vec<usize>)>,
        budget: &mut usize,
    ) -> bool {
        if pending.is_empty() {
            return true;
        }
        if *budget == 0 {
            return true;
        }
        *budget -= 1;
        if !seen.insert((part.clone(), pending.to_vec())) {
            return false;
        }
        pending.iter().enumerate().any(|(n, &k)| {
            self.merge_if_valid(&part, k).is_some_and(|next| {
                let rest: Vec<usize> = [&pending[..n], &pending[n + 1..]].concat();
                self.completable(next, &rest, seen, budget)
            })
        })
    }
}

impl Coordinator {
    /// Forming: a lone non-pilot that waits in the corridor of an active pair's staged
    /// approach ([`Coordinator::approach_blockers`]) steps out of it. The approach chooser
    /// skips blocked pairs, but growing often has only one pair to choose, and a robot
    /// docking at a lone pilot would otherwise push against one waiting in its lane.
    pub(super) fn make_way(
        &self,
        tasks: &mut [RobotTask],
        segments: &BTreeMap<RobotId, usize>,
        active: &[usize],
    ) {
        if self.mode != Mode::Form {
            return;
        }
        for &i in active {
            if !matches!(
                self.pairs.get(i).map(|p| p.status),
                Some(PairStatus::Decoupled | PairStatus::HeadAligned)
            ) {
                continue;
            }
            for (id, goal, _) in self.approach_blockers(i, segments) {
                if let Some(task) = tasks.iter_mut().find(|t| {
                    t.robot == id
                        && self.lone_non_pilot(id, segments)
                        && matches!(t.role, Role::Hold | Role::Wait)
                }) {
                    task.role = Role::GoTo {
                        goal,
                        use_yaw: false,
                    };
                    task.leader = Some(id);
                }
            }
        }
    }
}

/// The room a staged approach sweeps ([`Coordinator::approach_blockers`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Corridor {
    /// The final place; the axis runs along its x.
    fin: Pose2,
    /// +1: the approach comes from behind the place (own connection point at the front).
    s: f64,
    /// How far out along the axis the corridor reaches (m).
    reach: f64,
    /// Half its width (m).
    half: f64,
    /// A lane train's corridor (no stand-off).
    train: bool,
    /// Stand-off distance (m).
    standoff: f64,
    /// Room the route to the stand-off keeps (m).
    route_clearance: f64,
}

impl Corridor {
    /// A body centred at `p` in the way: on the axis nearer the place than `reach`, or too
    /// near the stand-off for the route there. Some((p in the place's frame, distance out
    /// past the stand-off, on the axis)).
    fn test(&self, p: [f64; 2]) -> Option<([f64; 2], f64, bool)> {
        let o = self.fin.inverse_transform(p);
        let out = -self.s * o[0];
        let on_axis = out > 0.0 && out < self.reach && o[1].abs() < self.half;
        let dx = out - self.standoff;
        let at_standoff = !self.train && dx.hypot(o[1]) < self.route_clearance;
        (on_axis || at_standoff).then_some((o, dx, on_axis))
    }
}

#[cfg(test)]
mod tests;
