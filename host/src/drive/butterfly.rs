//! The v–ω feasibility polygon of a differential-drive robot (THESIS 3.5.1, 4.3.4).

use puzzlebot_params::drive::Drive;
use serde::{Deserialize, Serialize};

use super::Twist;

/// The v–ω feasibility polygon ("butterfly", THESIS 3.5.1 Fig. 3.12–3.13, 4.3.4).
///
/// For v ≥ 0 the wing is the kite O = (0, 0), (a_v, −|a_ω|), B = (b_v, 0), (a_v, |a_ω|);
/// the wing for v ≤ 0 is its mirror image. The two wings touch at the origin: a robot turns
/// fast only while it also moves.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Butterfly {
    /// Corner A = (v, ω) as calibrated (ω may be given negative, as in THESIS).
    pub a: [f64; 2],
    /// Corner B = (v, 0): top speed straight ahead.
    pub b: [f64; 2],
}

impl Butterfly {
    /// From the shared parameter set.
    pub fn from_drive(d: &Drive) -> Self {
        Butterfly {
            a: [f64::from(d.butterfly_a[0]), f64::from(d.butterfly_a[1])],
            b: [f64::from(d.butterfly_b[0]), f64::from(d.butterfly_b[1])],
        }
    }

    /// True when A and B describe a non-degenerate kite (0 < a_v < b_v, a_ω ≠ 0).
    pub fn is_valid(&self) -> bool {
        let [av, aw] = self.a;
        let bv = self.b[0];
        [av, aw, bv].iter().all(|x| x.is_finite()) && av > 0.0 && bv > av && aw.abs() > 0.0
    }

    /// The v ≥ 0 wing, counter-clockwise.
    fn wing(&self) -> [[f64; 2]; 4] {
        let av = self.a[0];
        let aw = self.a[1].abs();
        let bv = self.b[0];
        [[0.0, 0.0], [av, -aw], [bv, 0.0], [av, aw]]
    }

    /// Scale of the ω axis relative to v (for distances in the v–ω plane).
    fn omega_scale(&self) -> f64 {
        let aw = self.a[1].abs();
        if aw > 0.0 {
            self.b[0] / aw
        } else {
            1.0
        }
    }

    /// True when `t` lies in the butterfly (edges included, tolerance 1e-9).
    pub fn contains(&self, t: Twist) -> bool {
        let p = [t.v.abs(), t.omega];
        let w = self.wing();
        let s = self.omega_scale();
        (0..4).all(|i| {
            let a = w[i];
            let b = w[(i + 1) % 4];
            let cross = (b[0] - a[0]) * (p[1] - a[1]) * s - (b[1] - a[1]) * s * (p[0] - a[0]);
            cross >= -1e-9
        })
    }

    /// The nearest feasible twist (distance in v and scaled ω), keeping the sign of v.
    /// A twist with v = 0 and ω ≠ 0 is moved onto the forward wing.
    pub fn project(&self, t: Twist) -> Twist {
        if !self.is_valid() || !t.is_finite() {
            return Twist::ZERO;
        }
        if self.contains(t) {
            return t;
        }
        let sign = if t.v < 0.0 { -1.0 } else { 1.0 };
        let s = self.omega_scale();
        let p = [t.v.abs(), t.omega * s];
        let w = self.wing().map(|q| [q[0], q[1] * s]);
        let mut best = [0.0, 0.0];
        let mut best_d = f64::INFINITY;
        for i in 0..4 {
            let q = closest_on_segment(w[i], w[(i + 1) % 4], p);
            let d = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2);
            if d < best_d {
                best_d = d;
                best = q;
            }
        }
        Twist::new(sign * best[0], best[1] / s)
    }
}

fn closest_on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> [f64; 2] {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    if len2 <= 0.0 {
        return a;
    }
    let u = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0);
    [a[0] + u * d[0], a[1] + u * d[1]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_params::RobotKind;

    #[test]
    fn butterfly_contains_and_projects() {
        let b = Butterfly::from_drive(&Drive::for_kind(RobotKind::NonPilot));
        assert!(b.contains(Twist::new(0.05, 0.5)));
        assert!(b.contains(Twist::new(-0.05, -0.5)));
        assert!(!b.contains(Twist::new(0.0, 1.0)));
        assert!(!b.contains(Twist::new(0.2, 0.0)));
        let p = b.project(Twist::new(0.2, 0.0));
        assert!((p.v - 0.11).abs() < 1e-9 && p.omega.abs() < 1e-9);
        let p = b.project(Twist::new(-0.2, 0.0));
        assert!((p.v + 0.11).abs() < 1e-9);
        let p = b.project(Twist::new(0.0, 1.0));
        assert!(b.contains(p) && p.v > 0.0 && p.omega > 0.0);
        assert_eq!(b.project(Twist::new(f64::INFINITY, 0.0)), Twist::ZERO);
    }
}
