//! The tracking demo (`puzzlebot demo --tracking`): simulated robots over loopback UDP follow
//! lines and circles, driven by the host's trajectory follower.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

use puzzlebot_params::RobotKind;
use puzzlebot_protocol::messages::RobotId;
use puzzlebot_sim::{RobotSpec, Scenario};

use super::SimHarness;
use crate::app::{finish_folder, progress_bar, RunReport};
use crate::control::{Path as RefPath, Trajectory, TrajectoryFollower};
use crate::report::RunFolder;

/// The demo plan: two robots drive 0.4 m straight lines, two drive circles (r = 0.1 m).
pub fn demo_plans(n: usize) -> BTreeMap<RobotId, Trajectory> {
    let pi = std::f64::consts::PI;
    (0..n)
        .map(|i| {
            let id = (i + 1) as RobotId;
            let col = (i / 4) as f64 * 1.2;
            let path = match i % 4 {
                0 => RefPath::Line {
                    start: [col, 0.0],
                    heading: 0.0,
                    length: 0.4,
                },
                1 => RefPath::Line {
                    start: [col, 0.15],
                    heading: 0.0,
                    length: 0.4,
                },
                2 => RefPath::Circle {
                    center: [col + 0.75, 0.1],
                    radius: 0.1,
                    phase: -pi / 2.0,
                    ccw: true,
                },
                _ => RefPath::Circle {
                    center: [col + 0.75, 0.45],
                    radius: 0.1,
                    phase: pi / 2.0,
                    ccw: false,
                },
            };
            (
                id,
                Trajectory {
                    path,
                    speed: 0.07,
                    accel: 0.15,
                },
            )
        })
        .collect()
}

/// A scenario with one non-pilot robot at the start of each plan.
pub fn scenario_for(plans: &BTreeMap<RobotId, Trajectory>, seed: u64) -> Scenario {
    let robots = plans
        .iter()
        .map(|(id, p)| RobotSpec {
            id: *id,
            kind: RobotKind::NonPilot,
            pose: p.path.start_pose(),
            impairments: None,
            offline: false,
            mismatch: puzzlebot_sim::PlantMismatch::NONE,
        })
        .collect();
    Scenario {
        seed,
        robots,
        ..Scenario::default()
    }
}

/// Run `plans` on a simulated fleet of `scenario`, recording into a new run folder under
/// `runs_dir`. Returns the report; every socket is on loopback.
pub async fn run_simulated(
    scenario: Scenario,
    plans: BTreeMap<RobotId, Trajectory>,
    runs_dir: &Path,
    name: &str,
    progress: bool,
) -> anyhow::Result<RunReport> {
    let n = scenario.robots.iter().filter(|r| !r.offline).count();
    let h = SimHarness::start(scenario).await?;
    h.wait_ready(n, Duration::from_secs(5)).await?;
    let mut ctl = TrajectoryFollower::new(plans);
    let mut folder = RunFolder::create(runs_dir, name)?;
    let pb = progress.then(|| progress_bar((ctl.duration() + ctl.settle) * 10.0, "driving"));
    let mut lp = h.control_loop();
    let summary = lp.run(&mut ctl, Some(&mut folder), pb.as_ref()).await;
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    let report = finish_folder(folder, summary)?;
    h.shutdown().await;
    Ok(report)
}

/// The main job: four simulated robots follow lines and circles; returns the report.
pub async fn demo(runs_dir: &Path, progress: bool) -> anyhow::Result<RunReport> {
    let plans = demo_plans(4);
    let scenario = scenario_for(&plans, 1);
    run_simulated(scenario, plans, runs_dir, "demo", progress).await
}
