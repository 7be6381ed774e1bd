//! Coupling recognised by a tug: an anchor cannot be pulled straight out of its opening
//! (THESIS 4.2.2, 5.7), and an entering head that is pushed on seats with less than 0.2 N
//! (THESIS 4.4.1). So an anchor pair whose head stays inside the opening's guide (past the
//! face, on the axis, yaw within the range) without moving by more than the anchor's travel
//! while one of its robots drives away from the other at the approach speed is coupled:
//! uncoupled, the head would have left the guide. (Pushed together, a head that neither
//! seats nor moves is blocked, not held: a coupled one would be seen seated.)
//!
//! This is the evidence the poses alone cannot give. A head reaches its seat only for the
//! instant of insertion; a partner holding its place then pulls it out over its travel, and
//! at the pose rate the seat may never be seen: the docking robot backed off, could not get
//! away, and the two robots pulled against each other until the formation timed out.

use super::*;
use crate::pair::PairMeasure;
use puzzlebot_params::coupling::Coupling;

/// The head is inside the opening's guide, where only the anchor governs: at least
/// `anchor_seat` inside the face (a head pressed against the face is stopped by the body),
/// no deeper than the seat less the travel, within `anchor_align_tolerance` of the axis and
/// the yaw within the range (THESIS 4.2.2).
fn in_guide(c: &Coupling, g: &Geometry, m: &PairMeasure) -> bool {
    let face = f64::from(g.anchor_opening[0]);
    let seat = face - Coupling::anchor_depth(g);
    let h = m.head_in_b;
    h[0] <= face - f64::from(c.anchor_seat)
        && h[0] >= seat - f64::from(c.anchor_travel)
        && (h[1] - f64::from(g.anchor_opening[1])).abs() <= f64::from(c.anchor_align_tolerance)
        && m.yaw_error.abs() <= f64::from(c.anchor_yaw_range)
}

/// A tug under way on one pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Tug {
    /// Since when (s).
    since: f64,
    /// The head in the opening robot's frame when it started (m).
    head: [f64; 2],
}

impl Coordinator {
    /// Watch every anchor pair not yet connected; confirm those that held through a tug of
    /// [`DockConfig::tug_s`] (their status goes to connected, their manoeuvre ends).
    pub(super) fn confirm_by_tug(&mut self, t: f64) {
        let c = self.cfg.tolerances.coupling;
        let reach = f64::from(c.anchor_travel) + f64::from(c.anchor_seat);
        let tol = self.cfg.tolerances;
        let mut confirmed = Vec::new();
        for (i, tp) in self.pairs.iter().enumerate() {
            let Some(m) = tp.last else {
                self.tugs.remove(&i);
                continue;
            };
            // Away from each other: the anchor robot (in front) forwards, the opening robot
            // backwards. Pushed together, a head that does not seat is blocked, not held.
            let speed = |id: RobotId| self.driving.get(&id).copied().unwrap_or(0.0);
            let pulled = speed(tp.pair.a) > 0.0 || speed(tp.pair.b) < 0.0;
            if tp.pair.kind != PairType::AnchorOpening
                || tp.status == PairStatus::Connected
                || self.released.contains(&i)
                || !pulled
                || !in_guide(&c, &self.geometry, &m)
            {
                self.tugs.remove(&i);
                continue;
            }
            let head = m.head_in_b;
            let tug = self.tugs.entry(i).or_insert(Tug { since: t, head });
            if (head[0] - tug.head[0]).hypot(head[1] - tug.head[1]) > reach {
                *tug = Tug { since: t, head };
            } else if t - tug.since >= self.cfg.dock.tug_s {
                confirmed.push(i);
            }
        }
        for i in confirmed {
            self.tugs.remove(&i);
            let Some(tp) = self.pairs.get_mut(i) else {
                continue;
            };
            let transitions = tp.confirm_held(t, &self.geometry, &tol);
            self.dock_dir.borrow_mut().remove(&i);
            self.push_transitions(i, transitions);
        }
    }
}
