//! Time the phases of one benchmark solve and print Clarabel's own log:
//! `cargo run --release -p puzzlebot-stability --example verbose_solve -- chain 100`
//! (relaxed program in the dual form; `DIRECT=1` for the direct form).

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSolver, IPSolver};
use puzzlebot_stability::bench_problems::{thread_cpu_seconds, Family};
use puzzlebot_stability::socp;
use std::time::Instant;

fn main() {
    let fam = std::env::args().nth(1).unwrap_or("chain".into());
    let n: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(100);
    let a = Family::parse(&fam).expect("family").build(n, 7);
    let reps: usize = std::env::var("REPS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5);
    for rep in 0..reps {
        let t0 = Instant::now();
        let c0 = thread_cpu_seconds().unwrap_or(0.0);
        let r = a.resolve().expect("valid");
        let p = if std::env::var("DIRECT").is_ok() {
            socp::build(&r, false)
        } else {
            puzzlebot_stability::dual::build_relaxed_with(&r, std::env::var("NO_PAD").is_err())
        };
        let t1 = Instant::now();
        let mut s = if std::env::var("FULL_IR").is_ok() {
            socp::settings()
        } else {
            socp::fast_settings_for(&p)
        };
        s.verbose = rep + 1 == reps || std::env::var("VERB").is_ok();
        if std::env::var("NO_EQ").is_ok() {
            s.equilibrate_enable = false;
        }
        let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
        if let Some(v) = env("IR_MAX") {
            s.iterative_refinement_max_iter = v as u32;
        }
        if let Some(v) = env("IR_RELTOL") {
            s.iterative_refinement_reltol = v;
        }
        if let Some(v) = env("IR_ABSTOL") {
            s.iterative_refinement_abstol = v;
        }
        if let Some(v) = env("STATIC_REG") {
            s.static_regularization_constant = v;
        }
        if let Some(v) = env("TOL") {
            s.tol_gap_abs = v;
            s.tol_gap_rel = v;
            s.tol_feas = v;
        }
        if let Some(v) = env("MAX_STEP") {
            s.max_step_fraction = v;
        }
        if let Some(v) = env("EQ_ITERS") {
            s.equilibrate_max_iter = v as u32;
        }
        if let Some(v) = env("THREADS") {
            s.max_threads = v as u32;
        }
        if let Ok(m) = std::env::var("METHOD") {
            s.direct_solve_method = m;
        }
        if std::env::var("IR_OFF").is_ok() {
            s.iterative_refinement_enable = false;
        }
        if std::env::var("NO_PRESOLVE").is_ok() {
            s.presolve_enable = false;
        }
        let pm = CscMatrix::zeros((p.n, p.n));
        let mut solver = DefaultSolver::new(&pm, &p.q, &p.a, &p.b, &p.cones, s).expect("setup");
        let t2 = Instant::now();
        let c2 = thread_cpu_seconds().unwrap_or(0.0);
        solver.solve();
        let t3 = Instant::now();
        let c3 = thread_cpu_seconds().unwrap_or(0.0);
        println!(
            "build {:.3} ms, setup {:.3} ms, solve {:.3} ms, iters {}; cpu: build+setup {:.3} ms, solve {:.3} ms",
            (t1 - t0).as_secs_f64() * 1e3,
            (t2 - t1).as_secs_f64() * 1e3,
            (t3 - t2).as_secs_f64() * 1e3,
            solver.solution.iterations,
            (c2 - c0) * 1e3,
            (c3 - c2) * 1e3,
        );
        if rep + 1 == reps {
            println!("{:?}", solver.timers);
        }
    }
}
