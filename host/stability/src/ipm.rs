//! A structure-exploiting interior-point method for the relaxed program in its dual form
//! ([`crate::dual`]): `min cᵀx  s.t.  Ax = b,  x ∈ K` (K: nonnegative orthant × second-order
//! cones), solved by a Mehrotra predictor–corrector with Nesterov–Todd scaling on the normal
//! equations `A W⁻² Aᵀ Δy = r`.
//!
//! The rows of A are 6 equilibrium rows per free module and one level row per connection; every
//! unknown's cone touches the rows of at most two modules and at most one level row, except
//! w_A^max, which touches every level row. So the normal matrix is, after eliminating the level
//! rows (each a 1×1 pivot coupled to its connection's two modules), a matrix of dense 6×6 blocks
//! over the module graph, factorised by [`crate::blockchol`]; w_A^max's rank-one term is added
//! in product form (Goldfarb–Scheinberg: one half-solve per factorisation, where the
//! Sherman–Morrison form needs a full one). Clarabel factorises the whole KKT matrix (one row per
//! unknown plus one per equilibrium row) with a scalar LDLᵀ instead.
//!
//! Normal equations of second-order cones grow ill-conditioned near the optimum (W⁻² has
//! eigenvalues ∝ 1/μ and ∝ μ). Three measures keep the directions accurate: the level rows are
//! eliminated in closed form (no cancellation of the huge ray stiffness), a small static
//! regularisation of the block factor, and iterative refinement against the exact, unfactorised
//! normal matrix; a direction the refinement cannot make accurate is recomputed with ten times
//! the regularisation.
//!
//! The solver only ever answers "optimal" (all of Clarabel's termination tests: primal and dual
//! residuals and the gap within the tolerance); anything else — a structure it does not
//! expect, a failed factorisation, no convergence — is [`Declined`], and the caller hands the
//! program to Clarabel, which also certifies infeasibility. So the gate's verdicts never rest
//! on this solver alone unless it proved optimality (DESIGN.md §10).

#![allow(clippy::needless_range_loop)] // index loops mirror the cone algebra

use crate::blockchol::{BlockCholesky, Slot, B};
use crate::socp::Program;
use clarabel::solver::SupportedConeT;

/// Why the structured solver gave no answer (the caller falls back to Clarabel).
#[derive(Debug, Clone, PartialEq)]
pub enum Declined {
    /// The program does not have the structure described in the module docs.
    Structure(&'static str),
    /// The normal matrix could not be factorised (e.g. a module without support).
    Factor,
    /// No optimal point within the iteration limit, or the iterates stalled or diverged.
    NotConverged {
        /// Iterations spent.
        iterations: u32,
    },
}

/// Statistics of a successful solve: the iterations and the work they took (the exact counts
/// that decide the solve time, where wall-clock time on a shared machine is noisy).
#[derive(Debug, Clone, Copy, Default)]
pub struct IpmInfo {
    /// Interior-point iterations.
    pub iterations: u32,
    /// Numeric factorisations of the normal matrix (the initial point's, one per iteration,
    /// and one more per raise of the regularisation: a failed pivot or a direction that
    /// could not be refined).
    pub factorisations: u32,
    /// Solves with the factorised normal matrix (two per iteration, plus refinement).
    pub solves: u32,
    /// Matrix-free products with the exact normal matrix (iterative refinement).
    pub products: u32,
}

/// Largest local row count of a cone block: two modules' rows plus one level row.
const MAX_ROWS: usize = 2 * B + 1;
/// No node.
const NONE: usize = usize::MAX;
/// Fraction of the distance to the cone boundary taken by a step.
const STEP_FRACTION: f64 = 0.99;
/// Static regularisation added to the diagonal of the reduced normal matrix at the start; the
/// refinement against the exact matrix ([`Ipm::refine`]) removes its effect on the direction,
/// and it is raised ×10 (up to [`MAX_REG`]) when a direction cannot be refined. Measured while
/// building it, with a fixed regularisation (before the raising existed): 0 and 1e-10 lost the
/// mesh and tree of 1,000 near the optimum (1e-10 also the chain of 10 in an earlier form),
/// 1e-8 still lost them, 1e-7 converged on every benchmark family, 1e-6 lost the chain of 3. With raising from 1e-8 the
/// families of ≤ 100 stay at 1e-8, the mesh and tree of 1,000 end at 1e-7, the mesh of 10,000
/// at 1e-6 and the tree of 10,000 at 1e-5.
const STATIC_REG: f64 = 1e-8;
/// Iterations over which the primal residual must halve.
const STALL_WINDOW: usize = 10;
/// Dual objective above the primal one by this many times the objective's scale: the dual
/// iterates run off along a Farkas direction (Zx = b has no solution in the cones).
const DIVERGED: f64 = 10.0;
/// Largest static regularisation tried.
const MAX_REG: f64 = 1e-5;
/// Refinement stops at this residual (relative to the right-hand side) ...
const REFINE_TARGET: f64 = 1e-12;
/// ... and a direction whose residual stays above this is recomputed with 10× the
/// regularisation.
const REFINE_OK: f64 = 1e-6;
/// Relative gap below which the corrector direction is refined: looser refines too early and
/// costs solves, tighter costs iterations on the large meshes and trees (the benchmark
/// problems of `bench_problems`).
const REFINE_FROM_GAP: f64 = 1e-3;
/// Iterative-refinement steps per Newton solve, at most.
const REFINE_STEPS: usize = 4;

/// One cone of K (a nonnegative unknown is a cone of dimension 1) and the rows it touches.
struct Block {
    /// First unknown.
    start: usize,
    /// Dimension.
    dim: usize,
    /// Second-order cone (else nonnegative, dim 1).
    soc: bool,
    /// Modules whose rows it touches (NONE if unused).
    nodes: [usize; 2],
    /// Number of those modules.
    nnode: usize,
    /// Level row it touches.
    level: Option<usize>,
    /// Position of `nodes[a]` in its level's node list.
    level_pos: [usize; 2],
    /// Offset of its local dense A (rows: 6 per node, then the level row; column-major).
    a_off: usize,
    /// Offset of its constant module-row matrix P (6·nnode square, row-major) of a cone:
    /// A J Aᵀ, or F Fᵀ for a strength cone head (its module columns F). None for a
    /// nonnegative unknown (rank one: a aᵀ from its column).
    p_off: usize,
    /// Slots of the diagonal blocks of its nodes and of the off-diagonal block.
    diag: [Option<Slot>; 2],
    off: Option<Slot>,
}

impl Block {
    fn rows(&self) -> usize {
        B * self.nnode + usize::from(self.level.is_some())
    }
}

/// A second-order cone's unknowns (the per-unknown passes read only these).
#[derive(Clone, Copy)]
struct SocCone {
    start: usize,
    dim: usize,
    block: usize,
}

/// Calls `$body` with `$d` bound to `$dim`, a compile-time constant for the dimensions the
/// gate's programs use (3: contact friction cones, 7: connection strength cones), so that the
/// per-cone loops unroll; any other dimension takes the general path.
macro_rules! with_dim {
    ($dim:expr, |$d:ident| $body:expr) => {
        match $dim {
            3 => {
                let $d: usize = 3;
                $body
            }
            7 => {
                let $d: usize = 7;
                $body
            }
            other => {
                let $d: usize = other;
                $body
            }
        }
    };
}

/// A level row `w_max − head − t = 0`: its slack t, its head cone (the connection's strength
/// cone with the level coefficient on its first entry, or a nonnegative head), the modules of
/// its connection and its slots.
struct Level {
    t: usize,
    head: usize,
    nodes: [usize; 2],
    nnode: usize,
    diag: [Option<Slot>; 2],
    off: Option<Slot>,
}

/// The solver: structure (built once per program) and work buffers.
struct Ipm<'a> {
    p: &'a Program,
    nx: usize,
    neq: usize,
    nlev: usize,
    blocks: Vec<Block>,
    /// Ranges of nonnegative unknowns (w_A^max included) and the second-order-cone blocks:
    /// the per-unknown passes run over these (contiguous, vectorisable) instead of all blocks.
    nn_ranges: Vec<std::ops::Range<usize>>,
    soc_blocks: Vec<SocCone>,
    local_a: Vec<f64>,
    pre: Vec<f64>,
    levels: Vec<Level>,
    /// w_A^max: its unknown and its coefficients on the level rows.
    wmax: Option<(usize, Vec<f64>)>,
    chol: BlockCholesky,
    /// Equality right-hand side b (= −q of Clarabel's dual) and cost c.
    b: Vec<f64>,
    c: Vec<f64>,
    /// Scaling: nonnegative W = √(s/x) per unknown; second-order cone: w̄ per unknown and
    /// η per block.
    w: Vec<f64>,
    eta: Vec<f64>,
    lambda: Vec<f64>,
    /// Level pivots g and couplings h (12 per level), for the current matrix.
    g: Vec<f64>,
    h: Vec<f64>,
    /// Product form of w_A^max's rank-one term: M = R (I + d p pᵀ) Rᵀ with M0 = R Rᵀ (level
    /// pivots, then the block factor) and p = R⁻¹ a; ‖p‖² and d = W⁻² of w_A^max.
    pf_p: Vec<f64>,
    pf_pp: f64,
    d_wmax: f64,
    /// Static regularisation of the block factorisation (raised when a direction cannot be
    /// refined).
    reg: f64,
    /// Work done so far (iterations filled in at the end).
    work: IpmInfo,
    /// Scratch.
    tmp_e: Vec<f64>,
    tmp_v: Vec<f64>,
    tmp_rhs: Vec<f64>,
    tmp_res: Vec<f64>,
    tmp_corr: Vec<f64>,
}

