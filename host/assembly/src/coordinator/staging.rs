//! Staging: while a robot docks at the assembly being grown, the lone robot whose anchor
//! pair with that assembly comes next drives to its own stand-off and turns to its axis, so
//! its docking starts there instead of across the floor. Robots join one at a time
//! ([`Coordinator::form_grown`]); staging overlaps one robot's way to the assembly with the
//! docking before it.

use super::approach::APPROACH_TURN_DONE;
use super::*;

impl Coordinator {
    /// Forming a grown shape while the grown assembly is busy with a docking (`active`): the
    /// anchor pair that comes next (lowest plan order) among those a lone non-pilot joins to
    /// that assembly by the staged approach, and that robot. None when the assembly is idle
    /// (then the pair starts itself) or no such pair is left.
    pub(super) fn next_to_stage(
        &self,
        active: &[usize],
        segments: &BTreeMap<RobotId, usize>,
    ) -> Option<(usize, RobotId)> {
        let home = self
            .grow_home(segments)
            .and_then(|h| segments.get(&h).copied())?;
        let in_active = |id: RobotId| {
            active
                .iter()
                .any(|&a| self.pairs[a].pair.a == id || self.pairs[a].pair.b == id)
        };
        if !self
            .robots
            .keys()
            .any(|&id| in_active(id) && segments.get(&id) == Some(&home))
        {
            return None;
        }
        (0..self.pairs.len())
            .filter(|i| {
                !active.contains(i)
                    && !self.released.contains(i)
                    && self.pairs[*i].status == PairStatus::Decoupled
            })
            .filter_map(|i| {
                let (me, partner) = self.lone_approach(i, segments)?;
                (segments.get(&partner) == Some(&home) && !in_active(me)).then_some((i, me))
            })
            .min_by_key(|&(i, _)| self.pairs[i].pair.order)
    }

    /// The role of robot `me` staging for pair `i` ([`Coordinator::next_to_stage`]): to the
    /// stand-off of its staged approach round every other robot, then turned on the spot to
    /// the axis. None once it stands there (it waits), when there is no way, or when that
    /// stand-off lies in the approach corridor of a docking in progress (`active`: it would
    /// block it).
    pub(super) fn staging_role(
        &self,
        i: usize,
        me: RobotId,
        active: &[usize],
        segments: &BTreeMap<RobotId, usize>,
    ) -> Option<Role> {
        let f = self.dock_frame(i, me)?;
        let km = self.robots.get(&me)?;
        let d = self.cfg.dock;
        let s = f.normal.0.signum();
        let (pre, _) = self.approach_standoff_pose(&f.fin, s, me);
        if active
            .iter()
            .any(|&a| self.in_approach_corridor(a, segments, pre.xy()))
        {
            return None;
        }
        if (km.pose.x - pre.x).hypot(km.pose.y - pre.y) > d.capture {
            let next = self.route_step(me, pre.xy())?;
            return Some(self.drive_to(i, &km.pose, next));
        }
        // Turned to the axis within what the approach's turn accepts.
        let yaw_rel = wrap_angle(km.pose.yaw - f.fin.yaw);
        if yaw_rel.abs() <= APPROACH_TURN_DONE {
            return None;
        }
        let w = self.spot_turn_rate(-yaw_rel);
        let (v, w) = self.turn_in_place(&km.pose, pre.xy(), w);
        Some(Role::Drive { v, w })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coordinator::fixtures::*;

    /// A line of three grown on its middle robot: both others join it, one at a time.
    fn line_grown_on_its_middle() -> (Coordinator, Vec<RobotState>, usize, RobotId, RobotId) {
        let mut c = coordinator();
        let robots = vec![
            np(1, 0.0, 0.0, 0.0),
            np(2, 0.45, 0.35, 2.5),
            np(3, -0.45, -0.35, -0.6),
        ];
        c.form_grown(0.0, ShapeSpec::Line, &robots, Some(1))
            .unwrap();
        let plan = c.plan().unwrap();
        // The seed is the middle of the line: both pairs are the seed's.
        assert!(plan.pairs.iter().all(|p| p.a == 1 || p.b == 1), "{plan:?}");
        let tick = c.tick(0.0, &robots);
        assert_eq!(tick.active.len(), 1, "one docking at a time");
        let p = c.pairs()[tick.active[0]].pair;
        let docking = if p.a == 1 { p.b } else { p.a };
        let next = if docking == 2 { 3 } else { 2 };
        (c, robots, tick.active[0], docking, next)
    }

    #[test]
    fn the_robot_that_joins_next_drives_to_its_stand_off_while_another_docks() {
        let (mut c, mut robots, active, docking, next) = line_grown_on_its_middle();
        let segments: BTreeMap<RobotId, usize> =
            robots.iter().map(|r| (r.id, usize::from(r.id))).collect();
        let (i, me) = c
            .next_to_stage(&[active], &segments)
            .expect("a robot to stage");
        assert_eq!(me, next);
        // It is driven, not left waiting where it stands.
        let tick = c.tick(0.1, &robots);
        assert!(
            matches!(
                role_of(&tick, next),
                Role::GoTo { .. } | Role::Dock { .. } | Role::Drive { .. }
            ),
            "{:?}",
            role_of(&tick, next)
        );
        assert!(!tick.active.contains(&i), "its pair has not started");
        // Standing at its stand-off turned to the axis, it waits there; its stand-off is
        // out of the docking robot's corridor.
        let f = c.dock_frame(i, me).unwrap();
        let s = f.normal.0.signum();
        let (pre, _) = c.approach_standoff_pose(&f.fin, s, me);
        assert!(!c.in_approach_corridor(active, &segments, pre.xy()));
        for r in robots.iter_mut().filter(|r| r.id == next) {
            r.pose = pre;
        }
        let tick = c.tick(0.2, &robots);
        if tick.active.contains(&i) {
            // Its pair came first in the queue and could start now: its docking goes on
            // from the stand-off.
            assert!(matches!(
                role_of(&tick, next),
                Role::Hold | Role::Dock { .. }
            ));
        } else {
            assert!(
                matches!(role_of(&tick, next), Role::Wait),
                "staged: {:?}",
                role_of(&tick, next)
            );
            assert!(!matches!(role_of(&tick, docking), Role::Wait | Role::Hold));
        }
    }
}
