//! Print the THESIS 3.5.1 open-loop calibration of the chapter-3 preset (and of the
//! chapter-5 defaults) as the simulator reproduces it.
//!
//! `cargo run --release -p puzzlebot-sim --example ch3_calibration`

use puzzlebot_params::{drive::Drive, plant::Plant, RobotKind, RobotParams};
use puzzlebot_sim::calibration::calibrate;

fn main() {
    for kind in [RobotKind::NonPilot, RobotKind::Pilot] {
        let mut p = RobotParams::for_kind(kind);
        p.plant = Plant::chapter3(kind);
        let c = calibrate(kind, &p, 23);
        let t = Drive::for_kind(kind);
        let a = c.corner_a();
        println!(
            "{kind:?} chapter-3: k_v {:.5} (THESIS {}), k_w {:.5} (THESIS {}), B {:.3} (THESIS {}), \
             A ({:.3}, {:.3}) (THESIS {:?}), |w|max at a_x {:.3}",
            c.k_v,
            t.k_v,
            c.k_omega,
            t.k_omega,
            c.b_x,
            t.butterfly_b[0],
            a[0],
            a[1],
            t.butterfly_a,
            c.omega_max_at(f64::from(t.butterfly_a[0]))
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