/// Solve the dual-form program `p` ([`crate::dual::build_relaxed`]) to the gap and
/// feasibility tolerance `tol`. Returns the optimal unknowns x (Clarabel's `z`).
pub fn solve(p: &Program, tol: f64, max_iter: u32) -> Result<(Vec<f64>, IpmInfo), Declined> {
    if !p.dual {
        return Err(Declined::Structure("not the dual form"));
    }
    let mut ipm = Ipm::new(p)?;
    ipm.run(tol, max_iter)
}

impl<'a> Ipm<'a> {
    fn new(p: &'a Program) -> Result<Self, Declined> {
        let nx = p.a.m;
        let meq = p.a.n;
        let nlev = p.conns.len();
        if meq < nlev || !(meq - nlev).is_multiple_of(B) {
            return Err(Declined::Structure("row layout"));
        }
        let neq = meq - nlev;
        let nnode = neq / B;
        // Rows of A per unknown (A is given transposed: column j of p.a = row j of A).
        let mut cnt = vec![0usize; nx + 1];
        for (k, &v) in p.a.rowval.iter().enumerate() {
            if p.a.nzval[k] != 0.0 {
                cnt[v + 1] += 1;
            }
        }
        for v in 0..nx {
            cnt[v + 1] += cnt[v];
        }
        let mut fill = cnt.clone();
        let mut rows = vec![(0u32, 0.0f64); cnt[nx]];
        for j in 0..meq {
            for k in p.a.colptr[j]..p.a.colptr[j + 1] {
                let val = p.a.nzval[k];
                if val != 0.0 {
                    let v = p.a.rowval[k];
                    rows[fill[v]] = (j as u32, val);
                    fill[v] += 1;
                }
            }
        }
        // Cone blocks.
        let mut blocks = Vec::new();
        let mut nn_ranges = Vec::new();
        let mut start = 0;
        let mut wmax = None;
        for cone in &p.cones {
            if let SupportedConeT::NonnegativeConeT(n) = cone {
                nn_ranges.push(start..start + n);
            }
            let (dims, soc): (Vec<usize>, bool) = match cone {
                SupportedConeT::NonnegativeConeT(n) => (vec![1; *n], false),
                SupportedConeT::SecondOrderConeT(d) => (vec![*d], true),
                _ => return Err(Declined::Structure("cone type")),
            };
            for dim in dims {
                let mut nodes = [NONE; 2];
                let mut nn = 0;
                let mut level = None;
                let mut nlevels = 0;
                for v in start..start + dim {
                    for &(r, _) in &rows[cnt[v]..cnt[v + 1]] {
                        let r = r as usize;
                        if r >= neq {
                            if level != Some(r - neq) {
                                nlevels += 1;
                            }
                            level = Some(r - neq);
                        } else {
                            let node = r / B;
                            if !nodes[..nn].contains(&node) {
                                if nn == 2 {
                                    return Err(Declined::Structure("a cone on three modules"));
                                }
                                nodes[nn] = node;
                                nn += 1;
                            }
                        }
                    }
                }
                let on_every_level = nlevels == nlev
                    && nn == 0
                    && rows[cnt[start]..cnt[start + dim]].iter().all(|e| e.1 > 0.0);
                if nlevels > 1 || (on_every_level && !soc && wmax.is_none()) {
                    // w_A^max: one nonnegative unknown on every level row (coefficient +1).
                    if soc || nn > 0 || wmax.is_some() {
                        return Err(Declined::Structure("a cone on several level rows"));
                    }
                    let mut coef = vec![0.0; nlev];
                    for &(r, val) in &rows[cnt[start]..cnt[start + 1]] {
                        coef[r as usize - neq] += val;
                    }
                    wmax = Some((start, coef));
                    start += dim;
                    continue;
                }
                blocks.push(Block {
                    start,
                    dim,
                    soc,
                    nodes,
                    nnode: nn,
                    level,
                    level_pos: [0; 2],
                    a_off: 0,
                    p_off: 0,
                    diag: [None; 2],
                    off: None,
                });
                start += dim;
            }
        }
        if start != nx {
            return Err(Declined::Structure("cones do not cover the unknowns"));
        }
        // Levels: the modules of their blocks.
        let mut levels: Vec<Level> = (0..nlev)
            .map(|_| Level {
                t: NONE,
                head: NONE,
                nodes: [NONE; 2],
                nnode: 0,
                diag: [None; 2],
                off: None,
            })
            .collect();
        for blk in &blocks {
            if let Some(l) = blk.level {
                let lev = &mut levels[l];
                for &node in &blk.nodes[..blk.nnode] {
                    if !lev.nodes[..lev.nnode].contains(&node) {
                        if lev.nnode == 2 {
                            return Err(Declined::Structure("a level row on three modules"));
                        }
                        lev.nodes[lev.nnode] = node;
                        lev.nnode += 1;
                    }
                }
            }
        }
        let mut edges = Vec::new();
        for blk in &blocks {
            if blk.nnode == 2 {
                edges.push((blk.nodes[0], blk.nodes[1]));
            }
        }
        for lev in &levels {
            if lev.nnode == 2 {
                edges.push((lev.nodes[0], lev.nodes[1]));
            }
        }
        let chol = BlockCholesky::new(nnode, &edges);
        // Local dense A of every block, its level positions and slots.
        let mut local_a = Vec::with_capacity(blocks.iter().map(|b| b.rows() * b.dim).sum());
        for blk in &mut blocks {
            blk.a_off = local_a.len();
            let nr = blk.rows();
            local_a.resize(local_a.len() + nr * blk.dim, 0.0);
            for c in 0..blk.dim {
                let v = blk.start + c;
                for &(r, val) in &rows[cnt[v]..cnt[v + 1]] {
                    let r = r as usize;
                    let lr = if r >= neq {
                        B * blk.nnode
                    } else {
                        let a = blk.nodes[..blk.nnode].iter().position(|&n| n == r / B);
                        B * a.unwrap_or(0) + r % B
                    };
                    local_a[blk.a_off + c * nr + lr] += val;
                }
            }
            for a in 0..blk.nnode {
                blk.diag[a] = chol.slot(blk.nodes[a], blk.nodes[a]);
            }
            if blk.nnode == 2 {
                blk.off = chol.slot(blk.nodes[0], blk.nodes[1]);
            }
            if let Some(l) = blk.level {
                let lev = &levels[l];
                for a in 0..blk.nnode {
                    blk.level_pos[a] = lev.nodes[..lev.nnode]
                        .iter()
                        .position(|&n| n == blk.nodes[a])
                        .unwrap_or(0);
                }
            }
        }
        for lev in &mut levels {
            for a in 0..lev.nnode {
                lev.diag[a] = chol.slot(lev.nodes[a], lev.nodes[a]);
            }
            if lev.nnode == 2 {
                lev.off = chol.slot(lev.nodes[0], lev.nodes[1]);
            }
        }
        // Each level row: exactly one slack t (nonnegative, on no module) and one head.
        for (bi, blk) in blocks.iter().enumerate() {
            let Some(l) = blk.level else { continue };
            let lev = &mut levels[l];
            let nr = blk.rows();
            let la = &local_a[blk.a_off..blk.a_off + nr * blk.dim];
            if !blk.soc && blk.nnode == 0 && lev.t == NONE {
                lev.t = bi;
            } else if lev.head == NONE {
                if blk.soc {
                    // Level coefficient on the first entry only, which is on no module row.
                    let lr = nr - 1;
                    let level_only_head = (0..nr - 1).all(|r| la[r] == 0.0)
                        && (1..blk.dim).all(|c| la[c * nr + lr] == 0.0)
                        && la[lr] != 0.0;
                    if !level_only_head {
                        return Err(Declined::Structure("a strength cone's level row"));
                    }
                }
                lev.head = bi;
            } else {
                return Err(Declined::Structure("a level row with several heads"));
            }
        }
        if levels.iter().any(|l| l.t == NONE || l.head == NONE) {
            return Err(Declined::Structure("a level row without its slack or head"));
        }
        // Constant parts of every block's contribution (module rows only).
        let mut pre = Vec::with_capacity(
            blocks
                .iter()
                .filter(|b| b.soc)
                .map(|b| (B * b.nnode).pow(2))
                .sum(),
        );
        for blk in &mut blocks {
            let nm = B * blk.nnode;
            blk.p_off = pre.len();
            if nm == 0 || !blk.soc {
                continue; // a nonnegative unknown's a aᵀ is rank one: built from a directly
            }
            let nr = blk.rows();
            let la = &local_a[blk.a_off..blk.a_off + nr * blk.dim];
            // Column signs: F Fᵀ for a strength cone head (its column 0 is on the level row
            // only), A J Aᵀ for any other cone.
            let head = blk.level.is_some();
            let mut sign = [if head { 1.0 } else { -1.0 }; 8];
            sign[0] = if head { 0.0 } else { 1.0 };
            let base = pre.len();
            pre.resize(base + nm * nm, 0.0);
            let pm = &mut pre[base..];
            for c in 0..blk.dim {
                if sign[c] == 0.0 {
                    continue;
                }
                let col = &la[c * nr..c * nr + nm];
                for r in 0..nm {
                    let f = sign[c] * col[r];
                    if f != 0.0 {
                        for q in 0..nm {
                            pm[r * nm + q] += f * col[q];
                        }
                    }
                }
            }
        }
        let nblk = blocks.len();
        let soc_blocks = (0..nblk)
            .filter(|&b| blocks[b].soc)
            .map(|b| SocCone {
                start: blocks[b].start,
                dim: blocks[b].dim,
                block: b,
            })
            .collect();
        Ok(Ipm {
            p,
            nx,
            neq,
            nlev,
            blocks,
            nn_ranges,
            soc_blocks,
            local_a,
            pre,
            levels,
            wmax,
            chol,
            b: p.q.iter().map(|v| -v).collect(),
            c: p.b.clone(),
            w: vec![1.0; nx],
            eta: vec![1.0; nblk],
            lambda: vec![0.0; nx],
            g: vec![0.0; nlev],
            h: vec![0.0; nlev * 2 * B],
            pf_p: vec![0.0; neq + nlev],
            pf_pp: 0.0,
            d_wmax: 0.0,
            reg: STATIC_REG,
            work: IpmInfo::default(),
            tmp_e: vec![0.0; neq],
            tmp_v: vec![0.0; neq + nlev],
            tmp_rhs: vec![0.0; neq + nlev],
            tmp_res: vec![0.0; neq + nlev],
            tmp_corr: vec![0.0; neq + nlev],
        })
    }

