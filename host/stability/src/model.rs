//! The general assembly model (SOCP §2): modules, connections with child/parent frames,
//! environmental and module–module point contacts, known external loads, connector limits.
//! Independent of PuzzleBots. All vectors are in the world frame ΣI unless said otherwise.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

mod resolve;
mod vector;

pub use resolve::{RConnection, RContact, Resolved};
pub use vector::{add, cross, dot, frame_from_z, norm, rot_rpy, scale, sub};

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

/// Standard gravity (m/s²): the default of [`Assembly::gravity`].
pub const GRAVITY: f64 = 9.81;

fn default_gravity() -> Vec3 {
    [0.0, 0.0, -GRAVITY]
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
