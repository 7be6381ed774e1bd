//! The layout's closing knobs: knob contacts of the goal shape that its spanning tree of pairs
//! (THESIS Algorithm 1) leaves out. A mesh's rows touch at more knobs than the tree plans (a
//! 2 × 2 mesh at three, of which the tree takes one or two); the others seat only when their
//! robots stand at their planned places, within the knob's 0.04 rad. A knob left open leaves
//! a robot held by its anchor alone, and it swings on that anchor when a wheel leaves a
//! platform. A grown formation therefore keeps its members at their planned places until
//! the closing knobs seat too, for at most [`CoordinatorConfig::closure_wait_s`].

use super::*;
use crate::assign::closest_points;
use crate::shape::CONTACT_TOLERANCE;

/// A knob contact of the goal shape that no planned pair covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Closure {
    /// Robot with the knob.
    pub knob: RobotId,
    /// Its knob point.
    pub knob_point: ConnPoint,
    /// Robot with the hole.
    pub hole: RobotId,
    /// Its hole point.
    pub hole_point: ConnPoint,
}

/// The closing knobs of `plan`: slots whose goal poses put a knob in a hole
/// (within [`CONTACT_TOLERANCE`]) where the plan has no pair between their robots.
pub(super) fn closures_of(plan: &Plan, g: &Geometry) -> Vec<Closure> {
    let n = plan.goal_poses.len();
    let planned = |i: usize, j: usize| {
        plan.pairs
            .iter()
            .any(|p| (p.slot_a, p.slot_b) == (i, j) || (p.slot_a, p.slot_b) == (j, i))
    };
    let mut out = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            if planned(i, j) {
                continue;
            }
            let Some((ci, cj, d)) = closest_points(&plan.goal_poses[i], &plan.goal_poses[j], g)
            else {
                continue;
            };
            if d > CONTACT_TOLERANCE || crate::geom::pair_type(ci, cj) != Some(PairType::KnobHole) {
                continue;
            }
            let (ri, rj) = (plan.slot_robot[i], plan.slot_robot[j]);
            let i_knob = matches!(ci.role(), crate::geom::PointRole::Knob);
            out.push(if i_knob {
                Closure {
                    knob: ri,
                    knob_point: ci,
                    hole: rj,
                    hole_point: cj,
                }
            } else {
                Closure {
                    knob: rj,
                    knob_point: cj,
                    hole: ri,
                    hole_point: ci,
                }
            });
        }
    }
    out
}

impl Coordinator {
    /// The plan's closing knobs that the measured poses do not show seated (a robot not
    /// measured counts as open).
    pub fn open_closures(&self) -> Vec<Closure> {
        let tol = &self.cfg.tolerances;
        let g = &self.geometry;
        self.closures
            .iter()
            .copied()
            .filter(|c| {
                let (Some(a), Some(b)) = (self.robots.get(&c.knob), self.robots.get(&c.hole))
                else {
                    return true;
                };
                let m = measure(&a.pose, c.knob_point, &b.pose, c.hole_point, 0.0, g);
                !is_inserted(PairType::KnobHole, &m, tol, g, 1.0)
            })
            .collect()
    }

    /// Growing, every planned pair connected since `since` (s): the members still keep their
    /// planned places at time `t` (s) for the closing knobs to seat and stay seated for
    /// [`CoordinatorConfig::form_settle_s`] (a knob passing through its tolerance as its
    /// robot turns is not yet a click).
    pub(super) fn closing(&self, t: f64, since: Option<f64>) -> bool {
        let settled = self
            .closed_since
            .is_some_and(|c| t - c >= self.cfg.form_settle_s - 1e-9);
        self.grow.is_some()
            && self.mode == Mode::Form
            && since.is_some_and(|s| t - s < self.cfg.closure_wait_s)
            && !settled
    }

    /// Since when (s) no closing knob has been open, updated at time `t` (s).
    pub(super) fn watch_closures(&mut self, t: f64) {
        self.closed_since = if self.open_closures().is_empty() {
            Some(self.closed_since.unwrap_or(t))
        } else {
            None
        };
    }
}

