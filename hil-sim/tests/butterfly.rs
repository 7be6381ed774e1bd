//! The v–ω feasible set ("butterfly", THESIS 3.5.1) from open-loop calibration runs.

use puzzlebot_params::{drive::Drive, plant::Plant, RobotKind, RobotParams};
use puzzlebot_sim::calibration::calibrate;

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
fn chapter3_pilot_preset_reproduces_k_v_k_omega_and_b_within_10_percent() {
    let kind = RobotKind::Pilot;
    let mut p = RobotParams::for_kind(kind);
    p.plant = Plant::chapter3(kind);
    let c = calibrate(kind, &p, 23);
    let t = Drive::for_kind(kind);
    let rel = |x: f64, y: f32| (x / f64::from(y) - 1.0).abs();
    println!(
        "k_v {} k_w {} B {} A {:?}",
        c.k_v,
        c.k_omega,
        c.b_x,
        c.corner_a()
    );
    assert!(rel(c.k_v, t.k_v) < 0.1, "k_v {}", c.k_v);
    assert!(rel(c.k_omega, t.k_omega) < 0.1, "k_w {}", c.k_omega);
    assert!(rel(c.b_x, t.butterfly_b[0]) < 0.1, "B {}", c.b_x);
    // The corner A: pilot needs forward speed before it turns (THESIS A = (0.34, −0.561)).
    let a = c.corner_a();
    assert!(
        a[0] > 0.5 * f64::from(t.butterfly_a[0]) && a[1] < 0.0,
        "{a:?}"
    );
}
