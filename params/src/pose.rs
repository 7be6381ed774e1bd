//! The one planar pose of a robot body frame in the world frame, shared by the simulator, the
//! MPC and the assembly planner (THESIS 3.2: p_i = [x_i, y_i, θ_i]); converts to and from
//! nalgebra's [`Isometry2`].

use nalgebra::{Isometry2, Vector2};
use serde::{Deserialize, Serialize};

use crate::angle::wrap_angle;

/// A planar pose: position (m) and heading (rad, counter-clockwise from +x).
///
/// The heading may hold any real value (a rolled-out trajectory keeps it continuous);
/// [`Pose::compose`], [`Pose::relative`] and [`Pose::inverse`] return it wrapped into (−π, π].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// x in the world frame (m).
    pub x: f64,
    /// y in the world frame (m).
    pub y: f64,
    /// Heading (rad), x forward, counter-clockwise positive; files may call it `theta`.
    #[serde(alias = "theta")]
    pub yaw: f64,
}

impl Pose {
    /// A pose from its parts.
    pub const fn new(x: f64, y: f64, yaw: f64) -> Self {
        Pose { x, y, yaw }
    }

    /// Position as an array.
    pub fn xy(&self) -> [f64; 2] {
        [self.x, self.y]
    }

    /// A body-frame point in the world frame: R(θ) p + [x, y] (THESIS 4.4).
    pub fn transform(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.yaw.sin_cos();
        [self.x + c * p[0] - s * p[1], self.y + s * p[0] + c * p[1]]
    }

    /// A world point in this body frame: R(θ)ᵀ (p − [x, y]) (THESIS 5.11–5.15).
    pub fn inverse_transform(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.yaw.sin_cos();
        let dx = p[0] - self.x;
        let dy = p[1] - self.y;
        [c * dx + s * dy, -s * dx + c * dy]
    }

    /// A body-frame direction in the world frame: R(θ) v.
    pub fn rotate(&self, v: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.yaw.sin_cos();
        [c * v[0] - s * v[1], s * v[0] + c * v[1]]
    }

    /// Composition `self ∘ other` (other expressed in this frame), heading wrapped.
    pub fn compose(&self, other: &Pose) -> Pose {
        let p = self.compose_unwrapped(other);
        Pose::new(p.x, p.y, wrap_angle(p.yaw))
    }

    /// Composition `self ∘ other` with the headings summed as they are (continuous along a
    /// trajectory whose headings are not wrapped).
    pub fn compose_unwrapped(&self, other: &Pose) -> Pose {
        let [x, y] = self.transform([other.x, other.y]);
        Pose::new(x, y, self.yaw + other.yaw)
    }

    /// `other` expressed in this frame: self⁻¹ ∘ other, heading wrapped.
    pub fn relative(&self, other: &Pose) -> Pose {
        let [x, y] = self.inverse_transform([other.x, other.y]);
        Pose::new(x, y, wrap_angle(other.yaw - self.yaw))
    }

    /// The inverse transform self⁻¹ (self ∘ self⁻¹ = identity), heading wrapped.
    pub fn inverse(&self) -> Pose {
        self.relative(&Pose::default())
    }

    /// One explicit Euler step of the unicycle at speed `v` (m/s) and turn rate `omega`
    /// (rad/s) over `dt` (s), THESIS (5.2); the heading is not wrapped.
    pub fn unicycle_step(&self, v: f64, omega: f64, dt: f64) -> Pose {
        let (s, c) = self.yaw.sin_cos();
        Pose::new(
            self.x + v * c * dt,
            self.y + v * s * dt,
            self.yaw + omega * dt,
        )
    }

    /// Euclidean distance between the positions (m).
    pub fn distance(&self, other: &Pose) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.yaw.is_finite()
    }

    /// The same transform as an nalgebra isometry.
    pub fn to_isometry(&self) -> Isometry2<f64> {
        Isometry2::new(Vector2::new(self.x, self.y), self.yaw)
    }

    /// The pose of an nalgebra isometry; the heading is its rotation angle in (−π, π].
    pub fn from_isometry(iso: &Isometry2<f64>) -> Pose {
        let t = iso.translation.vector;
        Pose::new(t.x, t.y, wrap_angle(iso.rotation.angle()))
    }
}

/// The spellings hil-sim's mechanics, terrain and 3-D world use.
impl Pose {
    /// [`Pose::transform`].
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        self.transform(p)
    }

    /// [`Pose::inverse_transform`].
    pub fn inverse_apply(&self, p: [f64; 2]) -> [f64; 2] {
        self.inverse_transform(p)
    }

    /// [`Pose::xy`].
    pub fn pos(&self) -> [f64; 2] {
        self.xy()
    }
}

impl From<Pose> for Isometry2<f64> {
    fn from(p: Pose) -> Self {
        p.to_isometry()
    }
}