    /// out = A x (length neq + nlev).
    fn a_mul(&self, x: &[f64], out: &mut [f64]) {
        let a = &self.p.a;
        for j in 0..a.n {
            let mut s = 0.0;
            for k in a.colptr[j]..a.colptr[j + 1] {
                s += a.nzval[k] * x[a.rowval[k]];
            }
            out[j] = s;
        }
    }

    /// out = Aᵀ y (length nx).
    fn at_mul(&self, y: &[f64], out: &mut [f64]) {
        let a = &self.p.a;
        out.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..a.n {
            let yj = y[j];
            if yj != 0.0 {
                for k in a.colptr[j]..a.colptr[j + 1] {
                    out[a.rowval[k]] += a.nzval[k] * yj;
                }
            }
        }
    }

    /// Nesterov–Todd scaling of (x, s) in every cone and λ = W x.
    fn scale(&mut self, x: &[f64], s: &[f64]) {
        for r in &self.nn_ranges {
            for v in r.clone() {
                self.w[v] = (s[v] / x[v]).sqrt();
                self.lambda[v] = (s[v] * x[v]).sqrt();
            }
        }
        for &SocCone { start, dim, block } in &self.soc_blocks {
            with_dim!(dim, |dim| {
                let r = start..start + dim;
                let (xs, ss) = (&x[r.clone()], &s[r.clone()]);
                let dx = soc_det(xs).sqrt();
                let ds = soc_det(ss).sqrt();
                let mut dot = 0.0;
                for k in 0..dim {
                    dot += xs[k] * ss[k];
                }
                let gamma = ((1.0 + dot / (dx * ds)) * 0.5).sqrt();
                let wb = &mut self.w[r.clone()];
                wb[0] = (ss[0] / ds + xs[0] / dx) / (2.0 * gamma);
                for k in 1..dim {
                    wb[k] = (ss[k] / ds - xs[k] / dx) / (2.0 * gamma);
                }
                let eta = (ds / dx).sqrt();
                self.eta[block] = eta;
                w_bar_mul(wb, xs, &mut self.lambda[r], false);
                for l in &mut self.lambda[start..start + dim] {
                    *l *= eta;
                }
            })
        }
    }

