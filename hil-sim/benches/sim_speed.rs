//! Simulation speed: 100 robots, firmware at 50 Hz, plant at 1 kHz, an in-process host
//! streaming wheel-speed commands at 30 Hz to every robot (so every robot runs its speed
//! loop, authenticates commands and seals telemetry). Prints the real-time factor.
//!
//! Two layouts: `spread` (rows of ten, 0.3 m apart: every robot circles on its own) and
//! `crowded` (0.15 m apart: the circles overlap, robots keep colliding and pushing).
//!
//! Each layout runs REPS times (default 3) from a fresh world; the machine may be shared,
//! so the figures are CPU time of this thread (what "on one core" means) and the best run
//! is reported next to the median. The last lines (`sim_speed RESULT`) are the summary.
//!
//! `cargo bench -p puzzlebot-sim --bench sim_speed [-- ROBOTS SECONDS REPS]`

#[path = "../tests/common/mod.rs"]
mod common;

use common::{key, speed, MiniHost};
use puzzlebot_sim::{Scenario, World};
use std::time::{Duration, Instant};

mod cpu_clock;
use cpu_clock::thread_cpu_ns;

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let robots: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(100);
    let secs: f64 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(20.0);
    let reps: usize = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(3).max(1);
    let mut summary = Vec::new();
    for (layout, spacing) in [("spread", 0.3), ("crowded", 0.15)] {
        let mut s = Scenario::grid(robots, 1);
        for (i, r) in s.robots.iter_mut().enumerate() {
            r.pose = [(i % 10) as f64 * spacing, (i / 10) as f64 * spacing, 0.0];
        }
        let mut runs: Vec<Run> = (0..reps).map(|_| run(layout, &s, robots, secs)).collect();
        runs.sort_by(|a, b| a.sim_cpu.total_cmp(&b.sim_cpu));
        let best = runs[0];
        let median = runs[runs.len() / 2];
        summary.push(format!(
            "sim_speed RESULT [{layout}]: {robots} robots at 50 Hz (plant 1 kHz), one core, CPU time: \
             simulator {:.1}x real time (best of {reps}; median {:.1}x), \
             simulator + in-process host {:.1}x (best; median {:.1}x)",
            secs / best.sim_cpu,
            secs / median.sim_cpu,
            secs / runs.iter().map(|r| r.cpu).fold(f64::INFINITY, f64::min),
            secs / {
                let mut c: Vec<f64> = runs.iter().map(|r| r.cpu).collect();
                c.sort_by(f64::total_cmp);
                c[c.len() / 2]
            },
        ));
    }
    for line in summary {
        println!("{line}");
    }
}

/// CPU seconds of one run: everything, and the simulator's share.
#[derive(Debug, Clone, Copy)]
struct Run {
    cpu: f64,
    sim_cpu: f64,
}

fn run(layout: &str, scenario: &Scenario, robots: usize, secs: f64) -> Run {
    let mut w = World::new(scenario, &key()).expect("world");
    let mut host = MiniHost::new(key());
    let ids = w.robot_ids();
    // Connect everyone first (not timed).
    common::connect(&mut w, &mut host, 5.0);
    let end = w.time_us() + (secs * 1e6) as u64;
    let mut next_cmd = w.time_us();
    let mut host_time = Duration::ZERO;
    let cpu0 = thread_cpu_ns();
    let start = Instant::now();
    while w.time_us() < end {
        w.step();
        let h0 = Instant::now();
        host.pump(&mut w);
        if w.time_us() >= next_cmd {
            next_cmd += 33_333;
            let t = w.time_us() as f64 * 1e-6;
            for &id in &ids {
                // Gentle circles so robots stay apart and keep their loops busy.
                let s = (t * 0.5 + f64::from(id)).sin() as f32;
                if let Some(f) = host.seal(id, &speed(80.0 + 20.0 * s, 80.0 - 20.0 * s)) {
                    w.send_to_robot(id, &f);
                }
            }
        }
        host_time += h0.elapsed();
    }
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu0
        .zip(thread_cpu_ns())
        .map(|(a, b)| (b - a) as f64 * 1e-9);
    let sim_wall = wall - host_time.as_secs_f64();
    let t = w.ground_truth();
    let contacts = w.contact_count();
    let driving = t
        .robots
        .iter()
        .filter(|r| r.wheel_rpm[0].abs() > 30.0)
        .count();
    println!(
        "sim_speed [{layout}, {contacts} robot pairs in contact at the end]: {robots} robots, {secs} s simulated (plant 1 kHz, firmware 50 Hz, commands 30 Hz): \
         wall {wall:.3} s total = {:.1}x real time; simulator alone (without the in-process host's \
         sealing/opening) {sim_wall:.3} s = {:.1}x real time; {driving}/{robots} robots driving; \
         {:.0} ns per robot-step",
        secs / wall,
        secs / sim_wall,
        sim_wall * 1e9 / (secs * 1000.0 * robots as f64)
    );
    // Without a thread CPU clock (not Linux), wall time stands in for CPU time.
    let cpu = cpu.unwrap_or(wall);
    // The host's share is measured in wall time; scale it to CPU time by the same ratio.
    let sim_cpu = cpu * (sim_wall / wall);
    println!(
        "sim_speed [{layout}]: one core, CPU time {cpu:.3} s total = {:.1}x real time; simulator alone \
         {sim_cpu:.3} s = {:.1}x real time ({:.0} ns per robot-step)",
        secs / cpu,
        secs / sim_cpu,
        sim_cpu * 1e9 / (secs * 1000.0 * robots as f64)
    );
    Run { cpu, sim_cpu }
}
