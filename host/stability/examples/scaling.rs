//! Quick scaling table (one solve per size): `cargo run --release -p puzzlebot-stability
//! --example scaling -- [max_n]`.

use puzzlebot_stability::bench_problems::Family;
use puzzlebot_stability::evaluate;
use std::time::Instant;

fn main() {
    let max_n: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1000);
    for fam in [
        Family::Chain,
        Family::Mesh,
        Family::TreeGround,
        Family::TreeHanging,
    ] {
        let mut n = 10;
        while n <= max_n {
            let a = fam.build(n, 7);
            let t = Instant::now();
            let r = evaluate(&a).expect("valid");
            let dt = t.elapsed().as_secs_f64();
            println!(
                "{:<13} n={:>6} {:>10.3} ms {:>8.2} µs/module  {:?} {} solves={} iters={} build={:.3} ms solve={:.3} ms",
                fam.name(),
                n,
                dt * 1e3,
                dt * 1e6 / n as f64,
                r.stats.path,
                r.verdict.name(),
                r.stats.solves,
                r.stats.iterations,
                r.stats.build_seconds * 1e3,
                r.stats.solve_seconds * 1e3
            );
            n *= 10;
        }
    }
}
