//! How much faster than real time the 3-D crossing world runs with 8 robots on one core
//! (DESIGN §9: ≥ 10×): a 2 × 4 mesh with two pilots driving over a 40 mm gap.
//!
//! `cargo run --release -p puzzlebot-sim --example physics3d_speed [simulated seconds]`
//! (`P3D_DT` and `P3D_IT` override the step in s and the solver iterations.)

use puzzlebot_params::terrain::{Platform, Terrain};
use puzzlebot_params::FleetParams;
use puzzlebot_sim::physics3d::assembly::{self, Formation, Shape};
use puzzlebot_sim::physics3d::{Config3d, World3d};
use std::time::Instant;

fn main() {
    let secs: f64 = match std::env::args().nth(1).map(|a| a.parse::<f64>()) {
        None => 10.0,
        Some(Ok(s)) if s > 0.0 && s.is_finite() => s,
        Some(_) => {
            eprintln!("physics3d_speed: the argument is the simulated time in seconds (> 0)");
            std::process::exit(2);
        }
    };
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
    let s = assembly::scenario(&f, terrain, FleetParams::default(), 1);
    let mut cfg = Config3d::default();
    if let Some(v) = std::env::var("P3D_DT").ok().and_then(|v| v.parse().ok()) {
        cfg.dt = v;
    }
    if let Some(v) = std::env::var("P3D_IT").ok().and_then(|v| v.parse().ok()) {
        cfg.solver_iterations = v;
    }
    let mut w = match World3d::new(&s, cfg) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("physics3d_speed: {e}");
            std::process::exit(1);
        }
    };
    w.command_all(Some([150.0, 150.0]));
    let t = Instant::now();
    w.run_for((secs * 1e6) as u64);
    let wall = t.elapsed().as_secs_f64();
    let front = w.states()[0].position;
    println!(
        "8 robots, {secs} s simulated in {wall:.3} s wall: {:.1}x real time \
         (step {} ms; front robot at x = {:.3} m, {} events)",
        secs / wall,
        cfg.dt * 1e3,
        front[0],
        w.events().len()
    );
    for e in w.events() {
        println!("  {e:?}");
    }
}
