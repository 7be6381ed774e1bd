//! Target shapes: line, mesh (THESIS 5.2.2) and custom shapes from a file, either as relative
//! poses or as an assembly graph of robots and ports (in the spirit of the AAM paper, §3).

use crate::assign::find_pairs;
use crate::geom::{body_corners, wrap_angle, ConnPoint, PairType, Pose};
use puzzlebot_params::geometry::Geometry;
use puzzlebot_params::RobotKind;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

mod file;
#[cfg(test)]
mod tests;

pub use file::{mate, LinkEntry, ShapeFile, SlotEntry};

/// Two connection points count as meeting in a goal shape when closer than this (m).
pub const CONTACT_TOLERANCE: f64 = 0.001;

/// Which robots may fill a slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SlotKind {
    /// Any robot.
    #[default]
    Any,
    /// Only a pilot robot (four wheels, climbs; THESIS 3.4).
    Pilot,
    /// Only a non-pilot robot.
    NonPilot,
}

impl SlotKind {
    /// True when a robot of `kind` may fill this slot.
    pub fn accepts(self, kind: RobotKind) -> bool {
        match self {
            SlotKind::Any => true,
            SlotKind::Pilot => kind == RobotKind::Pilot,
            SlotKind::NonPilot => kind == RobotKind::NonPilot,
        }
    }
}

/// One goal slot of a shape: a pose relative to the shape frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Slot {
    /// Pose in the shape frame (origin at the slot centroid, x = assembly forward).
    pub pose: Pose,
    /// Which robots may fill it.
    pub kind: SlotKind,
    /// Optional name (from a shape file).
    pub name: Option<String>,
}

/// A goal connection pair between two slots (THESIS Algorithm 1 output, one MST edge).
///
/// `a` is always the slot carrying the anchor or the knob, `b` the one with the opening or
/// the hole (THESIS Algorithm 7's `anchor_index`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GoalPair {
    /// Slot with the anchor (back) or the knob (left side).
    pub a: usize,
    /// Its connection point.
    pub point_a: ConnPoint,
    /// Slot with the opening (front) or the hole (right side).
    pub b: usize,
    /// Its connection point.
    pub point_b: ConnPoint,
    /// Anchor–opening or knob–hole.
    pub kind: PairType,
    /// Distance between the two slot centres (m); the convex-first sort key.
    pub centre_distance: f64,
    /// Distance between the two connection points in the goal (m); 0 for exact shapes.
    pub residual: f64,
}

/// A target configuration p_g (THESIS 3.2): N slot poses, defined up to a rigid motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Shape {
    /// Human name ("line", "mesh", file stem, ...).
    pub name: String,
    /// The slots, centred on their centroid.
    pub slots: Vec<Slot>,
}

/// How to build a shape; kept by plans so that a re-plan can rebuild it for fewer robots.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeSpec {
    /// Robots front to back in one row (THESIS 5.2.2 line configuration).
    Line,
    /// `rows` lines side by side, every other row offset by half a body (THESIS 5.2.2).
    Mesh {
        /// Number of rows (≥ 1).
        rows: usize,
    },
    /// A fixed shape (from a file or built in code); re-plans drop slots.
    Fixed(Shape),
}

impl ShapeSpec {
    /// Build the shape for `n` robots.
    pub fn build(&self, n: usize, g: &Geometry) -> Result<Shape, ShapeError> {
        match self {
            ShapeSpec::Line => Shape::line(n, g),
            ShapeSpec::Mesh { rows } => Shape::mesh(n, *rows, g),
            ShapeSpec::Fixed(s) => {
                if s.slots.len() == n {
                    Ok(s.clone())
                } else {
                    Err(ShapeError::invalid(
                        None,
                        "robots",
                        format!("shape '{}' has {} slots, not {n}", s.name, s.slots.len()),
                    ))
                }
            }
        }
    }
}

