//! Gate solve time vs module count (model construction included): chains, meshes and random
//! trees on the ground (cone program) and random trees hanging from a fixed root (fast path).
//!
//! `cargo bench -p puzzlebot-stability --bench gate` runs 10…1,000; set `GATE_BENCH_BIG=1` to
//! add 10,000 (run it once or twice only: slow on a 2-core machine). The closing summary gives
//! medians of wall-clock and thread CPU time per size against the DESIGN.md §9 targets; the
//! comparison with CVXPY + Clarabel is `bench/stability/compare.py`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use puzzlebot_stability::bench_problems::{thread_cpu_seconds, Family};
use puzzlebot_stability::evaluate;
use std::hint::black_box;
use std::time::{Duration, Instant};

fn sizes() -> Vec<usize> {
    let mut v = vec![10, 100, 1000];
    if std::env::var("GATE_BENCH_BIG").is_ok() {
        v.push(10_000);
    }
    v
}

fn bench(c: &mut Criterion) {
    let families = [
        Family::Chain,
        Family::Mesh,
        Family::TreeGround,
        Family::TreeHanging,
    ];
    let mut summary = Vec::new();
    for fam in families {
        let mut g = c.benchmark_group(format!("gate/{}", fam.name()));
        g.sample_size(10);
        g.warm_up_time(Duration::from_millis(300));
        g.measurement_time(Duration::from_secs(2));
        for n in sizes() {
            let a = fam.build(n, 7);
            // Timed calls for the per-module table (verdict printed as a sanity check).
            let reps = if n >= 10_000 { 1 } else { 5 };
            let (mut wall, mut cpu) = (Vec::new(), Vec::new());
            let mut rep = None;
            for _ in 0..reps {
                let c = thread_cpu_seconds().unwrap_or(f64::NAN);
                let t = Instant::now();
                rep = Some(evaluate(&a).expect("valid problem"));
                wall.push(t.elapsed().as_secs_f64());
                cpu.push(thread_cpu_seconds().unwrap_or(f64::NAN) - c);
            }
            let rep = rep.expect("at least one run");
            let median = |v: &mut Vec<f64>| {
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            let (w, c) = (median(&mut wall), median(&mut cpu));
            // DESIGN.md §9: 100 modules ≤ 5 ms, 1,000 modules ≤ 50 ms (CPU time judged).
            let target = match n {
                100 => Some(5e-3),
                1000 => Some(50e-3),
                _ => None,
            };
            let verdict = target.map_or("-".to_string(), |t| {
                format!(
                    "≤{:.0} ms {}",
                    t * 1e3,
                    if c <= t { "met" } else { "MISSED" }
                )
            });
            summary.push(format!(
                "{:<13} n={:>6}  wall {:>10.3} ms  cpu {:>10.3} ms  {:>8.2} µs/module  §9 {:<14} {:?} {} iters={} fallbacks={}",
                fam.name(),
                n,
                w * 1e3,
                c * 1e3,
                c * 1e6 / n as f64,
                verdict,
                rep.stats.path,
                rep.verdict.name(),
                rep.stats.iterations,
                rep.stats.fallbacks
            ));
            if n >= 10_000 {
                continue; // one measurement is enough at this size
            }
            g.bench_with_input(BenchmarkId::from_parameter(n), &a, |b, a| {
                b.iter(|| black_box(evaluate(black_box(a)).expect("valid")))
            });
        }
        g.finish();
    }
    println!("\nsummary (medians of 5 runs, model construction included):");
    for s in summary {
        println!("{s}");
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
