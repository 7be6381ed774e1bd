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

mod cone;
mod iteration;
mod normal;
mod structure;

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

#[cfg(test)]
mod tests;
