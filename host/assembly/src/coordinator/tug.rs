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

/// A tug under way on one pair: the head positions seen over the last
/// [`DockConfig::tug_s`].
#[derive(Debug, Clone, PartialEq, Default)]
pub(super) struct Tug {
    /// (time (s), the head in the opening robot's frame (m)), oldest first.
    heads: Vec<(f64, [f64; 2])>,
}

/// Mean head of `samples` (m).
fn mean(samples: &[(f64, [f64; 2])]) -> [f64; 2] {
    let n = samples.len().max(1) as f64;
    let s = samples
        .iter()
        .fold([0.0, 0.0], |s, (_, h)| [s[0] + h[0], s[1] + h[1]]);
    [s[0] / n, s[1] / n]
}

impl Tug {
    /// The tug's verdict: the head stayed in the guide and moved by no more than `reach`.
    /// Judged on the means over the first and the last third of the tug, not on single
    /// poses: one pose's head error is two robots' capture noise plus their yaw noise times
    /// the lever, comparable to the 1 mm by which a head at full travel lies inside the
    /// guide, so a test on every pose fails a held anchor under a noisy capture.
    fn held(&self, inside: impl Fn([f64; 2]) -> bool, reach: f64) -> bool {
        let third = self.heads.len() / 3;
        if third == 0 {
            return false;
        }
        let first = mean(&self.heads[..third]);
        let last = mean(&self.heads[self.heads.len() - third..]);
        inside(first) && inside(last) && (last[0] - first[0]).hypot(last[1] - first[1]) <= reach
    }
}

impl Coordinator {
    /// Watch every anchor pair not yet connected; confirm those that held through a tug of
    /// [`DockConfig::tug_s`] (their status goes to connected, their manoeuvre ends).
    pub(super) fn confirm_by_tug(&mut self, t: f64) {
        let c = self.cfg.tolerances.coupling;
        let reach = f64::from(c.anchor_travel) + f64::from(c.anchor_seat);
        let tol = self.cfg.tolerances;
        let g = self.geometry;
        let window = self.cfg.dock.tug_s;
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
            {
                self.tugs.remove(&i);
                continue;
            }
            let inside = |h: [f64; 2]| in_guide(&c, &g, &PairMeasure { head_in_b: h, ..m });
            let tug = self.tugs.entry(i).or_default();
            tug.heads.push((t, m.head_in_b));
            // The window: the last `tug_s`, evaluated once it is full.
            let full = tug.heads.first().is_some_and(|&(t0, _)| t - t0 >= window);
            if full && tug.held(inside, reach) {
                confirmed.push(i);
            }
            tug.heads.retain(|&(ts, _)| t - ts < window);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The guide test of an anchor pair in the default geometry, for a head at `h`.
    fn inside(h: [f64; 2]) -> bool {
        let m = PairMeasure {
            head_along: 0.0,
            head_gap: 0.0,
            point_along: 0.0,
            point_gap: 0.0,
            yaw_error: 0.0,
            head_in_b: h,
        };
        in_guide(&Coupling::default(), &Geometry::default(), &m)
    }

    /// A tug of 1.5 s at 10 Hz whose head lies at `x(k)` along the axis at update k.
    fn tug(x: impl Fn(usize) -> f64) -> Tug {
        Tug {
            heads: (0..15).map(|k| (0.1 * k as f64, [x(k), 0.0])).collect(),
        }
    }

    #[test]
    fn a_held_anchor_passes_its_tug_under_noise_and_one_pulled_out_does_not() {
        let (g, c) = (Geometry::default(), Coupling::default());
        let reach = f64::from(c.anchor_travel) + f64::from(c.anchor_seat);
        // Pulled to full travel: the head sits the travel out from its seat, 1 mm inside
        // the guide's mouth limit.
        let seat = f64::from(g.anchor_opening[0]) - Coupling::anchor_depth(&g);
        let held = seat + f64::from(c.anchor_travel);
        // Capture noise of ±1.5–2 mm on the head: several single poses lie outside the guide.
        let noise = [1.5e-3, -1.5e-3, 2.0e-3, -2.0e-3, 0.5e-3];
        let noisy = tug(|k| held + noise[k % noise.len()]);
        assert!(
            noisy.heads.iter().any(|&(_, h)| !inside(h)),
            "the noise must put single poses outside the guide"
        );
        assert!(noisy.held(inside, reach));
        // Not coupled: the head leaves the guide at the approach speed (0.05 m/s).
        let pulled_out = tug(|k| held + 0.005 * k as f64);
        assert!(!pulled_out.held(inside, reach));
        // Never in: a head that stays at the face is blocked, not held.
        let at_face = tug(|_| f64::from(g.anchor_opening[0]) + 1e-3);
        assert!(!at_face.held(inside, reach));
    }
}
