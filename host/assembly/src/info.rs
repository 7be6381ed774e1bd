//! Shape facts for users and the CLI: slots, pairs, diagonal angle α and the heading that
//! maximises the projected length over a terrain edge (THESIS 5.2.4, Fig 5.7A).

use crate::geom::{body_corners, ConnPoint, PairType};
use crate::shape::{Shape, SlotKind};
use puzzlebot_params::geometry::Geometry;
use serde::Serialize;
use std::fmt;

/// The longest line across an assembly (between two body corners) and its angle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Diagonal {
    /// Length of the diagonal (m): the largest projected length of the assembly.
    pub length: f64,
    /// Signed angle of the diagonal to the assembly's forward (x) axis (rad), in (−π/2, π/2].
    pub angle: f64,
    /// One end, shape frame (m).
    pub from: [f64; 2],
    /// Other end, shape frame (m).
    pub to: [f64; 2],
}

/// All body corners of a shape in its frame.
fn corners(shape: &Shape, g: &Geometry) -> Vec<[f64; 2]> {
    shape
        .slots
        .iter()
        .flat_map(|s| body_corners(g).map(|c| s.pose.transform(c)))
        .collect()
}

/// The diagonal of THESIS 5.2.4: "the longest possible line" in the assembly, and its angle α
/// to the heading. Ties (symmetric shapes) keep the first found, scanning corners in slot order.
pub fn diagonal(shape: &Shape, g: &Geometry) -> Diagonal {
    let c = corners(shape, g);
    let mut best = Diagonal {
        length: 0.0,
        angle: 0.0,
        from: [0.0; 2],
        to: [0.0; 2],
    };
    for i in 0..c.len() {
        for j in i + 1..c.len() {
            let d = (c[j][0] - c[i][0]).hypot(c[j][1] - c[i][1]);
            if d > best.length + 1e-12 {
                let (mut from, mut to) = (c[i], c[j]);
                if to[0] < from[0] || (to[0] == from[0] && to[1] < from[1]) {
                    std::mem::swap(&mut from, &mut to);
                }
                let mut angle = (to[1] - from[1]).atan2(to[0] - from[0]);
                if angle <= -std::f64::consts::FRAC_PI_2 {
                    angle += std::f64::consts::PI;
                }
                best = Diagonal {
                    length: d,
                    angle,
                    from,
                    to,
                };
            }
        }
    }
    best
}

/// Length of the assembly measured across a terrain edge (m) when its forward axis makes angle
/// `heading` (rad, counter-clockwise) with the crossing direction (the edge normal).
pub fn projected_length(shape: &Shape, g: &Geometry, heading: f64) -> f64 {
    // The crossing direction expressed in the shape frame: R(−heading)·x̂.
    let (s, c) = heading.sin_cos();
    let d = [c, -s];
    let (lo, hi) =
        corners(shape, g)
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                let v = p[0] * d[0] + p[1] * d[1];
                (lo.min(v), hi.max(v))
            });
    if lo.is_finite() {
        hi - lo
    } else {
        0.0
    }
}

/// One slot, for reports.
#[derive(Debug, Clone, Serialize)]
pub struct SlotInfo {
    /// Slot index.
    pub index: usize,
    /// x (m), shape frame.
    pub x: f64,
    /// y (m), shape frame.
    pub y: f64,
    /// Heading (degrees).
    pub yaw_deg: f64,
    /// Which robots may fill it.
    pub kind: SlotKind,
    /// Name from the shape file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
}

/// One goal pair, for reports.
#[derive(Debug, Clone, Serialize)]
pub struct PairInfo {
    /// Position in the convex-first queue.
    pub order: usize,
    /// Slot with the anchor or knob.
    pub a: usize,
    /// Its connection point.
    pub point_a: ConnPoint,
    /// Slot with the opening or hole.
    pub b: usize,
    /// Its connection point.
    pub point_b: ConnPoint,
    /// Pair type.
    #[serde(rename = "type")]
    pub kind: PairType,
    /// Where the points meet, shape frame (m).
    pub at: [f64; 2],
    /// Distance between the slot centres (m).
    pub centre_distance: f64,
}

