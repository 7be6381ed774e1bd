//! The plan and its pairs: forming a shape, installing a plan, and re-planning without a lost
//! robot (THESIS Algorithm 2 on the remaining fleet).

use super::*;

impl Coordinator {
    /// Start forming `spec` with every known robot plus `robots` (THESIS Algorithms 2 and 7).
    /// Pairs that already exist with the same robots and points keep their status.
    pub fn form(
        &mut self,
        t: f64,
        spec: ShapeSpec,
        robots: &[RobotState],
        heading: Option<f64>,
    ) -> Result<&Plan, PlanError> {
        self.observe(t, robots);
        let states = self.states();
        let plan = assign_connection_pairs(&spec, &states, heading, &self.geometry)?;
        self.grow_lane = None;
        Ok(self.start_form(t, plan, heading, None))
    }

    /// Install `plan` and switch to forming it.
    pub(super) fn start_form(
        &mut self,
        t: f64,
        plan: Plan,
        heading: Option<f64>,
        grow: Option<RobotId>,
    ) -> &Plan {
        self.heading = heading;
        self.grow = grow;
        self.install(t, plan, false);
        self.mode = Mode::Form;
        self.push(
            t,
            EventKind::BehaviourStarted {
                name: "form".into(),
            },
        );
        self.plan.as_ref().expect("just installed")
    }

    fn install(&mut self, t: f64, plan: Plan, replanned: bool) {
        let old: BTreeMap<_, _> = self
            .pairs
            .iter()
            .map(|p| (p.pair.key(), (p.status, p.since, p.last)))
            .collect();
        // Docking directions are per pair index: a new plan starts afresh.
        self.dock_dir.get_mut().clear();
        self.straighten_from.get_mut().clear();
        self.pairs = plan
            .pairs
            .iter()
            .map(|&pp| {
                let mut tp = TrackedPair::new(pp, t);
                if let Some(&(status, since, last)) = old.get(&pp.key()) {
                    tp.status = status;
                    tp.since = since;
                    tp.last = last;
                }
                tp
            })
            .collect();
        self.released.clear();
        self.release_watch = ReleaseWatch::default();
        self.complete_reported = false;
        self.complete_since = None;
        let robots = plan.slot_robot.clone();
        let n = plan.pairs.len();
        self.closures = closures::closures_of(&plan, &self.geometry);
        self.closed_since = None;
        self.plan = Some(plan);
        if replanned {
            self.push(t, EventKind::Replanned { robots });
        } else {
            self.push(t, EventKind::Planned { robots, pairs: n });
        }
    }

    /// Declare `robot` lost and, when it was part of the plan, recompute the plan without it.
    pub fn mark_lost(&mut self, t: f64, robot: RobotId) {
        if !self.lost.insert(robot) {
            return;
        }
        self.push(t, EventKind::RobotLost { robot });
        let Some(plan) = self.plan.clone() else {
            return;
        };
        let Some(slot) = plan.slot_of(robot) else {
            return;
        };
        let spec = match &plan.spec {
            ShapeSpec::Fixed(shape) => match shape.without_slot(slot, &self.geometry) {
                Ok(s) => ShapeSpec::Fixed(s),
                Err(e) => {
                    self.fail_replan(t, e.to_string());
                    return;
                }
            },
            other => other.clone(),
        };
        let states: Vec<RobotState> = self
            .states()
            .into_iter()
            .filter(|r| plan.slot_of(r.id).is_some())
            .collect();
        let replan = match self.grow {
            // Grown around a seed that is still there: around it again, else the most
            // central robot.
            Some(seed) => {
                let seed = if seed == robot || self.grow_lane == Some(robot) {
                    self.grow_seed(&states, None).map(|(s, l)| {
                        self.grow_lane = l;
                        s
                    })
                } else {
                    Ok(seed)
                };
                self.grow = seed.as_ref().ok().copied();
                seed.and_then(|s| {
                    assign_around_lane(&spec, &states, s, self.grow_lane, &self.geometry)
                })
            }
            None => assign_connection_pairs(&spec, &states, Some(plan.heading), &self.geometry),
        };
        match replan {
            Ok(p) => self.install(t, p, true),
            Err(e) => self.fail_replan(t, e.to_string()),
        }
    }

    /// Let a robot declared lost take part again (it joins the next `form`); returns whether
    /// it was lost.
    pub fn readmit(&mut self, robot: RobotId) -> bool {
        let was = self.lost.remove(&robot);
        if was {
            // Its old pose is stale; wait for a fresh measurement.
            self.robots.remove(&robot);
        }
        was
    }

    fn fail_replan(&mut self, t: f64, reason: String) {
        self.plan = None;
        self.pairs.clear();
        self.dock_dir.get_mut().clear();
        self.mode = Mode::Hold;
        self.push(t, EventKind::ReplanFailed { reason });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coordinator::fixtures::*;

    #[test]
    fn lost_robot_triggers_replan_without_it() {
        let mut c = coordinator();
        let robots: Vec<RobotState> = (1..=4)
            .map(|i| np(i, 0.1 * f64::from(i), 0.2, 0.0))
            .collect();
        c.form(0.0, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
        assert_eq!(c.plan().unwrap().pairs.len(), 3);
        c.tick(0.0, &robots);
        let without: Vec<RobotState> = robots.iter().copied().filter(|r| r.id != 3).collect();
        c.tick(0.5, &without);
        assert_eq!(c.plan().unwrap().slot_robot.len(), 4, "not lost yet");
        let tick = c.tick(1.2, &without);
        assert!(tick
            .events
            .iter()
            .any(|e| e.kind == EventKind::RobotLost { robot: 3 }));
        assert!(tick
            .events
            .iter()
            .any(|e| matches!(e.kind, EventKind::Replanned { .. })));
        let plan = c.plan().unwrap();
        assert_eq!(plan.slot_robot.len(), 3);
        assert!(!plan.slot_robot.contains(&3));
        assert_eq!(plan.pairs.len(), 2);
        assert!(plan.pairs.iter().all(|p| !p.involves(3)));
        assert!(tick.tasks.iter().all(|t| t.robot != 3));
        // If it shows up again it stays out of the plan until readmitted and re-formed.
        c.tick(1.3, &robots);
        assert!(!c.plan().unwrap().slot_robot.contains(&3));
        assert!(c.readmit(3));
        c.tick(1.4, &robots);
        c.form(1.4, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
        assert_eq!(c.plan().unwrap().slot_robot.len(), 4);
    }

    #[test]
    fn explicit_loss_of_a_fixed_shape_middle_slot_fails_cleanly() {
        let g = Geometry::default();
        let shape = crate::shape::Shape::line(3, &g).unwrap();
        let mut c = coordinator();
        let robots: Vec<RobotState> = (1..=3)
            .map(|i| np(i, 0.1 * f64::from(i), 0.0, 0.0))
            .collect();
        c.form(0.0, ShapeSpec::Fixed(shape), &robots, Some(0.0))
            .unwrap();
        let middle = c.plan().unwrap().slot_robot[1];
        c.mark_lost(0.1, middle);
        assert!(c.plan().is_none());
        assert!(c
            .events()
            .iter()
            .any(|e| matches!(e.kind, EventKind::ReplanFailed { .. })));
    }
}
