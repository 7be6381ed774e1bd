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

/// Speed of a released pair's robot driving clear (m/s): above the wheels' 20 RPM
/// dead-band.
const CLEAR_SPEED: f64 = 0.02;

/// How far two knob-coupled robots may stand from their planned relative place (m) for the
/// knob to count as planned: under half the 25 mm between a side's holes.
const KNOB_PLACE_TOLERANCE: f64 = 0.008;

/// A person is asked again to lift an unplanned knob pair after this long (s).
const KNOB_LIFT_REPEAT_S: f64 = 10.0;

/// A released anchor pair drives apart until the head is this far out of the opening (m):
/// held where it popped, a wiggling neighbour can push it back in while the rest of the
/// train wiggles.
pub const DECOUPLE_CLEAR: f64 = 0.015;

/// A released anchor pair whose head is still not [`DECOUPLE_CLEAR`] out after this many
/// times the time its robot needs to drive that far (plus the anchor's travel) at
/// [`CLEAR_SPEED`] is still held: its legs did not pop although the measured yaw left the
/// anchor's range for a moment, and driving straight on drags the partner along.
const CLEAR_TIME_FACTOR: f64 = 3.0;

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
                    let blocked = self.pairs.get(i).is_some_and(|p| {
                        self.kind_of(p.pair.a) == RobotKind::NonPilot && held(p.pair.a, i, false)
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
        let deadline = CLEAR_TIME_FACTOR
            * (DECOUPLE_CLEAR + f64::from(self.cfg.tolerances.coupling.anchor_travel))
            / CLEAR_SPEED;
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
    /// tell from a head just out of the opening; [`DECOUPLE_CLEAR`] is beyond the travel, so
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

    /// Robot `anchor`'s anchor head is [`DECOUPLE_CLEAR`] out of robot `opening`'s front
    /// (or either pose is unknown).
    fn head_clear(&self, anchor: RobotId, opening: RobotId) -> bool {
        let (Some(a), Some(b)) = (self.pose(anchor), self.pose(opening)) else {
            return true;
        };
        let g = &self.geometry;
        let h = [f64::from(g.anchor_head[0]), f64::from(g.anchor_head[1])];
        let head = b.inverse_transform(a.transform(h));
        head[0] > f64::from(g.length) * 0.5 + DECOUPLE_CLEAR
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
        w.wiggle.v_bias.max(CLEAR_SPEED)
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
    /// [`KNOB_LIFT_REPEAT_S`] per pair. Knobs between planned neighbours at their places in
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
                let seated = [ConnPoint::LeftFront, ConnPoint::LeftBack]
                    .into_iter()
                    .flat_map(|k| [(k, ConnPoint::RightFront), (k, ConnPoint::RightBack)])
                    .any(|(knob, hole)| {
                        let m = measure(&pa, knob, &pb, hole, 0.0, &g);
                        is_inserted(PairType::KnobHole, &m, &tol, &g, 1.0)
                    });
                if !seated {
                    continue;
                }
                let planned = match (plan.goal_of(a), plan.goal_of(b)) {
                    (Some(ga), Some(gb)) => {
                        let want = gb.inverse().compose(&ga);
                        let have = pb.inverse().compose(&pa);
                        (want.x - have.x).hypot(want.y - have.y) < KNOB_PLACE_TOLERANCE
                            && wrap_angle(want.yaw - have.yaw).abs() < 0.1
                    }
                    _ => false,
                };
                let asked = self
                    .knob_lifts
                    .get(&(a, b))
                    .is_some_and(|&t0| t - t0 < KNOB_LIFT_REPEAT_S);
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
mod tests {
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
            again |= c.tick(t, &held).events.iter().any(
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
}
