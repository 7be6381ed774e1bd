//! The six connection points of a PuzzleBot and the pair types they form
//! (THESIS 3.2 Fig 3.2, 5.4.1, 5.5.5 Fig 5.12–5.14).

use puzzlebot_params::geometry::Geometry;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

pub use puzzlebot_params::angle::wrap_angle;

/// The planar pose (x, y in m, yaw in rad), THESIS 3.2: p_i = [x_i, y_i, θ_i].
pub use puzzlebot_params::pose::Pose;

/// The coordinator's name for [`Pose`].
pub use puzzlebot_params::pose::Pose as Pose2;

/// Distance between two points.
pub fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// One of the six connection points used for planning (THESIS 5.5.5 Fig 5.12).
///
/// The front carries the anchor opening, the back the anchor; the two points on the left side
/// carry knobs and the two on the right side holes (at x = ±`side_point_x`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ConnPoint {
    /// Anchor opening, centre of the front face.
    Front,
    /// Anchor base, centre of the back face (the anchor head sticks out behind it).
    Back,
    /// Front knob on the left side.
    LeftFront,
    /// Back knob on the left side.
    LeftBack,
    /// Front hole on the right side.
    RightFront,
    /// Back hole on the right side.
    RightBack,
}

/// What a connection point carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PointRole {
    /// The anchor (back).
    Anchor,
    /// The anchor opening (front).
    Opening,
    /// A rigid knob (left side).
    Knob,
    /// A hole for a knob (right side).
    Hole,
}

/// Kind of a connection pair (THESIS Algorithm 7: "type = anchor or knob").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PairType {
    /// Anchor of one robot into the front opening of another (flexible, THESIS 4.2.2).
    AnchorOpening,
    /// Side knob of one robot into the hole of another (rigid, THESIS 5.5.3).
    KnobHole,
}

impl ConnPoint {
    /// All six points, in a fixed order.
    pub const ALL: [ConnPoint; 6] = [
        ConnPoint::Front,
        ConnPoint::Back,
        ConnPoint::LeftFront,
        ConnPoint::LeftBack,
        ConnPoint::RightFront,
        ConnPoint::RightBack,
    ];

    /// What this point carries.
    pub fn role(self) -> PointRole {
        match self {
            ConnPoint::Front => PointRole::Opening,
            ConnPoint::Back => PointRole::Anchor,
            ConnPoint::LeftFront | ConnPoint::LeftBack => PointRole::Knob,
            ConnPoint::RightFront | ConnPoint::RightBack => PointRole::Hole,
        }
    }

    /// Position in the body frame (m).
    pub fn position(self, g: &Geometry) -> [f64; 2] {
        let hl = f64::from(g.length) * 0.5;
        let hw = f64::from(g.width) * 0.5;
        let s = f64::from(g.side_point_x);
        match self {
            ConnPoint::Front => [
                f64::from(g.anchor_opening[0]),
                f64::from(g.anchor_opening[1]),
            ],
            ConnPoint::Back => [-hl, 0.0],
            ConnPoint::LeftFront => [s, hw],
            ConnPoint::LeftBack => [-s, hw],
            ConnPoint::RightFront => [s, -hw],
            ConnPoint::RightBack => [-s, -hw],
        }
    }

    /// Direction of the outward face normal in the body frame (rad).
    pub fn normal(self) -> f64 {
        match self {
            ConnPoint::Front => 0.0,
            ConnPoint::Back => PI,
            ConnPoint::LeftFront | ConnPoint::LeftBack => FRAC_PI_2,
            ConnPoint::RightFront | ConnPoint::RightBack => -FRAC_PI_2,
        }
    }

    /// Augmented ("head") point of THESIS Algorithm 7 in the body frame (m): the anchor head
    /// (THESIS 5.10: a = (−0.032, 0)) for the anchor, the knob tip for a knob, the point itself
    /// for an opening or a hole.
    pub fn head(self, g: &Geometry) -> [f64; 2] {
        let p = self.position(g);
        match self.role() {
            PointRole::Anchor => [f64::from(g.anchor_head[0]), f64::from(g.anchor_head[1])],
            PointRole::Knob => [p[0], p[1] + f64::from(g.knob_length)],
            PointRole::Opening | PointRole::Hole => p,
        }
    }

