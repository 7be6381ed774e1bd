//! The general assembly model (SOCP §2): modules, connections with child/parent frames,
//! environmental and module–module point contacts, known external loads, connector limits.
//! Independent of PuzzleBots. All vectors are in the world frame ΣI unless said otherwise.

use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};

/// A 3-vector (world frame unless said otherwise).
pub type Vec3 = [f64; 3];

/// A whole assembly: the input of the gate (file format documented in README.md).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Assembly {
    /// Gravity acceleration (m/s²), world frame. Default (0, 0, −9.81).
    #[serde(default = "default_gravity")]
    pub gravity: Vec3,
    /// Rigid modules (SOCP Assumption 1: connectors are the weak parts).
    pub modules: Vec<Module>,
    /// Named connector types (their limits and characteristic-strength weights).
    #[serde(default)]
    pub connectors: BTreeMap<String, ConnectorSpec>,
    /// Connections between modules (SOCP 2.2): each has a child and a parent module.
    #[serde(default)]
    pub connections: Vec<Connection>,
    /// Environmental frictional point contacts (SOCP 30–31).
    #[serde(default)]
    pub contacts: Vec<Contact>,
    /// Non-connected module–module frictional point contacts (SOCP 23, 32).
    #[serde(default)]
    pub module_contacts: Vec<ModuleContact>,
    /// Known external forces and couples (besides gravity).
    #[serde(default)]
    pub loads: Vec<Load>,
    /// Weights of the objective (41).
    #[serde(default)]
    pub objective: Objective,
}

fn default_gravity() -> Vec3 {
    [0.0, 0.0, -9.81]
}

/// One rigid module.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Module {
    /// Unique name, used by connections, contacts and loads.
    pub id: String,
    /// Mass (kg), ≥ 0.
    pub mass: f64,
    /// Body-frame origin in the world (m).
    pub position: Vec3,
    /// Body orientation as roll, pitch, yaw (rad), R = Rz(yaw)·Ry(pitch)·Rx(roll).
    #[serde(default)]
    pub rpy: Vec3,
    /// Centre of mass in the body frame (m).
    #[serde(default)]
    pub com: Vec3,
    /// Fixed to the world (like the paper's wall-mounted struts): no equilibrium needed.
    #[serde(default)]
    pub fixed: bool,
}

/// Per-dimension limits of a box connector (SOCP 33): `None` (absent) = unlimited (rigid in
/// that dimension, outside the margin), `0` = released (the connector transmits nothing).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits6 {
    /// Shear force along the local x axis (N).
    pub fx: Option<f64>,
    /// Shear force along the local y axis (N).
    pub fy: Option<f64>,
    /// Adhesion (pull-out) force along the local z axis (N).
    pub fz: Option<f64>,
    /// Couple about the local x axis (N·m).
    pub mx: Option<f64>,
    /// Couple about the local y axis (N·m).
    pub my: Option<f64>,
    /// Couple about the local z axis (torsion, N·m).
    pub mz: Option<f64>,
}

impl Limits6 {
    /// The limits as an array in the order of (34): fx, fy, fz, mx, my, mz.
    pub fn as_array(&self) -> [Option<f64>; 6] {
        [self.fx, self.fy, self.fz, self.mx, self.my, self.mz]
    }
    /// Same limit in every dimension: forces `force`, couples `couple`.
    pub fn uniform(force: f64, couple: f64) -> Self {
        Limits6 {
            fx: Some(force),
            fy: Some(force),
            fz: Some(force),
            mx: Some(couple),
            my: Some(couple),
            mz: Some(couple),
        }
    }
}

fn ones6() -> [f64; 6] {
    [1.0; 6]
}

