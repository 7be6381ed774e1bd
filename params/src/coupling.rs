//! Anchor and knob mechanics (THESIS 4.2.2, 4.4.1, 5.5.3, 5.5.6; DESIGN.md §8), and the one
//! definition of when a coupling forms: the simulator's mechanics and the host's pair status
//! machine (THESIS Algorithm 8) both call the predicates below, so "inserted" on the host
//! and "coupled" in the simulator are the same event.
//!
//! The predicates take points already expressed in the frame of the robot with the opening
//! (hole), so they need no trigonometry and build `no_std`.

use crate::geometry::Geometry;
use serde::{Deserialize, Serialize};

/// Limits and tolerances of the passive couplings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Coupling {
    /// Anchor head must be within this distance of the opening to go in (m). THESIS: 3.5 mm.
    pub anchor_align_tolerance: f32,
    /// Force to push the anchor in (N). THESIS 4.4.1: < 0.2 N.
    pub anchor_push_force: f32,
    /// Force to pull a coupled anchor straight out (N): above a robot's push. THESIS 4.4.1.
    pub anchor_pull_force: f32,
    /// Load a locked anchor holds (N). THESIS 4.4.1: 500 g ≈ 4.9 N.
    pub anchor_hold_force: f32,
    /// Yaw freedom of a coupled anchor (rad). THESIS 4.2.2: ±0.5.
    pub anchor_yaw_range: f32,
    /// Travel of a coupled anchor (m). THESIS 4.2.2: 5 mm.
    pub anchor_travel: f32,
    /// Relative yaw at which an anchor head can still start entering an opening (rad).
    /// Not a THESIS number: the opening's guide is ±20° wide in the CAD of Fig 4.3; 0.35 rad.
    pub anchor_entry_yaw: f32,
    /// The anchor's legs snap into the slits when its head is within this distance of its
    /// seat (m): the "head inserted" of THESIS Algorithm 8. Estimated from the slit width
    /// (Fig 4.3): 1 mm.
    pub anchor_seat: f32,
    /// Knob alignment needed to couple (m). THESIS 5.2.3: < 1 mm.
    pub knob_align_tolerance: f32,
    /// Heading agreement needed for a knob to slide in (rad): the 1 mm fit over the 25 mm
    /// between the two knobs of a side, atan(1/25) ≈ 0.04.
    pub knob_yaw_tolerance: f32,
    /// A knob clicks in when the two side faces are within this gap (m): the knob's hooks
    /// (THESIS 2.4.1: 1.5 mm hook width).
    pub knob_seat_gap: f32,
    /// Vertical play of a knob in its hole (m). THESIS 2.3.2: knobs are 1 mm lower than
    /// holes.
    pub knob_play: f32,
    /// Force one knob holds (N). THESIS 5.5.3: ≥ 3.2 N (sensor limit).
    pub knob_hold_force: f32,
    /// Push force of one robot at top speed (N). THESIS 4.4.1, 5.5.2: 0.5–0.72.
    pub robot_push_force: f32,
    /// Stiffness of a coupled connector's held translations (N/m). Not in THESIS (printed
    /// TPU): 3.2 N moves it 0.3 mm. The 3-D physics' springs and the gate's elastic load
    /// distribution both use it.
    pub connector_stiffness: f32,
    /// Stiffness of a coupled connector's held rotations (N·m/rad): 0.09 N·m turns it 9 mrad.
    pub connector_angular_stiffness: f32,
    /// Damping ratio ζ of a coupled connector's springs (1): the printed TPU's loss factor
    /// over two, ζ = tan δ / 2. THESIS prints the bodies with their knobs and the anchors in
    /// NinjaFlex Cheetah (TPU 95A, 2.3.2, 4.2.2) without measuring its damping; a 95A TPU's
    /// tan δ at room temperature and 1–100 Hz lies at about 0.05–0.15 (dynamic mechanical
    /// analysis), so the default takes the low end, 0.025. The stability gate bounds a
    /// connector's overshoot when a support rolls off an edge with it; a lab that measures
    /// its couplings (the decay of one ringing coupling) sets its own, 0 for the undamped
    /// bound.
    pub connector_damping_ratio: f32,
}

