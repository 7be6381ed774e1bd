//! Custom shape files: pose lists or assembly graphs of robots joined port to port.

use super::{Shape, ShapeError, Slot, SlotKind, CONTACT_TOLERANCE};
use crate::geom::{pair_type, wrap_angle, ConnPoint, Pose};
use puzzlebot_params::geometry::Geometry;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, VecDeque};
use std::path::Path;

impl Shape {
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
