//! Wiggling pairs apart: the decouple behaviour's anchor robots and unplanned couplings
//! (THESIS (5.7), closed loop on the measured relative yaw).

use super::*;

/// A robot wiggling a pair apart.
#[derive(Debug, Clone, Copy)]
pub(super) struct Wiggler {
    pub(super) robot: RobotId,
    pub(super) partner: RobotId,
    /// +1: pulls forward (the anchor robot); −1: backs off (the opening robot of a pilot's
    /// anchor).
    v_sign: f64,
    wiggle: Wiggle,
    /// When the wiggle started (s).
    start: f64,
    /// Released: drives straight on (no turning) until its anchor head is clear.
    pub(super) clearing: bool,
    /// A pilot whose anchor is in the wiggling robot's opening while that robot's own anchor
    /// is still held behind it: the wiggling robot turns where it is and the pilot pulls
    /// its anchor out straight ahead (pilots move straight only, THESIS 5.4.1).
    pub(super) puller: Option<RobotId>,
}

/// Release bookkeeping of a decouple behaviour ([`Coordinator::update_released`]).
#[derive(Debug, Clone, Default)]
pub(super) struct ReleaseWatch {
    /// When each released pair was released (s).
    at: BTreeMap<usize, f64>,
    /// Pairs wiggled again because their head stayed in after release: released only once
    /// the head is clear.
    stuck: BTreeSet<usize>,
}

impl Coordinator {
    /// Robots that wiggle now: one robot of each of a decouple behaviour's anchor pairs
    /// ([`Coordinator::wiggling_side`]; one pair per robot at a time, a released pair's robot
    /// driving clear first) once its knob pairs are out of their holes (lifted by hand, [`EventKind::LiftKnobs`]:
    /// a knob-locked robot cannot turn), and one robot of every unplanned coupling (the
    /// anchor robot, or the opening robot backing off when the anchor is a pilot's).
    pub(super) fn wigglers(&self) -> Vec<Wiggler> {
        let mut out = Vec::new();
        if let Mode::Decouple {
            pairs,
            wiggle,
            start,
        } = &self.mode
        {
            let open = |i: &usize| {
                self.released.contains(i)
                    || self
                        .pairs
                        .get(*i)
                        .is_none_or(|p| p.status == PairStatus::Decoupled)
            };
            let knobs_out = pairs
                .iter()
                .filter(|&&i| {
                    self.pairs
                        .get(i)
                        .is_some_and(|p| p.pair.kind == PairType::KnobHole)
                })
                .all(open);
            // One wiggle per robot at a time: in a train a robot between two pairs would
            // otherwise wiggle one pair and be wiggled against by the other, and neither
            // reaches the yaw that pops the legs.
            let mut busy = BTreeSet::new();
            // Released pairs still too close first: their robots are busy clearing. Then
            // pairs whose anchor robot can pull forward: not with another robot's anchor
            // still held in its own opening (between two pilots in a lane it would push
            // the front one; that pair goes first, the pilot pulling).
            let held = |robot: RobotId, i: usize, anchor_side: bool| {
                pairs.iter().any(|&k| {
                    k != i
                        && !self.released.contains(&k)
                        && self.pairs.get(k).is_some_and(|p| {
                            p.pair.kind == PairType::AnchorOpening
                                && p.status != PairStatus::Decoupled
                                && if anchor_side {
                                    p.pair.a == robot
                                } else {
                                    p.pair.b == robot
                                }
                        })
                })
            };
            let mut order: Vec<(bool, bool, usize)> = pairs
                .iter()
                .map(|&i| {
                    // The anchor robot pulls forward itself (a non-pilot) or, when the
                    // opening robot cannot back off (held behind), as a pilot puller.
                    let blocked = self.pairs.get(i).is_some_and(|p| {
                        let (a, b) = (p.pair.a, p.pair.b);
                        held(a, i, false)
                            && (self.kind_of(a) == RobotKind::NonPilot || held(b, i, true))
                    });
                    (!self.released.contains(&i), blocked, i)
                })
                .collect();
            order.sort_unstable();
            for (unreleased, _, i) in order {
                let Some(tp) = self
                    .pairs
                    .get(i)
                    .filter(|p| knobs_out && p.pair.kind != PairType::KnobHole)
                else {
                    continue;
                };
                let (a, b) = (tp.pair.a, tp.pair.b);
                if busy.contains(&a) || busy.contains(&b) || (!unreleased && self.head_clear(a, b))
                {
                    continue;
                }
                busy.extend([a, b]);
                let (robot, partner, mut v_sign) = self.wiggling_side(a, b);
                // Backing off from a pilot's anchor into its own held anchor (a non-pilot
                // between two pilots in a lane: each holds one of its ends), it turns in
                // place and the pilot pulls.
                let held_behind = v_sign < 0.0 && held(robot, i, true);
                let puller = held_behind.then_some(partner);
                if held_behind {
                    v_sign = 0.0;
                }
                out.push(Wiggler {
                    robot,
                    partner,
                    v_sign,
                    wiggle: *wiggle,
                    start: *start,
                    clearing: !unreleased,
                    puller,
                });
            }
        }
        if self.mode == Mode::Form {
            for (&(anchor, opening), &t0) in &self.unplanned {
                let (robot, partner, v_sign) = self.wiggling_side(anchor, opening);
                out.push(Wiggler {
                    robot,
                    partner,
                    v_sign,
                    wiggle: Wiggle::default(),
                    start: t0,
                    clearing: false,
                    puller: None,
                });
            }
        }
        out
    }

