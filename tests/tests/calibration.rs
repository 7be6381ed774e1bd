//! `puzzlebot calibrate` in simulation: the open-loop duty calibration of THESIS 3.5.1,
//! measured from the virtual motion capture over loopback, recovers the simulator's true
//! k_v and k_ω (the same THESIS 3.10 fit on ground-truth velocities) and its true dead-band
//! M_min (the plant's break-away duty) within 5 %, and writes a loadable parameter file.

use std::time::Duration;

use puzzlebot_host::calibrate::{apply, calibrate, describe, plot_fit, write_params, Mode, Plan};
use puzzlebot_host::simulated::calibrate::sim_probe;
use puzzlebot_host::simulated::SimHarness;
use puzzlebot_params::{RobotKind, RobotParams};
use puzzlebot_sim::Scenario;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn duty_calibration_recovers_true_k_v_k_omega_and_m_min_within_5_percent() {
    let h = SimHarness::start(Scenario::grid(1, 21))
        .await
        .expect("start");
    h.wait_ready(1, Duration::from_secs(5))
        .await
        .expect("ready");
    let plan = Plan::default_for(Mode::Duty, RobotKind::NonPilot);
    let cal = calibrate(
        &h.link,
        &h.poses.table,
        1,
        &plan,
        None,
        Some(sim_probe(&h, 1)),
    )
    .await
    .expect("calibration");
    let battery = h
        .fleet
        .ground_truth()
        .robot(1)
        .map(|r| r.battery_v)
        .expect("truth");
    let base = h.params.robot(RobotKind::NonPilot).clone();
    h.shutdown().await;
    print!("{}", describe(&cal));
    let (kv, kw) = cal.truth_fit.expect("ground-truth fit");
    let f = cal.fit;
    assert!(
        (f.k_v / kv - 1.0).abs() <= 0.05,
        "k_v {} vs true {kv}",
        f.k_v
    );
    assert!(
        (f.k_omega / kw - 1.0).abs() <= 0.05,
        "k_ω {} vs true {kw}",
        f.k_omega
    );
    let m_min_true = 1000.0 * f64::from(base.plant.dead_band_duty(battery as f32));
    println!("M_min fitted {:.1}, true {m_min_true:.1}", f.m_min);
    assert!(
        (f.m_min / m_min_true - 1.0).abs() <= 0.05,
        "M_min {} vs true {m_min_true}",
        f.m_min
    );
    // The fit is sane physically: forward duty drives forward, right > left turns left.
    assert!(f.k_v > 0.0 && f.k_omega > 0.0);
    assert!(f.a[0] > 0.0 && f.a[0] < f.b[0] && f.a[1] < 0.0);
    // Parameter file and plot.
    let dir = puzzlebot_e2e::scratch("calibration");
    let path = dir.join("robot-1-duty.toml");
    let params = apply(&base, &f);
    write_params(&path, &params, &cal).expect("write");
    let back = RobotParams::from_file(&path).expect("loadable parameter file");
    assert_eq!(back, params);
    plot_fit(&dir.join("fit.svg"), &cal).expect("plot");
    assert!(dir.join("fit.svg").is_file());
}