/// A shape that could not be built or loaded.
#[derive(Debug, thiserror::Error)]
pub enum ShapeError {
    /// TOML file unreadable or malformed (names file, line, column and field).
    #[error(transparent)]
    Load(#[from] puzzlebot_params::load::LoadError),
    /// JSON file malformed.
    #[error("{path}:{line}:{column}: {message}")]
    Json {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What was wrong.
        message: String,
    },
    /// The content is well-formed but does not describe a usable shape.
    #[error("{}{field}: {message}", path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default())]
    Invalid {
        /// The file, when the shape came from one.
        path: Option<PathBuf>,
        /// The offending field, e.g. `link[2].to`.
        field: String,
        /// What was wrong.
        message: String,
    },
}

impl ShapeError {
    pub(crate) fn invalid(path: Option<&Path>, field: &str, message: String) -> Self {
        ShapeError::Invalid {
            path: path.map(Path::to_path_buf),
            field: field.to_string(),
            message,
        }
    }
}

impl Shape {
    /// Number of slots.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// True when the shape has no slots.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Slot poses.
    pub fn poses(&self) -> Vec<Pose> {
        self.slots.iter().map(|s| s.pose).collect()
    }

    /// A line of `n` robots facing +x, each robot's anchor in the opening of the one behind
    /// (THESIS 5.2.2: line = front–back anchor couplings).
    pub fn line(n: usize, g: &Geometry) -> Result<Shape, ShapeError> {
        if n == 0 {
            return Err(ShapeError::invalid(
                None,
                "robots",
                "a line needs at least one robot".into(),
            ));
        }
        let l = f64::from(g.length);
        let poses = (0..n).map(|k| Pose::new(k as f64 * l, 0.0, 0.0)).collect();
        Shape::from_poses("line", poses, g)
    }

    /// A mesh of `n` robots in `rows` rows (row k at y = k·W, every odd row shifted forward
    /// by half a body, THESIS 5.2.2); earlier rows take the extra robots (THESIS 5.2.2 Fig 5.4D:
    /// three robots = two in the first row, one in the second).
    pub fn mesh(n: usize, rows: usize, g: &Geometry) -> Result<Shape, ShapeError> {
        if rows == 0 {
            return Err(ShapeError::invalid(
                None,
                "rows",
                "a mesh needs at least one row".into(),
            ));
        }
        if n < rows {
            return Err(ShapeError::invalid(
                None,
                "robots",
                format!("a mesh of {rows} rows needs at least {rows} robots, got {n}"),
            ));
        }
        let l = f64::from(g.length);
        let w = f64::from(g.width);
        // The rows of the crossing planner's mesh (`params::formation`): full rows first, the
        // last ones what is left, none empty; each row rear first, odd rows half a body ahead.
        let sizes = puzzlebot_params::formation::Shape::mesh_of(rows, n)
            .map(|s| s.row_sizes())
            .unwrap_or_default();
        let mut poses = Vec::with_capacity(n);
        for (r, &count) in sizes.iter().enumerate() {
            let offset = if r % 2 == 1 { 0.5 * l } else { 0.0 };
            for c in 0..count {
                poses.push(Pose::new(offset + c as f64 * l, r as f64 * w, 0.0));
            }
        }
        Shape::from_poses("mesh", poses, g)
    }

    /// A shape from relative poses; checks that the bodies do not overlap and that the shape
    /// is one connected assembly. The poses are re-centred on their centroid.
    pub fn from_poses(name: &str, poses: Vec<Pose>, g: &Geometry) -> Result<Shape, ShapeError> {
        let slots = poses
            .into_iter()
            .map(|pose| Slot {
                pose,
                kind: SlotKind::Any,
                name: None,
            })
            .collect();
        Shape::from_slots(name, slots, g, None)
    }

