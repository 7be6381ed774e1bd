//! Plant-level checks: motor step response against the analytic first-order solution.

use puzzlebot_params::{RobotKind, RobotParams};
use puzzlebot_sim::drive::{step, Bridge, DriveModel, DriveState};

#[test]
fn motor_step_response_matches_first_order_solution_within_2_percent() {
    let kind = RobotKind::NonPilot;
    let mut p = RobotParams::for_kind(kind);
    // Constant supply for the analytic solution (no sag, no discharge).
    p.plant.battery_resistance = 0.0;
    p.plant.battery_voltage_swing = 0.0;
    let m = DriveModel::new(kind, &p.plant, &p.mass, &p.geometry);
    let mut s = DriveState::at_rest(&m, 0.5);
    let v = f64::from(p.plant.battery_voltage);
    let duty = 0.2;
    let cmd = Bridge {
        in1: 1000,
        in2: (1000.0 * (1.0 - duty)) as u16,
    };
    // First order in the wheel speed (rolling, L → 0): J ω̇ = ηNk(DV − kNω)/R − bω − T_c − r F_c/2
    // with J = J_w + m r²/2 (each wheel carries half the body) and the caster drag F_c.
    let (eta, n, k, r_a) = (m.eta, m.n, m.k, m.res);
    let j = m.jw + m.m * m.r * m.r / 2.0;
    let b = eta * n * n * k * k / r_a + m.b_visc;
    let caster_drag: f64 = m.casters[..m.n_casters].iter().map(|c| c.1).sum();
    let drive = eta * n * k * duty * v / r_a - m.t_coulomb - m.r * caster_drag / 2.0;
    let w_ss = drive / b;
    let tau = j / b;
    let dt = 1e-3;
    let mut worst: f64 = 0.0;
    for i in 1..=300 {
        step(&m, &mut s, [cmd, cmd], dt);
        let t = i as f64 * dt;
        let analytic = w_ss * (1.0 - (-t / tau).exp());
        worst = worst.max((s.wheel[0] - analytic).abs() / w_ss);
    }
    println!(
        "ω_ss = {w_ss:.3} rad/s, τ = {:.1} ms, worst deviation {:.2} %",
        tau * 1e3,
        worst * 100.0
    );
    assert!(worst < 0.02, "worst deviation {:.2} %", worst * 100.0);
    assert!((s.wheel[0] - w_ss).abs() / w_ss < 0.005);
}
