//! How much faster than real time the 3-D crossing world runs with 8 robots on one core
//! (DESIGN §9: ≥ 10×): a 2 × 4 mesh with two pilots, every robot running its firmware and
//! driven through its motors, crossing a 40 mm gap down 6 mm. Each of REPS runs starts from
//! a fresh world; the figure is simulated time over this thread's CPU time (the machine may
//! be shared), best run and median, on the last line (`physics3d_speed RESULT`).
//!
//! `cargo run --release -p puzzlebot-sim --example physics3d_speed [-- SECONDS REPS]`
//! (defaults 10 and 3; `P3D_DT` and `P3D_IT` override the step in s and the solver
//! iterations).

#[path = "../benches/cpu_clock.rs"]
mod cpu_clock;

use cpu_clock::thread_cpu_ns;
use puzzlebot_params::terrain::{Platform, Terrain};
use puzzlebot_params::FleetParams;
use puzzlebot_sim::physics3d::assembly::{self, Formation, Shape};
use puzzlebot_sim::physics3d::{Config3d, World3d};
use std::time::Instant;

fn arg<T: std::str::FromStr>(i: usize, default: T, what: &str) -> T {
    match std::env::args().nth(i) {
        None => default,
        Some(a) => a.parse().unwrap_or_else(|_| {
            eprintln!("physics3d_speed: argument {i} ({what}) is not a number: {a:?}");
            std::process::exit(2);
        }),
    }
}

fn main() {
    let secs: f64 = arg(1, 10.0, "simulated seconds");
    let reps: usize = arg(2, 3, "runs");
    if !(secs > 0.0 && secs.is_finite()) || reps == 0 {
        eprintln!("physics3d_speed: needs SECONDS > 0 and REPS ≥ 1");
        std::process::exit(2);
    }
    let mut cfg = Config3d::default();
    if let Some(v) = std::env::var("P3D_DT").ok().and_then(|v| v.parse().ok()) {
        cfg.dt = v;
    }
    if let Some(v) = std::env::var("P3D_IT").ok().and_then(|v| v.parse().ok()) {
        cfg.solver_iterations = v;
    }
    let terrain = Terrain {
        platforms: vec![
            Platform::rect("near", [-1.0, -0.5], [0.0, 0.5], 0.006),
            Platform::rect("far", [0.04, -0.5], [4.04, 0.5], 0.0),
        ],
    };
    let f = Formation {
        shape: Shape::Mesh {
            rows: 2,
            per_row: 4,
        },
        pilots: vec![0, 4],
        front: [-0.03, -0.025, 0.0],
    };
    let mut factors = Vec::with_capacity(reps);
    for rep in 0..reps {
        let s = assembly::scenario(&f, terrain.clone(), FleetParams::default(), 1);
        let mut w = match World3d::new(&s, cfg) {
            Ok(w) => w,
            Err(e) => {
                eprintln!("physics3d_speed: {e}");
                std::process::exit(1);
            }
        };
        w.command_all(Some([150.0, 150.0]));
        let (t, cpu0) = (Instant::now(), thread_cpu_ns());
        w.run_for((secs * 1e6) as u64);
        let wall = t.elapsed().as_secs_f64();
        let cpu = cpu0
            .zip(thread_cpu_ns())
            .map_or(wall, |(a, b)| (b - a) as f64 * 1e-9);
        factors.push(secs / cpu);
        println!(
            "run {rep}: {secs} s simulated, {cpu:.3} s CPU ({wall:.3} s wall), front robot at \
             x = {:.3} m, {} events",
            w.states()[0].position[0],
            w.events().len()
        );
        if rep == 0 {
            for e in w.events() {
                println!("  {e:?}");
            }
        }
    }
    factors.sort_by(|a, b| b.total_cmp(a));
    println!(
        "physics3d_speed RESULT: 8 robots (2 × 4 mesh, 2 pilots), step {} ms, {} solver \
         iterations, one core, CPU time: best {:.1}x, median {:.1}x real time",
        cfg.dt * 1e3,
        cfg.solver_iterations,
        factors[0],
        factors[factors.len() / 2]
    );
}