/// Everything `puzzlebot shape info` shows (serialises to JSON for `--json`).
#[derive(Debug, Clone, Serialize)]
pub struct ShapeInfo {
    /// Shape name.
    pub name: String,
    /// Number of robots.
    pub robots: usize,
    /// Extent along the forward axis (m).
    pub length: f64,
    /// Extent across (m).
    pub width: f64,
    /// Slots.
    pub slots: Vec<SlotInfo>,
    /// Goal pairs in convex-first order.
    pub pairs: Vec<PairInfo>,
    /// Number of anchor–opening pairs.
    pub anchor_pairs: usize,
    /// Number of knob–hole pairs.
    pub knob_pairs: usize,
    /// Diagonal length (m).
    pub diagonal_length: f64,
    /// Diagonal angle α to the forward axis (degrees, ≥ 0; THESIS 5.2.4).
    pub diagonal_angle_deg: f64,
    /// Heading of the forward axis relative to the crossing direction that lays the diagonal
    /// across the edge (degrees, counter-clockwise; |value| = α).
    pub best_heading_deg: f64,
    /// Projected length at the best heading (m) = the diagonal.
    pub projected_length_best: f64,
    /// Projected length when driving straight across (heading 0) (m).
    pub projected_length_straight: f64,
    /// Widest gap the assembly can cross at the best heading (m): half its projected length
    /// (THESIS 5.2.4: "up to half the length of the assembly itself").
    pub max_gap_best: f64,
    /// Same, driving straight across (m).
    pub max_gap_straight: f64,
}

/// Facts about a shape (THESIS 5.2.4 for α and the best heading).
pub fn shape_info(shape: &Shape, g: &Geometry) -> ShapeInfo {
    let c = corners(shape, g);
    let ext = |k: usize| {
        let (lo, hi) = c
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p[k]), hi.max(p[k]))
            });
        hi - lo
    };
    let pairs = shape.pairs(g);
    let d = diagonal(shape, g);
    let best_heading = -d.angle;
    let straight = projected_length(shape, g, 0.0);
    let best = projected_length(shape, g, best_heading);
    ShapeInfo {
        name: shape.name.clone(),
        robots: shape.len(),
        length: ext(0),
        width: ext(1),
        slots: shape
            .slots
            .iter()
            .enumerate()
            .map(|(index, s)| SlotInfo {
                index,
                x: s.pose.x,
                y: s.pose.y,
                yaw_deg: s.pose.yaw.to_degrees(),
                kind: s.kind,
                name: s.name.clone(),
            })
            .collect(),
        anchor_pairs: pairs
            .iter()
            .filter(|p| p.kind == PairType::AnchorOpening)
            .count(),
        knob_pairs: pairs
            .iter()
            .filter(|p| p.kind == PairType::KnobHole)
            .count(),
        pairs: pairs
            .iter()
            .enumerate()
            .map(|(order, p)| PairInfo {
                order,
                a: p.a,
                point_a: p.point_a,
                b: p.b,
                point_b: p.point_b,
                kind: p.kind,
                at: shape.slots[p.a].pose.transform(p.point_a.position(g)),
                centre_distance: p.centre_distance,
            })
            .collect(),
        diagonal_length: d.length,
        diagonal_angle_deg: d.angle.abs().to_degrees(),
        best_heading_deg: best_heading.to_degrees(),
        projected_length_best: best,
        projected_length_straight: straight,
        max_gap_best: best * 0.5,
        max_gap_straight: straight * 0.5,
    }
}