/// A connector type.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ConnectorSpec {
    /// Decoupled limits: a 6-D box (SOCP 35–37), strength w = ‖ωK f̄‖ (40).
    Box {
        /// Maximum connection wrench f̄_cmax (33).
        #[serde(default)]
        max: Limits6,
        /// Diagonal of ωK (40), all > 0; default ones.
        #[serde(default = "ones6")]
        omega_k: [f64; 6],
        /// Diagonal of W̃ (42) that unifies force and couple units in the margin; default ones.
        #[serde(default = "ones6")]
        margin_weights: [f64; 6],
    },
    /// Magnetically enhanced contact: a 6-D Lorentz cone (SOCP 47–53).
    Lorentz {
        /// Maximum adhesion force f^z_max (N) (52).
        f_max_z: f64,
        /// Coupling coefficients μ = [μ1, μ2, μ4, μ5, μ6] (49, 53); 0 releases that dimension.
        mu: [f64; 5],
    },
}

/// A connection between a child and a parent module (SOCP 2.2–2.3).
///
/// The connection frame has its z axis pointing from the connection point into the child
/// module (default: towards the child's centre of mass); the child and parent frames
/// coincide, so the parent wrench is the negated child wrench (SOCP 20 with R̃_A = R̃_P).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Connection {
    /// Child module id (its frame ΣA points into it).
    pub child: String,
    /// Parent module id.
    pub parent: String,
    /// Connector type name (a key of `connectors`).
    pub connector: String,
    /// Connection point (m).
    pub point: Vec3,
    /// z axis of the connection frame; default from `point` towards the child's COM.
    #[serde(default)]
    pub axis: Option<Vec3>,
    /// Hint for the local x axis (projected onto the plane normal to z); default world z or x.
    #[serde(default)]
    pub x_axis: Option<Vec3>,
}

/// An environmental point contact on a module (SOCP 30).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Contact {
    /// Module id.
    pub module: String,
    /// Contact point (m).
    pub point: Vec3,
    /// Contact normal pointing into the module; default (0, 0, 1).
    #[serde(default)]
    pub normal: Option<Vec3>,
    /// Friction coefficients along the local x and y axes (anisotropic cone, 30).
    pub mu: [f64; 2],
    /// Hint for the local x axis of the contact frame.
    #[serde(default)]
    pub x_axis: Option<Vec3>,
    /// How far the contact stands clear of its support in the unloaded assembly (m; default
    /// 0): a lifted caster, a wheel over a lower platform. The rigid-body proof lets it touch;
    /// the elastic distribution ([`crate::elastic::distribution_with_gaps`]) loads it only
    /// once the deflection has closed the gap.
    #[serde(default)]
    pub gap: f64,
}

/// A non-connected contact between two modules (SOCP 23, 32).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModuleContact {
    /// Module the normal points into (the force acts on it; the reaction on `other`).
    pub module: String,
    /// The other module.
    pub other: String,
    /// Contact point (m).
    pub point: Vec3,
    /// Normal pointing into `module`.
    pub normal: Vec3,
    /// Friction coefficients along the local x and y axes.
    pub mu: [f64; 2],
    /// Hint for the local x axis of the contact frame.
    #[serde(default)]
    pub x_axis: Option<Vec3>,
}

/// A known external force and couple on a module.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Load {
    /// Module id.
    pub module: String,
    /// Force (N).
    #[serde(default)]
    pub force: Vec3,
    /// Point of action (m); default the module's centre of mass.
    #[serde(default)]
    pub point: Option<Vec3>,
    /// Couple (N·m).
    #[serde(default)]
    pub couple: Vec3,
}

/// Weights of the objective (41)/(51).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Objective {
    /// λ_max on the maximum characteristic strength w_A^max (paper: 10 000).
    pub lambda_max: f64,
    /// λ1 on the sum of characteristic strengths.
    pub lambda_sum: f64,
    /// λ2 on the sum of non-connected contact normal forces.
    pub lambda_module_contacts: f64,
    /// λ3 on the sum of environmental contact normal forces.
    pub lambda_contacts: f64,
}