    /// A decouple behaviour's pairs: released once measured apart (a pair wiggled again
    /// after a failed clearing only once its head is clear), and wiggled again when a
    /// released anchor pair is seen connected (a neighbour's wiggle shoved the robot that
    /// had driven clear back in) or its head is still in long after release (it is still
    /// held). The behaviour ends only with every pair apart.
    pub(super) fn update_released(&mut self, t: f64) {
        let Mode::Decouple { pairs, .. } = &self.mode else {
            return;
        };
        let dc = self.cfg.decouple;
        let deadline = dc.clear_time_factor
            * (dc.clear + f64::from(self.cfg.tolerances.coupling.anchor_travel))
            / dc.clear_speed;
        let mut done = Vec::new();
        let mut again = Vec::new();
        for &i in pairs {
            let Some(tp) = self.pairs.get(i) else {
                continue;
            };
            let (a, b) = (tp.pair.a, tp.pair.b);
            let anchor = tp.pair.kind == PairType::AnchorOpening;
            if !self.released.contains(&i) {
                let apart = tp.status == PairStatus::Decoupled
                    && (!self.release_watch.stuck.contains(&i) || self.head_clear(a, b));
                if apart {
                    done.push(i);
                }
            } else if anchor {
                let late = self
                    .release_watch
                    .at
                    .get(&i)
                    .is_some_and(|&t0| t - t0 > deadline && !self.head_clear(a, b));
                if tp.status == PairStatus::Connected || late {
                    again.push((i, late));
                }
            }
        }
        for i in done {
            self.released.insert(i);
            self.release_watch.at.insert(i, t);
            self.release_watch.stuck.remove(&i);
            let p = self.pairs[i].pair;
            self.push(t, EventKind::PairReleased { a: p.a, b: p.b });
        }
        for (i, late) in again {
            self.released.remove(&i);
            self.release_watch.at.remove(&i);
            if late {
                self.release_watch.stuck.insert(i);
            }
            let p = self.pairs[i].pair;
            self.push(t, EventKind::PairRecoupled { a: p.a, b: p.b });
        }
    }

    /// Every pair of the decouple behaviour is apart: a knob pair measured decoupled, an
    /// anchor pair released with its head clear. An anchor still held at the end of its
    /// travel stands only millimetres further out than a seated one, which the poses do not
    /// tell from a head just out of the opening; [`DecoupleConfig::clear`] is beyond the travel, so
    /// a clear head cannot be a held one (the robots disperse otherwise dragging their
    /// partner along).
    pub fn decouple_done(&self) -> bool {
        let Mode::Decouple { pairs, .. } = &self.mode else {
            return true;
        };
        pairs.iter().all(|&i| {
            self.pairs.get(i).is_none_or(|p| match p.pair.kind {
                PairType::KnobHole => p.status == PairStatus::Decoupled,
                PairType::AnchorOpening => {
                    self.released.contains(&i) && self.head_clear(p.pair.a, p.pair.b)
                }
            })
        })
    }