    /// out = W v (inverse: W⁻¹ v), cone by cone.
    fn w_mul(&self, v: &[f64], out: &mut [f64], inverse: bool) {
        for r in &self.nn_ranges {
            let (w, vi, o) = (&self.w[r.clone()], &v[r.clone()], &mut out[r.clone()]);
            if inverse {
                for k in 0..o.len() {
                    o[k] = vi[k] / w[k];
                }
            } else {
                for k in 0..o.len() {
                    o[k] = vi[k] * w[k];
                }
            }
        }
        for &SocCone { start, dim, block } in &self.soc_blocks {
            with_dim!(dim, |dim| {
                let r = start..start + dim;
                w_bar_mul(
                    &self.w[r.clone()],
                    &v[r.clone()],
                    &mut out[r.clone()],
                    inverse,
                );
                let f = if inverse {
                    1.0 / self.eta[block]
                } else {
                    self.eta[block]
                };
                out[r].iter_mut().for_each(|o| *o *= f);
            })
        }
    }

    /// Assemble the normal matrix A W⁻² Aᵀ (level rows eliminated), factorise it, and
    /// prepare w_A^max's product-form vector p = R⁻¹ a.
    fn factor(&mut self) -> Result<(), Declined> {
        self.work.factorisations += 1;
        self.chol.clear();
        self.g.iter_mut().for_each(|v| *v = 0.0);
        self.h.iter_mut().for_each(|v| *v = 0.0);
        for (bi, blk) in self.blocks.iter().enumerate() {
            let nr = blk.rows();
            let nm = B * blk.nnode;
            if nm == 0 || blk.level.is_some() {
                continue;
            }
            let la = &self.local_a[blk.a_off..blk.a_off + nr * blk.dim];
            // G = A_loc W⁻² A_locᵀ: for a cone W⁻² = (2 u uᵀ − J)/η², u = J w̄, so
            // G = (2 (A u)(A u)ᵀ − A J Aᵀ)/η²; for a nonnegative unknown G = a aᵀ/w².
            let mut q = [0.0; MAX_ROWS];
            if blk.soc {
                let pm = &self.pre[blk.p_off..blk.p_off + nm * nm];
                let wb = &self.w[blk.start..blk.start + blk.dim];
                for c in 0..blk.dim {
                    let u = if c == 0 { wb[0] } else { -wb[c] };
                    for r in 0..nm {
                        q[r] += la[c * nr + r] * u;
                    }
                }
                let inv_e2 = 1.0 / (self.eta[bi] * self.eta[bi]);
                add_sym(
                    &mut self.chol,
                    blk.nnode,
                    &blk.diag,
                    blk.off,
                    Some(pm),
                    -inv_e2,
                    &q,
                    2.0 * inv_e2,
                );
            } else {
                let w = self.w[blk.start];
                q[..nm].copy_from_slice(&la[..nm]);
                add_sym(
                    &mut self.chol,
                    blk.nnode,
                    &blk.diag,
                    blk.off,
                    None,
                    0.0,
                    &q,
                    1.0 / (w * w),
                );
            }
        }
        // Level rows, eliminated in closed form (an explicit S −= h hᵀ/g cancels catastrophically
        // once a strength cone reaches its boundary, where W⁻² has one huge eigenvalue).
        for (l, lev) in self.levels.iter().enumerate() {
            let hb = &self.blocks[lev.head];
            let wt = self.w[self.blocks[lev.t].start];
            let d_t = 1.0 / (wt * wt);
            let nr = hb.rows();
            let nm = nr - 1; // module rows
            let la = &self.local_a[hb.a_off..hb.a_off + nr * hb.dim];
            let h = &mut self.h[l * 2 * B..(l + 1) * 2 * B];
            let g;
            if hb.soc {
                // Head column 0 (coefficient a_l on the level row only), module columns F = 1..:
                // with D = (2uuᵀ − J)/η², u = J w̄, the Schur complement of the level row is
                // F [I − κ u1 u1ᵀ] Fᵀ / η², κ = 2(1 − ε)/(2u0² − 1 + ε), ε = η² d_t / a_l².
                let wb = &self.w[hb.start..hb.start + hb.dim];
                let eta2 = self.eta[lev.head] * self.eta[lev.head];
                let al = la[nr - 1];
                let u0 = wb[0];
                let eps = eta2 * d_t / (al * al);
                let kappa = 2.0 * (1.0 - eps) / (2.0 * u0 * u0 - 1.0 + eps);
                let mut fu = [0.0; MAX_ROWS];
                for c in 1..hb.dim {
                    for r in 0..nm {
                        fu[r] -= la[c * nr + r] * wb[c]; // u1 = −w̄1
                    }
                }
                let pm = &self.pre[hb.p_off..hb.p_off + nm * nm];
                add_sym(
                    &mut self.chol,
                    lev.nnode,
                    &lev.diag,
                    lev.off,
                    Some(pm),
                    1.0 / eta2,
                    &fu,
                    -kappa / eta2,
                );
                // h = a_l F d0, d0 = 2 u0 u1 / η²; g = a_l² d00 + d_t.
                for r in 0..nm {
                    h[r] = al * 2.0 * u0 * fu[r] / eta2;
                }
                g = al * al * (2.0 * u0 * u0 - 1.0) / eta2 + d_t;
            } else {
                // Nonnegative head with column a = (a_E, a_l): S = d d_t/(d a_l² + d_t) a_E a_Eᵀ.
                let w = self.w[hb.start];
                let d = 1.0 / (w * w);
                let al = la[nr - 1];
                g = d * al * al + d_t;
                let k = d * d_t / g;
                let mut a = [0.0; MAX_ROWS];
                for r in 0..nm {
                    h[r] = d * al * la[r];
                    a[r] = la[r];
                }
                add_sym(
                    &mut self.chol,
                    lev.nnode,
                    &lev.diag,
                    lev.off,
                    None,
                    0.0,
                    &a,
                    k,
                );
            }
            if !(g > 0.0 && g.is_finite()) {
                return Err(Declined::Factor);
            }
            self.g[l] = g;
        }
        self.chol.factor(self.reg).map_err(|_| Declined::Factor)?;
        // w_A^max's column a (on the level rows) in product form (Goldfarb–Scheinberg): M =
        // M0 + d a aᵀ = R (I + d p pᵀ) Rᵀ, p = R⁻¹ a: a half-solve here. The Sherman–Morrison
        // form M0⁻¹ − … needs the full solve M0⁻¹ a instead; with the refinement and the
        // raised regularisation both reach the same iteration counts on the benchmark
        // families (measured), so the cheaper one is kept.
        self.d_wmax = 0.0;
        self.pf_pp = 0.0;
        if let Some((v, coef)) = self.wmax.take() {
            let w = self.w[v];
            self.d_wmax = 1.0 / (w * w);
            let mut r = std::mem::take(&mut self.tmp_rhs);
            r[..self.neq].iter_mut().for_each(|v| *v = 0.0);
            r[self.neq..].copy_from_slice(&coef);
            let mut p = std::mem::take(&mut self.pf_p);
            self.r_inv(&r, &mut p);
            self.pf_pp = p.iter().map(|v| v * v).sum();
            self.pf_p = p;
            self.tmp_rhs = r;
            self.wmax = Some((v, coef));
        }
        Ok(())
    }

