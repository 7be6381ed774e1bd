//! The crossing drive's one extension past the plan: a drifted assembly with a robot still
//! astride at the end of the planned advance drives on as far as the gate proves afresh.

use puzzlebot_stability::crossing::{advance_across, platform_at};
use puzzlebot_stability::puzzlebot::max_safe_advance_with;

use super::{assembly_of, CrossingController};
use crate::control::FleetView;

impl CrossingController {
    /// At the end of the planned advance with a robot not across (the assembly drifted off
    /// its straight path): the further advance along the heading that takes every member,
    /// as measured, across ([`advance_across`]), when the gate proves it from the measured
    /// poses with the planner's own check ([`max_safe_advance_with`], nowhere a stretch
    /// proven only at speed, so the drive may stop anywhere in it). At most the assembly's
    /// own extent along the heading and a body diagonal: farther, it is not a straggler.
    pub(super) fn extension(&self, view: &FleetView) -> Option<f64> {
        let start = platform_at(&self.terrain, self.plan.start)?;
        let poses = self.member_poses(view);
        if poses.len() != self.members.len() {
            return None;
        }
        let [c, s] = self.direction();
        let along: Vec<f64> = poses.iter().map(|(_, p)| p.x * c + p.y * s).collect();
        let g = &self.params.non_pilot.geometry;
        let extent = along.iter().copied().fold(f64::MIN, f64::max)
            - along.iter().copied().fold(f64::MAX, f64::min)
            + f64::from(g.length).hypot(f64::from(g.width));
        let robots: Vec<_> = poses.iter().map(|(_, p)| *p).collect();
        let e = advance_across(
            &robots,
            &self.params,
            &self.terrain,
            start,
            self.heading(),
            extent,
        )?;
        let a = assembly_of(&poses, &self.links, g);
        let opt = self.opt.advance_options(e);
        let horizon = opt.horizon;
        let proven = max_safe_advance_with(
            &a,
            &self.params,
            &self.terrain,
            self.heading(),
            self.opt.step,
            opt,
        )
        .ok()?;
        (proven.distance >= horizon - 1e-9 && proven.bridged.is_empty()).then_some(e)
    }
}
