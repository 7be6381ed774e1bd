//! One robot's controller: Clarabel QP (reused across ticks), real-time iteration,
//! output check and fallback.

use crate::problem::{Builder, DenseQp, ProblemInstance};
use crate::types::*;
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus, SupportedConeT,
    ZeroConeT,
};

/// Tolerance of the output check against box and butterfly (m/s, rad/s).
pub const OUTPUT_TOLERANCE: f64 = 1e-6;

/// A Clarabel solver kept for one problem shape.
struct CachedSolver {
    solver: DefaultSolver<f64>,
    a_colptr: Vec<usize>,
    a_rowval: Vec<usize>,
    p_colptr: Vec<usize>,
    p_rowval: Vec<usize>,
    n: usize,
    n_eq: usize,
}

/// CSC of the upper triangle of the symmetric P following its structural mask.
fn p_upper(qp: &DenseQp) -> CscMatrix<f64> {
    let n = qp.n;
    let mut colptr = Vec::with_capacity(n + 1);
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    colptr.push(0);
    for c in 0..n {
        for r in 0..=c {
            if qp.p_mask[r * n + c] {
                rowval.push(r);
                nzval.push(qp.p[r * n + c]);
            }
        }
        colptr.push(rowval.len());
    }
    CscMatrix::new(n, n, colptr, rowval, nzval)
}

/// CSC of A following its structural mask.
fn a_csc(qp: &DenseQp) -> CscMatrix<f64> {
    let (m, n) = (qp.m, qp.n);
    let mut colptr = Vec::with_capacity(n + 1);
    let mut rowval = Vec::new();
    let mut nzval = Vec::new();
    colptr.push(0);
    for c in 0..n {
        for r in 0..m {
            if qp.mask[r * n + c] {
                rowval.push(r);
                nzval.push(qp.a[r * n + c]);
            }
        }
        colptr.push(rowval.len());
    }
    CscMatrix::new(m, n, colptr, rowval, nzval)
}

fn settings(t: &SolverTuning) -> DefaultSettings<f64> {
    DefaultSettings {
        verbose: false,
        presolve_enable: false,
        input_sparse_dropzeros: false,
        max_iter: t.max_iter,
        tol_gap_abs: t.tol_gap,
        tol_gap_rel: t.tol_gap,
        tol_feas: t.tol_feas,
        iterative_refinement_max_iter: t.refinement_max_iter,
        iterative_refinement_reltol: t.refinement_reltol,
        ..DefaultSettings::default()
    }
}

/// One robot's controller: the memory it keeps between ticks (plan, held plan, solver).
#[derive(Default)]
pub struct RobotController {
    /// Last accepted (or held) plan, as executed from the previous tick on.
    pub(crate) plan: Vec<Command>,
    /// Last command handed out.
    pub(crate) last_command: Command,
    /// Remaining inputs of the last accepted plan (for fallback).
    held: Vec<Command>,
    /// Consecutive ticks on the held plan.
    fallback_ticks: u32,
    solver: Option<CachedSolver>,
    builder: Builder,
}

impl std::fmt::Debug for RobotController {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RobotController")
            .field("plan", &self.plan)
            .field("last_command", &self.last_command)
            .field("fallback_ticks", &self.fallback_ticks)
            .finish()
    }
}

impl RobotController {
    /// A controller with no plan yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The plan shifted by one step (last input repeated), length `h`: what this robot is
    /// expected to execute from now on.
    pub(crate) fn shifted_plan(&self, h: usize) -> Vec<Command> {
        let mut u: Vec<Command> = self.plan.iter().skip(1).copied().collect();
        let last = u.last().copied().or(self.plan.last().copied());
        u.resize(h, last.unwrap_or(Command::STOP));
        u
    }

