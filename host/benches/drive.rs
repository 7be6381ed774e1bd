//! Cost of the per-tick host work: the THESIS 3.10 QP (exact, nine box QPs), the butterfly
//! projection, and one stabiliser step with velocity estimation.

use criterion::{criterion_group, criterion_main, Criterion};
use puzzlebot_host::drive::{
    DriveMap, PoseSample, Stabiliser, StabiliserGains, Twist, VelocityEstimator,
};
use puzzlebot_params::{RobotKind, RobotParams};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let map = DriveMap::geometric(&RobotParams::for_kind(RobotKind::NonPilot));
    let twists: Vec<Twist> = (0..64)
        .map(|i| {
            Twist::new(
                0.002 * f64::from(i % 16) - 0.01,
                0.25 * f64::from(i % 9) - 1.0,
            )
        })
        .collect();
    c.bench_function("drive_qp_wheels", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % twists.len();
            black_box(map.wheels(black_box(twists[i])))
        })
    });
    c.bench_function("butterfly_project_and_map", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % twists.len();
            black_box(map.command(black_box(twists[i])))
        })
    });
    c.bench_function("stabiliser_tick_with_estimate", |b| {
        let mut s = Stabiliser::new(map, StabiliserGains::default());
        let mut e = VelocityEstimator::new(0.12);
        let mut t = 0.0;
        b.iter(|| {
            t += 0.01;
            e.push(PoseSample {
                t,
                x: 0.05 * t,
                y: 0.0,
                theta: 0.0,
            });
            black_box(s.step(Twist::new(0.05, 0.2), e.estimate(), 1.0 / 30.0))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