impl Default for Coupling {
    fn default() -> Self {
        Coupling {
            anchor_align_tolerance: 0.0035,
            anchor_push_force: 0.2,
            anchor_pull_force: 0.6,
            anchor_hold_force: 0.5 * 9.81,
            anchor_yaw_range: 0.5,
            anchor_travel: 0.005,
            anchor_entry_yaw: 0.35,
            anchor_seat: 0.001,
            knob_align_tolerance: 0.001,
            knob_yaw_tolerance: 0.04,
            knob_seat_gap: 0.0015,
            knob_play: 0.001,
            knob_hold_force: 3.2,
            robot_push_force: 0.5,
            connector_stiffness: 1.0e4,
            connector_angular_stiffness: 10.0,
            connector_damping_ratio: 0.025,
        }
    }
}

/// Where an anchor head is relative to an opening: `head` is the anchor head of robot `a` in
/// the body frame of robot `b` (the one with the opening), `yaw` = θ_a − θ_b wrapped to (−π, π].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnchorProbe {
    /// Anchor head of `a` in `b`'s frame (m).
    pub head: [f64; 2],
    /// Relative yaw θ_a − θ_b (rad), wrapped.
    pub yaw: f64,
}

/// Where a knob is relative to a hole: the knob's root point on `a`'s side face, in the body
/// frame of robot `b` (the one with the hole), minus the hole's root point on `b`'s face.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KnobProbe {
    /// Offset along `b`'s side face (m).
    pub along: f64,
    /// Gap between the faces along the hole's outward normal (m); 0 = faces touching.
    pub gap: f64,
    /// Relative yaw θ_a − θ_b (rad), wrapped.
    pub yaw: f64,
}