    /// Robot `anchor`'s anchor head is [`DecoupleConfig::clear`] out of robot `opening`'s front,
    /// beside its body, or behind its centre (a held head sits in the opening within the
    /// anchor's travel of the front face: one behind the centre has gone round the side), or
    /// either pose is unknown.
    fn head_clear(&self, anchor: RobotId, opening: RobotId) -> bool {
        let (Some(a), Some(b)) = (self.pose(anchor), self.pose(opening)) else {
            return true;
        };
        let g = &self.geometry;
        let h = [f64::from(g.anchor_head[0]), f64::from(g.anchor_head[1])];
        let head = b.inverse_transform(a.transform(h));
        head[0] > f64::from(g.length) * 0.5 + self.cfg.decouple.clear
            || head[0] < 0.0
            || head[1].abs() > f64::from(g.width) * 0.5
    }

    /// Who wiggles an anchor pair open: the anchor robot pulling forward, or, when the
    /// anchor is a pilot's (it turns imprecisely, THESIS 5.4.1), the opening robot backing
    /// off. Returns (robot, partner, v_sign).
    fn wiggling_side(&self, anchor: RobotId, opening: RobotId) -> (RobotId, RobotId, f64) {
        if self.kind_of(anchor) == RobotKind::NonPilot {
            (anchor, opening, 1.0)
        } else {
            (opening, anchor, -1.0)
        }
    }

    /// Closed-loop wiggles ([`WiggleTurn`]): each wiggling robot turns back once its yaw
    /// relative to its partner reached [`WIGGLE_REACH`] of the anchor's yaw range.
    pub(super) fn update_wiggles(&mut self, t: f64) {
        let reach = WIGGLE_REACH * f64::from(self.cfg.tolerances.coupling.anchor_yaw_range);
        let now = self.wigglers();
        self.wiggle_turns
            .retain(|id, _| now.iter().any(|w| w.robot == *id));
        for w in now {
            let yaw = |id| self.robots.get(&id).map(|k| k.pose.yaw);
            let phi = match (yaw(w.robot), yaw(w.partner)) {
                (Some(a), Some(b)) => wrap_angle(a - b),
                _ => f64::NAN,
            };
            self.wiggle_turns
                .entry(w.robot)
                .or_insert_with(|| WiggleTurn::new(t))
                .update(t, phi, reach, w.wiggle.period_s);
        }
    }

    /// Speed of a released robot driving clear, and of a pilot pulling its anchor out of a
    /// wiggling robot's opening ([`Wiggler::puller`]).
    pub(super) fn pull_speed(&self, w: &Wiggler) -> f64 {
        w.wiggle.v_bias.max(self.cfg.decouple.clear_speed)
    }

    /// (v, ω) of a wiggling robot at time `t`.
    pub(super) fn wiggle_command(&self, w: &Wiggler, t: f64) -> (f64, f64) {
        let turn = self
            .wiggle_turns
            .get(&w.robot)
            .copied()
            .unwrap_or_else(|| WiggleTurn::new(t));
        if w.clearing {
            return (w.v_sign * self.pull_speed(w), 0.0);
        }
        let (v, om) = w.wiggle.command_closed(t - w.start, &turn);
        (w.v_sign * v, om)
    }

