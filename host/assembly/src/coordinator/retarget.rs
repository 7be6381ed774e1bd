//! Side pairs re-targeted to the hole a knob actually found (a mesh side has a hole every
//! half body).

use super::*;

impl Coordinator {
    /// Knob pairs the planned shape could use instead of pair `i` (same place in the shape):
    /// one robot kept, the other replaced by a robot of the plan whose knob / hole lands on
    /// the same point in the goal shape.
    pub(super) fn side_alternatives(&self, i: usize) -> Vec<PlannedPair> {
        let (Some(plan), Some(tp)) = (&self.plan, self.pairs.get(i)) else {
            return Vec::new();
        };
        let p = tp.pair;
        let g = &self.geometry;
        let slot_pose = |r: RobotId| plan.slot_of(r).map(|s| (s, plan.shape.slots[s].pose));
        let mut out = Vec::new();
        for &q in &plan.slot_robot {
            if q == p.a || q == p.b || self.lost.contains(&q) {
                continue;
            }
            for (ka, hb) in [(q, p.b), (p.a, q)] {
                let (Some((sa, pa)), Some((sb, pb))) = (slot_pose(ka), slot_pose(hb)) else {
                    continue;
                };
                let rel = wrap_angle(pa.yaw - pb.yaw);
                if (rel - p.relative_yaw).abs() > 1e-3 {
                    continue;
                }
                for knob in [ConnPoint::LeftFront, ConnPoint::LeftBack] {
                    for hole in [ConnPoint::RightFront, ConnPoint::RightBack] {
                        let (x, y) = (
                            pa.transform(knob.position(g)),
                            pb.transform(hole.position(g)),
                        );
                        if (x[0] - y[0]).hypot(x[1] - y[1]) > 1e-3 {
                            continue;
                        }
                        out.push(PlannedPair {
                            a: ka,
                            point_a: knob,
                            b: hb,
                            point_b: hole,
                            slot_a: sa,
                            slot_b: sb,
                            relative_yaw: rel,
                            centre_distance: (pa.x - pb.x).hypot(pa.y - pb.y),
                            ..p
                        });
                    }
                }
            }
        }
        out
    }

    /// A knob pair not yet in whose docking robot is seated at an equivalent pair (see
    /// [`EventKind::PairRetargeted`]) tracks that pair from now on.
    pub(super) fn retarget_side_pairs(&mut self, t: f64) {
        for i in 0..self.pairs.len() {
            let tp = &self.pairs[i];
            if tp.pair.kind != PairType::KnobHole
                || !matches!(tp.status, PairStatus::Decoupled | PairStatus::HeadAligned)
                || self.released.contains(&i)
            {
                continue;
            }
            let tol = self.cfg.tolerances;
            // A pair seen seated itself stays: it needs `SEATED_UPDATES` of the last
            // `SEATED_WINDOW` updates seated to count as inserted, and re-targeting would
            // start it afresh.
            if tp.seated_updates() > 0 {
                continue;
            }
            let seated = self.side_alternatives(i).into_iter().find(|alt| {
                let taken = self.pairs.iter().any(|o| {
                    (o.pair.a, o.pair.b) == (alt.a, alt.b) || (o.pair.a, o.pair.b) == (alt.b, alt.a)
                });
                let (Some(ka), Some(kb)) = (self.robots.get(&alt.a), self.robots.get(&alt.b))
                else {
                    return false;
                };
                let m = measure(
                    &ka.pose,
                    alt.point_a,
                    &kb.pose,
                    alt.point_b,
                    alt.relative_yaw,
                    &self.geometry,
                );
                !taken && is_inserted(alt.kind, &m, &tol, &self.geometry, 1.0)
            });
            if let Some(alt) = seated {
                let from = (self.pairs[i].pair.a, self.pairs[i].pair.b);
                self.pairs[i] = TrackedPair::new(alt, t);
                self.dock_dir.borrow_mut().remove(&i);
                self.push(
                    t,
                    EventKind::PairRetargeted {
                        pair: i,
                        from,
                        to: (alt.a, alt.b),
                    },
                );
            }
        }
    }
}
