//! Target shapes: line, mesh (THESIS 5.2.2) and custom shapes from a file, either as relative
//! poses or as an assembly graph of robots and ports (in the spirit of the AAM paper, §3).

use crate::assign::find_pairs;
use crate::geom::{body_corners, pair_type, wrap_angle, ConnPoint, PairType, Pose};
use puzzlebot_params::geometry::Geometry;
use puzzlebot_params::RobotKind;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};

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
        let per_row = n.div_ceil(rows);
        let mut poses = Vec::with_capacity(n);
        let mut left = n;
        for r in 0..rows {
            // Spread the remainder so that no row is empty: the last rows take what is left.
            let rows_after = rows - r - 1;
            let count = per_row.min(left - rows_after);
            let offset = if r % 2 == 1 { 0.5 * l } else { 0.0 };
            for c in 0..count {
                poses.push(Pose::new(offset + c as f64 * l, r as f64 * w, 0.0));
            }
            left -= count;
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

    /// Load a custom shape from a TOML or JSON file (chosen by extension; see [`ShapeFile`]).
    pub fn from_file(path: &Path, g: &Geometry) -> Result<Shape, ShapeError> {
        let is_json = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
        let file: ShapeFile = if is_json {
            let text = std::fs::read_to_string(path).map_err(|cause| {
                ShapeError::Load(puzzlebot_params::load::LoadError::Io {
                    path: path.to_path_buf(),
                    cause,
                })
            })?;
            serde_json::from_str(&text).map_err(|e| ShapeError::Json {
                path: path.to_path_buf(),
                line: e.line(),
                column: e.column(),
                message: e.to_string(),
            })?
        } else {
            puzzlebot_params::load::from_toml_file(path)?
        };
        let default_name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("custom")
            .to_string();
        file.build(Some(path), &default_name, g)
    }

    /// Parse a custom shape from TOML text (`path` names it in errors).
    pub fn from_toml_str(path: &Path, text: &str, g: &Geometry) -> Result<Shape, ShapeError> {
        let file: ShapeFile = puzzlebot_params::load::from_toml_str(path, text)?;
        file.build(Some(path), "custom", g)
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

/// A custom shape file (TOML or JSON).
///
/// Either every slot has a pose (`x`, `y`, and `yaw` in rad or `yaw_deg`), or the slots have
/// names and `link` entries join named slots by their ports (an assembly graph, AAM paper §3:
/// robots are vertices, couplings are edges labelled with the two ports); the first slot then
/// sits at the origin and the others are placed by walking the links.
///
/// ```toml
/// name = "tee"
/// [[slot]]
/// name = "a"
/// [[slot]]
/// name = "b"
/// kind = "pilot"
/// [[link]]
/// from = "a"
/// from_port = "front"
/// to = "b"
/// to_port = "back"
/// ```
#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ShapeFile {
    /// Shape name (defaults to the file stem).
    #[serde(default)]
    pub name: Option<String>,
    /// The slots.
    #[serde(default)]
    pub slot: Vec<SlotEntry>,
    /// Port-to-port links (assembly graph form).
    #[serde(default)]
    pub link: Vec<LinkEntry>,
}

/// One slot of a shape file.
#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SlotEntry {
    /// Name used by links.
    #[serde(default)]
    pub name: Option<String>,
    /// x (m), pose form.
    #[serde(default)]
    pub x: Option<f64>,
    /// y (m), pose form.
    #[serde(default)]
    pub y: Option<f64>,
    /// Heading (rad).
    #[serde(default)]
    pub yaw: Option<f64>,
    /// Heading (degrees), instead of `yaw`.
    #[serde(default)]
    pub yaw_deg: Option<f64>,
    /// Which robots may fill the slot.
    #[serde(default)]
    pub kind: SlotKind,
}

/// One coupling of the assembly graph: `from`'s port meets `to`'s port.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LinkEntry {
    /// Name of the first slot.
    pub from: String,
    /// Its port.
    pub from_port: ConnPoint,
    /// Name of the second slot.
    pub to: String,
    /// Its port.
    pub to_port: ConnPoint,
}

