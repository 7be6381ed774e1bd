//! Random search of the chapter-3 preset's free plant parameters against THESIS 3.5.1
//! (k_v, k_ω, B and the butterfly corner A). Used once to choose `Plant::chapter3`;
//! kept so the choice can be re-derived: `cargo run --release -p puzzlebot-sim --example
//! ch3_tune -- pilot|non-pilot [iterations]`.

use puzzlebot_params::{drive::Drive, plant::Plant, RobotKind, RobotParams};
use puzzlebot_sim::calibration::calibrate;
use puzzlebot_sim::rng::Rng;

fn loss(kind: RobotKind, p: &RobotParams) -> (f64, String) {
    let c = calibrate(kind, p, 46);
    let t = Drive::for_kind(kind);
    let rel = |x: f64, y: f32| x / f64::from(y) - 1.0;
    let wa = c.omega_max_at(f64::from(t.butterfly_a[0]));
    let e = [
        rel(c.k_v, t.k_v),
        rel(c.k_omega, t.k_omega),
        rel(c.b_x, t.butterfly_b[0]),
        rel(wa, -t.butterfly_a[1]),
    ];
    let l = e.iter().map(|x| x * x).sum();
    (
        l,
        format!(
            "errors k_v {:+.3} k_w {:+.3} B {:+.3} |w|(a_x) {:+.3}",
            e[0], e[1], e[2], e[3]
        ),
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let kind = if args.get(1).is_some_and(|a| a == "pilot") {
        RobotKind::Pilot
    } else {
        RobotKind::NonPilot
    };
    let iters: usize = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(200);
    let mut rng = Rng::new(1, 2);
    let mut best = RobotParams::for_kind(kind);
    best.plant = Plant::chapter3(kind);
    let (mut best_l, mut best_s) = loss(kind, &best);
    println!("start {best_l:.4} {best_s}");
    for i in 0..iters {
        let mut p = best.clone();
        let scale = if i < iters / 2 { 0.5 } else { 0.15 };
        let mut jig = |v: f32| (f64::from(v) * (1.0 + scale * (2.0 * rng.uniform() - 1.0))) as f32;
        p.plant.gear_ratio = jig(p.plant.gear_ratio);
        p.plant.wheel_axle_offset = jig(p.plant.wheel_axle_offset.max(0.001)).min(0.022);
        p.plant.wheel_lateral_friction = jig(p.plant.wheel_lateral_friction).clamp(0.2, 2.0);
        p.plant.slip_angle_saturation = jig(p.plant.slip_angle_saturation).clamp(0.02, 1.5);
        p.plant.friction_static = jig(p.plant.friction_static);
        p.plant.friction_coulomb = p.plant.friction_static * 0.66;
        if kind == RobotKind::NonPilot {
            p.plant.caster_friction = jig(p.plant.caster_friction).clamp(0.02, 1.0);
        }
        let (l, s) = loss(kind, &p);
        if l < best_l {
            best_l = l;
            best_s = s;
            best = p;
            println!("{i}: {best_l:.4} {best_s}");
        }
    }
    let q = best.plant;
    println!(
        "best {best_l:.4} {best_s}\n gear_ratio {} wheel_axle_offset {} wheel_lateral_friction {} \
         slip_angle_saturation {} friction_static {} friction_coulomb {} caster_friction {}",
        q.gear_ratio,
        q.wheel_axle_offset,
        q.wheel_lateral_friction,
        q.slip_angle_saturation,
        q.friction_static,
        q.friction_coulomb,
        q.caster_friction
    );
}