impl fmt::Display for ShapeInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "shape {} — {} robots", self.name, self.robots)?;
        writeln!(
            f,
            "  footprint        {:.1} mm long × {:.1} mm wide",
            self.length * 1e3,
            self.width * 1e3
        )?;
        writeln!(
            f,
            "  diagonal         {:.1} mm at α = {:.1}° to the heading",
            self.diagonal_length * 1e3,
            self.diagonal_angle_deg
        )?;
        writeln!(
            f,
            "  best heading     {:+.1}° to the crossing direction: projected {:.1} mm (straight: {:.1} mm)",
            self.best_heading_deg,
            self.projected_length_best * 1e3,
            self.projected_length_straight * 1e3
        )?;
        writeln!(
            f,
            "  widest gap       ≈ {:.1} mm at the best heading, {:.1} mm straight (half the projected length)",
            self.max_gap_best * 1e3,
            self.max_gap_straight * 1e3
        )?;
        writeln!(f, "  slots (x, y mm; yaw °):")?;
        for s in &self.slots {
            write!(
                f,
                "    {:>3}  {:>7.1} {:>7.1} {:>6.1}",
                s.index,
                s.x * 1e3,
                s.y * 1e3,
                s.yaw_deg
            )?;
            if s.kind != SlotKind::Any {
                write!(f, "  {:?}", s.kind)?;
            }
            if let Some(n) = &s.name {
                write!(f, "  '{n}'")?;
            }
            writeln!(f)?;
        }
        writeln!(
            f,
            "  pairs ({} anchor–opening, {} knob–hole), convex-first order:",
            self.anchor_pairs, self.knob_pairs
        )?;
        for p in &self.pairs {
            writeln!(
                f,
                "    {:>3}  slot {:>3} {:<11} → slot {:>3} {:<11} {:<14} at ({:.1}, {:.1}) mm",
                p.order,
                p.a,
                p.point_a.name(),
                p.b,
                p.point_b.name(),
                p.kind.to_string(),
                p.at[0] * 1e3,
                p.at[1] * 1e3
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mesh_diagonal_angles_match_thesis() {
        let g = Geometry::default();
        // THESIS 5.2.4: α = 38.7° (4-robot mesh), 24.0° (8-robot mesh).
        let four = shape_info(&Shape::mesh(4, 2, &g).unwrap(), &g);
        assert!(
            (four.diagonal_angle_deg - 38.7).abs() < 0.05,
            "{}",
            four.diagonal_angle_deg
        );
        let eight = shape_info(&Shape::mesh(8, 2, &g).unwrap(), &g);
        assert!(
            (eight.diagonal_angle_deg - 24.0).abs() < 0.05,
            "{}",
            eight.diagonal_angle_deg
        );
        assert!((four.best_heading_deg.abs() - four.diagonal_angle_deg).abs() < 1e-9);
    }

    #[test]
    fn best_heading_maximises_projected_length() {
        let g = Geometry::default();
        for shape in [
            Shape::mesh(4, 2, &g).unwrap(),
            Shape::mesh(8, 2, &g).unwrap(),
            Shape::line(4, &g).unwrap(),
            Shape::mesh(9, 3, &g).unwrap(),
        ] {
            let info = shape_info(&shape, &g);
            assert!((info.projected_length_best - info.diagonal_length).abs() < 1e-9);
            for k in -90..=90 {
                let p = projected_length(&shape, &g, f64::from(k).to_radians());
                assert!(
                    p <= info.projected_length_best + 1e-9,
                    "{} at {k}°",
                    shape.name
                );
            }
        }
    }

    #[test]
    fn line_info_and_json() {
        let g = Geometry::default();
        let info = shape_info(&Shape::line(4, &g).unwrap(), &g);
        assert!((info.length - 0.2).abs() < 1e-6);
        assert!((info.projected_length_straight - 0.2).abs() < 1e-6);
        assert_eq!(info.anchor_pairs, 3);
        assert_eq!(info.knob_pairs, 0);
        let json = serde_json::to_value(&info).unwrap();
        assert_eq!(json["pairs"][0]["type"], "anchor_opening");
        assert!(info.to_string().contains("α = 14.0°"));
    }
}
