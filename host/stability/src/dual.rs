//! The relaxed cone program (41)/(51) without connector limits (the potential stable state set
//! 𝕏 of Definition 1) handed to Clarabel in its *dual* form: one Clarabel variable per
//! equilibrium row (the multipliers y of Zx = b, SOCP 29), one conic constraint row per
//! wrench/force variable.
//!
//! Every unknown of the program is placed in exactly one cone, so the program is
//! `min cᵀx  s.t.  Ax = b,  x ∈ K` (A: the equilibrium rows (1), (11) and one row
//! `w_max − w_k − t_k = 0` per connection). Clarabel solves `min −bᵀy  s.t.  Aᵀy + s = c,
//! s ∈ K`, whose conic dual is exactly that program: Clarabel's dual variable `z` is x, and a
//! certified *dual* infeasibility of Clarabel's problem is a Farkas certificate that Zx = b has
//! no solution in the cones (whole-body instability). The KKT system has one row per
//! unknown plus one per equilibrium row, instead of one per unknown, one per cone row and one
//! per equilibrium row in the direct form ([`crate::socp::build`]): about 40 % smaller, with
//! fewer non-zeros and a cheaper ordering.
//!
//! Differences from the direct form, none of which changes the optimum of (41):
//! - f_con^z ≤ 0 (24) is not imposed on box connections: f_con and f_s have the same column
//!   in Z, so any point with f_con > 0 maps to (0, f_s + f_con), which is feasible and has a
//!   smaller or equal strength (40) and objective. [`crate::socp::connection_values_of`]
//!   applies that map to the solution ([`Program::clamp_fcon`]).
//! - w_k ≤ w_A^max is the equality `w_max − w_k − t_k = 0` with a slack t_k ≥ 0.
//! - The Lorentz adhesion −f_con is the nonnegative variable u = −f_con (51).
//!
//! The w_A^max row couples every level row; it is padded with explicit zeros so that AMD
//! treats it as dense and orders it last (values unchanged; see `pad_dense_row`).

#![allow(clippy::needless_range_loop)] // index loops mirror the paper's per-component equations

use crate::model::{cross, sub, ConnectorSpec, RContact, Resolved, Vec3};
use crate::socp::{char_length, ConnLayout, ContactLayout, Program, SLOTS, SLOT_AXIS};
use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT::{self, *};

/// Tag of a second-order-cone variable before renumbering (nonnegative variables come first).
const SOC_TAG: usize = 1 << (usize::BITS - 1);

/// Unknowns and their equality rows, before the transpose handed to Clarabel.
struct Builder {
    /// Entries of A as (unknown, equality row, value); unknowns tagged with [`SOC_TAG`].
    ent: Vec<(usize, u32, f64)>,
    /// Cost of each nonnegative unknown.
    c_nn: Vec<f64>,
    /// Cost of each second-order-cone unknown.
    c_soc: Vec<f64>,
    /// Second-order cone dimensions, in order.
    soc_dims: Vec<usize>,
}

impl Builder {
    fn nonneg(&mut self, cost: f64) -> usize {
        self.c_nn.push(cost);
        self.c_nn.len() - 1
    }
    fn soc(&mut self, cost: f64) -> usize {
        self.c_soc.push(cost);
        SOC_TAG + self.c_soc.len() - 1
    }
    #[inline]
    fn push(&mut self, var: usize, row: usize, val: f64) {
        if val != 0.0 {
            self.ent.push((var, row as u32, val));
        }
    }
}

/// AMD's "dense" threshold in Clarabel's QDLDL: degree > 1.5 · 10 · √(KKT dimension).
const AMD_DENSE: f64 = 15.0;

/// w_A^max is coupled to every connection's level row: a nearly dense row of the KKT matrix
/// that stays just below AMD's dense threshold, which made the ordering 3–10× slower (chain /
/// mesh of 1,000 modules: 14 / 57 ms instead of 3 / 6 ms; `examples/kkt_fill.rs`). When
/// possible its row is padded with explicit zeros in the equilibrium columns (Clarabel keeps
/// explicit zeros, `input_sparse_dropzeros = false`) so AMD recognises it as dense and orders
/// it last, where it only costs one dense row of L. The values of the program are unchanged.
fn pad_dense_row(bld: &mut Builder, w: usize, neq: usize, dim_base: usize) {
    let expanded = bld.soc_dims.iter().filter(|&&d| d > 4).count();
    let dim = (dim_base + 2 * expanded) as f64;
    let threshold = (AMD_DENSE * dim.sqrt()).max(16.0);
    let degree = bld.ent.iter().filter(|e| e.0 == w).count();
    if ((degree + neq) as f64) > threshold + 1.0 {
        bld.ent.extend((0..neq).map(|row| (w, row as u32, 0.0)));
    }
}

/// Build the relaxed program (no connector limits) in the dual form described in the module
/// documentation. [`crate::socp::solve_with`] maps Clarabel's answer back to the unknowns.
pub fn build_relaxed(r: &Resolved) -> Program {
    build_relaxed_with(r, true)
}