impl From<Isometry2<f64>> for Pose {
    fn from(iso: Isometry2<f64>) -> Self {
        Pose::from_isometry(&iso)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;
    use nalgebra::Point2;

    /// Poses over all four quadrants and both sides of ±π.
    fn samples() -> Vec<Pose> {
        let mut v = Vec::new();
        for i in 0..7 {
            for j in 0..9 {
                let x = -1.5 + 0.47 * f64::from(i);
                let y = 0.8 - 0.31 * f64::from(j);
                let yaw = -3.0 * PI + 0.77 * f64::from(i * 9 + j) % (6.0 * PI);
                v.push(Pose::new(x, y, yaw));
            }
        }
        v.push(Pose::new(0.1, 0.2, PI));
        v.push(Pose::new(0.1, 0.2, -PI));
        v
    }

    fn close(a: &Pose, b: &Pose, tol: f64) -> bool {
        a.distance(b) < tol && wrap_angle(a.yaw - b.yaw).abs() < tol
    }

    #[test]
    fn compose_and_inverse_round_trip() {
        let ps = samples();
        for a in &ps {
            assert!(
                close(&a.compose(&a.inverse()), &Pose::default(), 1e-12),
                "{a:?}"
            );
            assert!(
                close(&a.inverse().compose(a), &Pose::default(), 1e-12),
                "{a:?}"
            );
            for b in ps.iter().step_by(5) {
                assert!(close(&a.compose(&a.relative(b)), b, 1e-12), "{a:?} {b:?}");
                let back = a.inverse_transform(a.transform(b.xy()));
                assert!((back[0] - b.x).abs() < 1e-12 && (back[1] - b.y).abs() < 1e-12);
                // Composition is associative.
                let c = Pose::new(0.3, -0.7, 2.9);
                assert!(close(
                    &a.compose(b).compose(&c),
                    &a.compose(&b.compose(&c)),
                    1e-12
                ));
            }
        }
    }

    #[test]
    fn headings_wrap_into_the_half_open_interval() {
        let a = Pose::new(0.0, 0.0, 3.0);
        let b = Pose::new(1.0, 0.0, 0.5);
        let c = a.compose(&b);
        assert!((c.yaw - (3.5 - 2.0 * PI)).abs() < 1e-12, "{c:?}");
        assert!((a.compose_unwrapped(&b).yaw - 3.5).abs() < 1e-15);
        // −π is outside (−π, π]: it comes back as +π.
        assert_eq!(Pose::new(0.0, 0.0, -PI).compose(&Pose::default()).yaw, PI);
        assert_eq!(Pose::new(0.0, 0.0, PI).inverse().yaw, PI);
        assert_eq!(Pose::default().relative(&Pose::new(0.0, 0.0, -PI)).yaw, PI);
        for p in samples() {
            for q in [
                p.compose(&p),
                p.inverse(),
                p.relative(&Pose::new(0.0, 0.0, 3.1)),
            ] {
                assert!(q.yaw > -PI && q.yaw <= PI, "{p:?} → {q:?}");
            }
        }
    }

    #[test]
    fn agrees_with_nalgebra_isometry2() {
        let ps = samples();
        let pt = [0.05, -0.13];
        for a in &ps {
            let ia = a.to_isometry();
            let w = ia * Point2::new(pt[0], pt[1]);
            let t = a.transform(pt);
            assert!((w.x - t[0]).abs() < 1e-12 && (w.y - t[1]).abs() < 1e-12);
            let b = ia.inverse_transform_point(&Point2::new(pt[0], pt[1]));
            let u = a.inverse_transform(pt);
            assert!((b.x - u[0]).abs() < 1e-12 && (b.y - u[1]).abs() < 1e-12);
            let r = ia.transform_vector(&Vector2::new(pt[0], pt[1]));
            let v = a.rotate(pt);
            assert!((r.x - v[0]).abs() < 1e-12 && (r.y - v[1]).abs() < 1e-12);
            assert!(close(&Pose::from(ia.inverse()), &a.inverse(), 1e-12));
            for b in ps.iter().step_by(3) {
                let ib: Isometry2<f64> = (*b).into();
                assert!(
                    close(&Pose::from(ia * ib), &a.compose(b), 1e-12),
                    "{a:?} {b:?}"
                );
                assert!(close(&Pose::from(ia.inv_mul(&ib)), &a.relative(b), 1e-12));
            }
            let back = Pose::from_isometry(&ia);
            assert!(close(&back, a, 1e-12) && back.yaw > -PI && back.yaw <= PI);
        }
    }

    #[test]
    fn unicycle_step_follows_the_heading() {
        let p = Pose::new(1.0, 2.0, PI / 2.0).unicycle_step(0.2, 0.5, 0.1);
        assert!((p.x - 1.0).abs() < 1e-15 && (p.y - 2.02).abs() < 1e-15);
        assert!((p.yaw - (PI / 2.0 + 0.05)).abs() < 1e-15);
        // Headings accumulate without wrapping.
        let q = Pose::new(0.0, 0.0, PI).unicycle_step(0.0, 1.0, 1.0);
        assert_eq!(q.yaw, PI + 1.0);
    }

    #[test]
    fn reads_yaw_or_theta_and_writes_yaw() {
        let a: Pose = toml::from_str("x = 1.0\ny = -2.0\nyaw = 0.5").unwrap();
        let b: Pose = toml::from_str("x = 1.0\ny = -2.0\ntheta = 0.5").unwrap();
        assert_eq!(a, b);
        assert_eq!(a, Pose::new(1.0, -2.0, 0.5));
        let s = toml::to_string(&a).unwrap();
        assert!(s.contains("yaw = 0.5"), "{s}");
        assert!(!Pose::new(f64::NAN, 0.0, 0.0).is_finite());
        assert!(!Pose::new(0.0, 0.0, f64::INFINITY).is_finite());
    }
}
