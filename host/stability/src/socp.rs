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

use crate::model::{cross, ConnectorSpec, Resolved, Vec3};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT, SupportedConeT::*,
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

/// Outcome of one solve.
#[derive(Debug, Clone)]
pub enum Outcome {
    /// Optimal (Clarabel `Solved` or `AlmostSolved`): the primal solution.
    Optimal(Vec<f64>),
    /// Certified primal infeasible (Clarabel `PrimalInfeasible`).
    Infeasible,
    /// Anything else: no certificate.
    Failed(String),
}

/// Statistics of one solve.
#[derive(Debug, Clone, Copy, Default)]
pub struct SolveInfo {
    /// Interior-point iterations.
    pub iterations: u32,
    /// Seconds in Clarabel (setup + solve).
    pub seconds: f64,
}

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

/// Iterative-refinement steps per KKT solve in the first attempt. Clarabel's default (up to
/// 10 steps to a 1e-13 relative residual) spends about half of every interior-point iteration
/// in refinement; one step was measured to keep the iteration counts (chain/mesh/tree-ground
/// at 1,000 modules: 11/14/18) while cutting the solve time by 15–20 %. Termination is judged on
/// the unrefined problem's own residuals, so a `Solved` status means the same tolerances.
pub const FAST_REFINEMENT_STEPS: u32 = 1;

/// Solver settings: Clarabel defaults with quiet output and tolerances in force units.
pub fn settings() -> DefaultSettings<f64> {
    DefaultSettings {
        verbose: false,
        tol_gap_abs: TIGHT_TOL,
        tol_gap_rel: TIGHT_TOL,
        tol_feas: TIGHT_TOL,
        max_iter: 100,
        ..DefaultSettings::default()
    }
}

/// Settings of the first (fast) attempt: [`settings`] with [`FAST_REFINEMENT_STEPS`].
pub fn fast_settings() -> DefaultSettings<f64> {
    DefaultSettings {
        iterative_refinement_max_iter: FAST_REFINEMENT_STEPS,
        ..settings()
    }
}

/// Settings of the first attempt on the dual form ([`crate::dual`]): [`settings`] without
/// iterative refinement. Measured (2026-11-22, CPU time, `examples/verbose_solve`): the same
/// iteration counts as with one refinement step (chain/tree-ground/mesh of 1,000: 8/16/15) and
/// 20–35 % less solve time; a solve without a certificate is repeated with [`settings`].
pub fn dual_fast_settings() -> DefaultSettings<f64> {
    DefaultSettings {
        iterative_refinement_enable: false,
        ..settings()
    }
}

/// The first-attempt settings for a program: [`dual_fast_settings`] for the dual form,
/// [`fast_settings`] for the direct form.
pub fn fast_settings_for(p: &Program) -> DefaultSettings<f64> {
    if p.dual {
        dual_fast_settings()
    } else {
        fast_settings()
    }
}

/// Solve the program. Only `Solved | AlmostSolved` give a state; only `PrimalInfeasible`
/// certifies infeasibility; everything else is "no certificate" (DESIGN.md §10).
///
/// The first attempt uses [`fast_settings`]; when it reaches no certificate the program is
/// solved again with Clarabel's full iterative refinement ([`settings`]), so the cheaper
/// attempt can never turn a certificate the full solver would find into "not proven".
pub fn solve(p: &Program, max_iter: u32) -> (Outcome, SolveInfo) {
    solve_tol(p, max_iter, TIGHT_TOL)
}

/// Default feasibility/gap tolerance of [`settings`].
pub const TIGHT_TOL: f64 = 1e-7;
/// Looser tolerance for a first solve whose answer is re-checked (saves 1–2 iterations of
/// 9–18); [`crate::gate`] re-solves at [`TIGHT_TOL`] when a limit is within reach.
pub const LOOSE_TOL: f64 = 1e-6;

/// [`solve`] with the gap and feasibility tolerances set to `tol` in the first attempt (the
/// fallback with full refinement always uses [`TIGHT_TOL`]). Infeasibility tolerances are
/// unchanged, so `Infeasible` is the same certificate.
pub fn solve_tol(p: &Program, max_iter: u32, tol: f64) -> (Outcome, SolveInfo) {
    let first = DefaultSettings {
        tol_gap_abs: tol,
        tol_gap_rel: tol,
        tol_feas: tol,
        ..fast_settings_for(p)
    };
    let (out, info) = solve_with(p, max_iter, first);
    match out {
        Outcome::Failed(_) => {
            let (out2, info2) = solve_with(p, max_iter, settings());
            let info = SolveInfo {
                iterations: info.iterations + info2.iterations,
                seconds: info.seconds + info2.seconds,
            };
            (out2, info)
        }
        out => (out, info),
    }
}

/// One Clarabel solve of the program with the given settings (`max_iter` overrides).
pub fn solve_with(
    p: &Program,
    max_iter: u32,
    settings: DefaultSettings<f64>,
) -> (Outcome, SolveInfo) {
    let t = std::time::Instant::now();
    let pm = CscMatrix::zeros((p.n, p.n));
    let settings = DefaultSettings {
        max_iter,
        ..settings
    };
    let mut solver = match DefaultSolver::new(&pm, &p.q, &p.a, &p.b, &p.cones, settings) {
        Ok(s) => s,
        Err(e) => {
            return (
                Outcome::Failed(format!("solver setup: {e}")),
                SolveInfo::default(),
            )
        }
    };
    solver.solve();
    let info = SolveInfo {
        iterations: solver.solution.iterations,
        seconds: t.elapsed().as_secs_f64(),
    };
    let out = match (solver.solution.status, p.dual) {
        (SolverStatus::Solved | SolverStatus::AlmostSolved, false) => {
            Outcome::Optimal(std::mem::take(&mut solver.solution.x))
        }
        // Dual form: the unknowns are Clarabel's dual variables.
        (SolverStatus::Solved | SolverStatus::AlmostSolved, true) => {
            Outcome::Optimal(std::mem::take(&mut solver.solution.z))
        }
        (SolverStatus::PrimalInfeasible, false) => Outcome::Infeasible,
        // Dual form: an unbounded multiplier problem is a Farkas certificate that Zx = b has
        // no solution in the cones.
        (SolverStatus::DualInfeasible, true) => Outcome::Infeasible,
        (s, _) => Outcome::Failed(format!("solver status {s:?}")),
    };
    (out, info)
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