    /// Knobs seated where the plan does not put those two robots side by side (a robot
    /// joining along a side that an earlier knock left bent can click a knob into the wrong
    /// robot and stand rigidly locked there): a knob holds more than
    /// the robots can pull (THESIS 5.5.3), so a person is asked to lift it
    /// ([`EventKind::LiftKnobs`]; in simulation the simulator's hand does it), at most every
    /// [`DecoupleConfig::knob_lift_repeat_s`] per pair. Knobs between planned neighbours at their places in
    /// the shape (a mesh's extra clicks, re-targeted side pairs) are left in.
    fn watch_unplanned_knobs(&mut self, t: f64, ids: &[RobotId]) {
        let Some(plan) = &self.plan else {
            return;
        };
        let g = self.geometry;
        let tol = self.cfg.tolerances;
        let mut lift = Vec::new();
        for &a in ids {
            for &b in ids {
                let (Some(ka), Some(kb)) = (self.robots.get(&a), self.robots.get(&b)) else {
                    continue;
                };
                let (pa, pb) = (ka.pose, kb.pose);
                if a == b || (pa.x - pb.x).hypot(pa.y - pb.y) > 2.0 * f64::from(g.length) {
                    continue;
                }
                if !crate::pair::knob_seated_between(&pa, &pb, &tol, &g) {
                    continue;
                }
                let planned = match (plan.goal_of(a), plan.goal_of(b)) {
                    (Some(ga), Some(gb)) => {
                        let want = gb.inverse().compose(&ga);
                        let have = pb.inverse().compose(&pa);
                        (want.x - have.x).hypot(want.y - have.y)
                            < self.cfg.decouple.knob_place_tolerance
                            && wrap_angle(want.yaw - have.yaw).abs() < 0.1
                    }
                    _ => false,
                };
                let asked = self
                    .knob_lifts
                    .get(&(a, b))
                    .is_some_and(|&t0| t - t0 < self.cfg.decouple.knob_lift_repeat_s);
                if !planned && !asked {
                    lift.push((a, b));
                }
            }
        }
        for (a, b) in lift {
            self.knob_lifts.insert((a, b), t);
            self.push(
                t,
                EventKind::LiftKnobs {
                    robots: vec![a, b],
                    pairs: vec![(a, b)],
                },
            );
        }
    }

    /// Anchor couplings between robots that no tracked pair covers, from the measured poses
    /// (during formation only: the planner drives the plan's pairs). An anchor counts as in
    /// by [`puzzlebot_params::coupling::Coupling::anchor_seated`] and as out once
    /// [`puzzlebot_params::coupling::Coupling::anchor_held`] fails by the
    /// release factor.
    pub(super) fn watch_unplanned(&mut self, t: f64) {
        if self.mode != Mode::Form {
            self.unplanned.clear();
            return;
        }
        let tol = self.cfg.tolerances;
        let c = tol.coupling;
        let g = self.geometry;
        let ids = self.live_ids();
        let planned = |a: RobotId, b: RobotId| {
            self.pairs.iter().enumerate().any(|(i, p)| {
                p.pair.kind == PairType::AnchorOpening
                    && (p.pair.a, p.pair.b) == (a, b)
                    && !self.released.contains(&i)
            })
        };
        let mut found = Vec::new();
        for &a in &ids {
            for &b in &ids {
                if a == b || planned(a, b) {
                    continue;
                }
                let (pa, pb) = (self.robots[&a].pose, self.robots[&b].pose);
                if (pa.x - pb.x).hypot(pa.y - pb.y) > 2.0 * f64::from(g.length) {
                    continue;
                }
                let m = measure(&pa, ConnPoint::Back, &pb, ConnPoint::Front, 0.0, &g);
                let probe = AnchorProbe {
                    head: m.head_in_b,
                    yaw: m.yaw_error,
                };
                let known = self.unplanned.contains_key(&(a, b));
                let coupled = if known {
                    c.anchor_held(&g, &probe, tol.release.max(1.0))
                } else {
                    c.anchor_seated(&g, &probe, 1.0)
                };
                if coupled {
                    found.push((a, b));
                }
            }
        }
        self.watch_unplanned_knobs(t, &ids);
        let gone: Vec<(RobotId, RobotId)> = self
            .unplanned
            .keys()
            .copied()
            .filter(|k| !found.contains(k))
            .collect();
        for (anchor, opening) in gone {
            self.unplanned.remove(&(anchor, opening));
            self.push(t, EventKind::UnplannedReleased { anchor, opening });
        }
        for (anchor, opening) in found {
            if let std::collections::btree_map::Entry::Vacant(e) =
                self.unplanned.entry((anchor, opening))
            {
                e.insert(t);
                self.push(t, EventKind::UnplannedCoupling { anchor, opening });
            }
        }
    }
}

#[cfg(test)]
mod tests;
