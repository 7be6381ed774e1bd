//! The model resolved: ids replaced by indices, frames built, every number checked, loads
//! reduced to one wrench per module about its centre of mass.

use super::vector::{add, cross, frame_from_z, rot_rpy, scale, sub};
use super::{Assembly, ConnectorSpec, ModelError, Objective, Vec3};
use std::collections::HashMap;

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
