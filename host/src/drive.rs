//! Drive mapping: (v, ω) → wheel speed targets, the v–ω "butterfly" feasibility polygon,
//! pose-based velocity estimation and the 30 Hz velocity stabiliser.
//!
//! Wheel commands `M` are wheel (output-shaft) speed targets in RPM, the unit of
//! [`puzzlebot_protocol::HostMsg::WheelSpeed`]; the on-robot PI loop holds them.
//!
//! * THESIS (2.1)–(2.2): differential drive, `ω_r = (2v + ωL)/(2R)`, `ω_l = (2v − ωL)/(2R)`;
//!   in RPM units this gives the nominal gains [`DriveMap::geometric`].
//! * THESIS (3.10): `v = k_v (M_r + M_l)/2`, `ω = k_ω (M_r − M_l)`, calibrated per robot,
//!   and the QP under it (weights μ_v, μ_ω; `M_min ≤ |M_r|, |M_l| ≤ M_max`), solved
//!   exactly by [`DriveMap::wheels`]: the feasible set of each wheel is
//!   `{0} ∪ [−M_max, −M_min] ∪ [M_min, M_max]`, so the QP splits into nine convex
//!   two-variable box QPs whose exact minima are compared.
//! * THESIS 3.5.1, 4.3.4: the feasible v–ω set is a butterfly of two kites with the
//!   corner points A = (a_v, a_ω) and B = (b_v, 0) ([`Butterfly`]).
//! * THESIS 4.4.3, 5.2.1: a 30 Hz stabiliser estimates the instant (v, ω) from poses over
//!   a short window and corrects the command ([`Stabiliser`]); commands too small for the
//!   wheels' dead-band M_min are dithered so that their mean motion is still made (ours).

mod butterfly;
mod stabiliser;
mod velocity;

pub use butterfly::Butterfly;
pub use stabiliser::{Stabiliser, StabiliserGains};
pub use velocity::{wrap_angle, PoseSample, VelocityEstimator};

use puzzlebot_params::{geometry::Geometry, RobotParams};
use serde::{Deserialize, Serialize};

/// RPM per rad/s.
pub const RPM_PER_RAD_S: f64 = 60.0 / (2.0 * std::f64::consts::PI);

/// Wheel speed targets (RPM), left and right.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct WheelTargets {
    /// Left wheel target (RPM).
    pub left_rpm: f64,
    /// Right wheel target (RPM).
    pub right_rpm: f64,
}

/// A body velocity command: forward speed (m/s) and turn rate (rad/s, CCW).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// Forward speed (m/s).
    pub v: f64,
    /// Turn rate (rad/s), counter-clockwise.
    pub omega: f64,
}

impl Twist {
    /// A twist from its parts.
    pub const fn new(v: f64, omega: f64) -> Self {
        Twist { v, omega }
    }

    /// Standing still.
    pub const ZERO: Twist = Twist { v: 0.0, omega: 0.0 };

    /// True when both components are finite.
    pub fn is_finite(&self) -> bool {
        self.v.is_finite() && self.omega.is_finite()
    }
}

/// The calibrated (v, ω) → wheel mapping of one robot (THESIS 3.10 and its QP).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DriveMap {
    /// k_v: m/s per RPM of mean wheel command.
    pub k_v: f64,
    /// k_ω: rad/s per RPM of wheel command difference (right − left).
    pub k_omega: f64,
    /// M_min: smallest non-zero wheel command magnitude (RPM).
    pub m_min: f64,
    /// M_max: largest wheel command magnitude (RPM).
    pub m_max: f64,
    /// μ_v: weight of the linear-speed error in the QP.
    pub mu_v: f64,
    /// μ_ω: weight of the turn-rate error in the QP.
    pub mu_omega: f64,
    /// Feasible v–ω set.
    pub butterfly: Butterfly,
}

impl DriveMap {
    /// The calibrated mapping of a robot's parameter set (k_v, k_ω, M_min, M_max, A, B).
    pub fn from_params(p: &RobotParams) -> Self {
        let d = &p.drive;
        let half_base = f64::from(p.geometry.wheel_base) * 0.5;
        DriveMap {
            k_v: f64::from(d.k_v),
            k_omega: f64::from(d.k_omega),
            m_min: f64::from(d.min_rpm),
            m_max: f64::from(d.max_rpm),
            mu_v: 1.0,
            // Weigh ω errors as the wheel-rim speed they cause: (L/2)·Δω.
            mu_omega: half_base * half_base,
            butterfly: Butterfly::from_drive(d),
        }
    }

