//! Growing a shape around one robot: choosing the seed (and the pilot in its lane), and holding
//! the grown assembly where it stands while a robot joins it.

use super::*;

impl Coordinator {
    /// Growing: the robot whose assembly grows. The seed, unless it was knocked off on its
    /// own (a lone non-pilot: a pair popped while a robot docked) while a larger assembly of
    /// the plan stands: then that assembly's lowest-id member, and the seed joins it like
    /// any other robot (held as the home, both would wait for each other). A lone pilot
    /// seed stays the home: it cannot drive to the others (THESIS 3.5.2).
    pub(super) fn grow_home(&self, segments: &BTreeMap<RobotId, usize>) -> Option<RobotId> {
        let seed = self.grow?;
        let size = |id: RobotId| {
            segments
                .get(&id)
                .map_or(0, |s| segments.values().filter(|&x| x == s).count())
        };
        if size(seed) > 1 || self.kind_of(seed) == RobotKind::Pilot {
            return Some(seed);
        }
        let planned = |id: RobotId| self.plan.as_ref().is_some_and(|p| p.slot_of(id).is_some());
        segments
            .keys()
            .copied()
            .filter(|&id| planned(id) && size(id) > 1)
            .max_by_key(|&id| (size(id), std::cmp::Reverse(id)))
            .or(Some(seed))
    }

    /// Start forming `spec` grown around one robot (`seed`; default: the pilot, else the
    /// robot nearest the fleet's centre), which stays where it is: the shape is placed on it
    /// ([`crate::assign::assign_around`]) and the other robots join its assembly one at a time, each alone,
    /// by the staged approaches (stand off, turn, drive in), while the assembly holds still.
    /// Slower than forming in parallel, but it needs no train to manoeuvre, so it works from
    /// scattered starts. A lone pilot is not driven (THESIS 3.5.2) and moves straight only
    /// (5.4.1), so with two pilots they must stand in one lane (the second behind the first,
    /// facing the same way): the front one is the seed, a non-pilot couples to the other,
    /// and the two drive straight up to the seed before the rest joins
    /// ([`assign_around_lane`]). More pilots, or two out of lane, are an error.
    pub fn form_grown(
        &mut self,
        t: f64,
        spec: ShapeSpec,
        robots: &[RobotState],
        seed: Option<RobotId>,
    ) -> Result<&Plan, PlanError> {
        self.observe(t, robots);
        let states = self.states();
        let (seed, lane) = self.grow_seed(&states, seed)?;
        let plan = assign_around_lane(&spec, &states, seed, lane, &self.geometry)?;
        let heading = Some(plan.heading);
        self.grow_lane = lane;
        self.grow_origin = states.iter().find(|r| r.id == seed).map(|r| r.pose.xy());
        Ok(self.start_form(t, plan, heading, Some(seed)))
    }

    /// The seed of a grown shape and the pilot in its lane, if any ([`Coordinator::form_grown`]).
    pub(super) fn grow_seed(
        &self,
        states: &[RobotState],
        seed: Option<RobotId>,
    ) -> Result<(RobotId, Option<RobotId>), PlanError> {
        let pilots: Vec<&RobotState> = states
            .iter()
            .filter(|r| r.kind == RobotKind::Pilot)
            .collect();
        let too_many = PlanError::GrowPilots {
            pilots: pilots.len().max(2),
            radius: self.cfg.pilot_turn_radius,
        };
        match pilots[..] {
            [] => {
                let s = match seed {
                    Some(s) => s,
                    None => Self::central(states).ok_or(PlanError::NotEnoughRobots {
                        needed: 1,
                        available: 0,
                    })?,
                };
                Ok((s, None))
            }
            [p] => match seed {
                Some(s) if s != p.id => Err(too_many),
                _ => Ok((p.id, None)),
            },
            [a, b] => {
                // The front one (further along the pair's mean heading) is the seed.
                let h = wrap_angle(b.pose.yaw - a.pose.yaw) / 2.0 + a.pose.yaw;
                let along = |r: &RobotState| r.pose.x * h.cos() + r.pose.y * h.sin();
                let (front, back) = if along(a) >= along(b) { (a, b) } else { (b, a) };
                if seed.is_some_and(|s| s != front.id) {
                    return Err(too_many);
                }
                let d = front.pose.inverse_transform(back.pose.xy());
                let yaw = wrap_angle(back.pose.yaw - front.pose.yaw);
                let (max_lateral, max_yaw) = crate::assign::LANE_TOLERANCE;
                if d[1].abs() > max_lateral || yaw.abs() > max_yaw {
                    return Err(PlanError::PilotsNotInLane {
                        seed: front.id,
                        pilot: back.id,
                        lateral: d[1].abs(),
                        yaw,
                        max_lateral,
                        max_yaw,
                    });
                }
                Ok((front.id, Some(back.id)))
            }
            _ => Err(too_many),
        }
    }

