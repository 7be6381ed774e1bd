//! Planar frames and small vector helpers (f64, metres and radians).

/// A 2-D vector.
pub type V2 = [f64; 2];

/// The planar pose (one type for simulator, MPC and planner).
pub use puzzlebot_params::pose::Pose;

/// A pose with its sine and cosine computed once (for many transforms in a row).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// sin(yaw).
    pub s: f64,
    /// cos(yaw).
    pub c: f64,
}

impl Frame {
    /// The frame of `p`.
    pub fn of(p: &Pose) -> Frame {
        let (s, c) = p.yaw.sin_cos();
        Frame {
            x: p.x,
            y: p.y,
            s,
            c,
        }
    }

    /// Same rotation, position of `p` (when only the position changed).
    pub fn moved(self, p: &Pose) -> Frame {
        Frame {
            x: p.x,
            y: p.y,
            ..self
        }
    }

    /// A body-frame point in the world frame.
    pub fn apply(&self, p: V2) -> V2 {
        [
            self.x + self.c * p[0] - self.s * p[1],
            self.y + self.s * p[0] + self.c * p[1],
        ]
    }

    /// A world point in this body frame.
    pub fn inverse_apply(&self, p: V2) -> V2 {
        let d = [p[0] - self.x, p[1] - self.y];
        [
            self.c * d[0] + self.s * d[1],
            -self.s * d[0] + self.c * d[1],
        ]
    }

    /// A body-frame direction in the world frame.
    pub fn rotate(&self, v: V2) -> V2 {
        [self.c * v[0] - self.s * v[1], self.s * v[0] + self.c * v[1]]
    }

    /// Position.
    pub fn pos(&self) -> V2 {
        [self.x, self.y]
    }
}

/// Wrap an angle to (−π, π].
pub use puzzlebot_params::angle::wrap_angle as wrap;

/// a − b.
pub fn sub(a: V2, b: V2) -> V2 {
    [a[0] - b[0], a[1] - b[1]]
}

/// a + b.
pub fn add(a: V2, b: V2) -> V2 {
    [a[0] + b[0], a[1] + b[1]]
}

/// k·a.
pub fn scale(a: V2, k: f64) -> V2 {
    [a[0] * k, a[1] * k]
}

/// Dot product.
pub fn dot(a: V2, b: V2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// z of the cross product.
pub fn cross(a: V2, b: V2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Euclidean length.
pub fn norm(a: V2) -> f64 {
    (a[0] * a[0] + a[1] * a[1]).sqrt()
}

/// True when `p` is inside the convex hull of `pts` (any order, ≥ 3 points; fewer: false).
pub fn in_convex_hull(pts: &[V2], p: V2) -> bool {
    if pts.len() < 3 {
        return false;
    }
    // Monotone-chain hull, then a same-side test.
    let mut v: Vec<V2> = pts.to_vec();
    v.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let mut hull: Vec<V2> = Vec::with_capacity(v.len() * 2);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &V2>> = if pass == 0 {
            Box::new(v.iter())
        } else {
            Box::new(v.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && cross(
                    sub(hull[hull.len() - 1], hull[hull.len() - 2]),
                    sub(q, hull[hull.len() - 2]),
                ) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    if hull.len() < 3 {
        return false;
    }
    let n = hull.len();
    (0..n).all(|i| cross(sub(hull[(i + 1) % n], hull[i]), sub(p, hull[i])) >= -1e-12)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_round_trip_and_hull() {
        let p = Pose::new(1.0, 2.0, 0.7);
        let w = p.transform([0.3, -0.1]);
        let b = p.inverse_transform(w);
        let f = Frame::of(&p);
        assert_eq!(f.apply([0.3, -0.1]), w);
        assert_eq!(f.inverse_apply(w), b);
        assert!((b[0] - 0.3).abs() < 1e-12 && (b[1] + 0.1).abs() < 1e-12);
        let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]];
        assert!(in_convex_hull(&sq, [0.5, 0.2]));
        assert!(!in_convex_hull(&sq, [1.5, 0.2]));
        assert!(!in_convex_hull(&sq[..2], [0.5, 0.0]));
        assert!(
            (wrap(3.5 * core::f64::consts::PI) - core::f64::consts::PI * 1.5
                + 2.0 * core::f64::consts::PI)
                .abs()
                < 1e-9
        );
    }
}
