//! Random search of the chapter-3 preset's free plant parameters against THESIS 3.5.1
//! (k_v, k_ω, B and the butterfly corner A, both coordinates), measured with the thesis's
//! procedure ([`Procedure::thesis_3_5_1`]). Used to choose `Plant::chapter3`; kept so the
//! choice can be re-derived:
//! `cargo run --release -p puzzlebot-sim --example ch3_tune -- pilot|non-pilot [iterations] [seed]`.

use puzzlebot_params::{drive::Drive, plant::Plant, RobotKind, RobotParams};
use puzzlebot_sim::calibration::{calibrate_with, Procedure};
use puzzlebot_sim::rng::Rng;

fn loss(kind: RobotKind, p: &RobotParams, proc: &Procedure) -> (f64, String) {
    let c = calibrate_with(kind, p, proc);
    let t = Drive::for_kind(kind);
    let rel = |x: f64, y: f32| x / f64::from(y) - 1.0;
    let a = c.corner_a();
    let e = [
        rel(c.k_v, t.k_v),
        rel(c.k_omega, t.k_omega),
        rel(c.b_x, t.butterfly_b[0]),
        rel(a[0], t.butterfly_a[0]),
        rel(a[1], t.butterfly_a[1]),
    ];
    // Minimise the worst error first (the goal is every number within 10 %).
    let worst = e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let l = worst + 0.1 * e.iter().map(|x| x * x).sum::<f64>();
    (
        l,
        format!(
            "errors k_v {:+.3} k_w {:+.3} B {:+.3} A_x {:+.3} A_y {:+.3}",
            e[0], e[1], e[2], e[3], e[4]
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
    let seed: u64 = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(1);
    let proc = Procedure::thesis_3_5_1();
    let mut rng = Rng::new(seed, 2);
    let mut best = RobotParams::for_kind(kind);
    best.plant = Plant::chapter3(kind);
    let (mut best_l, mut best_s) = loss(kind, &best, &proc);
    println!("start {best_l:.4} {best_s}");
    for i in 0..iters {
        let mut p = best.clone();
        let scale = if i < iters / 2 { 0.5 } else { 0.15 };
        let mut jig = |v: f32| (f64::from(v) * (1.0 + scale * (2.0 * rng.uniform() - 1.0))) as f32;
        let q = &mut p.plant;
        q.gear_ratio = jig(q.gear_ratio).clamp(10.0, 400.0);
        q.wheel_axle_offset = jig(q.wheel_axle_offset.max(0.001)).min(0.022);
        q.wheel_lateral_friction = jig(q.wheel_lateral_friction).clamp(0.2, 2.0);
        q.slip_angle_saturation = jig(q.slip_angle_saturation).clamp(0.02, 1.5);
        q.friction_static = jig(q.friction_static);
        q.friction_coulomb = q.friction_static * 0.66;
        q.friction_viscous = jig(q.friction_viscous.max(1e-7));
        q.wheel_friction = jig(q.wheel_friction).clamp(0.3, 1.2);
        q.battery_resistance = jig(q.battery_resistance).clamp(0.2, 2.0);
        q.traction_slip_speed = jig(q.traction_slip_speed).clamp(0.001, 0.05);
        if kind == RobotKind::NonPilot {
            q.caster_friction = jig(q.caster_friction).clamp(0.02, 1.0);
            q.wheel_load_fraction = jig(q.wheel_load_fraction).clamp(0.3, 1.0);
        }
        let (l, s) = loss(kind, &p, &proc);
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
         slip_angle_saturation {} friction_static {} friction_coulomb {} friction_viscous {} caster_friction {} \
         wheel_friction {} traction_slip_speed {} wheel_load_fraction {} battery_resistance {}",
        q.gear_ratio,
        q.wheel_axle_offset,
        q.wheel_lateral_friction,
        q.slip_angle_saturation,
        q.friction_static,
        q.friction_coulomb,
        q.friction_viscous,
        q.caster_friction,
        q.wheel_friction,
        q.traction_slip_speed,
        q.wheel_load_fraction,
        q.battery_resistance
    );
}
