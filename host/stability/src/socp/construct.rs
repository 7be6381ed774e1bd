//! Construction of the cone program (41)/(51) from the resolved model: variables, equilibrium
//! rows (1), (11), connector and contact cones, assembled in compressed sparse columns.

use super::{ConnLayout, ContactLayout, Program, SLOTS, SLOT_AXIS};
use crate::model::{cross, ConnectorSpec, Resolved, Vec3};
use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT::*;

struct Triplets {
    col: Vec<u32>,
    row: Vec<u32>,
    val: Vec<f64>,
}

impl Triplets {
    fn with_capacity(n: usize) -> Self {
        Triplets {
            col: Vec::with_capacity(n),
            row: Vec::with_capacity(n),
            val: Vec::with_capacity(n),
        }
    }
    #[inline]
    fn push(&mut self, row: usize, col: usize, val: f64) {
        if val != 0.0 {
            self.row.push(row as u32);
            self.col.push(col as u32);
            self.val.push(val);
        }
    }
}

/// CSC from triplets by a counting sort on columns, rows sorted within each column. O(nnz).
fn csc(m: usize, n: usize, t: &Triplets) -> CscMatrix<f64> {
    let nnz = t.val.len();
    let mut colptr = vec![0usize; n + 1];
    for &c in &t.col {
        colptr[c as usize + 1] += 1;
    }
    for j in 0..n {
        colptr[j + 1] += colptr[j];
    }
    let mut next = colptr.clone();
    let mut rowval = vec![0usize; nnz];
    let mut nzval = vec![0.0; nnz];
    for k in 0..nnz {
        let c = t.col[k] as usize;
        let p = next[c];
        next[c] += 1;
        rowval[p] = t.row[k] as usize;
        nzval[p] = t.val[k];
    }
    // Columns have a handful of entries: insertion sort each, merging duplicates is not needed
    // (every (row, col) pair is produced once).
    for j in 0..n {
        let (s, e) = (colptr[j], colptr[j + 1]);
        for a in s + 1..e {
            let mut b = a;
            while b > s && rowval[b - 1] > rowval[b] {
                rowval.swap(b - 1, b);
                nzval.swap(b - 1, b);
                b -= 1;
            }
        }
    }
    CscMatrix::new(m, n, colptr, rowval, nzval)
}

/// Characteristic length used to scale the moment rows (mean lever arm, ≥ 1 mm).
pub(crate) fn char_length(r: &Resolved) -> f64 {
    let mut s = 0.0;
    let mut k = 0usize;
    for c in &r.connections {
        s += crate::model::norm(crate::model::sub(c.point, r.com[c.child]));
        k += 1;
    }
    for c in &r.contacts {
        s += crate::model::norm(crate::model::sub(c.point, r.com[c.module]));
        k += 1;
    }
    if k == 0 {
        1.0
    } else {
        (s / k as f64).max(1e-3)
    }
}