/// [`build_relaxed`], with the padding of the w_A^max row (see the module docs) switchable
/// (for measurements).
pub fn build_relaxed_with(r: &Resolved, pad_dense: bool) -> Program {
    let nmod = r.com.len();
    let mut eq_row = vec![usize::MAX; nmod];
    let mut neq = 0;
    for i in 0..nmod {
        if !r.fixed[i] {
            eq_row[i] = neq;
            neq += 6;
        }
    }
    let ncon = r.connections.len();
    let nct = r.contacts.len() + r.module_contacts.len();
    let w_row0 = neq;
    let inv_l = 1.0 / char_length(r);
    let obj = r.objective;
    let mut bld = Builder {
        ent: Vec::with_capacity(ncon * 7 * 12 + ncon * 3 + nct * 3 * 12),
        c_nn: Vec::with_capacity(2 * ncon + nct + 1),
        c_soc: Vec::with_capacity(7 * ncon + 3 * nct),
        soc_dims: Vec::with_capacity(ncon + nct),
    };
    // Equilibrium entries (1), (11) of a unit local force/couple axis at `point` on `module`.
    let add_eq = |bld: &mut Builder,
                  module: usize,
                  v: usize,
                  axis: Vec3,
                  is_couple: bool,
                  point: Vec3,
                  s: f64| {
        let row = eq_row[module];
        if row == usize::MAX {
            return;
        }
        if is_couple {
            for d in 0..3 {
                bld.push(v, row + 3 + d, s * axis[d] * inv_l);
            }
        } else {
            let mo = cross(sub(point, r.com[module]), axis);
            for d in 0..3 {
                bld.push(v, row + d, s * axis[d]);
            }
            for d in 0..3 {
                bld.push(v, row + 3 + d, s * mo[d] * inv_l);
            }
        }
    };
    // One level row per connection: w_max − (w_k or u_k) − t_k = 0.
    let m_eq = w_row0 + ncon;
    let w_max = if ncon > 0 {
        Some(bld.nonneg(obj.lambda_max))
    } else {
        None
    };
    let mut conns = Vec::with_capacity(ncon);
    for (k, c) in r.connections.iter().enumerate() {
        let mut lay = ConnLayout {
            var: [None; SLOTS],
            scale: [1.0; SLOTS],
            strength: None,
        };
        let head;
        match &r.connectors[c.connector] {
            ConnectorSpec::Box { max, omega_k, .. } => {
                // Strength cone ‖ωK f̄‖ ≤ w_k (40): head first.
                let lim = max.as_array();
                let wk = bld.soc(obj.lambda_sum);
                lay.strength = Some(wk);
                head = wk;
                let mut dim = 1;
                for slot in [0usize, 1, 2, 4, 5, 6] {
                    let ax = SLOT_AXIS[slot];
                    if lim[ax] == Some(0.0) {
                        continue; // released
                    }
                    lay.scale[slot] = 1.0 / omega_k[ax];
                    lay.var[slot] = Some(bld.soc(0.0));
                    dim += 1;
                }
                bld.soc_dims.push(dim);
                lay.var[3] = Some(bld.nonneg(0.0)); // f_s ≥ 0 (24)
            }
            ConnectorSpec::Lorentz { mu, .. } => {
                // (49): [f_s, f_x/μ1, f_y/μ2, m_x/μ4, m_y/μ5, m_z/μ6] ∈ K_Lorentz, head first.
                let mus = [mu[0], mu[1], 1.0, 1.0, mu[2], mu[3], mu[4]];
                let tail: Vec<usize> = [0usize, 1, 4, 5, 6]
                    .into_iter()
                    .filter(|&s| mus[s] != 0.0)
                    .collect();
                if tail.is_empty() {
                    lay.var[3] = Some(bld.nonneg(0.0));
                } else {
                    lay.var[3] = Some(bld.soc(0.0));
                    for &slot in &tail {
                        lay.scale[slot] = mus[slot];
                        lay.var[slot] = Some(bld.soc(0.0));
                    }
                    bld.soc_dims.push(1 + tail.len());
                }
                // u = −f_con ≥ 0, cost λ1·u (51); its level is u + t_k.
                let u = bld.nonneg(obj.lambda_sum);
                lay.var[2] = Some(u);
                lay.scale[2] = -1.0;
                head = u;
            }
        }
        let t = bld.nonneg(0.0);
        let w_row = w_row0 + k;
        bld.push(head, w_row, -1.0);
        bld.push(t, w_row, -1.0);
        if let Some(w) = w_max {
            bld.push(w, w_row, 1.0);
        }
        for (module, v, axis, is_couple, s) in lay.equilibrium_terms(c) {
            add_eq(&mut bld, module, v, axis, is_couple, c.point, s);
        }
        conns.push(lay);
    }
    let add_contact = |bld: &mut Builder, ct: &RContact, other: Option<usize>, cost: f64| {
        let muz = [1.0, ct.mu[0], ct.mu[1]];
        let axes = [ct.frame[2], ct.frame[0], ct.frame[1]];
        let mut lay = ContactLayout { var: [None; 3] };
        if ct.mu[0] == 0.0 && ct.mu[1] == 0.0 {
            lay.var[0] = Some(bld.nonneg(cost)); // frictionless: f_z ≥ 0
        } else {
            // (30)–(32): (f_z, f_x/μ_x, f_y/μ_y) ∈ SOC; one friction direction: SOC(2).
            let mut dim = 0;
            for k in 0..3 {
                if muz[k] != 0.0 {
                    lay.var[k] = Some(bld.soc(if k == 0 { cost } else { 0.0 }));
                    dim += 1;
                }
            }
            bld.soc_dims.push(dim);
        }
        for k in 0..3 {
            if let Some(v) = lay.var[k] {
                add_eq(bld, ct.module, v, axes[k], false, ct.point, muz[k]);
                if let Some(o) = other {
                    add_eq(bld, o, v, axes[k], false, ct.point, -muz[k]);
                }
            }
        }
        lay
    };
    let contacts: Vec<ContactLayout> = r
        .contacts
        .iter()
        .map(|ct| add_contact(&mut bld, ct, None, obj.lambda_contacts))
        .collect();
    let module_contacts: Vec<ContactLayout> = r
        .module_contacts
        .iter()
        .map(|(ct, o)| add_contact(&mut bld, ct, Some(*o), obj.lambda_module_contacts))
        .collect();

    // Renumber: nonnegative unknowns first, then the second-order cones in order.
    let nnn = bld.c_nn.len();
    let nx = nnn + bld.c_soc.len();
    if let (Some(w), true) = (w_max, pad_dense) {
        pad_dense_row(&mut bld, w, w_row0, m_eq + nx);
    }
    let fix = |v: usize| if v >= SOC_TAG { v - SOC_TAG + nnn } else { v };
    for lay in &mut conns {
        for v in lay.var.iter_mut().flatten() {
            *v = fix(*v);
        }
        if let Some(w) = lay.strength.as_mut() {
            *w = fix(*w);
        }
    }
    let mut contacts = contacts;
    let mut module_contacts = module_contacts;
    for lay in contacts.iter_mut().chain(module_contacts.iter_mut()) {
        for v in lay.var.iter_mut().flatten() {
            *v = fix(*v);
        }
    }
    // Clarabel's constraint matrix is Aᵀ: column j = equality row j, row = unknown. Counting
    // sort on the equality row, then each (short) column sorted by unknown where needed
    // (renumbering puts the nonnegative unknowns first).
    let nnz = bld.ent.len();
    let mut colptr = vec![0usize; m_eq + 1];
    for e in &bld.ent {
        colptr[e.1 as usize + 1] += 1;
    }
    for j in 0..m_eq {
        colptr[j + 1] += colptr[j];
    }
    let mut next = colptr.clone();
    let mut rowval = vec![0usize; nnz];
    let mut nzval = vec![0.0; nnz];
    for &(v, row, val) in &bld.ent {
        let p = next[row as usize];
        next[row as usize] += 1;
        rowval[p] = fix(v);
        nzval[p] = val;
    }
    for j in 0..m_eq {
        let (s, e) = (colptr[j], colptr[j + 1]);
        if !rowval[s..e].windows(2).all(|w| w[0] < w[1]) {
            let mut pairs: Vec<(usize, f64)> = rowval[s..e]
                .iter()
                .copied()
                .zip(nzval[s..e].iter().copied())
                .collect();
            pairs.sort_unstable_by_key(|p| p.0);
            for (k, (rv, v)) in pairs.into_iter().enumerate() {
                rowval[s + k] = rv;
                nzval[s + k] = v;
            }
        }
    }
    let a = CscMatrix::new(nx, m_eq, colptr, rowval, nzval);
    // Clarabel's objective −bᵀy: b is minus the external wrench of each free module.
    let mut q = vec![0.0; m_eq];
    for i in 0..nmod {
        let row = eq_row[i];
        if row == usize::MAX {
            continue;
        }
        let (f, mo) = r.ext[i];
        for d in 0..3 {
            q[row + d] = f[d]; // −b = +f_ext
            q[row + 3 + d] = mo[d] * inv_l;
        }
    }
    let mut c = bld.c_nn;
    c.extend_from_slice(&bld.c_soc);
    let mut cones: Vec<SupportedConeT<f64>> = Vec::with_capacity(1 + bld.soc_dims.len());
    if nnn > 0 {
        cones.push(NonnegativeConeT(nnn));
    }
    cones.extend(bld.soc_dims.iter().map(|&d| SecondOrderConeT(d)));
    Program {
        n: m_eq,
        q,
        a,
        b: c,
        cones,
        conns,
        contacts,
        module_contacts,
        dual: true,
        n_unknowns: nx,
        clamp_fcon: true,
    }
}
