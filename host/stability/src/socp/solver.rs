//! Solution of the program with Clarabel: settings, the fast first attempt and its fallback,
//! and how a solver status becomes an outcome.

use super::Program;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus};

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