impl Coupling {
    /// Check ranges: every field finite and ≥ 0, the forces and stiffnesses that hold a
    /// coupling > 0. The error names the field (`coupling.<field>`).
    #[cfg(feature = "std")]
    pub fn check(&self) -> Result<(), std::string::String> {
        let positive = [
            ("anchor_hold_force", self.anchor_hold_force),
            ("knob_hold_force", self.knob_hold_force),
            ("connector_stiffness", self.connector_stiffness),
            (
                "connector_angular_stiffness",
                self.connector_angular_stiffness,
            ),
        ];
        let non_negative = [
            ("anchor_align_tolerance", self.anchor_align_tolerance),
            ("anchor_push_force", self.anchor_push_force),
            ("anchor_pull_force", self.anchor_pull_force),
            ("anchor_yaw_range", self.anchor_yaw_range),
            ("anchor_travel", self.anchor_travel),
            ("anchor_entry_yaw", self.anchor_entry_yaw),
            ("anchor_seat", self.anchor_seat),
            ("knob_align_tolerance", self.knob_align_tolerance),
            ("knob_yaw_tolerance", self.knob_yaw_tolerance),
            ("knob_seat_gap", self.knob_seat_gap),
            ("knob_play", self.knob_play),
            ("robot_push_force", self.robot_push_force),
            ("connector_damping_ratio", self.connector_damping_ratio),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("coupling.{name}: must be > 0, got {v}"));
            }
        }
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("coupling.{name}: must be ≥ 0, got {v}"));
            }
        }
        Ok(())
    }

    /// Tilt a knob allows about the shared face before its hooks catch (rad): the play over
    /// the knob across the knob and its hook (THESIS 2.4.1, Fig 2.11: the 1.5 mm hook
    /// `knob_seat_gap` behind the `geometry.knob_length` knob blocks the tilt). An estimate:
    /// THESIS measures the angle (Fig 2.13) without giving the geometry behind it.
    #[cfg(feature = "std")]
    pub fn knob_tilt_limit(&self, g: &Geometry) -> f64 {
        let lever = f64::from(g.knob_length) + f64::from(self.knob_seat_gap);
        (f64::from(self.knob_play) / lever.max(1e-4)).atan()
    }

    /// Depth of the anchor head inside the opening when seated (m): how far the head stands
    /// behind its robot's back face (`Geometry::anchor_head` vs the body length).
    pub fn anchor_depth(g: &Geometry) -> f64 {
        (-f64::from(g.anchor_head[0]) - 0.5 * f64::from(g.length)).max(0.0)
    }

    /// The head is at the mouth of the opening (at the front face or up to its seat inside),
    /// laterally within `anchor_align_tolerance · k` and yawed within `anchor_entry_yaw`:
    /// pushing now guides it in. `k` ≥ 1 widens the lateral tolerance (hysteresis).
    pub fn anchor_at_mouth(&self, g: &Geometry, p: &AnchorProbe, k: f64) -> bool {
        let face = f64::from(g.anchor_opening[0]);
        let depth = Self::anchor_depth(g);
        p.head[0] <= face + 1e-4
            && p.head[0] >= face - depth - f64::from(self.anchor_seat)
            && (p.head[1] - f64::from(g.anchor_opening[1])).abs()
                <= f64::from(self.anchor_align_tolerance) * k
            && p.yaw.abs() <= f64::from(self.anchor_entry_yaw)
    }

    /// The head has reached its seat (within `anchor_seat · k`): the legs are in the slits
    /// and the anchor is coupled (THESIS 4.2.2; Algorithm 8 "head inserted").
    pub fn anchor_seated(&self, g: &Geometry, p: &AnchorProbe, k: f64) -> bool {
        let face = f64::from(g.anchor_opening[0]);
        let seat = face - Self::anchor_depth(g);
        self.not_past_seat(seat, p, k)
            && p.head[0] <= seat + f64::from(self.anchor_seat) * k
            && (p.head[1] - f64::from(g.anchor_opening[1])).abs()
                <= f64::from(self.anchor_align_tolerance) * k
            && p.yaw.abs() <= f64::from(self.anchor_yaw_range) * k
    }

    /// A coupled anchor is still held: the head is inside the anchor's travel of its seat
    /// (`anchor_travel · k`) and the yaw inside the range (THESIS 4.2.2: ±0.5 rad, 5 mm).
    pub fn anchor_held(&self, g: &Geometry, p: &AnchorProbe, k: f64) -> bool {
        let face = f64::from(g.anchor_opening[0]);
        let seat = face - Self::anchor_depth(g);
        self.not_past_seat(seat, p, k)
            && p.head[0] <= seat + f64::from(self.anchor_travel) * k
            && (p.head[1] - f64::from(g.anchor_opening[1])).abs()
                <= f64::from(self.anchor_align_tolerance) * k
            && p.yaw.abs() <= f64::from(self.anchor_yaw_range) * k
    }

    /// The head is not further in than the opening allows (the seat, less the anchor's
    /// travel · k as a margin): a head deeper than that belongs to a robot lying behind this
    /// one on its centre line, not to an anchor in its opening.
    fn not_past_seat(&self, seat: f64, p: &AnchorProbe, k: f64) -> bool {
        p.head[0] >= seat - f64::from(self.anchor_travel) * k
    }

    /// A knob is in front of its hole: along within `knob_align_tolerance · k`, the faces
    /// less than a knob length (plus the tolerance) apart and not overlapping, and the
    /// headings within `knob_yaw_tolerance · k` (THESIS 5.5.5 augmented knob point).
    pub fn knob_aligned(&self, g: &Geometry, p: &KnobProbe, k: f64) -> bool {
        let e = f64::from(self.knob_align_tolerance) * k;
        p.along.abs() <= e
            && p.gap <= f64::from(g.knob_length) + e
            && p.gap >= -e
            && p.yaw.abs() <= f64::from(self.knob_yaw_tolerance) * k
    }

    /// The knob clicks into (stays in) the hole: along within `knob_align_tolerance · k`,
    /// faces within `knob_seat_gap · k`, headings within `knob_yaw_tolerance · k`.
    pub fn knob_seated(&self, p: &KnobProbe, k: f64) -> bool {
        p.along.abs() <= f64::from(self.knob_align_tolerance) * k
            && p.gap.abs() <= f64::from(self.knob_seat_gap) * k
            && p.yaw.abs() <= f64::from(self.knob_yaw_tolerance) * k
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(feature = "std")]
    #[test]
    fn a_coupling_out_of_range_is_named() {
        assert_eq!(Coupling::default().check(), Ok(()));
        let c = Coupling {
            knob_hold_force: f32::NAN,
            ..Coupling::default()
        };
        assert!(c
            .check()
            .unwrap_err()
            .starts_with("coupling.knob_hold_force"));
        let c = Coupling {
            connector_damping_ratio: -0.1,
            ..Coupling::default()
        };
        assert!(c
            .check()
            .unwrap_err()
            .starts_with("coupling.connector_damping_ratio: must be ≥ 0"));
    }

    fn probe(x: f64, y: f64, yaw: f64) -> AnchorProbe {
        AnchorProbe { head: [x, y], yaw }
    }

    #[test]
    fn a_head_far_behind_the_seat_is_not_in_the_opening() {
        let (g, c) = (Geometry::default(), Coupling::default());
        let seat = f64::from(g.anchor_opening[0]) - Coupling::anchor_depth(&g);
        // On the centre line, seated: in.
        assert!(c.anchor_seated(&g, &probe(seat, 0.0, 0.0), 1.0));
        assert!(c.anchor_held(&g, &probe(seat, 0.0, 0.0), 1.0));
        // On the centre line but a body length further back (a robot behind this one).
        let behind = seat - f64::from(g.length);
        assert!(!c.anchor_seated(&g, &probe(behind, 0.0, 0.0), 1.0));
        assert!(!c.anchor_held(&g, &probe(behind, 0.0, 0.0), 2.0));
    }

    #[test]
    fn anchor_enters_at_the_mouth_and_seats_seven_mm_in() {
        let (g, c) = (Geometry::default(), Coupling::default());
        assert!((Coupling::anchor_depth(&g) - 0.007).abs() < 1e-6);
        // At the front face, 3 mm aside: may enter, not seated.
        assert!(c.anchor_at_mouth(&g, &probe(0.025, 0.003, 0.1), 1.0));
        assert!(!c.anchor_seated(&g, &probe(0.025, 0.003, 0.1), 1.0));
        // 4 mm aside or 0.4 rad yawed: may not enter.
        assert!(!c.anchor_at_mouth(&g, &probe(0.025, 0.004, 0.0), 1.0));
        assert!(!c.anchor_at_mouth(&g, &probe(0.025, 0.0, 0.4), 1.0));
        // 1 mm outside the face: not yet at the mouth.
        assert!(!c.anchor_at_mouth(&g, &probe(0.026, 0.0, 0.0), 1.0));
        // 6.5 mm in: seated (within 1 mm of the 7 mm seat); 5 mm in: not yet.
        assert!(c.anchor_seated(&g, &probe(0.0185, 0.0, 0.0), 1.0));
        assert!(!c.anchor_seated(&g, &probe(0.020, 0.0, 0.0), 1.0));
        // Coupled: held over the 5 mm travel, lost beyond it.
        assert!(c.anchor_held(&g, &probe(0.022, 0.0, 0.45), 1.0));
        assert!(!c.anchor_held(&g, &probe(0.0245, 0.0, 0.0), 1.0));
    }

    #[test]
    fn knobs_need_a_sub_millimetre_fit() {
        let (g, c) = (Geometry::default(), Coupling::default());
        let p = |along, gap, yaw| KnobProbe { along, gap, yaw };
        assert!(c.knob_aligned(&g, &p(0.0008, 0.003, 0.0), 1.0));
        assert!(!c.knob_aligned(&g, &p(0.0012, 0.003, 0.0), 1.0));
        assert!(!c.knob_aligned(&g, &p(0.0, 0.003, 0.05), 1.0));
        assert!(c.knob_seated(&p(0.0008, 0.001, 0.03), 1.0));
        assert!(!c.knob_seated(&p(0.0008, 0.002, 0.0), 1.0));
    }
}