    /// The ideal differential drive of THESIS (2.1)–(2.2) in RPM units:
    /// `k_v = 2πR/60`, `k_ω = 2πR/(60 L)`; M_min, M_max and the butterfly from `p`.
    pub fn geometric(p: &RobotParams) -> Self {
        let (k_v, k_omega) = geometric_gains(&p.geometry);
        DriveMap {
            k_v,
            k_omega,
            ..DriveMap::from_params(p)
        }
    }

    /// Check the numbers; the error names the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err(format!("drive.{name} must be a positive number (got {x})"))
            }
        };
        pos("k_v", self.k_v)?;
        pos("k_omega", self.k_omega)?;
        pos("max_rpm", self.m_max)?;
        if !(self.m_min.is_finite() && self.m_min >= 0.0 && self.m_min < self.m_max) {
            return Err(format!(
                "drive.min_rpm must lie in [0, max_rpm) (got {})",
                self.m_min
            ));
        }
        if !self.butterfly.is_valid() {
            return Err(format!(
                "drive.butterfly_a/butterfly_b must satisfy 0 < a_v < b_v and a_ω ≠ 0 (got A = {:?}, B = {:?})",
                self.butterfly.a, self.butterfly.b
            ));
        }
        Ok(())
    }

    /// The twist the robot makes for wheel commands (THESIS 3.10, dead-band ignored).
    pub fn twist_of(&self, w: WheelTargets) -> Twist {
        Twist::new(
            self.k_v * (w.right_rpm + w.left_rpm) * 0.5,
            self.k_omega * (w.right_rpm - w.left_rpm),
        )
    }

    /// Wheel commands for `t`: the exact minimiser of the THESIS 3.10 QP
    /// `μ_v (k_v (M_r+M_l)/2 − v)² + μ_ω (k_ω (M_r−M_l) − ω)²` subject to each wheel being
    /// 0 or `M_min ≤ |M| ≤ M_max`. Non-finite input gives a stop.
    pub fn wheels(&self, t: Twist) -> WheelTargets {
        if !t.is_finite() || self.validate().is_err() {
            return WheelTargets::default();
        }
        // Objective f(r, l) = ½ xᵀ H x − gᵀ x + const, x = (r, l).
        let cv = self.k_v * 0.5;
        let cw = self.k_omega;
        // f = μv (cv r + cv l − v)² + μω (cw r − cw l − ω)²
        let f = |r: f64, l: f64| {
            self.mu_v * (cv * (r + l) - t.v).powi(2)
                + self.mu_omega * (cw * (r - l) - t.omega).powi(2)
        };
        let intervals = [
            (-self.m_max, -self.m_min),
            (0.0, 0.0),
            (self.m_min, self.m_max),
        ];
        // Unconstrained minimiser (exact inverse of 3.10).
        let free_r = t.v / self.k_v + t.omega / (2.0 * self.k_omega);
        let free_l = t.v / self.k_v - t.omega / (2.0 * self.k_omega);
        let mut best = (0.0, 0.0);
        let mut best_f = f(0.0, 0.0);
        for &(r0, r1) in &intervals {
            for &(l0, l1) in &intervals {
                let (r, l) = box_qp(&f, self, t, (r0, r1), (l0, l1), (free_r, free_l));
                let val = f(r, l);
                if val < best_f - 1e-15 {
                    best_f = val;
                    best = (r, l);
                }
            }
        }
        WheelTargets {
            right_rpm: best.0,
            left_rpm: best.1,
        }
    }

    /// Project onto the butterfly, then map to wheels: what the host sends for `t`.
    pub fn command(&self, t: Twist) -> WheelTargets {
        self.wheels(self.butterfly.project(t))
    }
}

/// Nominal gains of THESIS (2.1)–(2.2) in RPM units: `(k_v, k_ω)`.
pub fn geometric_gains(g: &Geometry) -> (f64, f64) {
    let r = f64::from(g.wheel_radius);
    let l = f64::from(g.wheel_base);
    let k_v = r / RPM_PER_RAD_S;
    (k_v, k_v / l)
}

