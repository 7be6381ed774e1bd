//! Product-of-exponentials forward kinematics of an articulated chain of modules (AAM paper
//! §4: local frame representation, Eq. (5) and (18)), and the chain of a PuzzleBot line bent
//! at its soft anchors (THESIS 4.2: each anchor a revolute joint in pitch).

use puzzlebot_params::coupling::Coupling;
use puzzlebot_params::geometry::Geometry;

/// A rigid transform: rotation (row-major) and translation (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Se3 {
    /// Rotation matrix.
    pub r: [[f64; 3]; 3],
    /// Translation (m).
    pub p: [f64; 3],
}

impl Se3 {
    /// The identity.
    pub const IDENTITY: Se3 = Se3 {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        p: [0.0; 3],
    };

    /// A pure translation.
    pub fn translation(p: [f64; 3]) -> Se3 {
        Se3 { p, ..Se3::IDENTITY }
    }

    /// `self · other`.
    pub fn mul(&self, o: &Se3) -> Se3 {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| self.r[i][k] * o.r[k][j]).sum();
            }
        }
        Se3 {
            r,
            p: self.apply(o.p),
        }
    }

    /// The point `x` of this frame in the parent frame.
    pub fn apply(&self, x: [f64; 3]) -> [f64; 3] {
        let mut y = self.p;
        for (i, yi) in y.iter_mut().enumerate() {
            *yi += (0..3).map(|k| self.r[i][k] * x[k]).sum::<f64>();
        }
        y
    }

    /// Pitch (rotation about y, rad) of a transform whose rotation is about y only.
    pub fn pitch(&self) -> f64 {
        self.r[0][2].atan2(self.r[0][0])
    }
}

/// Twist coordinates ξ = (v, ω) of a joint axis (AAM Eq. (5)); |ω| = 1 for a revolute joint,
/// ω = 0 and |v| = 1 for a prismatic one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Twist {
    /// Linear part.
    pub v: [f64; 3],
    /// Angular part.
    pub w: [f64; 3],
}

impl Twist {
    /// A revolute joint about the unit axis `w` through the point `q`: v = −ω × q.
    pub fn revolute(w: [f64; 3], q: [f64; 3]) -> Twist {
        let c = cross(w, q);
        Twist {
            v: [-c[0], -c[1], -c[2]],
            w,
        }
    }

    /// e^{ξ̂ θ} (the exponential of a unit twist; Murray, Li, Sastry (2.36)).
    pub fn exp(&self, theta: f64) -> Se3 {
        let (w, v) = (self.w, self.v);
        let n2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        if n2 < 1e-18 {
            return Se3::translation([v[0] * theta, v[1] * theta, v[2] * theta]);
        }
        let (s, c) = theta.sin_cos();
        let k = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
        let mut r = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                let kk: f64 = (0..3).map(|m| k[i][m] * k[m][j]).sum();
                r[i][j] = f64::from(u8::from(i == j)) + s * k[i][j] + (1.0 - c) * kk;
            }
        }
        // p = (I − R)(ω × v) + ω ωᵀ v θ
        let wv = cross(w, v);
        let wdotv = w[0] * v[0] + w[1] * v[1] + w[2] * v[2];
        let mut p = [0.0; 3];
        for i in 0..3 {
            let iw: f64 = (0..3)
                .map(|j| (f64::from(u8::from(i == j)) - r[i][j]) * wv[j])
                .sum();
            p[i] = iw + w[i] * wdotv * theta;
        }
        Se3 { r, p }
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// One link of a serial chain: the initial pose of module i relative to module i − 1,
/// T_{i−1,i}(0), and the twist of the joint between them in module i's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// T_{i−1,i}(0).
    pub initial: Se3,
    /// ξ_i, in module i's frame.
    pub twist: Twist,
}

