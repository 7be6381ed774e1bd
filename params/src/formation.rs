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
    /// `robots` robots in `rows` rows they do not fill evenly (the assembly coordinator's
    /// mesh of, say, 5 robots in 2 rows): the first rows hold ⌈robots / rows⌉ each, the last
    /// ones what is left ([`Shape::row_sizes`]). As in a full mesh, each row's rear robot
    /// sits half a body ahead of the rear robot of the row before, so a shorter row lacks
    /// robots at the front. Made by [`Shape::mesh_of`].
    Uneven {
        /// Rows.
        rows: usize,
        /// Robots.
        robots: usize,
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
    /// The mesh of `robots` robots in `rows` rows: full rows when they divide evenly,
    /// otherwise [`Shape::Uneven`]; a line for one row. `None` when a row would be empty.
    pub fn mesh_of(rows: usize, robots: usize) -> Option<Shape> {
        match (rows, robots) {
            (0, _) | (_, 0) => None,
            (r, n) if n < r => None,
            (1, n) => Some(Shape::Line(n)),
            (r, n) if n.is_multiple_of(r) => Some(Shape::Mesh {
                rows: r,
                per_row: n / r,
            }),
            (r, n) => Some(Shape::Uneven { rows: r, robots: n }),
        }
    }

    /// Number of robots.
    pub fn count(&self) -> usize {
        match *self {
            Shape::Line(n) => n,
            Shape::Mesh { rows, per_row } => rows * per_row,
            Shape::Uneven { robots, .. } => robots,
        }
    }

    /// Rows and robots in the longest row.
    pub fn rows(&self) -> (usize, usize) {
        match *self {
            Shape::Line(n) => (1, n),
            Shape::Mesh { rows, per_row } => (rows, per_row),
            Shape::Uneven { rows, robots } => (rows, robots.div_ceil(rows.max(1))),
        }
    }

    /// Robots in each row, the first (rightmost) row first.
    pub fn row_sizes(&self) -> Vec<usize> {
        match *self {
            Shape::Uneven { rows, robots } => {
                let per_row = robots.div_ceil(rows.max(1));
                let mut left = robots;
                (0..rows)
                    .map(|r| {
                        let count = per_row.min(left.saturating_sub(rows - r - 1));
                        left -= count;
                        count
                    })
                    .collect()
            }
            _ => {
                let (rows, per_row) = self.rows();
                vec![per_row; rows]
            }
        }
    }

    /// Row and place in the row (0: its front robot) of robot `k` (row-major, as the layout).
    pub fn place_in_row(&self, k: usize) -> Option<(usize, usize)> {
        let mut start = 0;
        for (r, n) in self.row_sizes().into_iter().enumerate() {
            if k < start + n {
                return Some((r, k - start));
            }
            start += n;
        }
        None
    }

    /// The shapes `n` robots can form: the line, every mesh of two or more full rows of two
    /// or more robots, and the mesh of two uneven rows when `n` is odd.
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
        if n >= 5 && !n.is_multiple_of(2) {
            out.push(Shape::Uneven { rows: 2, robots: n });
        }
        out
    }

    /// Short name, e.g. `line 4`, `mesh 2x2`, `mesh 3+2`.
    pub fn name(&self) -> String {
        match *self {
            Shape::Line(n) => format!("line {n}"),
            Shape::Mesh { rows, per_row } => format!("mesh {rows}x{per_row}"),
            Shape::Uneven { .. } => {
                let sizes: Vec<String> = self.row_sizes().iter().map(|n| n.to_string()).collect();
                format!("mesh {}", sizes.join("+"))
            }
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
    let at = layout(shape, g).0;
    let (lo, hi) = at
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p[0]), hi.max(p[0]))
        });
    let rows = shape.row_sizes().len();
    [
        (hi - lo).max(0.0) + f64::from(g.length),
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
    let sizes = shape.row_sizes();
    let first = sizes.first().copied().unwrap_or(0);
    let mut at = Vec::with_capacity(shape.count());
    let mut links = Vec::new();
    let mut starts = Vec::with_capacity(sizes.len());
    for (r, &n) in sizes.iter().enumerate() {
        // Odd rows sit half a body forward (THESIS 5.2.2), each row to the left of the last;
        // the rear robots line up so, and a shorter row lacks robots at the front.
        let shift = if r % 2 == 1 { 0.5 * pitch } else { 0.0 };
        let front = shift - pitch * first.saturating_sub(n) as f64;
        starts.push(at.len());
        for i in 0..n {
            let k = at.len();
            at.push([front - pitch * i as f64, width * r as f64]);
            if i > 0 {
                links.push((Link::Anchor, k - 1, k));
            }
        }
    }
    for r in 1..sizes.len() {
        for a in starts[r - 1]..starts[r - 1] + sizes[r - 1] {
            for b in starts[r]..starts[r] + sizes[r] {
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

    #[test]
    fn an_uneven_mesh_nests_its_short_row_as_the_coordinator_lays_it_out() {
        let g = Geometry::default();
        let p = anchor_pitch(&g);
        assert_eq!(
            Shape::mesh_of(2, 4),
            Some(Shape::Mesh {
                rows: 2,
                per_row: 2
            })
        );
        assert_eq!(Shape::mesh_of(1, 3), Some(Shape::Line(3)));
        assert_eq!(Shape::mesh_of(3, 2), None);
        let five = Shape::mesh_of(2, 5).unwrap();
        assert_eq!(five, Shape::Uneven { rows: 2, robots: 5 });
        assert_eq!((five.count(), five.name()), (5, "mesh 3+2".to_string()));
        assert_eq!(
            Shape::Uneven { rows: 3, robots: 7 }.row_sizes(),
            vec![3, 3, 1]
        );
        assert_eq!(five.place_in_row(3), Some((1, 0)));
        assert_eq!(five.place_in_row(5), None);
        // Rows of 3 and 2: the rear robots half a body apart, the short row between the
        // long row's front and rear robots, held by 3 anchors and 4 knobs.
        let (at, links) = layout(five, &g);
        let x: Vec<f64> = at.iter().map(|o| o[0] / p).collect();
        for (got, want) in x.iter().zip([0.0, -1.0, -2.0, -0.5, -1.5]) {
            assert!((got - want).abs() < 1e-12, "{x:?}");
        }
        let count = |l: Link| links.iter().filter(|k| k.0 == l).count();
        assert_eq!((count(Link::Anchor), count(Link::Knob)), (3, 4));
        // Its footprint is the long row's.
        let [l, w] = footprint(five, &g);
        assert!((l - (2.0 * p + f64::from(g.length))).abs() < 1e-12);
        assert!((w - 2.0 * f64::from(g.width)).abs() < 1e-12);
        assert!(Shape::candidates(5).contains(&five));
        assert!(!Shape::candidates(6)
            .iter()
            .any(|s| matches!(s, Shape::Uneven { .. })));
    }
}
