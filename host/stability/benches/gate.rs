//! Gate solve time vs module count (model construction included): chains, meshes and random
//! trees on the ground (cone program) and random trees hanging from a fixed root (fast path).
//!
//! `cargo bench -p puzzlebot-stability --bench gate` runs 10…1,000; set `GATE_BENCH_BIG=1` to
//! add 10,000 (run it once or twice only: slow on a 2-core machine).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use puzzlebot_stability::bench_problems::Family;
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
            // One timed call for the per-module table (verdict printed as a sanity check).
            let t = Instant::now();
            let rep = evaluate(&a).expect("valid problem");
            let dt = t.elapsed().as_secs_f64();
            summary.push(format!(
                "{:<13} n={:>6}  {:>10.3} ms  {:>8.2} µs/module  {:?} {} iters={}",
                fam.name(),
                n,
                dt * 1e3,
                dt * 1e6 / n as f64,
                rep.stats.path,
                rep.verdict.name(),
                rep.stats.iterations
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
    println!("\nsingle-shot summary (model construction included):");
    for s in summary {
        println!("{s}");
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