/// Poses of every module of a serial chain rooted at `base` (AAM Eq. (18)):
/// T_{0,i}(q) = base · T_{0,1}(0) e^{ξ₁q₁} ⋯ T_{i−1,i}(0) e^{ξᵢqᵢ}; `base` is the first
/// module's pose, the links follow it (one angle per link).
pub fn chain(base: Se3, links: &[Link], q: &[f64]) -> Vec<Se3> {
    let mut out = Vec::with_capacity(links.len() + 1);
    let mut t = base;
    out.push(t);
    for (l, &qi) in links.iter().zip(q) {
        t = t.mul(&l.initial).mul(&l.twist.exp(qi));
        out.push(t);
    }
    out
}

/// The links of a PuzzleBot line of `n` robots front to back: each robot one anchor pitch
/// behind the one before it, joined at the seat of its front opening (at the coupling
/// height `coupling_height` above its ground plane) by a revolute joint about its y axis.
pub fn line_links(n: usize, g: &Geometry, coupling_height: f64) -> Vec<Link> {
    let pitch = puzzlebot_params::formation::anchor_pitch(g);
    let seat = f64::from(g.anchor_opening[0]) - Coupling::anchor_depth(g);
    let joint = [seat, 0.0, coupling_height];
    (1..n)
        .map(|_| Link {
            initial: Se3::translation([-pitch, 0.0, 0.0]),
            twist: Twist::revolute([0.0, 1.0, 0.0], joint),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
    }

    #[test]
    fn a_revolute_twist_turns_about_its_axis_through_its_point() {
        // About z through (1, 0, 0) by 90°: the origin goes to (1, −1, 0).
        let t = Twist::revolute([0.0, 0.0, 1.0], [1.0, 0.0, 0.0]).exp(std::f64::consts::FRAC_PI_2);
        assert!(close(t.apply([0.0; 3]), [1.0, -1.0, 0.0]), "{t:?}");
        assert!(close(t.apply([1.0, 0.0, 0.0]), [1.0, 0.0, 0.0]));
        // A prismatic twist moves along v.
        let p = Twist {
            v: [0.0, 0.0, 1.0],
            w: [0.0; 3],
        }
        .exp(0.25);
        assert!(close(p.apply([1.0, 2.0, 3.0]), [1.0, 2.0, 3.25]));
    }

    #[test]
    fn a_line_bent_at_its_anchors_puts_each_robot_where_hand_geometry_does() {
        let g = Geometry::default();
        let h = 0.02;
        let links = line_links(3, &g, h);
        let pitch = puzzlebot_params::formation::anchor_pitch(&g);
        let seat = f64::from(g.anchor_opening[0]) - Coupling::anchor_depth(&g);
        // Straight: every robot one pitch behind the last.
        let straight = chain(Se3::IDENTITY, &links, &[0.0, 0.0]);
        assert!(close(straight[2].p, [-2.0 * pitch, 0.0, 0.0]));
        // Robot 2 pitched by θ about its opening's seat (robot 1 level): its origin swings
        // about the joint at (−pitch + seat, 0, h) in robot 1's frame.
        let th: f64 = 0.3;
        let bent = chain(Se3::IDENTITY, &links, &[th, 0.0]);
        let (s, c) = th.sin_cos();
        let j = [-pitch + seat, 0.0, h];
        let rel = [-seat, 0.0, -h]; // origin − joint, robot 2's frame
        let hand = [
            j[0] + c * rel[0] + s * rel[2],
            0.0,
            j[2] - s * rel[0] + c * rel[2],
        ];
        assert!(close(bent[1].p, hand), "{:?} vs {hand:?}", bent[1].p);
        assert!((bent[1].pitch() - th).abs() < 1e-12);
        // Robot 3 follows rigidly (its own joint straight): one pitch behind along robot 2's x.
        let third = [hand[0] - pitch * c, 0.0, hand[2] + pitch * s];
        assert!(close(bent[2].p, third), "{:?} vs {third:?}", bent[2].p);
        // Opposite bends cancel in orientation.
        let zig = chain(Se3::IDENTITY, &links, &[th, -th]);
        assert!(zig[2].pitch().abs() < 1e-12);
    }
}
