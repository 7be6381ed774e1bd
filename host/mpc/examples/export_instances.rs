//! Exports the benchmark's one-robot problems (0, 1, 2 couplings) as JSON for the CasADi +
//! IPOPT peer (`bench/mpc/ipopt_peer.py`), with this crate's solutions and CPU times.
//!
//! `cargo run --release -p puzzlebot-mpc --example export_instances -- bench/mpc/instances.json`

use puzzlebot_mpc::scenario::robot_instance;
use puzzlebot_mpc::*;
use serde::Serialize;
use std::time::Duration;

#[derive(Serialize)]
struct Entry {
    couplings: usize,
    instance: ProblemInstance,
    /// One QP (real-time iteration), as run every tick.
    rti_plan: Vec<Command>,
    rti_cost: f64,
    rti_cpu_median_us: f64,
    /// Sequential QPs until the plan stops changing (for cost comparison).
    sqp_plan: Vec<Command>,
    sqp_cost: f64,
    sqp_iterations: usize,
    sqp_cpu_median_us: f64,
    max_coupling_violation_rti: f64,
}

fn thread_cpu() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec into the valid pointer given.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

fn median_cpu(cfg: &MpcConfig, inst: &ProblemInstance, reps: usize) -> (f64, Vec<Command>) {
    let mut ctl = RobotController::new();
    let mut v = Vec::with_capacity(reps);
    let mut plan = Vec::new();
    for _ in 0..reps {
        let mut x = inst.clone();
        let t = thread_cpu();
        let out = ctl.step(cfg, &mut x, 0);
        v.push((thread_cpu() - t).as_secs_f64() * 1e6);
        assert!(out.status.is_solved(), "{:?}", out.status);
        plan = out.plan;
    }
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], plan)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "bench/mpc/instances.json".into());
    let cfg = MpcConfig::default();
    let mut entries = Vec::new();
    for c in 0..=2 {
        let inst = robot_instance(c, &cfg)?;
        let (rti_us, rti_plan) = median_cpu(&cfg, &inst, 1000);
        // The converged reference solves the NLP itself: base damping only (the
        // consistency damping of coupled robots is a proximal term that slows convergence).
        let inst_rti = inst.clone();
        let mut inst = inst;
        inst.w_damping = cfg.w_damping;
        // Converged SQP: iterate until the plan moves less than 1e-6.
        let mut sqp_iters = 1;
        for k in 2..=30 {
            let c2 = MpcConfig {
                sqp_iterations: k,
                ..cfg.clone()
            };
            let mut a = inst.clone();
            let mut b = inst.clone();
            let pa = RobotController::new()
                .step(
                    &MpcConfig {
                        sqp_iterations: k - 1,
                        ..cfg.clone()
                    },
                    &mut a,
                    0,
                )
                .plan;
            let pb = RobotController::new().step(&c2, &mut b, 0).plan;
            sqp_iters = k;
            let d = pa
                .iter()
                .zip(&pb)
                .map(|(x, y)| (x.v - y.v).abs().max((x.omega - y.omega).abs()))
                .fold(0.0, f64::max);
            if d < 1e-6 {
                break;
            }
        }
        let scfg = MpcConfig {
            sqp_iterations: sqp_iters,
            ..cfg.clone()
        };
        let (sqp_us, sqp_plan) = median_cpu(&scfg, &inst, 200);
        println!(
            "couplings={c}: RTI {rti_us:.1} µs (cost {:.5}), converged SQP ({sqp_iters} QPs) {sqp_us:.1} µs (cost {:.5})",
            inst.cost(&rti_plan),
            inst.cost(&sqp_plan)
        );
        entries.push(Entry {
            couplings: c,
            rti_cost: inst.cost(&rti_plan),
            sqp_cost: inst.cost(&sqp_plan),
            max_coupling_violation_rti: inst.max_coupling_violation(&rti_plan),
            instance: inst_rti,
            rti_plan,
            rti_cpu_median_us: rti_us,
            sqp_plan,
            sqp_iterations: sqp_iters,
            sqp_cpu_median_us: sqp_us,
        });
    }
    std::fs::write(&path, serde_json::to_string_pretty(&entries)?)?;
    println!("wrote {path}");
    Ok(())
}