    /// [`Self::factor`], raising the static regularisation (up to [`MAX_REG`]) while the
    /// block factorisation finds a non-positive pivot.
    fn factor_regularised(&mut self) -> Result<(), Declined> {
        loop {
            match self.factor() {
                Err(Declined::Factor) if self.reg < MAX_REG => self.reg *= 10.0,
                r => return r,
            }
        }
    }

    /// v = R⁻¹ r, M0 = R Rᵀ, R = [[G^½, 0], [H G^-½, L]] over (level rows, module rows);
    /// v's module part is in the block factor's order.
    fn r_inv(&mut self, r: &[f64], v: &mut [f64]) {
        let neq = self.neq;
        let re = &mut self.tmp_e;
        re.copy_from_slice(&r[..neq]);
        for (l, lev) in self.levels.iter().enumerate() {
            let f = r[neq + l] / self.g[l];
            let h = &self.h[l * 2 * B..(l + 1) * 2 * B];
            for a in 0..lev.nnode {
                let base = B * lev.nodes[a];
                for k in 0..B {
                    re[base + k] -= h[a * B + k] * f;
                }
            }
            v[neq + l] = r[neq + l] / self.g[l].sqrt();
        }
        self.chol.solve_lower(re);
        v[..neq].copy_from_slice(re);
    }

    /// z = R⁻ᵀ v.
    fn rt_inv(&mut self, v: &[f64], z: &mut [f64]) {
        let neq = self.neq;
        let re = &mut self.tmp_e;
        re.copy_from_slice(&v[..neq]);
        self.chol.solve_upper(re);
        z[..neq].copy_from_slice(re);
        for (l, lev) in self.levels.iter().enumerate() {
            let h = &self.h[l * 2 * B..(l + 1) * 2 * B];
            let mut hz = 0.0;
            for a in 0..lev.nnode {
                let base = B * lev.nodes[a];
                for k in 0..B {
                    hz += h[a * B + k] * re[base + k];
                }
            }
            let g = self.g[l];
            z[neq + l] = v[neq + l] / g.sqrt() - hz / g;
        }
    }

    /// z = M⁻¹ r = R⁻ᵀ (I + d p pᵀ)⁻¹ R⁻¹ r.
    fn solve_m(&mut self, r: &[f64], z: &mut [f64]) {
        self.work.solves += 1;
        let mut v = std::mem::take(&mut self.tmp_v);
        self.r_inv(r, &mut v);
        if self.d_wmax > 0.0 {
            let pv: f64 = self.pf_p.iter().zip(&v).map(|(a, b)| a * b).sum();
            let f = pv / (1.0 / self.d_wmax + self.pf_pp);
            for (vi, pi) in v.iter_mut().zip(&self.pf_p) {
                *vi -= f * pi;
            }
        }
        self.rt_inv(&v, z);
        self.tmp_v = v;
    }

