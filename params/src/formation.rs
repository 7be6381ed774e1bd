//! Formed assemblies as THESIS's crossing experiments use them (THESIS 3.5.3, 5.2.2, 5.2.4):
//! a line (robots front to back on soft anchors) or a mesh (rows of lines, each row offset by
//! half a body from the previous and held to it by side knobs). One layout for the simulator
//! and the host's crossing planner.

use crate::coupling::Coupling;
use crate::geometry::Geometry;

/// Shape of a formed assembly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// One row of `n` robots on soft anchors.
    Line(usize),
    /// `rows` rows of `per_row` robots.
    Mesh {
        /// Rows.
        rows: usize,
        /// Robots per row.
        per_row: usize,
    },
}

/// A coupling of a layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Link {
    /// Soft anchor of robot `a` (in front) in the opening of robot `b` (behind it).
    Anchor,
    /// Left knob of robot `a` in the right hole of robot `b` (the next row, to its left).
    Knob,
}

impl Shape {
    /// Number of robots.
    pub fn count(&self) -> usize {
        match *self {
            Shape::Line(n) => n,
            Shape::Mesh { rows, per_row } => rows * per_row,
        }
    }

    /// Rows and robots per row.
    pub fn rows(&self) -> (usize, usize) {
        match *self {
            Shape::Line(n) => (1, n),
            Shape::Mesh { rows, per_row } => (rows, per_row),
        }
    }

    /// The shapes `n` robots can form: the line, and every mesh of two or more rows of two or
    /// more robots.
    pub fn candidates(n: usize) -> Vec<Shape> {
        let mut out = vec![Shape::Line(n)];
        for rows in 2..=n / 2 {
            if n.is_multiple_of(rows) && n / rows >= 2 {
                out.push(Shape::Mesh {
                    rows,
                    per_row: n / rows,
                });
            }
        }
        out
    }

    /// Short name, e.g. `line 4`, `mesh 2x2`.
    pub fn name(&self) -> String {
        match *self {
            Shape::Line(n) => format!("line {n}"),
            Shape::Mesh { rows, per_row } => format!("mesh {rows}x{per_row}"),
        }
    }
}

/// Distance between the centres of two robots coupled by a seated anchor (m): from the
/// anchor head (`anchor_head`) to the seat inside the opening.
pub fn anchor_pitch(g: &Geometry) -> f64 {
    let seat = f64::from(g.anchor_opening[0]) - Coupling::anchor_depth(g);
    seat - f64::from(g.anchor_head[0])
}

/// Footprint of the formed shape (m): length along the rows (half a body more for a mesh,
/// whose rows are offset) and width across them.
pub fn footprint(shape: Shape, g: &Geometry) -> [f64; 2] {
    let (rows, per_row) = shape.rows();
    let pitch = anchor_pitch(g);
    let offset = if rows > 1 { 0.5 * pitch } else { 0.0 };
    [
        pitch * (per_row - 1) as f64 + f64::from(g.length) + offset,
        f64::from(g.width) * rows as f64,
    ]
}

/// Diagonal angle α of the shape (rad): between its rows and its footprint's diagonal
/// (THESIS 5.2.4, Figure 5.7 A: 38.7° for the 4-robot mesh, 24.0° for the 8-robot one).
pub fn diagonal_angle(shape: Shape, g: &Geometry) -> f64 {
    let [l, w] = footprint(shape, g);
    w.atan2(l)
}

/// Body-centre offsets (forward, left; m) of a layout, one per robot.
pub type Offsets = Vec<[f64; 2]>;
/// Couplings `(link, a, b)` of a layout (robot indices).
pub type Links = Vec<(Link, usize, usize)>;

/// Body-centre offsets (forward, left; m) of every robot, row-major with the front robot of
/// each row first, and the couplings `(link, a, b)` (indices) that hold them: anchors within a
/// row, knobs between neighbouring rows where the bodies overlap by half a body.
pub fn layout(shape: Shape, g: &Geometry) -> (Offsets, Links) {
    let pitch = anchor_pitch(g);
    let width = f64::from(g.width);
    let (rows, per_row) = shape.rows();
    let mut at = Vec::with_capacity(rows * per_row);
    let mut links = Vec::new();
    for r in 0..rows {
        // Odd rows sit half a body forward (THESIS 5.2.2), each row to the left of the last.
        let shift = if r % 2 == 1 { 0.5 * pitch } else { 0.0 };
        for i in 0..per_row {
            at.push([shift - pitch * i as f64, width * r as f64]);
            if i > 0 {
                let k = r * per_row + i;
                links.push((Link::Anchor, k - 1, k));
            }
        }
    }
    for r in 1..rows {
        for i in 0..per_row {
            for j in 0..per_row {
                let (a, b) = ((r - 1) * per_row + i, r * per_row + j);
                if (at[a][0] - at[b][0]).abs() < 0.75 * pitch {
                    links.push((Link::Knob, a, b));
                }
            }
        }
    }
    (at, links)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_two_by_two_mesh_has_two_anchors_and_three_knobs() {
        let g = Geometry::default();
        let (at, links) = layout(
            Shape::Mesh {
                rows: 2,
                per_row: 2,
            },
            &g,
        );
        assert_eq!(at.len(), 4);
        assert!((anchor_pitch(&g) - 0.050).abs() < 1e-6);
        let anchors = links.iter().filter(|l| l.0 == Link::Anchor).count();
        let knobs = links.iter().filter(|l| l.0 == Link::Knob).count();
        assert_eq!((anchors, knobs), (2, 3));
        // THESIS 5.2.4: diagonal angles 38.7° (4 robots) and 24.0° (8 robots).
        let a4 = diagonal_angle(
            Shape::Mesh {
                rows: 2,
                per_row: 2,
            },
            &g,
        )
        .to_degrees();
        let a8 = diagonal_angle(
            Shape::Mesh {
                rows: 2,
                per_row: 4,
            },
            &g,
        )
        .to_degrees();
        assert!(
            (a4 - 38.7).abs() < 0.05 && (a8 - 24.0).abs() < 0.05,
            "{a4} {a8}"
        );
        assert_eq!(
            Shape::candidates(8),
            vec![
                Shape::Line(8),
                Shape::Mesh {
                    rows: 2,
                    per_row: 4
                },
                Shape::Mesh {
                    rows: 4,
                    per_row: 2
                }
            ]
        );
    }
}
