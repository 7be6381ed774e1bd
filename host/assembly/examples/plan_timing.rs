//! Rough timing of planning (THESIS Algorithm 2) and of one coordinator tick for fleets of
//! growing size: `cargo run --release -p puzzlebot-assembly --example plan_timing`.

use puzzlebot_assembly::{Coordinator, Pose, RobotState, ShapeSpec};
use puzzlebot_params::{FleetParams, RobotKind};
use std::time::Instant;

fn main() {
    let params = FleetParams::default();
    for n in [4usize, 10, 100, 400] {
        let mut seed: u64 = 42;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) as f64 / (1u64 << 31) as f64
        };
        let side = (n as f64).sqrt() * 0.15;
        let robots: Vec<RobotState> = (0..n)
            .map(|i| RobotState {
                id: i as u16,
                kind: if i % 3 == 0 {
                    RobotKind::Pilot
                } else {
                    RobotKind::NonPilot
                },
                pose: Pose::new(rnd() * side, rnd() * side, rnd() * 6.0 - 3.0),
            })
            .collect();
        let mut c = Coordinator::from_params(&params);
        let t0 = Instant::now();
        c.form(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, Some(0.0))
            .expect("plan");
        let plan_ms = t0.elapsed().as_secs_f64() * 1e3;
        let reps = 50;
        let t1 = Instant::now();
        for k in 0..reps {
            std::hint::black_box(c.tick(0.1 * f64::from(k), &robots));
        }
        let tick_ms = t1.elapsed().as_secs_f64() * 1e3 / f64::from(reps);
        println!("{n:>4} robots: plan {plan_ms:8.3} ms, tick {tick_ms:7.3} ms");
    }
}
