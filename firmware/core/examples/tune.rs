//! Grid search of the feed-forward scale and the PI gain sets against the first-order motor
//! model (`puzzlebot_firmware_core::model`), with the motor's gain off by ±10 %.
//!
//! `cargo run --release -p puzzlebot-firmware-core --example tune`
//!
//! For each scheduling point (target change of 123, 265, 495 RPM; from rest the largest
//! possible step is 450 RPM, which is used for the last point) and each feed-forward
//! scale it prints the gains with the smallest worst-case ±2 % settling time whose
//! overshoot stays below 5 % on the nominal motor and below 12 % on the mismatched ones
//! (a motor 10 % stronger than the feed-forward assumes overshoots by 10 % under the
//! feed-forward alone; at low speed the few encoder edges cannot correct that in time).

use puzzlebot_firmware_core::model::{ClosedLoop, MotorModel};
use puzzlebot_params::firmware::Firmware;
use puzzlebot_protocol::PiGains;

fn main() {
    let base = Firmware::default();
    let nominal_slope = (1000.0 - base.ff_deadband_duty) / MotorModel::default().no_load_rpm;
    let ff_scale = 1.0f32;
    for tau in [45.0f32, 50.0] {
        println!(
            "feed-forward slope {:.3} ({ff_scale} of nominal), reference tau {tau} ms",
            nominal_slope * ff_scale
        );
        for (i, &point) in base.schedule_rpm.iter().enumerate() {
            let target = point.min(base.max_rpm);
            // Steps below the first point use the first set: check them too.
            let targets: &[f32] = match i {
                0 => &[60.0, 100.0, target],
                1 => &[200.0, 250.0, target],
                _ => &[400.0, target],
            };
            let mut best: Option<(f32, f32, PiGains)> = None;
            for kp20 in 0..=30 {
                for ki in (0..=120).step_by(2) {
                    let g = PiGains {
                        kp: kp20 as f32 * 0.05,
                        ki: ki as f32,
                    };
                    let mut p = base;
                    p.pi = [g; 3];
                    p.ff_duty_per_rpm = nominal_slope * ff_scale;
                    p.reference_tau_ms = tau;
                    let mut worst_settle = 0.0f32;
                    let mut worst_over = 0.0f32;
                    let mut nominal_over = 0.0f32;
                    for (f, &target) in [0.9f32, 1.0, 1.1]
                        .into_iter()
                        .flat_map(|f| targets.iter().map(move |t| (f, t)))
                    {
                        let motor = MotorModel {
                            no_load_rpm: MotorModel::default().no_load_rpm * f,
                            ..MotorModel::default()
                        };
                        let r = ClosedLoop::new(p, motor).step_response(target, 0.8);
                        worst_settle = worst_settle.max(r.settle_s);
                        worst_over = worst_over.max(r.overshoot);
                        if f == 1.0 {
                            nominal_over = nominal_over.max(r.overshoot);
                        }
                    }
                    if nominal_over < 0.05
                        && worst_over < 0.12
                        && best.is_none_or(|b| worst_settle < b.0)
                    {
                        best = Some((worst_settle, worst_over, g));
                    }
                }
            }
            match best {
                Some((s, o, g)) => println!(
                    "  set {i} (step {point} RPM, run at {target}): kp {:.2} ki {:.1} -> settle {:.3} s, overshoot {:.1} %",
                    g.kp,
                    g.ki,
                    s,
                    o * 100.0
                ),
                None => println!("  set {i}: no gains meet the overshoot bound"),
            }
        }
    }
}