impl ShapeFile {
    /// Turn the file content into a shape.
    pub fn build(
        &self,
        path: Option<&Path>,
        default_name: &str,
        g: &Geometry,
    ) -> Result<Shape, ShapeError> {
        let name = self
            .name
            .clone()
            .unwrap_or_else(|| default_name.to_string());
        if self.slot.is_empty() {
            return Err(ShapeError::invalid(
                path,
                "slot",
                "no [[slot]] entries".into(),
            ));
        }
        let mut yaws = Vec::with_capacity(self.slot.len());
        for (i, s) in self.slot.iter().enumerate() {
            let yaw = match (s.yaw, s.yaw_deg) {
                (Some(_), Some(_)) => {
                    return Err(ShapeError::invalid(
                        path,
                        &format!("slot[{i}].yaw_deg"),
                        "give either yaw (rad) or yaw_deg, not both".into(),
                    ))
                }
                (Some(y), None) => Some(y),
                (None, Some(d)) => Some(d.to_radians()),
                (None, None) => None,
            };
            yaws.push(yaw);
        }
        let slots = if self.link.is_empty() {
            self.slot
                .iter()
                .enumerate()
                .map(|(i, s)| match (s.x, s.y) {
                    (Some(x), Some(y)) => Ok(Slot {
                        pose: Pose::new(x, y, yaws[i].unwrap_or(0.0)),
                        kind: s.kind,
                        name: s.name.clone(),
                    }),
                    _ => Err(ShapeError::invalid(
                        path,
                        &format!("slot[{i}]"),
                        "needs x and y (or give [[link]] entries to place slots by ports)".into(),
                    )),
                })
                .collect::<Result<Vec<_>, _>>()?
        } else {
            self.place_by_links(path, &yaws, g)?
        };
        Shape::from_slots(&name, slots, g, path)
    }

    fn place_by_links(
        &self,
        path: Option<&Path>,
        yaws: &[Option<f64>],
        g: &Geometry,
    ) -> Result<Vec<Slot>, ShapeError> {
        let mut index = HashMap::new();
        for (i, s) in self.slot.iter().enumerate() {
            let Some(n) = &s.name else {
                return Err(ShapeError::invalid(
                    path,
                    &format!("slot[{i}].name"),
                    "slots need names when [[link]] entries are given".into(),
                ));
            };
            if i > 0 && (s.x.is_some() || s.y.is_some() || yaws[i].is_some()) {
                return Err(ShapeError::invalid(
                    path,
                    &format!("slot[{i}]"),
                    "with [[link]] entries only the first slot may have a pose".into(),
                ));
            }
            if index.insert(n.clone(), i).is_some() {
                return Err(ShapeError::invalid(
                    path,
                    &format!("slot[{i}].name"),
                    format!("duplicate slot name '{n}'"),
                ));
            }
        }
        // Adjacency: (other slot, own port, other port, link index).
        let mut adj: Vec<Vec<(usize, ConnPoint, ConnPoint, usize)>> =
            vec![Vec::new(); self.slot.len()];
        let mut used: HashMap<(usize, ConnPoint), usize> = HashMap::new();
        for (k, l) in self.link.iter().enumerate() {
            let lookup = |n: &String, field: &str| {
                index.get(n).copied().ok_or_else(|| {
                    ShapeError::invalid(
                        path,
                        &format!("link[{k}].{field}"),
                        format!("unknown slot '{n}'"),
                    )
                })
            };
            let a = lookup(&l.from, "from")?;
            let b = lookup(&l.to, "to")?;
            if a == b {
                return Err(ShapeError::invalid(
                    path,
                    &format!("link[{k}].to"),
                    "a slot cannot link to itself".into(),
                ));
            }
            if pair_type(l.from_port, l.to_port).is_none() {
                return Err(ShapeError::invalid(
                    path,
                    &format!("link[{k}].to_port"),
                    format!(
                        "{} cannot couple with {} (anchor–opening: back with front; knob–hole: left with right)",
                        l.from_port, l.to_port
                    ),
                ));
            }
            for (s, p, f) in [(a, l.from_port, "from_port"), (b, l.to_port, "to_port")] {
                if let Some(prev) = used.insert((s, p), k) {
                    return Err(ShapeError::invalid(
                        path,
                        &format!("link[{k}].{f}"),
                        format!(
                            "port {p} of '{}' is already used by link[{prev}]",
                            self.slot[s].name.as_deref().unwrap_or("")
                        ),
                    ));
                }
            }
            adj[a].push((b, l.from_port, l.to_port, k));
            adj[b].push((a, l.to_port, l.from_port, k));
        }
        let root = Pose::new(
            self.slot[0].x.unwrap_or(0.0),
            self.slot[0].y.unwrap_or(0.0),
            yaws[0].unwrap_or(0.0),
        );
        let mut poses: Vec<Option<Pose>> = vec![None; self.slot.len()];
        poses[0] = Some(root);
        let mut queue = VecDeque::from([0usize]);
        while let Some(i) = queue.pop_front() {
            let pi = poses[i].expect("queued slots are placed");
            for &(j, port_i, port_j, k) in &adj[i] {
                let pj = mate(&pi, port_i, port_j, g);
                match poses[j] {
                    None => {
                        poses[j] = Some(pj);
                        queue.push_back(j);
                    }
                    Some(existing) => {
                        let off = existing.distance(&pj);
                        let dyaw = wrap_angle(existing.yaw - pj.yaw).abs();
                        if off > CONTACT_TOLERANCE || dyaw > 1e-3 {
                            return Err(ShapeError::invalid(
                                path,
                                &format!("link[{k}]"),
                                format!(
                                    "closes a loop inconsistently: it places '{}' {:.1} mm / {:.1}° away from where other links put it",
                                    self.slot[j].name.as_deref().unwrap_or(""),
                                    off * 1e3,
                                    dyaw.to_degrees()
                                ),
                            ));
                        }
                    }
                }
            }
        }
        self.slot
            .iter()
            .enumerate()
            .map(|(i, s)| match poses[i] {
                Some(pose) => Ok(Slot {
                    pose,
                    kind: s.kind,
                    name: s.name.clone(),
                }),
                None => Err(ShapeError::invalid(
                    path,
                    &format!("slot[{i}]"),
                    format!(
                        "'{}' is not linked to the first slot",
                        s.name.as_deref().unwrap_or("")
                    ),
                )),
            })
            .collect()
    }
}