    fn run(&mut self, tol: f64, max_iter: u32) -> Result<(Vec<f64>, IpmInfo), Declined> {
        let (nx, m) = (self.nx, self.neq + self.nlev);
        let nu = (self.blocks.len() + usize::from(self.wmax.is_some())) as f64;
        // Initial point (as CVXOPT): least-norm x with Ax = b and least-squares s = c − Aᵀy,
        // each shifted into the interior of K.
        let mut x = vec![0.0; nx];
        let mut s = vec![0.0; nx];
        let mut y = vec![0.0; m];
        self.identity(&mut x);
        self.identity(&mut s);
        self.scale(&x, &s);
        self.factor_regularised()?;
        let mut tm = vec![0.0; m];
        let mut tx = vec![0.0; nx];
        let b = self.b.clone();
        self.solve_m(&b, &mut tm);
        self.at_mul(&tm, &mut x);
        let c = self.c.clone();
        self.a_mul(&c, &mut tm);
        self.solve_m(&tm.clone(), &mut y);
        self.at_mul(&y, &mut tx);
        for i in 0..nx {
            s[i] = c[i] - tx[i];
        }
        self.shift_interior(&mut x);
        self.shift_interior(&mut s);

        let nb = 1.0 + b.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let nc = 1.0 + c.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let mut rp = vec![0.0; m];
        let mut rd = vec![0.0; nx];
        let (mut dx, mut dy, mut ds) = (vec![0.0; nx], vec![0.0; m], vec![0.0; nx]);
        let (mut dxa, mut dsa) = (vec![0.0; nx], vec![0.0; nx]);
        let mut rc = vec![0.0; nx];
        let mut t1 = vec![0.0; nx];
        let mut t2 = vec![0.0; nx];
        let mut pres_hist = [f64::INFINITY; STALL_WINDOW];
        for iter in 0..=max_iter {
            // Residuals rp = b − Ax, rd = c − Aᵀy − s.
            self.a_mul(&x, &mut rp);
            for j in 0..m {
                rp[j] = b[j] - rp[j];
            }
            self.at_mul(&y, &mut rd);
            for i in 0..nx {
                rd[i] = c[i] - rd[i] - s[i];
            }
            let gap: f64 = x.iter().zip(&s).map(|(a, b)| a * b).sum();
            let pcost: f64 = c.iter().zip(&x).map(|(a, b)| a * b).sum();
            let dcost: f64 = b.iter().zip(&y).map(|(a, b)| a * b).sum();
            let pres = rp.iter().fold(0.0f64, |a, v| a.max(v.abs())) / nb;
            let dres = rd.iter().fold(0.0f64, |a, v| a.max(v.abs())) / nc;
            let scale = pcost.abs().min(dcost.abs()).max(1.0);
            let gap_ok = gap <= tol * scale && (pcost - dcost).abs() <= tol * scale;
            if pres <= tol && dres <= tol && gap_ok {
                return Ok((
                    x,
                    IpmInfo {
                        iterations: iter,
                        ..self.work
                    },
                ));
            }
            if iter == max_iter || !(gap.is_finite() && pcost.is_finite()) {
                break;
            }
            // No certificate of infeasibility here (Clarabel gives it): stop once the primal
            // residual stalls, as it does when Zx = b has no solution in the cones.
            let k = iter as usize % STALL_WINDOW;
            let diverging = dcost > pcost.abs() + DIVERGED * scale;
            if (iter as usize >= STALL_WINDOW && pres > 0.5 * pres_hist[k] && pres > tol)
                || (iter >= 5 && diverging)
            {
                return Err(Declined::NotConverged { iterations: iter });
            }
            pres_hist[k] = pres;
            self.scale(&x, &s);
            let mu = gap / nu;
            // Far from the optimum an inexact direction does as well (measured: the same
            // iteration counts, ~10 % less time); refinement starts near it.
            let refine_to = if gap > REFINE_FROM_GAP * scale {
                f64::INFINITY
            } else {
                REFINE_TARGET
            };
            // A direction the refinement cannot make accurate is retried with a stronger
            // static regularisation (kept for the following iterations).
            loop {
                self.factor_regularised()?;
                // Predictor: rc = −λ.
                for i in 0..nx {
                    rc[i] = -self.lambda[i];
                }
                // The predictor only sets the step and the centring: not refined (measured: the
                // same iteration counts, 15–20 % less time).
                self.newton(
                    &rp,
                    &rd,
                    &rc,
                    &mut dxa,
                    &mut dy,
                    &mut dsa,
                    &mut t1,
                    &mut t2,
                    f64::INFINITY,
                );
                let alpha_a = self
                    .max_step(&x, &dxa)
                    .min(self.max_step(&s, &dsa))
                    .min(1.0);
                // Centring (1 − α_aff)³, as Clarabel (Mehrotra's (μ_aff/μ)³ measured no better).
                let sigma = (1.0 - alpha_a).powi(3);
                // Corrector: rc = λ \ (σμe − λ∘λ − (W⁻¹Δs_a)∘(WΔx_a)).
                self.w_mul(&dsa, &mut t1, true);
                self.w_mul(&dxa, &mut t2, false);
                self.combined_rc(sigma * mu, &t1, &t2, &mut rc);
                let e2 = self.newton(
                    &rp, &rd, &rc, &mut dx, &mut dy, &mut ds, &mut t1, &mut t2, refine_to,
                );
                if e2 <= REFINE_OK || self.reg >= MAX_REG || refine_to.is_infinite() {
                    break;
                }
                self.reg *= 10.0;
            }
            let alpha =
                (STEP_FRACTION * self.max_step(&x, &dx).min(self.max_step(&s, &ds))).min(1.0);
            if alpha.is_nan() || alpha <= 1e-10 {
                return Err(Declined::NotConverged { iterations: iter });
            }
            for i in 0..nx {
                x[i] += alpha * dx[i];
                s[i] += alpha * ds[i];
            }
            for j in 0..m {
                y[j] += alpha * dy[j];
            }
        }
        Err(Declined::NotConverged {
            iterations: max_iter,
        })
    }

    /// Newton direction for the residuals (rp, rd) and scaled complementarity rc:
    /// A Δx = rp, AᵀΔy + Δs = rd, WΔx + W⁻¹Δs = rc.
    #[allow(clippy::too_many_arguments)]
    fn newton(
        &mut self,
        rp: &[f64],
        rd: &[f64],
        rc: &[f64],
        dx: &mut [f64],
        dy: &mut [f64],
        ds: &mut [f64],
        t1: &mut [f64],
        t2: &mut [f64],
        target: f64,
    ) -> f64 {
        let nx = self.nx;
        // rhs = rp + A (W⁻² rd − W⁻¹ rc)
        self.w_mul(rd, t1, true);
        for i in 0..nx {
            t1[i] -= rc[i];
        }
        self.w_mul(t1, t2, true);
        let mut rhs = std::mem::take(&mut self.tmp_rhs);
        self.a_mul(t2, &mut rhs);
        for j in 0..rhs.len() {
            rhs[j] += rp[j];
        }
        self.solve_m(&rhs, dy);
        let e = self.refine(&rhs, dy, target);
        self.tmp_rhs = rhs;
        // Δs = rd − AᵀΔy; Δx = W⁻¹(rc − W⁻¹Δs).
        self.at_mul(dy, ds);
        for i in 0..nx {
            ds[i] = rd[i] - ds[i];
        }
        self.w_mul(ds, t1, true);
        for i in 0..nx {
            t1[i] = rc[i] - t1[i];
        }
        self.w_mul(t1, dx, true);
        e
    }