impl Default for Objective {
    fn default() -> Self {
        Objective {
            lambda_max: 1.0e4,
            lambda_sum: 1.0,
            lambda_module_contacts: 1.0,
            lambda_contacts: 1.0,
        }
    }
}

/// A model error that names the offending field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct ModelError {
    /// Field path, e.g. `connections[3].parent`.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

fn err(field: impl Into<String>, message: impl Into<String>) -> ModelError {
    ModelError {
        field: field.into(),
        message: message.into(),
    }
}

/// Every component finite; the field's name is only built for the error.
fn finite3(v: &Vec3, field: impl FnOnce() -> String) -> Result<(), ModelError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(err(field(), "non-finite number"))
    }
}

/// Rotation matrix (columns are the local axes in the world) from roll, pitch, yaw.
pub fn rot_rpy(rpy: Vec3) -> [Vec3; 3] {
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    // R = Rz Ry Rx; columns:
    [
        [cy * cp, sy * cp, -sp],
        [cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr],
        [cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr],
    ]
}

/// a · b
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// a × b
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// a − b
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// a + b
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
/// s·a
pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
/// ‖a‖
pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// A right-handed frame [x, y, z] (columns of ᴵR) with z along `z`; x from the hint.
pub fn frame_from_z(z: Vec3, x_hint: Option<Vec3>) -> Option<[Vec3; 3]> {
    let nz = norm(z);
    if nz.is_nan() || nz <= 1e-12 {
        return None;
    }
    let z = scale(z, 1.0 / nz);
    let candidates = [
        x_hint.unwrap_or([0.0, 0.0, 1.0]),
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    for h in candidates {
        let x = sub(h, scale(z, dot(h, z)));
        let nx = norm(x);
        if nx > 1e-6 * norm(h).max(1e-300) && nx > 1e-9 {
            let x = scale(x, 1.0 / nx);
            let y = cross(z, x);
            return Some([x, y, z]);
        }
    }
    None
}

/// The model with ids resolved, frames built and every number checked.
#[derive(Debug, Clone)]
pub struct Resolved {
    /// Centre of mass of each module (world).
    pub com: Vec<Vec3>,
    /// Fixed flag per module.
    pub fixed: Vec<bool>,
    /// Mass per module.
    pub mass: Vec<f64>,
    /// Module ids.
    pub ids: Vec<String>,
    /// Resolved connections.
    pub connections: Vec<RConnection>,
    /// Resolved environmental contacts.
    pub contacts: Vec<RContact>,
    /// Resolved module contacts (`module` = force receiver, `other` = reaction).
    pub module_contacts: Vec<(RContact, usize)>,
    /// External wrench on each module about its COM: force, couple.
    pub ext: Vec<(Vec3, Vec3)>,
    /// Connector types in a dense table.
    pub connectors: Vec<ConnectorSpec>,
    /// Connector type names.
    pub connector_names: Vec<String>,
    /// Objective weights.
    pub objective: Objective,
}

/// A resolved connection.
#[derive(Debug, Clone)]
pub struct RConnection {
    /// Child module index.
    pub child: usize,
    /// Parent module index.
    pub parent: usize,
    /// Connector index into `Resolved::connectors`.
    pub connector: usize,
    /// Connection point.
    pub point: Vec3,
    /// Frame axes [x, y, z] in the world (columns of ᴵR_A).
    pub frame: [Vec3; 3],
}

/// A resolved point contact.
#[derive(Debug, Clone)]
pub struct RContact {
    /// Module index (normal points into it).
    pub module: usize,
    /// Contact point.
    pub point: Vec3,
    /// Frame axes [x, y, z]; z is the normal.
    pub frame: [Vec3; 3],
    /// Friction coefficients along x and y.
    pub mu: [f64; 2],
}

impl Assembly {
    /// Check every field and resolve ids and frames; errors name the field.
    pub fn resolve(&self) -> Result<Resolved, ModelError> {
        finite3(&self.gravity, || "gravity".into())?;
        let mut index: HashMap<&str, usize> = HashMap::with_capacity(self.modules.len());
        let n = self.modules.len();
        let mut com = Vec::with_capacity(n);
        let mut fixed = Vec::with_capacity(n);
        let mut mass = Vec::with_capacity(n);
        let mut ext = Vec::with_capacity(n);
        let mut ids = Vec::with_capacity(n);
        for (i, m) in self.modules.iter().enumerate() {
            let f = |s: &str| format!("modules[{i}].{s}");
            if m.id.is_empty() {
                return Err(err(f("id"), "empty id"));
            }
            if index.insert(m.id.as_str(), i).is_some() {
                return Err(err(f("id"), format!("duplicate module id {:?}", m.id)));
            }
            if !(m.mass.is_finite() && m.mass >= 0.0) {
                return Err(err(f("mass"), "must be a finite number ≥ 0"));
            }
            finite3(&m.position, || f("position"))?;
            finite3(&m.rpy, || f("rpy"))?;
            finite3(&m.com, || f("com"))?;
            let r = rot_rpy(m.rpy);
            let c = add(
                m.position,
                add(
                    add(scale(r[0], m.com[0]), scale(r[1], m.com[1])),
                    scale(r[2], m.com[2]),
                ),
            );
            com.push(c);
            fixed.push(m.fixed);
            mass.push(m.mass);
            ids.push(m.id.clone());
            ext.push((scale(self.gravity, m.mass), [0.0; 3]));
        }
        let lookup = |id: &str, field: &dyn Fn() -> String| -> Result<usize, ModelError> {
            index
                .get(id)
                .copied()
                .ok_or_else(|| err(field(), format!("unknown module {id:?}")))
        };
        let mut connector_names = Vec::new();
        let mut connectors = Vec::new();
        let mut cindex: HashMap<&str, usize> = HashMap::new();
        for (name, spec) in &self.connectors {
            let f = |s: &str| format!("connectors.{name}.{s}");
            match spec {
                ConnectorSpec::Box {
                    max,
                    omega_k,
                    margin_weights,
                } => {
                    let names = ["fx", "fy", "fz", "mx", "my", "mz"];
                    for (d, l) in max.as_array().iter().enumerate() {
                        if let Some(l) = l {
                            if !(l.is_finite() && *l >= 0.0) {
                                return Err(err(
                                    f(&format!("max.{}", names[d])),
                                    "must be a finite number ≥ 0",
                                ));
                            }
                        }
                    }
                    if omega_k.iter().any(|w| !(w.is_finite() && *w > 0.0)) {
                        return Err(err(f("omega_k"), "every weight must be finite and > 0"));
                    }
                    if margin_weights.iter().any(|w| !(w.is_finite() && *w > 0.0)) {
                        return Err(err(
                            f("margin_weights"),
                            "every weight must be finite and > 0",
                        ));
                    }
                }
                ConnectorSpec::Lorentz { f_max_z, mu } => {
                    if !(f_max_z.is_finite() && *f_max_z >= 0.0) {
                        return Err(err(f("f_max_z"), "must be a finite number ≥ 0"));
                    }
                    if mu.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
                        return Err(err(f("mu"), "every coefficient must be finite and ≥ 0"));
                    }
                }
            }
            cindex.insert(name.as_str(), connectors.len());
            connectors.push(spec.clone());
            connector_names.push(name.clone());
        }
        let mut connections = Vec::with_capacity(self.connections.len());
        for (k, c) in self.connections.iter().enumerate() {
            let f = |s: &str| format!("connections[{k}].{s}");
            let child = lookup(&c.child, &|| f("child"))?;
            let parent = lookup(&c.parent, &|| f("parent"))?;
            if child == parent {
                return Err(err(f("parent"), "a module cannot connect to itself"));
            }
            let connector = *cindex.get(c.connector.as_str()).ok_or_else(|| {
                err(
                    f("connector"),
                    format!("unknown connector type {:?}", c.connector),
                )
            })?;
            finite3(&c.point, || f("point"))?;
            let z = match c.axis {
                Some(a) => {
                    finite3(&a, || f("axis"))?;
                    a
                }
                None => sub(com[child], c.point),
            };
            if let Some(h) = c.x_axis {
                finite3(&h, || f("x_axis"))?;
            }
            let frame = frame_from_z(z, c.x_axis).ok_or_else(|| {
                err(
                    f("axis"),
                    "zero axis (give `axis` when the point is at the child's centre of mass)",
                )
            })?;
            connections.push(RConnection {
                child,
                parent,
                connector,
                point: c.point,
                frame,
            });
        }
        let contact = |module: usize,
                       point: &Vec3,
                       normal: Vec3,
                       mu: [f64; 2],
                       xh: Option<Vec3>,
                       f: &dyn Fn(&str) -> String|
         -> Result<RContact, ModelError> {
            finite3(point, || f("point"))?;
            finite3(&normal, || f("normal"))?;
            if mu.iter().any(|m| !(m.is_finite() && *m >= 0.0)) {
                return Err(err(f("mu"), "friction coefficients must be finite and ≥ 0"));
            }
            if let Some(h) = xh {
                finite3(&h, || f("x_axis"))?;
            }
            let frame = frame_from_z(normal, xh).ok_or_else(|| err(f("normal"), "zero normal"))?;
            Ok(RContact {
                module,
                point: *point,
                frame,
                mu,
            })
        };
        let mut contacts = Vec::with_capacity(self.contacts.len());
        for (k, c) in self.contacts.iter().enumerate() {
            let f = |s: &str| format!("contacts[{k}].{s}");
            let m = lookup(&c.module, &|| f("module"))?;
            let xh = c.x_axis.or(Some([1.0, 0.0, 0.0]));
            contacts.push(contact(
                m,
                &c.point,
                c.normal.unwrap_or([0.0, 0.0, 1.0]),
                c.mu,
                xh,
                &f,
            )?);
        }
        let mut module_contacts = Vec::with_capacity(self.module_contacts.len());
        for (k, c) in self.module_contacts.iter().enumerate() {
            let f = |s: &str| format!("module_contacts[{k}].{s}");
            let m = lookup(&c.module, &|| f("module"))?;
            let o = lookup(&c.other, &|| f("other"))?;
            if m == o {
                return Err(err(f("other"), "a module cannot touch itself"));
            }
            module_contacts.push((contact(m, &c.point, c.normal, c.mu, c.x_axis, &f)?, o));
        }
        for (k, l) in self.loads.iter().enumerate() {
            let f = |s: &str| format!("loads[{k}].{s}");
            let m = lookup(&l.module, &|| f("module"))?;
            finite3(&l.force, || f("force"))?;
            finite3(&l.couple, || f("couple"))?;
            let p = match l.point {
                Some(p) => {
                    finite3(&p, || f("point"))?;
                    p
                }
                None => com[m],
            };
            let e = &mut ext[m];
            e.0 = add(e.0, l.force);
            e.1 = add(e.1, add(l.couple, cross(sub(p, com[m]), l.force)));
        }
        let o = &self.objective;
        for (v, name) in [
            (o.lambda_max, "objective.lambda_max"),
            (o.lambda_sum, "objective.lambda_sum"),
            (o.lambda_module_contacts, "objective.lambda_module_contacts"),
            (o.lambda_contacts, "objective.lambda_contacts"),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(err(name, "must be a finite number ≥ 0"));
            }
        }
        Ok(Resolved {
            com,
            fixed,
            mass,
            ids,
            connections,
            contacts,
            module_contacts,
            ext,
            connectors,
            connector_names,
            objective: self.objective,
        })
    }
}