    /// Short lower-case name, as used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ConnPoint::Front => "front",
            ConnPoint::Back => "back",
            ConnPoint::LeftFront => "left_front",
            ConnPoint::LeftBack => "left_back",
            ConnPoint::RightFront => "right_front",
            ConnPoint::RightBack => "right_back",
        }
    }
}

impl std::fmt::Display for ConnPoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::fmt::Display for PairType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PairType::AnchorOpening => "anchor-opening",
            PairType::KnobHole => "knob-hole",
        })
    }
}

/// The pair type two points form, or `None` when they cannot couple (opening–opening,
/// anchor–anchor, knob–knob, hole–hole, or a face with a side).
pub fn pair_type(a: ConnPoint, b: ConnPoint) -> Option<PairType> {
    use PointRole::*;
    match (a.role(), b.role()) {
        (Anchor, Opening) | (Opening, Anchor) => Some(PairType::AnchorOpening),
        (Knob, Hole) | (Hole, Knob) => Some(PairType::KnobHole),
        _ => None,
    }
}

/// Corners of the body rectangle in the body frame, counter-clockwise from rear right.
pub fn body_corners(g: &Geometry) -> [[f64; 2]; 4] {
    let hl = f64::from(g.length) * 0.5;
    let hw = f64::from(g.width) * 0.5;
    [[-hl, -hw], [hl, -hw], [hl, hw], [-hl, hw]]
}

/// True when `p` lies inside the convex counter-clockwise polygon `poly` grown by `margin`
/// (THESIS (5.9): every edge has the point on its left; a margin moves each edge outward).
pub fn point_in_convex(p: [f64; 2], poly: &[[f64; 2]], margin: f64) -> bool {
    signed_outside(p, poly) <= margin
}

/// Largest outward distance of `p` beyond the edges of a convex counter-clockwise polygon
/// (≤ 0 inside). THESIS (5.9) with each row normalised to unit length.
pub fn signed_outside(p: [f64; 2], poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    let mut worst = f64::NEG_INFINITY;
    for k in 0..n {
        let a = poly[k];
        let b = poly[(k + 1) % n];
        let ex = b[0] - a[0];
        let ey = b[1] - a[1];
        let len = ex.hypot(ey);
        if len <= 0.0 {
            continue;
        }
        // (y_{k+1} − y_k, −(x_{k+1} − x_k)) · (P − A_k) ≤ 0 inside.
        let d = (ey * (p[0] - a[0]) - ex * (p[1] - a[1])) / len;
        worst = worst.max(d);
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transforms_round_trip() {
        let p = Pose::new(0.3, -0.2, 1.1);
        let w = p.transform([0.01, 0.02]);
        let b = p.inverse_transform(w);
        assert!((b[0] - 0.01).abs() < 1e-12 && (b[1] - 0.02).abs() < 1e-12);
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        let q = Pose::new(-0.1, 0.4, -2.0);
        let r = p.relative(&q);
        let back = p.compose(&r);
        assert!(back.distance(&q) < 1e-12 && wrap_angle(back.yaw - q.yaw).abs() < 1e-12);
        assert!((wrap_angle(-3.0 * PI) - PI).abs() < 1e-12);
    }

    #[test]
    fn pair_types_follow_roles() {
        use ConnPoint::*;
        assert_eq!(pair_type(Front, Back), Some(PairType::AnchorOpening));
        assert_eq!(pair_type(LeftFront, RightBack), Some(PairType::KnobHole));
        assert_eq!(pair_type(Front, Front), None);
        assert_eq!(pair_type(LeftFront, LeftBack), None);
        assert_eq!(pair_type(Front, LeftFront), None);
    }

    #[test]
    fn anchor_head_is_seven_mm_behind_the_back_face() {
        let g = Geometry::default();
        let h = ConnPoint::Back.head(&g);
        let b = ConnPoint::Back.position(&g);
        assert!((b[0] - h[0] - 0.007).abs() < 1e-6);
    }

    #[test]
    fn point_in_polygon_with_margin() {
        let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        assert!(point_in_convex([0.5, 0.5], &sq, 0.0));
        assert!(!point_in_convex([1.05, 0.5], &sq, 0.0));
        assert!(point_in_convex([1.05, 0.5], &sq, 0.1));
    }
}