    /// out = M v = A W⁻² Aᵀ v, matrix-free, cone block by cone block (local dense A).
    fn m_mul(&self, v: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        let neq = self.neq;
        for (bi, blk) in self.blocks.iter().enumerate() {
            // Constant shapes for the gate's blocks (strength cone on two modules and a level
            // row; contact cone, nonnegative unknowns on one or two modules or a level row).
            match (blk.rows(), blk.dim) {
                (0, _) => {}
                (13, 7) => self.m_mul_block(bi, blk, 13, 7, v, out),
                (6, 3) => self.m_mul_block(bi, blk, 6, 3, v, out),
                (12, 1) => self.m_mul_block(bi, blk, 12, 1, v, out),
                (6, 1) => self.m_mul_block(bi, blk, 6, 1, v, out),
                (1, 1) => self.m_mul_block(bi, blk, 1, 1, v, out),
                (nr, dim) => self.m_mul_block(bi, blk, nr, dim, v, out),
            }
        }
        if let Some((i, coef)) = &self.wmax {
            let w = self.w[*i];
            let av: f64 = coef.iter().zip(&v[neq..]).map(|(a, b)| a * b).sum();
            let f = av / (w * w);
            for (o, a) in out[neq..].iter_mut().zip(coef) {
                *o += f * a;
            }
        }
    }

    /// out += A_blk W_blk⁻² A_blkᵀ v for one block of `nr` local rows and dimension `dim`
    /// (inlined with constant shapes by [`Self::m_mul`]).
    #[inline(always)]
    fn m_mul_block(
        &self,
        bi: usize,
        blk: &Block,
        nr: usize,
        dim: usize,
        v: &[f64],
        out: &mut [f64],
    ) {
        let neq = self.neq;
        let nnode = nr / B; // 6 rows per module, then at most one level row
        let la = &self.local_a[blk.a_off..blk.a_off + nr * dim];
        let mut vl = [0.0; MAX_ROWS];
        for a in 0..nnode {
            let base = B * blk.nodes[a];
            vl[a * B..a * B + B].copy_from_slice(&v[base..base + B]);
        }
        if let Some(l) = blk.level {
            vl[nr - 1] = v[neq + l];
        }
        // t = A_locᵀ v, u = W⁻² t, out += A_loc u.
        let mut t = [0.0; 8];
        for c in 0..dim {
            let col = &la[c * nr..(c + 1) * nr];
            t[c] = col.iter().zip(&vl[..nr]).map(|(a, b)| a * b).sum();
        }
        let mut u = [0.0; 8];
        if blk.soc {
            // W⁻² = (2 (Jw̄)(Jw̄)ᵀ − J)/η².
            let wb = &self.w[blk.start..blk.start + dim];
            let inv_e2 = 1.0 / (self.eta[bi] * self.eta[bi]);
            let mut ut = wb[0] * t[0];
            for k in 1..dim {
                ut -= wb[k] * t[k];
            }
            u[0] = (2.0 * wb[0] * ut - t[0]) * inv_e2;
            for k in 1..dim {
                u[k] = (t[k] - 2.0 * wb[k] * ut) * inv_e2;
            }
        } else {
            let w = self.w[blk.start];
            u[0] = t[0] / (w * w);
        }
        let mut ol = [0.0; MAX_ROWS];
        for c in 0..dim {
            let col = &la[c * nr..(c + 1) * nr];
            for r in 0..nr {
                ol[r] += col[r] * u[c];
            }
        }
        for a in 0..nnode {
            let base = B * blk.nodes[a];
            for k in 0..B {
                out[base + k] += ol[a * B + k];
            }
        }
        if let Some(l) = blk.level {
            out[neq + l] += ol[nr - 1];
        }
    }

    /// Iterative refinement of M dy = rhs against the exact (unfactorised) M.
    /// Returns the final residual relative to ‖rhs‖.
    fn refine(&mut self, rhs: &[f64], dy: &mut [f64], target: f64) -> f64 {
        if target.is_infinite() {
            return 0.0;
        }
        let m = rhs.len();
        let norm = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let scale = norm(rhs).max(1e-300);
        let mut res = std::mem::take(&mut self.tmp_res);
        let mut corr = std::mem::take(&mut self.tmp_corr);
        let mut last = f64::INFINITY;
        let mut out = f64::INFINITY;
        for step in 0..=REFINE_STEPS {
            self.work.products += 1;
            self.m_mul(dy, &mut res);
            for j in 0..m {
                res[j] = rhs[j] - res[j];
            }
            let e = norm(&res) / scale;
            if e <= target || e >= 0.5 * last || step == REFINE_STEPS {
                out = e.min(last);
                break;
            }
            last = e;
            self.solve_m(&res, &mut corr);
            for j in 0..m {
                dy[j] += corr[j];
            }
        }
        self.tmp_res = res;
        self.tmp_corr = corr;
        out
    }

    /// rc = λ \ (σμ e − λ∘λ − a∘b), cone by cone.
    fn combined_rc(&self, sm: f64, a: &[f64], b: &[f64], rc: &mut [f64]) {
        let lam = &self.lambda;
        for r in &self.nn_ranges {
            for i in r.clone() {
                rc[i] = (sm - lam[i] * lam[i] - a[i] * b[i]) / lam[i];
            }
        }
        for &SocCone { start, dim, .. } in &self.soc_blocks {
            with_dim!(dim, |dim| {
                let r = start..start + dim;
                let (l, av, bv) = (&lam[r.clone()], &a[r.clone()], &b[r.clone()]);
                let mut t = [0.0; 8];
                let ll: f64 = l.iter().map(|v| v * v).sum();
                let ab: f64 = av.iter().zip(bv).map(|(p, q)| p * q).sum();
                t[0] = sm - ll - ab;
                for k in 1..dim {
                    t[k] = -(2.0 * l[0] * l[k]) - (av[0] * bv[k] + bv[0] * av[k]);
                }
                // u = λ \ t: u0 = (λ0 t0 − λ1ᵀt1)/det λ, u1 = (t1 − u0 λ1)/λ0.
                let mut l1t1 = 0.0;
                for k in 1..dim {
                    l1t1 += l[k] * t[k];
                }
                let u0 = (l[0] * t[0] - l1t1) / soc_det(l);
                rc[start] = u0;
                for k in 1..dim {
                    rc[start + k] = (t[k] - u0 * l[k]) / l[0];
                }
            })
        }
    }