/// Build the program (41)/(51); `with_limits = false` drops the connector limits (35)/(52),
/// which gives the potential stable state set 𝕏 of Definition 1.
pub fn build(r: &Resolved, with_limits: bool) -> Program {
    let nmod = r.com.len();
    // Equality rows: 6 per free module.
    let mut eq_row = vec![usize::MAX; nmod];
    let mut neq = 0;
    for i in 0..nmod {
        if !r.fixed[i] {
            eq_row[i] = neq;
            neq += 6;
        }
    }
    let inv_l = 1.0 / char_length(r);
    let ncon = r.connections.len();
    let nct = r.contacts.len() + r.module_contacts.len();
    let mut eq = Triplets::with_capacity(ncon * 7 * 12 + nct * 3 * 12);
    let mut nn = Triplets::with_capacity(ncon * 8);
    let mut nn_b: Vec<f64> = Vec::with_capacity(ncon * 8);
    let mut soc = Triplets::with_capacity(ncon * 7 + nct * 3);
    let mut soc_dims: Vec<usize> = Vec::with_capacity(ncon + nct);
    let mut q: Vec<f64> = Vec::with_capacity(ncon * 8 + nct * 3 + 1);
    let mut nvar = 0usize;
    let mut new_var = |q: &mut Vec<f64>, cost: f64| {
        q.push(cost);
        nvar += 1;
        nvar - 1
    };
    let obj = r.objective;
    // w_A^max ≥ w_k for every connection (41). A single w in every such row is a dense KKT
    // column, but measured against a topology-following tree of partial maxima it converges in
    // fewer iterations (11–13 vs 18–28 on chains/meshes) and scales linearly on chains, so the
    // plain form is kept.
    let mut t_of = vec![usize::MAX; nmod];
    if ncon > 0 {
        let w = new_var(&mut q, obj.lambda_max);
        t_of.iter_mut().for_each(|t| *t = w);
    }
    // Adds the equilibrium entries of a unit local force/couple axis applied at `point`
    // on `module` with sign `sgn`, for variable `v` with physical scale `s`.
    let add_eq = |eq: &mut Triplets,
                  module: usize,
                  v: usize,
                  axis_world: Vec3,
                  is_couple: bool,
                  point: Vec3,
                  s: f64| {
        let row = eq_row[module];
        if row == usize::MAX {
            return;
        }
        if is_couple {
            for d in 0..3 {
                eq.push(row + 3 + d, v, s * axis_world[d] * inv_l);
            }
        } else {
            let arm = crate::model::sub(point, r.com[module]);
            let mo = cross(arm, axis_world);
            for d in 0..3 {
                eq.push(row + d, v, s * axis_world[d]);
            }
            for d in 0..3 {
                eq.push(row + 3 + d, v, s * mo[d] * inv_l);
            }
        }
    };

    let mut conns = Vec::with_capacity(ncon);
    let mut soc_row = 0usize;
    for c in &r.connections {
        let spec = &r.connectors[c.connector];
        let mut lay = ConnLayout {
            var: [None; SLOTS],
            scale: [1.0; SLOTS],
            strength: None,
        };
        match spec {
            ConnectorSpec::Box {
                max,
                omega_k,
                margin_weights: _,
            } => {
                let lim = max.as_array();
                for slot in 0..SLOTS {
                    let ax = SLOT_AXIS[slot];
                    if slot == 3 {
                        // f_s: support force, not part of the connector wrench (34).
                        lay.var[slot] = Some(new_var(&mut q, 0.0));
                        continue;
                    }
                    if lim[ax] == Some(0.0) {
                        continue; // released
                    }
                    lay.scale[slot] = 1.0 / omega_k[ax];
                    lay.var[slot] = Some(new_var(&mut q, 0.0));
                }
                let wc = new_var(&mut q, obj.lambda_sum);
                lay.strength = Some(wc);
                // strength cone ‖ωK f̄‖ ≤ w_c (40)
                let mut dim = 1;
                soc.push(soc_row, wc, -1.0);
                for slot in [0usize, 1, 2, 4, 5, 6] {
                    if let Some(v) = lay.var[slot] {
                        soc.push(soc_row + dim, v, -1.0);
                        dim += 1;
                    }
                }
                soc_row += dim;
                soc_dims.push(dim);
                // w_c ≤ w_A^max
                let row = nn_b.len();
                nn.push(row, wc, 1.0);
                nn.push(row, t_of[c.child], -1.0);
                nn_b.push(0.0);
                if with_limits {
                    for slot in [0usize, 1, 4, 5, 6] {
                        let ax = SLOT_AXIS[slot];
                        if let (Some(v), Some(l)) = (lay.var[slot], lim[ax]) {
                            let bnd = l / lay.scale[slot];
                            let row = nn_b.len();
                            nn.push(row, v, 1.0);
                            nn_b.push(bnd);
                            nn.push(row + 1, v, -1.0);
                            nn_b.push(bnd);
                        }
                    }
                    if let (Some(v), Some(l)) = (lay.var[2], lim[2]) {
                        let row = nn_b.len();
                        nn.push(row, v, -1.0);
                        nn_b.push(l / lay.scale[2]);
                    }
                }
            }
            ConnectorSpec::Lorentz { f_max_z, mu } => {
                // (49): [f_x/μ1, f_y/μ2, f_s, m_x/μ4, m_y/μ5, m_z/μ6] ∈ K_Lorentz.
                let mus = [mu[0], mu[1], 1.0, 1.0, mu[2], mu[3], mu[4]];
                for slot in 0..SLOTS {
                    if slot == 2 {
                        lay.var[slot] = Some(new_var(&mut q, -obj.lambda_sum));
                        continue;
                    }
                    if slot == 3 {
                        lay.var[slot] = Some(new_var(&mut q, 0.0));
                        continue;
                    }
                    if mus[slot] == 0.0 {
                        continue;
                    }
                    lay.scale[slot] = mus[slot];
                    lay.var[slot] = Some(new_var(&mut q, 0.0));
                }
                let fs = lay.var[3].unwrap_or(0);
                let fcon = lay.var[2].unwrap_or(0);
                let mut dim = 1;
                soc.push(soc_row, fs, -1.0);
                for slot in [0usize, 1, 4, 5, 6] {
                    if let Some(v) = lay.var[slot] {
                        soc.push(soc_row + dim, v, -1.0);
                        dim += 1;
                    }
                }
                if dim == 1 {
                    // Only the head: a nonnegativity, expressed as a 2-D cone with a zero row.
                    soc_dims.push(2);
                    soc_row += 2;
                } else {
                    soc_dims.push(dim);
                    soc_row += dim;
                }
                // −f_con ≤ f_max  (51)
                let row = nn_b.len();
                nn.push(row, fcon, -1.0);
                nn.push(row, t_of[c.child], -1.0);
                nn_b.push(0.0);
                if with_limits {
                    let row = nn_b.len();
                    nn.push(row, fcon, -1.0);
                    nn_b.push(*f_max_z);
                }
            }
        }
        // f_s ≥ 0, f_con ≤ 0 (24)
        if let Some(v) = lay.var[3] {
            let row = nn_b.len();
            nn.push(row, v, -1.0);
            nn_b.push(0.0);
        }
        if let Some(v) = lay.var[2] {
            let row = nn_b.len();
            nn.push(row, v, 1.0);
            nn_b.push(0.0);
        }
        // Equilibrium (1), (11) for the child (+) and the parent (−, SOCP 20).
        for (module, v, axis, is_couple, s) in lay.equilibrium_terms(c) {
            add_eq(&mut eq, module, v, axis, is_couple, c.point, s);
        }
        conns.push(lay);
    }

    let mut add_contact = |q: &mut Vec<f64>,
                           new_var: &mut dyn FnMut(&mut Vec<f64>, f64) -> usize,
                           eq: &mut Triplets,
                           ct: &crate::model::RContact,
                           other: Option<usize>,
                           cost: f64|
     -> ContactLayout {
        let mut lay = ContactLayout { var: [None; 3] };
        let muz = [1.0, ct.mu[0], ct.mu[1]];
        let axes = [ct.frame[2], ct.frame[0], ct.frame[1]];
        let frictionless = ct.mu[0] == 0.0 && ct.mu[1] == 0.0;
        let mut dim = 0;
        for k in 0..3 {
            if muz[k] == 0.0 {
                continue;
            }
            let v = new_var(q, if k == 0 { cost } else { 0.0 });
            lay.var[k] = Some(v);
            if frictionless {
                // A lone normal force: f_z ≥ 0 (a nonnegative row, no cone).
                let row = nn_b.len();
                nn.push(row, v, -1.0);
                nn_b.push(0.0);
            } else {
                soc.push(soc_row + dim, v, -1.0);
                dim += 1;
            }
            add_eq(eq, ct.module, v, axes[k], false, ct.point, muz[k]);
            if let Some(o) = other {
                add_eq(eq, o, v, axes[k], false, ct.point, -muz[k]);
            }
        }
        if !frictionless {
            let dim = dim.max(2); // one friction direction: SOC(2) ⇔ |f_t/μ| ≤ f_z
            soc_dims.push(dim);
            soc_row += dim;
        }
        lay
    };
    let mut contacts = Vec::with_capacity(r.contacts.len());
    for ct in &r.contacts {
        contacts.push(add_contact(
            &mut q,
            &mut new_var,
            &mut eq,
            ct,
            None,
            obj.lambda_contacts,
        ));
    }
    let mut module_contacts = Vec::with_capacity(r.module_contacts.len());
    for (ct, o) in &r.module_contacts {
        module_contacts.push(add_contact(
            &mut q,
            &mut new_var,
            &mut eq,
            ct,
            Some(*o),
            obj.lambda_module_contacts,
        ));
    }
    let n = q.len();

    // Assemble rows: [equalities][nonnegatives][second-order cones].
    let nnn = nn_b.len();
    let m = neq + nnn + soc_row;
    let mut all = Triplets::with_capacity(eq.val.len() + nn.val.len() + soc.val.len());
    all.col.extend_from_slice(&eq.col);
    all.row.extend_from_slice(&eq.row);
    all.val.extend_from_slice(&eq.val);
    all.col.extend_from_slice(&nn.col);
    all.row.extend(nn.row.iter().map(|&x| x + neq as u32));
    all.val.extend_from_slice(&nn.val);
    all.col.extend_from_slice(&soc.col);
    all.row
        .extend(soc.row.iter().map(|&x| x + (neq + nnn) as u32));
    all.val.extend_from_slice(&soc.val);
    let a = csc(m, n, &all);

    let mut b = vec![0.0; m];
    for i in 0..nmod {
        let row = eq_row[i];
        if row == usize::MAX {
            continue;
        }
        let (f, mo) = r.ext[i];
        for d in 0..3 {
            b[row + d] = -f[d];
            b[row + 3 + d] = -mo[d] * inv_l;
        }
    }
    b[neq..neq + nnn].copy_from_slice(&nn_b);

    let mut cones = Vec::with_capacity(2 + soc_dims.len());
    if neq > 0 {
        cones.push(ZeroConeT(neq));
    }
    if nnn > 0 {
        cones.push(NonnegativeConeT(nnn));
    }
    for d in soc_dims {
        cones.push(SecondOrderConeT(d));
    }
    Program {
        n,
        q,
        a,
        b,
        cones,
        conns,
        contacts,
        module_contacts,
        dual: false,
        n_unknowns: n,
        clamp_fcon: false,
    }
}
