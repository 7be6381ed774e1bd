//! Time the phases of one benchmark solve and print Clarabel's own log:
//! `cargo run --release -p puzzlebot-stability --example verbose_solve -- chain 100`.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSolver, IPSolver};
use puzzlebot_stability::bench_problems::Family;
use puzzlebot_stability::socp;
use std::time::Instant;

fn main() {
    let fam = std::env::args().nth(1).unwrap_or("chain".into());
    let n: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(100);
    let a = Family::parse(&fam).expect("family").build(n, 7);
    for rep in 0..5 {
        let t0 = Instant::now();
        let r = a.resolve().expect("valid");
        let p = socp::build(&r, false);
        let t1 = Instant::now();
        let mut s = socp::settings();
        s.verbose = rep == 4;
        if std::env::var("NO_EQ").is_ok() {
            s.equilibrate_enable = false;
        }
        let pm = CscMatrix::zeros((p.n, p.n));
        let mut solver = DefaultSolver::new(&pm, &p.q, &p.a, &p.b, &p.cones, s).expect("setup");
        let t2 = Instant::now();
        solver.solve();
        let t3 = Instant::now();
        println!(
            "build {:.3} ms, setup {:.3} ms, solve {:.3} ms, iters {}",
            (t1 - t0).as_secs_f64() * 1e3,
            (t2 - t1).as_secs_f64() * 1e3,
            (t3 - t2).as_secs_f64() * 1e3,
            solver.solution.iterations
        );
        if rep == 4 {
            println!("{:?}", solver.timers);
        }
    }
}
