//! `puzzlebot calibrate` without `--fleet`: THESIS 3.5.1's calibration of one simulated
//! robot, checked against the simulator's ground truth.

use std::path::Path;
use std::time::Duration;

use puzzlebot_params::RobotKind;
use puzzlebot_protocol::messages::RobotId;

use super::SimHarness;
use crate::calibrate::{calibrate, cli_folder, finish_cli, Mode, Plan, VelocityProbe};

/// Ground-truth (v, ω) probe of a simulated robot.
pub fn sim_probe(h: &SimHarness, robot: RobotId) -> VelocityProbe {
    let fleet = std::sync::Arc::clone(&h.fleet);
    Box::new(move || fleet.ground_truth().robot(robot).map(|r| (r.v, r.omega)))
}

/// Calibrate a simulated non-pilot `robot` in `mode`; returns the text to print (with the
/// simulator's own dead-band next to the fitted one in duty mode).
pub async fn run_cli(
    robot: RobotId,
    mode: Mode,
    out: Option<&Path>,
    runs_dir: &Path,
) -> anyhow::Result<String> {
    let (folder, out) = cli_folder(robot, mode, out, runs_dir)?;
    let scenario = puzzlebot_sim::Scenario {
        robots: vec![puzzlebot_sim::RobotSpec {
            id: robot,
            kind: RobotKind::NonPilot,
            pose: [0.0, 0.0, 0.0],
            impairments: None,
            offline: false,
            mismatch: puzzlebot_sim::PlantMismatch::NONE,
        }],
        ..puzzlebot_sim::Scenario::default()
    };
    let h = SimHarness::start(scenario).await?;
    h.wait_ready(1, Duration::from_secs(5)).await?;
    let plan = Plan::default_for(mode, RobotKind::NonPilot);
    let pb = crate::app::progress_bar(plan.steps() as f64, "calibrating");
    let cal = calibrate(
        &h.link,
        &h.poses.table,
        robot,
        &plan,
        Some(&pb),
        Some(sim_probe(&h, robot)),
    )
    .await;
    pb.finish_and_clear();
    let base = h.params.robot(RobotKind::NonPilot).clone();
    let v = h.fleet.ground_truth().robot(robot).map(|r| r.battery_v);
    h.shutdown().await;
    let truth = match (mode, v) {
        (Mode::Duty, Some(v)) => Some(1000.0 * f64::from(base.plant.dead_band_duty(v as f32))),
        _ => None,
    };
    finish_cli(folder, &out, &base, &cal?, truth)
}
