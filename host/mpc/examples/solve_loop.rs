//! Repeats one robot's solve (2 couplings) for profiling: `solve_loop [N] [tol] [accel 0/1] [refine_iter] [refine_tol] [reuse 0/1] [tol_feas]`.
use puzzlebot_mpc::scenario::coupled_lines;
use puzzlebot_mpc::*;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = a.first().and_then(|s| s.parse().ok()).unwrap_or(5000);
    let tol: f64 = a.get(1).and_then(|s| s.parse().ok()).unwrap_or(1e-7);
    let accel = a.get(2).map(|s| s != "0").unwrap_or(true);
    let mut cfg = MpcConfig::default();
    cfg.solver.refinement_max_iter = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(10);
    cfg.solver.refinement_reltol = a.get(4).and_then(|s| s.parse().ok()).unwrap_or(1e-13);
    cfg.solver.reuse_factorisation = a.get(5).map(|s| s != "0").unwrap_or(true);
    cfg.condensed = std::env::var("MPC_SPARSE").is_err();
    cfg.solver.tol_gap = tol;
    cfg.solver.tol_feas = a.get(6).and_then(|s| s.parse().ok()).unwrap_or(tol);
    let (mut robots, pairs) = coupled_lines(3, 3, cfg.horizon, cfg.dt);
    if !accel {
        for r in &mut robots {
            r.limits.accel_max = None;
        }
    }
    let mut mpc = DistributedMpc::with_threads(cfg.clone(), 1).expect("config");
    for _ in 0..5 {
        mpc.tick(&robots, &pairs).expect("tick");
    }
    let inst = mpc
        .instances(&robots, &pairs)
        .expect("instances")
        .swap_remove(1);
    let mut ctl = RobotController::new();
    let t = std::time::Instant::now();
    let mut it = 0;
    for _ in 0..n {
        let mut x = inst.clone();
        if let SolveStatus::Solved { iterations } = ctl.step(&cfg, &mut x, 1).status {
            it = iterations;
        }
    }
    println!(
        "{:.1} µs/solve, {it} iterations",
        t.elapsed().as_secs_f64() * 1e6 / n as f64
    );
}