/// Pose of a robot whose `port_j` meets `port_i` of the robot at `pi`: the ports coincide
/// and their outward normals are opposite (AAM paper: port vectors of adjacent modules).
pub fn mate(pi: &Pose, port_i: ConnPoint, port_j: ConnPoint, g: &Geometry) -> Pose {
    let yaw_j = wrap_angle(pi.yaw + port_i.normal() - port_j.normal() + std::f64::consts::PI);
    let ci = pi.transform(port_i.position(g));
    let rel = port_j.position(g);
    let (s, c) = yaw_j.sin_cos();
    Pose::new(
        ci[0] - (c * rel[0] - s * rel[1]),
        ci[1] - (s * rel[0] + c * rel[1]),
        yaw_j,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn g() -> Geometry {
        Geometry::default()
    }

    #[test]
    fn mesh_rows_are_offset_by_half_a_body() {
        let s = Shape::mesh(3, 2, &g()).unwrap();
        assert_eq!(s.len(), 3);
        let row1: Vec<_> = s.slots.iter().filter(|sl| sl.pose.y > 0.0).collect();
        let row0: Vec<_> = s.slots.iter().filter(|sl| sl.pose.y < 0.0).collect();
        assert_eq!(
            (row0.len(), row1.len()),
            (2, 1),
            "THESIS Fig 5.4D: two then one"
        );
        let dx = row1[0].pose.x - row0.iter().map(|r| r.pose.x).fold(f64::INFINITY, f64::min);
        assert!((dx - 0.025).abs() < 1e-9);
        assert!(Shape::mesh(1, 2, &g()).is_err());
        assert!(Shape::line(0, &g()).is_err());
    }

    #[test]
    fn pose_file_and_graph_file_give_the_same_shape() {
        let poses = "name = \"pair\"\n[[slot]]\nx = 0.0\ny = 0.0\n[[slot]]\nx = 0.05\ny = 0.0\nkind = \"pilot\"\n";
        let a = Shape::from_toml_str(Path::new("p.toml"), poses, &g()).unwrap();
        // Slot b's back (anchor) meets slot a's front (opening): b is in front.
        let graph = "[[slot]]\nname = \"a\"\n[[slot]]\nname = \"b\"\nkind = \"pilot\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"front\"\nto = \"b\"\nto_port = \"back\"\n";
        let b = Shape::from_toml_str(Path::new("g.toml"), graph, &g()).unwrap();
        for (x, y) in a.slots.iter().zip(&b.slots) {
            assert!(x.pose.distance(&y.pose) < 1e-9 && (x.pose.yaw - y.pose.yaw).abs() < 1e-9);
            assert_eq!(x.kind, y.kind);
        }
        assert_eq!(a.pairs(&g()).len(), 1);
    }

    #[test]
    fn graph_file_builds_a_tee_with_a_side_coupling() {
        // A line of two and a third robot knob-coupled on the left of the first.
        let text = r#"
[[slot]]
name = "a"
[[slot]]
name = "b"
[[slot]]
name = "c"
[[link]]
from = "a"
from_port = "front"
to = "b"
to_port = "back"
[[link]]
from = "a"
from_port = "left_front"
to = "c"
to_port = "right_back"
"#;
        let s = Shape::from_toml_str(Path::new("tee.toml"), text, &g()).unwrap();
        let p = s.pairs(&g());
        assert_eq!(p.len(), 2);
        assert_eq!(p.iter().filter(|x| x.kind == PairType::KnobHole).count(), 1);
        let json = r#"{"slot":[{"name":"a"},{"name":"b"}],"link":[{"from":"a","from_port":"front","to":"b","to_port":"back"}]}"#;
        let dir = std::env::temp_dir().join(format!("pb-asm-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("two.json");
        std::fs::write(&f, json).unwrap();
        let two = Shape::from_file(&f, &g()).unwrap();
        assert_eq!(two.name, "two");
        assert_eq!(two.len(), 2);
        std::fs::write(&f, "{\"slot\": [\n  {\"nam\": 1}\n]}").unwrap();
        let e = Shape::from_file(&f, &g()).unwrap_err().to_string();
        assert!(e.contains("two.json:2:"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_shape_files_name_the_field() {
        let e = |t: &str| {
            Shape::from_toml_str(Path::new("s.toml"), t, &g())
                .unwrap_err()
                .to_string()
        };
        let msg = e("[[slot]]\nname = \"a\"\n[[slot]]\nname = \"b\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"front\"\nto = \"b\"\nto_port = \"front\"\n");
        assert!(
            msg.contains("link[0].to_port") && msg.contains("cannot couple"),
            "{msg}"
        );
        let msg = e("[[slot]]\nname = \"a\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"front\"\nto = \"x\"\nto_port = \"back\"\n");
        assert!(
            msg.contains("link[0].to") && msg.contains("unknown slot 'x'"),
            "{msg}"
        );
        let msg = e("[[slot]]\nx = 0.0\ny = 0.0\n[[slot]]\nx = 0.01\ny = 0.0\n");
        assert!(msg.contains("slot[1]") && msg.contains("overlaps"), "{msg}");
        let msg = e("[[slot]]\nx = 0.0\ny = 0.0\n[[slot]]\nx = 0.2\ny = 0.0\n");
        assert!(msg.contains("one coupled assembly"), "{msg}");
        let msg = e("[[slot]]\nx = 0.0\nyy = 0.0\n");
        assert!(msg.starts_with("s.toml:3:") && msg.contains("yy"), "{msg}");
        let msg = e("[[slot]]\nx = 0.0\n");
        assert!(
            msg.contains("slot[0]") && msg.contains("needs x and y"),
            "{msg}"
        );
        let msg = e("[[slot]]\nx = 0.0\ny = 0.0\nyaw = 0.0\nyaw_deg = 0.0\n");
        assert!(msg.contains("slot[0].yaw_deg"), "{msg}");
        // Side by side without offset: knob meets knob? No: left (knobs) meets right (holes),
        // so this is a valid knob–hole pair at both side points.
        let ok = Shape::from_toml_str(
            Path::new("s.toml"),
            "[[slot]]\nx = 0.0\ny = 0.0\n[[slot]]\nx = 0.0\ny = 0.05\n",
            &g(),
        )
        .unwrap();
        assert_eq!(ok.pairs(&g())[0].kind, PairType::KnobHole);
        // Loop closed inconsistently.
        let msg = e("[[slot]]\nname = \"a\"\n[[slot]]\nname = \"b\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"front\"\nto = \"b\"\nto_port = \"back\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"left_front\"\nto = \"b\"\nto_port = \"right_back\"\n");
        assert!(msg.contains("link[1]") && msg.contains("loop"), "{msg}");
    }
}