    fn from_slots(
        name: &str,
        mut slots: Vec<Slot>,
        g: &Geometry,
        path: Option<&Path>,
    ) -> Result<Shape, ShapeError> {
        if slots.is_empty() {
            return Err(ShapeError::invalid(
                path,
                "slot",
                "a shape needs at least one slot".into(),
            ));
        }
        for (i, s) in slots.iter().enumerate() {
            if !s.pose.is_finite() {
                return Err(ShapeError::invalid(
                    path,
                    &format!("slot[{i}]"),
                    "pose is not finite".into(),
                ));
            }
        }
        check_overlaps(&slots, g, path)?;
        let n = slots.len() as f64;
        let cx = slots.iter().map(|s| s.pose.x).sum::<f64>() / n;
        let cy = slots.iter().map(|s| s.pose.y).sum::<f64>() / n;
        for s in &mut slots {
            s.pose.x -= cx;
            s.pose.y -= cy;
            s.pose.yaw = wrap_angle(s.pose.yaw);
        }
        let shape = Shape {
            name: name.to_string(),
            slots,
        };
        let pairs = find_pairs(&shape.poses(), g);
        if shape.len() > 1 && pairs.len() + 1 != shape.len() {
            return Err(ShapeError::invalid(
                path,
                "slot",
                format!(
                    "the slots do not form one coupled assembly: only {} of {} robots are joined \
                     by connection points that meet (anchor–opening front/back, knob–hole sides)",
                    pairs.len() + 1,
                    shape.len()
                ),
            ));
        }
        Ok(shape)
    }

    /// The goal connection pairs of this shape (THESIS Algorithm 1 on p_g), in convex-first
    /// order (THESIS 3.3.3 / 5.4.3: sorted by the distance between the slot centres).
    pub fn pairs(&self, g: &Geometry) -> Vec<GoalPair> {
        let mut p = find_pairs(&self.poses(), g);
        crate::assign::sort_convex_first(&mut p);
        p
    }

    /// This shape rotated by `yaw` and moved to `centre` (world poses of the slots).
    pub fn placed(&self, centre: [f64; 2], yaw: f64) -> Vec<Pose> {
        let frame = Pose::new(centre[0], centre[1], yaw);
        self.slots.iter().map(|s| frame.compose(&s.pose)).collect()
    }

    /// Shape without slot `index` (used by re-planning of fixed shapes); errors when the
    /// rest would no longer be one assembly.
    pub fn without_slot(&self, index: usize, g: &Geometry) -> Result<Shape, ShapeError> {
        if index >= self.len() {
            return Err(ShapeError::invalid(
                None,
                "slot",
                format!("no slot {index}"),
            ));
        }
        let mut slots = self.slots.clone();
        slots.remove(index);
        Shape::from_slots(&self.name, slots, g, None)
    }
}

/// Reject shapes whose bodies overlap by more than [`CONTACT_TOLERANCE`] (separating axis test
/// on the body rectangles).
fn check_overlaps(slots: &[Slot], g: &Geometry, path: Option<&Path>) -> Result<(), ShapeError> {
    let corners: Vec<[[f64; 2]; 4]> = slots
        .iter()
        .map(|s| body_corners(g).map(|c| s.pose.transform(c)))
        .collect();
    for i in 0..slots.len() {
        for j in i + 1..slots.len() {
            let depth = overlap_depth(&corners[i], &corners[j]);
            if depth > CONTACT_TOLERANCE {
                return Err(ShapeError::invalid(
                    path,
                    &format!("slot[{j}]"),
                    format!("body overlaps slot {i} by {:.1} mm", depth * 1e3),
                ));
            }
        }
    }
    Ok(())
}

/// Penetration depth of two convex quadrilaterals (0 when separated or touching).
fn overlap_depth(a: &[[f64; 2]; 4], b: &[[f64; 2]; 4]) -> f64 {
    let mut depth = f64::INFINITY;
    for poly in [a, b] {
        for k in 0..4 {
            let p = poly[k];
            let q = poly[(k + 1) % 4];
            let (nx, ny) = (q[1] - p[1], p[0] - q[0]);
            let len = nx.hypot(ny);
            let (nx, ny) = (nx / len, ny / len);
            let proj = |pts: &[[f64; 2]; 4]| {
                pts.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), c| {
                        let d = c[0] * nx + c[1] * ny;
                        (lo.min(d), hi.max(d))
                    })
            };
            let (alo, ahi) = proj(a);
            let (blo, bhi) = proj(b);
            let o = ahi.min(bhi) - alo.max(blo);
            if o <= 0.0 {
                return 0.0;
            }
            depth = depth.min(o);
        }
    }
    depth
}
