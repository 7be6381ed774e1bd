//! Print the THESIS 3.5.1 open-loop calibration of the chapter-3 preset as the simulator
//! reproduces it, next to the thesis's numbers.
//!
//! `cargo run --release -p puzzlebot-sim --example ch3_calibration`

use puzzlebot_params::{drive::Drive, plant::Plant, RobotKind, RobotParams};
use puzzlebot_sim::calibration::{calibrate_with, Procedure};

fn main() {
    for kind in [RobotKind::NonPilot, RobotKind::Pilot] {
        let mut p = RobotParams::for_kind(kind);
        p.plant = Plant::chapter3(kind);
        let c = calibrate_with(kind, &p, &Procedure::thesis_3_5_1());
        let t = Drive::for_kind(kind);
        let a = c.corner_a();
        let rel = |x: f64, y: f32| 100.0 * (x / f64::from(y) - 1.0);
        println!(
            "{kind:?} chapter-3: k_v {:.5} (THESIS {}, {:+.1} %), k_w {:.5} (THESIS {}, {:+.1} %), \
             B {:.3} (THESIS {}, {:+.1} %), A ({:.3}, {:.3}) (THESIS ({}, {}), {:+.1} %, {:+.1} %)",
            c.k_v,
            t.k_v,
            rel(c.k_v, t.k_v),
            c.k_omega,
            t.k_omega,
            rel(c.k_omega, t.k_omega),
            c.b_x,
            t.butterfly_b[0],
            rel(c.b_x, t.butterfly_b[0]),
            a[0],
            a[1],
            t.butterfly_a[0],
            t.butterfly_a[1],
            rel(a[0], t.butterfly_a[0]),
            rel(a[1], t.butterfly_a[1]),
        );
        println!(
            "  hull {:?}",
            c.hull
                .iter()
                .map(|p| [
                    (p[0] * 1000.0).round() / 1000.0,
                    (p[1] * 1000.0).round() / 1000.0
                ])
                .collect::<Vec<_>>()
        );
    }
}
