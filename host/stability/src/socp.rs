//! Sparse construction of the equilibrium system Zx = b (SOCP 29) and of the cone program
//! (41)/(51), straight from the topology, and its solution with Clarabel.
//!
//! Variables (eliminating what statics determines: the parent wrench is the negated child
//! wrench, SOCP 20, and a non-connected contact has one force, SOCP 23):
//! - per connection: f_x, f_y, f_con^z, f_s, m_x, m_y, m_z in the connection frame (34, 24),
//!   scaled so that the cones act on the variables directly (box: v = ωK·f; Lorentz: v = f/μ);
//! - per box connection its characteristic strength w_Aik (40); one global w_A^max;
//! - per point contact (f_z, f_x/μ_x, f_y/μ_y), which is directly the cone (30–32).

#![allow(clippy::needless_range_loop)] // index loops mirror the paper's per-component equations

use crate::model::Vec3;
use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT;

mod construct;
mod solver;

pub use construct::build;
pub(crate) use construct::char_length;
pub use solver::{
    dual_fast_settings, fast_settings, fast_settings_for, settings, solve, solve_tol, solve_with,
    Outcome, SolveInfo, FAST_REFINEMENT_STEPS, LOOSE_TOL, TIGHT_TOL,
};

/// Component slots of a connection: f_x, f_y, f_con^z, f_s, m_x, m_y, m_z.
pub const SLOTS: usize = 7;
/// Local wrench axis of each slot (0..3 force, 3..6 couple).
pub(crate) const SLOT_AXIS: [usize; SLOTS] = [0, 1, 2, 2, 3, 4, 5];

/// Where a connection's components live in x.
#[derive(Debug, Clone)]
pub struct ConnLayout {
    /// Variable index per slot (None: released, identically 0).
    pub var: [Option<usize>; SLOTS],
    /// Physical value = scale · variable.
    pub scale: [f64; SLOTS],
    /// Index of w_Aik (box connectors).
    pub strength: Option<usize>,
}

impl ConnLayout {
    /// This connection's terms of the module equilibria (SOCP (1), (11)): for every present
    /// component, (module, variable, world axis, is a couple, signed scale), with + on the child
    /// and − on the parent (SOCP 20).
    pub(crate) fn equilibrium_terms<'a>(
        &'a self,
        c: &'a crate::model::RConnection,
    ) -> impl Iterator<Item = (usize, usize, Vec3, bool, f64)> + 'a {
        (0..SLOTS).flat_map(move |slot| {
            self.var[slot].into_iter().flat_map(move |v| {
                let ax = SLOT_AXIS[slot];
                let (axis, is_couple) = if ax < 3 {
                    (c.frame[ax], false)
                } else {
                    (c.frame[ax - 3], true)
                };
                let s = self.scale[slot];
                [
                    (c.child, v, axis, is_couple, s),
                    (c.parent, v, axis, is_couple, -s),
                ]
            })
        })
    }
}

/// Where a contact's components live in x: (f_z, f_x/μ_x, f_y/μ_y).
#[derive(Debug, Clone, Copy)]
pub struct ContactLayout {
    /// Variable index of f_z, f_x/μ_x, f_y/μ_y (None when μ = 0 in that direction).
    pub var: [Option<usize>; 3],
}

/// The assembled cone program  min qᵀx  s.t.  Ax + s = b, s ∈ K.
pub struct Program {
    /// Number of variables.
    pub n: usize,
    /// Objective.
    pub q: Vec<f64>,
    /// Constraint matrix (CSC).
    pub a: CscMatrix<f64>,
    /// Right-hand side.
    pub b: Vec<f64>,
    /// Cones in row order.
    pub cones: Vec<SupportedConeT<f64>>,
    /// Connection layouts.
    pub conns: Vec<ConnLayout>,
    /// Environmental contact layouts.
    pub contacts: Vec<ContactLayout>,
    /// Module contact layouts.
    pub module_contacts: Vec<ContactLayout>,
    /// The program is the dual form of [`crate::dual`]: Clarabel's variables are the
    /// equilibrium multipliers, the unknowns are its dual variables `z`.
    pub dual: bool,
    /// Number of unknowns of the physical program (= `n` in the direct form).
    pub n_unknowns: usize,
    /// f_con^z > 0 is allowed by the program and mapped to (0, f_s + f_con) when read.
    pub clamp_fcon: bool,
}

/// Physical connection components [f_x, f_y, f_con^z, f_s, m_x, m_y, m_z] from a solution.
pub fn connection_values(lay: &ConnLayout, x: &[f64]) -> [f64; SLOTS] {
    let mut v = [0.0; SLOTS];
    for s in 0..SLOTS {
        if let Some(k) = lay.var[s] {
            v[s] = x[k] * lay.scale[s];
        }
    }
    v
}

/// [`connection_values`] of connection `k` of a program; for a program that does not impose
/// f_con^z ≤ 0 ([`Program::clamp_fcon`]) a positive f_con is moved into f_s (same column of Z
/// (24), smaller or equal strength (40)), which keeps the point feasible and optimal.
pub fn connection_values_of(p: &Program, k: usize, x: &[f64]) -> [f64; SLOTS] {
    let mut v = connection_values(&p.conns[k], x);
    if p.clamp_fcon && v[2] > 0.0 && p.conns[k].var[3].is_some() {
        v[3] += v[2];
        v[2] = 0.0;
    }
    v
}

/// Local contact force (f_x, f_y, f_z) from a solution.
pub fn contact_force(lay: &ContactLayout, mu: [f64; 2], x: &[f64]) -> Vec3 {
    let g = |k: usize| lay.var[k].map(|v| x[v]).unwrap_or(0.0);
    [g(1) * mu[0], g(2) * mu[1], g(0)]
}