    /// Largest α with v + α d in K (infinite when d never leaves).
    fn max_step(&self, v: &[f64], d: &[f64]) -> f64 {
        let mut alpha = f64::INFINITY;
        for r in &self.nn_ranges {
            for i in r.clone() {
                if d[i] < 0.0 {
                    alpha = alpha.min(-v[i] / d[i]);
                }
            }
        }
        for &SocCone { start, dim, .. } in &self.soc_blocks {
            with_dim!(dim, |dim| {
                let r = start..start + dim;
                alpha = alpha.min(soc_step(&v[r.clone()], &d[r]));
            })
        }
        alpha
    }

    /// The identity element e of K.
    fn identity(&self, v: &mut [f64]) {
        v.iter_mut().for_each(|x| *x = 0.0);
        for blk in &self.blocks {
            v[blk.start] = 1.0;
        }
        if let Some((i, _)) = &self.wmax {
            v[*i] = 1.0;
        }
    }

    /// v + (1 + t) e with t the largest violation, when v is not strictly inside K.
    fn shift_interior(&self, v: &mut [f64]) {
        let mut worst = f64::NEG_INFINITY;
        if let Some((i, _)) = &self.wmax {
            worst = worst.max(-v[*i]);
        }
        for blk in &self.blocks {
            let r = blk.start..blk.start + blk.dim;
            let viol = if blk.soc {
                let n1: f64 = v[blk.start + 1..r.end].iter().map(|x| x * x).sum();
                n1.sqrt() - v[blk.start]
            } else {
                -v[blk.start]
            };
            worst = worst.max(viol);
        }
        if worst >= -1e-8 {
            let t = 1.0 + worst.max(0.0);
            for blk in &self.blocks {
                v[blk.start] += t;
            }
            if let Some((i, _)) = &self.wmax {
                v[*i] += t;
            }
        }
    }
}

/// Add c1·P + c2·q qᵀ (module rows: 6 per node, P row-major, 6·nnode square; no P: c2·q qᵀ
/// only) to the block matrix, block by block.
#[allow(clippy::too_many_arguments)]
fn add_sym(
    chol: &mut BlockCholesky,
    nnode: usize,
    diag: &[Option<Slot>; 2],
    off: Option<Slot>,
    pm: Option<&[f64]>,
    c1: f64,
    q: &[f64; MAX_ROWS],
    c2: f64,
) {
    let nm = B * nnode;
    // Block (a, b) is c2 q_a q_bᵀ + c1 P_ab; stored column-major in L's orientation, i.e. as
    // (x, y) = (a, b) or, for a transposed slot, (b, a): column c gets c2 q_y[c] q_x +
    // c1 P[y c, x ·] (P is symmetric, so that column of P_xy is contiguous). The products are
    // rounded as (c2 q_a[r]) q_b[c] either way (the iteration counts are sensitive to it).
    let put = |chol: &mut BlockCholesky, slot: Slot, a: usize, b: usize| {
        let (v, transposed) = chol.block_mut(slot);
        let (x, y) = if transposed { (b, a) } else { (a, b) };
        let qx: &[f64; B] = q[x * B..x * B + B].try_into().unwrap();
        let qy: &[f64; B] = q[y * B..y * B + B].try_into().unwrap();
        let mut blk = [0.0; 36];
        if transposed {
            for c in 0..B {
                let f = c2 * qy[c];
                for r in 0..B {
                    blk[c * B + r] = f * qx[r];
                }
            }
        } else {
            let cqx = qx.map(|e| c2 * e);
            for c in 0..B {
                for r in 0..B {
                    blk[c * B + r] = cqx[r] * qy[c];
                }
            }
        }
        if let Some(pm) = pm {
            for c in 0..B {
                let o = (y * B + c) * nm + x * B;
                let pc: &[f64; B] = pm[o..o + B].try_into().unwrap();
                for r in 0..B {
                    blk[c * B + r] += c1 * pc[r];
                }
            }
        }
        for (vi, bi) in v.iter_mut().zip(&blk) {
            *vi += bi;
        }
    };
    for a in 0..nnode {
        if let Some(slot) = diag[a] {
            put(chol, slot, a, a);
        }
    }
    if let (2, Some(slot)) = (nnode, off) {
        put(chol, slot, 0, 1);
    }
}

/// x0² − ‖x1‖² of a second-order-cone vector.
#[inline(always)]
fn soc_det(x: &[f64]) -> f64 {
    let n1: f64 = x[1..].iter().map(|v| v * v).sum();
    (x[0] - n1.sqrt()) * (x[0] + n1.sqrt())
}

/// out = W̄ v (or W̄⁻¹ v = J W̄ J v) for the normalised scaling point w̄ (det w̄ = 1):
/// W̄ = [[w̄0, w̄1ᵀ], [w̄1, I + w̄1 w̄1ᵀ/(1 + w̄0)]].
#[inline(always)]
fn w_bar_mul(wb: &[f64], v: &[f64], out: &mut [f64], inverse: bool) {
    let sgn = if inverse { -1.0 } else { 1.0 };
    let mut w1v1 = 0.0;
    for k in 1..wb.len() {
        w1v1 += wb[k] * v[k];
    }
    out[0] = wb[0] * v[0] + sgn * w1v1;
    let f = sgn * v[0] + w1v1 / (1.0 + wb[0]);
    for k in 1..wb.len() {
        out[k] = v[k] + f * wb[k];
    }
}

/// Largest α ≥ 0 with x + α d in the second-order cone (x strictly inside).
#[inline(always)]
fn soc_step(x: &[f64], d: &[f64]) -> f64 {
    let a = soc_det(d);
    let mut xd1 = 0.0;
    for k in 1..x.len() {
        xd1 += x[k] * d[k];
    }
    let b = 2.0 * (x[0] * d[0] - xd1);
    let c = soc_det(x).max(0.0);
    let disc = b * b - 4.0 * a * c;
    if (a > 0.0 && b > 0.0) || disc < 0.0 {
        return if d[0] >= 0.0 || a > 0.0 {
            f64::INFINITY
        } else {
            -x[0] / d[0]
        };
    }
    if a == 0.0 {
        return if b < 0.0 { -c / b } else { f64::INFINITY };
    }
    // Roots of a α² + b α + c (numerically stable form).
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let r1 = q / a;
    let r2 = c / q;
    let mut alpha = f64::INFINITY;
    for r in [r1, r2] {
        if r > 0.0 && r.is_finite() {
            alpha = alpha.min(r);
        }
    }
    alpha
}

#[cfg(test)]
mod tests;
