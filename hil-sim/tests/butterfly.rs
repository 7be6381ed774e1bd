//! The v–ω feasible set ("butterfly", THESIS 3.5.1) from open-loop calibration runs.

use puzzlebot_params::{drive::Drive, plant::Plant, RobotKind, RobotParams};
use puzzlebot_sim::calibration::{calibrate, calibrate_with, Procedure};

#[test]
fn chapter5_defaults_non_pilot_turns_almost_in_place_pilot_needs_forward_speed() {
    let np = calibrate(
        RobotKind::NonPilot,
        &RobotParams::for_kind(RobotKind::NonPilot),
        46,
    );
    let pi = calibrate(
        RobotKind::Pilot,
        &RobotParams::for_kind(RobotKind::Pilot),
        46,
    );
    let peak = |c: &puzzlebot_sim::calibration::Calibration| -c.corner_a()[1];
    // Non-pilot: at 3 % of its top speed it already turns at ≥ half its fastest rate.
    assert!(
        np.omega_max_at(0.03 * np.b_x) >= 0.5 * peak(&np),
        "{:?}",
        np.hull
    );
    // Pilot: at 5 % of top speed it barely turns; its fastest turn needs real speed.
    assert!(
        pi.omega_max_at(0.05 * pi.b_x) <= 0.2 * peak(&pi),
        "{:?}",
        pi.hull
    );
    assert!(pi.corner_a()[0] >= 0.2 * pi.b_x, "{:?}", pi.corner_a());
    // And the non-pilot turns far better than the pilot.
    assert!(peak(&np) > 3.0 * peak(&pi));
}

#[test]
fn chapter3_presets_reproduce_thesis_3_5_1_within_10_percent() {
    for kind in [RobotKind::Pilot, RobotKind::NonPilot] {
        let mut p = RobotParams::for_kind(kind);
        p.plant = Plant::chapter3(kind);
        let c = calibrate_with(kind, &p, &Procedure::thesis_3_5_1());
        let t = Drive::for_kind(kind);
        let a = c.corner_a();
        let rel = |x: f64, y: f32| (x / f64::from(y) - 1.0).abs();
        let got = format!(
            "{kind:?}: k_v {} k_w {} B {} A {a:?}",
            c.k_v, c.k_omega, c.b_x
        );
        println!("{got}");
        assert!(rel(c.k_v, t.k_v) < 0.1, "{got}");
        assert!(rel(c.k_omega, t.k_omega) < 0.1, "{got}");
        assert!(rel(c.b_x, t.butterfly_b[0]) < 0.1, "{got}");
        match kind {
            RobotKind::Pilot => {
                // The pilot needs forward speed to turn: its corner A (THESIS (0.34, −0.561)).
                assert!(rel(a[0], t.butterfly_a[0]) < 0.1, "{got}");
                assert!(rel(a[1], t.butterfly_a[1]) < 0.1, "{got}");
            }
            RobotKind::NonPilot => {
                // Forward-only commands: the sharpest turn pivots about the stopped inner
                // wheel, a_x = |a_y|·L/2 (see the `calibration` module on THESIS's A), at
                // the pivot's full speed.
                let half = f64::from(p.geometry.wheel_base) / 2.0;
                assert!((a[0] / (-a[1] * half) - 1.0).abs() < 0.05, "{got}");
                assert!((a[0] / (0.5 * c.b_x) - 1.0).abs() < 0.1, "{got}");
            }
        }
    }
}