/// Exact minimum of the convex quadratic `f` over the box `[r0, r1] × [l0, l1]`.
fn box_qp(
    f: &impl Fn(f64, f64) -> f64,
    m: &DriveMap,
    t: Twist,
    (r0, r1): (f64, f64),
    (l0, l1): (f64, f64),
    (fr, fl): (f64, f64),
) -> (f64, f64) {
    if (r0..=r1).contains(&fr) && (l0..=l1).contains(&fl) {
        return (fr, fl);
    }
    // Otherwise the minimum lies on an edge: minimise the 1-D quadratic along each edge.
    let cv = m.k_v * 0.5;
    let cw = m.k_omega;
    // ∂f/∂r = 2μv cv (cv(r+l) − v) + 2μω cw (cw(r−l) − ω); minimiser in r for fixed l:
    let a = m.mu_v * cv * cv + m.mu_omega * cw * cw;
    let r_for = |l: f64| {
        let b = m.mu_v * cv * (cv * l - t.v) + m.mu_omega * cw * (-cw * l - t.omega);
        (-b / a).clamp(r0, r1)
    };
    let l_for = |r: f64| {
        let b = m.mu_v * cv * (cv * r - t.v) - m.mu_omega * cw * (cw * r - t.omega);
        (-b / a).clamp(l0, l1)
    };
    let candidates = [
        (r_for(l0), l0),
        (r_for(l1), l1),
        (r0, l_for(r0)),
        (r1, l_for(r1)),
    ];
    let mut best = candidates[0];
    let mut best_f = f(best.0, best.1);
    for &c in &candidates[1..] {
        let v = f(c.0, c.1);
        if v < best_f {
            best_f = v;
            best = c;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_params::RobotKind;

    pub(super) fn map() -> DriveMap {
        DriveMap::geometric(&RobotParams::for_kind(RobotKind::NonPilot))
    }

    #[test]
    fn unconstrained_mapping_inverts_thesis_3_10_and_matches_2_1() {
        let m = map();
        let t = Twist::new(0.08, 0.8);
        let w = m.wheels(t);
        let back = m.twist_of(w);
        assert!((back.v - t.v).abs() < 1e-12 && (back.omega - t.omega).abs() < 1e-12);
        // THESIS (2.1): right wheel rad/s = (2v + ωL)/(2R).
        let g = Geometry::default();
        let (r, l) = (f64::from(g.wheel_radius), f64::from(g.wheel_base));
        let wr = (2.0 * t.v + t.omega * l) / (2.0 * r) * RPM_PER_RAD_S;
        assert!((w.right_rpm - wr).abs() < 1e-9, "{w:?} vs {wr}");
    }

    #[test]
    fn dead_band_and_saturation_are_respected() {
        let m = map();
        // A crawl that would need |M| < M_min on both wheels: stop or jump to M_min, whichever is closer.
        let tiny = m.wheels(Twist::new(m.k_v * m.m_min * 0.3, 0.0));
        assert_eq!(tiny, WheelTargets::default());
        let small = m.wheels(Twist::new(m.k_v * m.m_min * 0.8, 0.0));
        assert!(
            (small.left_rpm - m.m_min).abs() < 1e-9 && (small.right_rpm - m.m_min).abs() < 1e-9
        );
        let huge = m.wheels(Twist::new(10.0, 0.0));
        assert!((huge.left_rpm - m.m_max).abs() < 1e-9);
        // Turning in place where one wheel would need less than M_min.
        let w = m.wheels(Twist::new(m.k_v * m.m_min * 1.5, 2.0 * m.k_omega * m.m_min));
        for x in [w.left_rpm, w.right_rpm] {
            assert!(
                x == 0.0 || (m.m_min - 1e-9..=m.m_max + 1e-9).contains(&x.abs()),
                "{w:?}"
            );
        }
        assert_eq!(m.wheels(Twist::new(f64::NAN, 0.0)), WheelTargets::default());
    }

    #[test]
    fn brute_force_agrees_with_exact_qp() {
        let m = map();
        let f = |t: Twist, w: WheelTargets| {
            let c = m.twist_of(w);
            m.mu_v * (c.v - t.v).powi(2) + m.mu_omega * (c.omega - t.omega).powi(2)
        };
        let feasible = |x: f64| x == 0.0 || (m.m_min..=m.m_max).contains(&x.abs());
        let grid: Vec<f64> = (-900..=900)
            .map(|i| f64::from(i) * 0.5)
            .filter(|x| feasible(*x))
            .collect();
        for t in [
            Twist::new(0.03, 3.0),
            Twist::new(-0.5, 1.0),
            Twist::new(0.01, -0.3),
            Twist::new(0.2, 20.0),
        ] {
            let w = m.wheels(t);
            assert!(feasible(w.left_rpm) && feasible(w.right_rpm), "{w:?}");
            let mut best = f64::INFINITY;
            for &r in &grid {
                for &l in grid.iter().step_by(3) {
                    best = best.min(f(
                        t,
                        WheelTargets {
                            left_rpm: l,
                            right_rpm: r,
                        },
                    ));
                }
            }
            assert!(f(t, w) <= best + 1e-9, "{t:?}: {} > {best}", f(t, w));
        }
    }
}