impl Coordinator {
    /// Closing: the robot of each open closing knob that hangs at its anchors (no seated
    /// knob of its own; not the seed) keeps its planned place relative to where its knob
    /// partner stands now, not relative to the seed: the knob seats against the partner.
    pub(super) fn close_open(&self, tasks: &mut [RobotTask]) {
        let Some(plan) = &self.plan else {
            return;
        };
        let knobs_of = |id: RobotId| {
            self.pairs
                .iter()
                .filter(|p| {
                    p.status == PairStatus::Connected
                        && p.pair.kind == PairType::KnobHole
                        && p.pair.involves(id)
                })
                .count()
        };
        for c in self.open_closures() {
            let (free, partner) = if knobs_of(c.hole) <= knobs_of(c.knob) {
                (c.hole, c.knob)
            } else {
                (c.knob, c.hole)
            };
            if Some(free) == self.grow || self.kind_of(free) == RobotKind::Pilot {
                continue;
            }
            let (Some(now), Some(gp), Some(gf)) = (
                self.robots.get(&partner).map(|k| k.pose),
                plan.goal_of(partner),
                plan.goal_of(free),
            ) else {
                continue;
            };
            for task in tasks.iter_mut().filter(|k| k.robot == free) {
                if let Role::Keep { pose } = &mut task.role {
                    *pose = now.compose(&gp.relative(&gf));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coordinator::fixtures::*;

    /// A pilot and three non-pilots growing a 2 × 2 mesh round the pilot, settle-free.
    fn grown_mesh() -> (Coordinator, BTreeMap<RobotId, RobotKind>) {
        let mut c = coordinator();
        let robots = pilot_and_three_scattered();
        let kinds = robots.iter().map(|r| (r.id, r.kind)).collect();
        c.form_grown(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, None)
            .unwrap();
        (c, kinds)
    }

    #[test]
    fn a_mesh_closes_every_knob_its_pairs_leave_out() {
        let (c, _) = grown_mesh();
        let plan = c.plan().unwrap();
        let knob_pairs = plan
            .pairs
            .iter()
            .filter(|p| p.kind == PairType::KnobHole)
            .count();
        // Rows offset by half a body meet at three knobs (THESIS 5.2.2); the spanning tree
        // of three pairs takes some of them.
        assert_eq!(c.closures.len(), 3 - knob_pairs, "{:?}", c.closures);
        assert!(!c.closures.is_empty());
        for k in &c.closures {
            assert!(!plan
                .pairs
                .iter()
                .any(|p| p.involves(k.knob) && p.involves(k.hole)));
            assert_eq!(
                (k.knob_point.role(), k.hole_point.role()),
                (crate::geom::PointRole::Knob, crate::geom::PointRole::Hole)
            );
        }
    }

    /// A closing knob with a robot whose planned pairs are all anchors (it hangs at them):
    /// the knob, that robot and the point it pivots about (its anchor head or its opening),
    /// in its body frame.
    fn hanging(c: &Coordinator) -> (Closure, RobotId, [f64; 2]) {
        let plan = c.plan().unwrap();
        let g = c.geometry;
        c.closures
            .iter()
            .flat_map(|k| [(*k, k.hole), (*k, k.knob)])
            .find_map(|(k, id)| {
                let mine: Vec<_> = plan.pairs.iter().filter(|p| p.involves(id)).collect();
                let anchors = mine.iter().all(|p| p.kind == PairType::AnchorOpening);
                let pivot = if mine[0].a == id {
                    mine[0].point_a.head(&g)
                } else {
                    mine[0].point_b.position(&g)
                };
                (anchors && c.kind_of(id) != RobotKind::Pilot).then_some((k, id, pivot))
            })
            .expect("a closing knob of a 2 x 2 mesh has a robot hanging at an anchor")
    }

    /// `robots` with robot `id` swung by `yaw` (rad) about `pivot` (its body frame).
    fn swing(robots: &[RobotState], id: RobotId, pivot: [f64; 2], yaw: f64) -> Vec<RobotState> {
        let mut out = robots.to_vec();
        for r in out.iter_mut().filter(|r| r.id == id) {
            let p = r.pose.transform(pivot);
            let turned = Pose2::new(p[0], p[1], r.pose.yaw + yaw);
            let centre = turned.transform([-pivot[0], -pivot[1]]);
            r.pose = Pose2::new(centre[0], centre[1], r.pose.yaw + yaw);
        }
        out
    }

    #[test]
    fn a_grown_mesh_counts_as_formed_once_its_closing_knobs_seat() {
        let (mut c, kinds) = grown_mesh();
        let (k, id, pivot) = hanging(&c);
        // Every robot at its goal but the hanging one, swung 0.06 rad about its anchor: its
        // planned pairs hold, the closing knob (0.04 rad) does not.
        let goals = at_goals(&c, &kinds);
        let swung = swing(&goals, id, pivot, 0.06);
        let mut t = 0.0;
        let mut kept = None;
        while t < 5.0 {
            let tick = c.tick(t, &swung);
            assert!(!tick.complete, "complete at {t:.1} s with a knob open");
            if let Role::Keep { pose } = role_of(&tick, id) {
                kept = Some(*pose);
            }
            t += 0.1;
        }
        assert!(c.is_complete(), "the planned pairs hold: {:?}", c.pairs());
        assert_eq!(c.open_closures(), vec![k]);
        // Kept at its planned place beside its knob partner: where its goal is.
        let goal = goals.iter().find(|r| r.id == id).unwrap().pose;
        let kept = kept.expect("the hanging robot keeps its place");
        assert!(goal.distance(&kept) < 1e-9 && (goal.yaw - kept.yaw).abs() < 1e-9);
        // It swings back: the knob seats and the formation completes a settle time later.
        let seated = t;
        loop {
            let tick = c.tick(t, &goals);
            if tick.complete {
                assert!(t - seated >= c.cfg.form_settle_s - 1e-9);
                assert!(!tick
                    .events
                    .iter()
                    .any(|e| matches!(e.kind, EventKind::ClosuresOpen { .. })));
                break;
            }
            t += 0.1;
            assert!(t < seated + 3.0, "not complete once the knob seated");
        }
    }

    #[test]
    fn a_closing_knob_that_does_not_seat_is_reported_after_the_wait() {
        let (mut c, kinds) = grown_mesh();
        c.cfg.closure_wait_s = 2.0;
        let (k, id, pivot) = hanging(&c);
        let swung = swing(&at_goals(&c, &kinds), id, pivot, 0.06);
        let mut t = 0.0;
        let tick = loop {
            let tick = c.tick(t, &swung);
            if tick.complete {
                break tick;
            }
            t += 0.1;
            assert!(t < 10.0, "never complete");
        };
        assert!(t >= 2.0, "complete at {t:.1} s, before the wait");
        let open: Vec<_> = tick
            .events
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::ClosuresOpen { pairs } => Some(pairs.clone()),
                _ => None,
            })
            .collect();
        assert_eq!(open, vec![vec![(k.knob, k.hole)]]);
    }
}
