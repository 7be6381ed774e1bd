//! Criterion benchmarks of the distributed MPC (DESIGN.md §9 targets: median robot-solve
//! ≤ 200 µs with coupling constraints active; 100-robot tick ≤ 25 ms on 2 cores).
//!
//! Besides criterion's own report, prints median and p99 of one robot's solve with 0, 1
//! and 2 coupling constraints, and of one tick per fleet size, with time per robot.
//! `MPC_BENCH_THREADS` sets the pool size of the tick benchmarks (default 2).

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion};
use puzzlebot_mpc::scenario::coupled_lines;
use puzzlebot_mpc::*;
use std::hint::black_box;
use std::time::{Duration, Instant};

fn robot_instance(couplings: usize, cfg: &MpcConfig) -> ProblemInstance {
    let inst = puzzlebot_mpc::scenario::robot_instance(couplings, cfg).expect("scenario");
    assert_eq!(inst.couplings.len(), couplings);
    inst
}

/// CPU time of the calling thread (or the whole process): immune to other processes
/// sharing the two cores, unlike wall time.
fn cpu_time(process: bool) -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    let clock = if process {
        libc::CLOCK_PROCESS_CPUTIME_ID
    } else {
        libc::CLOCK_THREAD_CPUTIME_ID
    };
    // SAFETY: clock_gettime writes one timespec into the valid pointer given.
    unsafe { libc::clock_gettime(clock, &mut ts) };
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

fn percentiles(mut v: Vec<Duration>) -> (Duration, Duration) {
    v.sort();
    let med = v[v.len() / 2];
    let p99 = v[(v.len() * 99 / 100).min(v.len() - 1)];
    (med, p99)
}

fn threads() -> usize {
    std::env::var("MPC_BENCH_THREADS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2)
}

fn report_percentiles() {
    let base = MpcConfig::default();
    let sparse_cfg = MpcConfig {
        condensed: false,
        ..base.clone()
    };
    let no_reuse = {
        let mut c = base.clone();
        c.solver.reuse_factorisation = false;
        c
    };
    let variants: [(usize, bool, &MpcConfig, &str); 6] = [
        (0, false, &base, ""),
        (1, false, &base, ""),
        (2, false, &base, ""),
        (2, true, &base, " +accel box"),
        (2, false, &sparse_cfg, " sparse (not condensed)"),
        (2, false, &no_reuse, " new solver every solve"),
    ];
    for (c, accel, cfg, label) in variants {
        let cfg = cfg.clone();
        let mut inst = robot_instance(c, &cfg);
        if accel {
            // THESIS 4.12's optional acceleration box: +4 rows per step.
            inst.limits.accel_max = Some([1.0, 20.0]);
        }
        let mut ctl = RobotController::new();
        let mut samples = Vec::with_capacity(2000);
        let mut cpu = Vec::with_capacity(2000);
        let mut iters = 0;
        for i in 0..2100 {
            let mut x = inst.clone();
            let c0 = cpu_time(false);
            let t = Instant::now();
            let out = ctl.step(&cfg, &mut x, 0);
            let el = t.elapsed();
            let cel = cpu_time(false) - c0;
            assert!(out.status.is_solved(), "{:?}", out.status);
            if let SolveStatus::Solved { iterations } = out.status {
                iters = iterations;
            }
            if i >= 100 {
                samples.push(el);
                cpu.push(cel);
            }
        }
        let (med, p99) = percentiles(samples);
        let (cmed, cp99) = percentiles(cpu);
        println!(
            "robot-solve couplings={c}{}: wall median {:.1} µs, p99 {:.1} µs | thread-CPU median {:.1} µs, p99 {:.1} µs ({} rows/coupling-step, {iters} IPM iterations)",
            label,
            med.as_secs_f64() * 1e6,
            p99.as_secs_f64() * 1e6,
            cmed.as_secs_f64() * 1e6,
            cp99.as_secs_f64() * 1e6,
            cfg.geometry.anchor_polygon.len() + 4
        );
    }
    let cfg = base;
    let th = threads();
    for &n in &[2usize, 8, 32, 100, 300] {
        let (robots, pairs) = coupled_lines(n, 4, cfg.horizon, cfg.dt);
        let mut mpc = DistributedMpc::with_threads(cfg.clone(), th).expect("config");
        for _ in 0..3 {
            mpc.tick(&robots, &pairs).expect("tick");
        }
        let reps = (2000 / n).clamp(20, 200);
        let mut samples = Vec::with_capacity(reps);
        let mut cpu = Vec::with_capacity(reps);
        for _ in 0..reps {
            let c0 = cpu_time(true);
            let t = Instant::now();
            let out = mpc.tick(&robots, &pairs).expect("tick");
            samples.push(t.elapsed());
            cpu.push(cpu_time(true) - c0);
            black_box(out);
        }
        let (med, p99) = percentiles(samples);
        let (cmed, _) = percentiles(cpu);
        println!(
            "tick n={n:3} threads={th}: wall median {:.2} ms, p99 {:.2} ms | process-CPU median {:.2} ms (= {:.2} ms on {th} idle cores), {:.1} µs CPU/robot",
            med.as_secs_f64() * 1e3,
            p99.as_secs_f64() * 1e3,
            cmed.as_secs_f64() * 1e3,
            cmed.as_secs_f64() * 1e3 / th as f64,
            cmed.as_secs_f64() * 1e6 / n as f64
        );
    }
}

fn bench_robot(c: &mut Criterion) {
    report_percentiles();
    let cfg = MpcConfig::default();
    let mut g = c.benchmark_group("robot_solve");
    for k in 0..=2 {
        let inst = robot_instance(k, &cfg);
        let mut ctl = RobotController::new();
        g.bench_with_input(BenchmarkId::new("couplings", k), &inst, |b, inst| {
            b.iter_batched(
                || inst.clone(),
                |mut x| black_box(ctl.step(&cfg, &mut x, 0)),
                BatchSize::SmallInput,
            )
        });
    }
    g.finish();
}

fn bench_tick(c: &mut Criterion) {
    let cfg = MpcConfig::default();
    let mut g = c.benchmark_group("tick");
    g.sample_size(10);
    for &n in &[2usize, 8, 32, 100, 300] {
        let (robots, pairs) = coupled_lines(n, 4, cfg.horizon, cfg.dt);
        let mut mpc = DistributedMpc::with_threads(cfg.clone(), threads()).expect("config");
        mpc.tick(&robots, &pairs).expect("tick");
        g.bench_with_input(BenchmarkId::new("robots", n), &n, |b, _| {
            b.iter(|| black_box(mpc.tick(&robots, &pairs).expect("tick")))
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(Duration::from_secs(3)).warm_up_time(Duration::from_secs(1));
    targets = bench_robot, bench_tick
}
criterion_main!(benches);
