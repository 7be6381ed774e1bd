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
    /// False for a knob pair: its robot only pulls.
    turns: bool,
    wiggle: Wiggle,
    /// When the wiggle started (s).
    start: f64,
}

impl Coordinator {
    /// Robots that wiggle now: the anchor robots of a decouple behaviour's pairs, and one
    /// robot of every unplanned coupling (the anchor robot, or the opening robot backing off
    /// when the anchor is a pilot's).
    pub(super) fn wigglers(&self) -> Vec<Wiggler> {
        let mut out = Vec::new();
        if let Mode::Decouple {
            pairs,
            wiggle,
            start,
        } = &self.mode
        {
            for &i in pairs {
                if self.released.contains(&i) {
                    continue;
                }
                if let Some(tp) = self.pairs.get(i) {
                    out.push(Wiggler {
                        robot: tp.pair.a,
                        partner: tp.pair.b,
                        v_sign: 1.0,
                        turns: tp.pair.kind != PairType::KnobHole,
                        wiggle: *wiggle,
                        start: *start,
                    });
                }
            }
        }
        if self.mode == Mode::Form {
            for (&(anchor, opening), &t0) in &self.unplanned {
                let (robot, partner, v_sign) = if self.kind_of(anchor) == RobotKind::NonPilot {
                    (anchor, opening, 1.0)
                } else {
                    (opening, anchor, -1.0)
                };
                out.push(Wiggler {
                    robot,
                    partner,
                    v_sign,
                    turns: true,
                    wiggle: Wiggle::default(),
                    start: t0,
                });
            }
        }
        out
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

    /// (v, ω) of a wiggling robot at time `t`.
    pub(super) fn wiggle_command(&self, w: &Wiggler, t: f64) -> (f64, f64) {
        let turn = self
            .wiggle_turns
            .get(&w.robot)
            .copied()
            .unwrap_or_else(|| WiggleTurn::new(t));
        let (v, om) = w.wiggle.command_closed(t - w.start, &turn);
        (w.v_sign * v, if w.turns { om } else { 0.0 })
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