    /// The robot nearest the centre of `states`.
    fn central(states: &[RobotState]) -> Option<RobotId> {
        let poses: Vec<Pose2> = states.iter().map(|r| r.pose).collect();
        let [cx, cy] = crate::assign::mean_position(&poses);
        states
            .iter()
            .min_by(|a, b| {
                let da = (a.pose.x - cx).hypot(a.pose.y - cy);
                let db = (b.pose.x - cx).hypot(b.pose.y - cy);
                da.total_cmp(&db)
            })
            .map(|r| r.id)
    }

    /// Growing: the held members of the grown assembly keep their planned places relative
    /// to the seed, which keeps where it was first held ([`Role::Keep`]). A robot docking at
    /// the assembly's side turns its members about their anchors (rubbing along them, and
    /// steering by their poses); held at zero speed, or where they first stood, a row stays
    /// bent to the anchors' play, its corner in the docking lane. Once every planned pair
    /// is connected they keep on while the layout's closing knobs seat ([`super::closures`]),
    /// a robot hanging at its anchors beside an open one kept beside its knob partner.
    pub(super) fn keep_grown(
        &mut self,
        tasks: &mut [RobotTask],
        segments: &BTreeMap<RobotId, usize>,
    ) {
        let home_robot = self.grow_home(segments);
        // Only while robots still join or a closing knob is open: once every knob is in
        // nobody docks at the side, and two coupled robots each driven to its own pose push
        // each other through the anchor's play (late, noisy poses make that a wiggle that
        // pops the legs).
        let home = match (&self.mode, home_robot) {
            (Mode::Form, Some(seed))
                if !self.is_complete() || self.closing(self.now, self.complete_since) =>
            {
                segments.get(&seed).copied()
            }
            _ => None,
        };
        let size = home.map_or(0, |h| segments.values().filter(|&&s| s == h).count());
        let mut kept = BTreeMap::new();
        for task in tasks.iter_mut() {
            if task.role != Role::Hold || Some(task.segment) != home || size < 2 {
                continue;
            }
            // The lane pilot hangs at an anchor and turns no tighter than its butterfly:
            // driven back to where it was first held after a joining robot knocked the
            // assembly round, it lags the others until its anchor pops. It holds where it is.
            if Some(task.robot) == self.grow_lane {
                continue;
            }
            let Some(now) = self.robots.get(&task.robot).map(|k| k.pose) else {
                continue;
            };
            let pose = self.kept_at.get(&task.robot).copied().unwrap_or(now);
            kept.insert(task.robot, pose);
            task.role = Role::Keep { pose };
        }
        // Every member keeps its planned place relative to where the seed is kept: a row
        // held where its members first stood stays bent to its anchors' play, and a robot
        // that docks at its side against two members of a bent row finds no fit (its knob
        // needs 0.04 rad and flush faces with both). The seed itself keeps where it stood.
        if let (Some(seed), Some(plan)) = (home_robot, &self.plan) {
            if let (Some(&at), Some(seed_goal)) = (kept.get(&seed), plan.goal_of(seed)) {
                for task in tasks.iter_mut() {
                    if task.robot == seed {
                        continue;
                    }
                    if let (Role::Keep { pose }, Some(goal)) =
                        (&mut task.role, plan.goal_of(task.robot))
                    {
                        *pose = at.compose(&seed_goal.relative(&goal));
                    }
                }
            }
        }
        self.kept_at = kept;
        if self.closing(self.now, self.complete_since) {
            self.close_open(tasks);
        }
    }

    /// Growing: a bent assembly of `members` that straightens along `heading` (rad) drives
    /// backwards, led by its rear robot, when the seed among them stands ahead of where it
    /// stood at the formation's start. Either way a towed row straightens behind its head,
    /// so the sense is free; chosen so, straightening keeps the assembly about its start
    /// instead of carrying it, pair after pair, towards what lies ahead (a gap's edge, a
    /// wall).
    pub(super) fn straighten_backwards(&self, members: &[RobotId], heading: f64) -> bool {
        let (Some(origin), Some(seed)) = (self.grow_origin, self.grow) else {
            return false;
        };
        let Some(at) = members
            .contains(&seed)
            .then(|| self.robots.get(&seed))
            .flatten()
        else {
            return false;
        };
        let (s, c) = heading.sin_cos();
        (at.pose.x - origin[0]) * c + (at.pose.y - origin[1]) * s > 0.0
    }
}

#[cfg(test)]
mod tests;
