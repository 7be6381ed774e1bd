//! Four simulated robots track 0.4 m straight lines and circles over loopback UDP, with a
//! clean link (mean error ≤ 5 mm) and with 10 % datagram loss both ways (≤ 10 mm).

use puzzlebot_host::simulated::tracking::{demo_plans, run_simulated, scenario_for};
use puzzlebot_sim::Impairments;

fn check(report: &puzzlebot_host::app::RunReport, limit_m: f64) {
    print!("{}", puzzlebot_host::app::describe(report));
    assert_eq!(report.summary.tracking.len(), 4, "every robot tracked");
    for (id, t) in &report.summary.tracking {
        assert!(t.samples > 100, "robot {id}: {} samples", t.samples);
        assert!(
            t.mean_error <= limit_m,
            "robot {id}: mean error {:.2} mm",
            t.mean_error * 1e3
        );
    }
    assert!(report.folder.join("trajectories.svg").is_file());
    assert!(report.folder.join("wheel_speeds.svg").is_file());
    assert!(report.folder.join("telemetry.jsonl").is_file());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn four_robots_track_lines_and_circles_within_5_mm() {
    let plans = demo_plans(4);
    let scenario = scenario_for(&plans, 11);
    let runs = puzzlebot_e2e::scratch("tracking");
    let report = run_simulated(scenario, plans, &runs, "tracking", false)
        .await
        .expect("run");
    check(&report, 0.005);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tracking_holds_within_10_mm_with_10_percent_loss() {
    let plans = demo_plans(4);
    let mut scenario = scenario_for(&plans, 12);
    scenario.impairments = Impairments {
        loss: 0.1,
        ..Impairments::NONE
    };
    let runs = puzzlebot_e2e::scratch("lossy");
    let report = run_simulated(scenario, plans, &runs, "lossy", false)
        .await
        .expect("run");
    check(&report, 0.010);
    // The loss is real and measured: both directions drop about one datagram in ten.
    for (id, l) in &report.summary.link {
        assert!(
            l.rx_loss() > 0.04 && l.rx_loss() < 0.2,
            "robot {id}: measured loss {}",
            l.rx_loss()
        );
    }
}