    /// Solves one QP linearised at `ubar`; returns the plan or a failure reason.
    fn solve_qp(
        &mut self,
        inst: &mut ProblemInstance,
        ubar: &[Command],
        tuning: &SolverTuning,
        condensed: bool,
    ) -> Result<(Vec<Command>, u32), String> {
        self.builder.build(inst, ubar, condensed);
        let qp = &self.builder.qp;
        let a = a_csc(qp);
        let p = p_upper(qp);
        let reuse = tuning.reuse_factorisation
            && self.solver.as_ref().is_some_and(|s| {
                s.n == qp.n
                    && s.n_eq == qp.n_eq
                    && s.a_colptr == a.colptr
                    && s.a_rowval == a.rowval
                    && s.p_colptr == p.colptr
                    && s.p_rowval == p.rowval
            });
        if reuse {
            let s = self.solver.as_mut().expect("checked above");
            let upd = s
                .solver
                .update_P(&p.nzval)
                .and_then(|_| s.solver.update_q(&qp.q))
                .and_then(|_| s.solver.update_A(&a.nzval))
                .and_then(|_| s.solver.update_b(&qp.b));
            if let Err(e) = upd {
                self.solver = None;
                return Err(format!("solver data update failed: {e}"));
            }
        } else {
            let mut cones: Vec<SupportedConeT<f64>> = Vec::with_capacity(2);
            if qp.n_eq > 0 {
                cones.push(ZeroConeT(qp.n_eq));
            }
            cones.push(NonnegativeConeT(qp.m - qp.n_eq));
            let solver = DefaultSolver::new(&p, &qp.q, &a, &qp.b, &cones, settings(tuning))
                .map_err(|e| format!("solver setup failed: {e}"))?;
            self.solver = Some(CachedSolver {
                solver,
                a_colptr: a.colptr.clone(),
                a_rowval: a.rowval.clone(),
                p_colptr: p.colptr.clone(),
                p_rowval: p.rowval.clone(),
                n: qp.n,
                n_eq: qp.n_eq,
            });
        }
        let s = self.solver.as_mut().expect("set above");
        s.solver.solve();
        let sol = &s.solver.solution;
        match sol.status {
            SolverStatus::Solved | SolverStatus::AlmostSolved => {}
            other => return Err(format!("solver status {other:?}")),
        }
        let nu = 2 * inst.horizon;
        if sol.x.len() < nu || sol.x.iter().any(|v| !v.is_finite()) {
            return Err("solver returned a non-finite solution".into());
        }
        let plan = sol.x[..nu]
            .chunks_exact(2)
            .map(|c| Command::new(c[0], c[1]))
            .collect();
        Ok((plan, sol.iterations))
    }

    /// Runs the tick for this robot on a resolved problem: RTI solve(s), output check,
    /// fallback. `inst.guess` is the linearisation point; `inst.wings` is filled.
    pub fn step(
        &mut self,
        cfg: &MpcConfig,
        inst: &mut ProblemInstance,
        id: RobotId,
    ) -> RobotOutput {
        let mut ubar = inst.guess.clone();
        let mut iterations = 0;
        let mut failure = None;
        for _ in 0..cfg.sqp_iterations {
            match self.solve_qp(inst, &ubar, &cfg.solver, cfg.condensed) {
                Ok((plan, it)) => {
                    iterations += it;
                    ubar = plan;
                }
                Err(e) => {
                    failure = Some(e);
                    break;
                }
            }
        }
        if failure.is_none() {
            if let Some((k, u)) = ubar
                .iter()
                .enumerate()
                .find(|(_, u)| !inst.limits.contains(**u, OUTPUT_TOLERANCE))
            {
                failure = Some(format!(
                    "plan step {k} (v = {}, ω = {}) outside box/butterfly",
                    u.v, u.omega
                ));
            }
        }
        if let Some(k) = check_rates(inst, &ubar).filter(|_| failure.is_none()) {
            failure = Some(format!("plan step {k} violates the acceleration box"));
        }
        let status = match failure {
            None => {
                self.fallback_ticks = 0;
                self.held = ubar.iter().skip(1).copied().collect();
                self.plan = ubar;
                SolveStatus::Solved { iterations }
            }
            Some(reason) => {
                self.fallback_ticks += 1;
                // With established couplings only inputs whose successor states were
                // constrained (k ≤ H_c) may be replayed: fallback tick t plays u_t → x_{t+1}.
                let limit = if inst.couplings.is_empty() {
                    cfg.max_fallback_ticks
                } else {
                    cfg.max_fallback_ticks.min(
                        u32::try_from(inst.constraint_horizon.saturating_sub(1))
                            .unwrap_or(u32::MAX),
                    )
                };
                if self.fallback_ticks <= limit && !self.held.is_empty() {
                    let mut plan = std::mem::take(&mut self.held);
                    self.held = plan.iter().skip(1).copied().collect();
                    plan.resize(inst.horizon, Command::STOP);
                    self.plan = plan;
                    SolveStatus::Fallback {
                        reason,
                        ticks: self.fallback_ticks,
                    }
                } else {
                    self.held.clear();
                    self.plan = vec![Command::STOP; inst.horizon];
                    SolveStatus::Stopped { reason }
                }
            }
        };
        let command = self.plan[0];
        self.last_command = command;
        RobotOutput {
            id,
            command,
            status,
            predicted: inst.rollout(&self.plan),
            plan: self.plan.clone(),
        }
    }
}

/// First step whose rate box (if any) is violated by more than the output tolerance.
fn check_rates(inst: &ProblemInstance, u: &[Command]) -> Option<usize> {
    let acc = inst.limits.accel_max?;
    let mut prev = inst.u_prev;
    for (k, ui) in u.iter().enumerate() {
        if (ui.v - prev.v).abs() > acc[0] * inst.dt + OUTPUT_TOLERANCE
            || (ui.omega - prev.omega).abs() > acc[1] * inst.dt + OUTPUT_TOLERANCE
        {
            return Some(k);
        }
        prev = *ui;
    }
    None
}
