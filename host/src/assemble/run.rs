//! Running an assembly scenario on a simulated fleet, in real time over loopback
//! ([`run_scenario`]) or in lockstep with the simulator ([`run_scenario_lockstep`]).

use std::path::Path;
use std::time::Duration;

use anyhow::Context;
use puzzlebot_assembly::Scenario as AsmScenario;

use super::controller::AssemblyController;
use super::gate::GateConfig;
use super::report::{write_events, AssemblyReport, TruthRecord};
use super::truth::report_of;
use crate::control::RunSummary;
use crate::report::RunFolder;
use crate::simulated::SimHarness;

/// Optional hook called every 100 ms of a simulated run with the harness and the time (s):
/// tests use it to switch robots off mid-run.
pub type RunHook = Box<dyn FnMut(&SimHarness, f64) + Send>;

/// Run an assembly scenario against an in-process simulated fleet `sim` (loopback), recording
/// into a new run folder under `runs_dir`: `events.jsonl` gets every pair status change and
/// gate stop with its time, `assembly_events.jsonl` the coordinator events alone, plus the
/// trajectory plots.
pub async fn run_scenario(
    scenario: AsmScenario,
    sim: puzzlebot_sim::Scenario,
    runs_dir: &Path,
    max_duration: f64,
    mut hook: Option<RunHook>,
) -> anyhow::Result<AssemblyReport> {
    let sim = on_its_ground(&scenario, sim)?;
    let n = sim.robots.iter().filter(|r| !r.offline).count();
    let gate = GateConfig {
        terrain: sim.terrain.clone(),
        ..GateConfig::default()
    };
    let params = sim.params.clone();
    let name = format!("assembly-{}", scenario.name);
    let h = SimHarness::start(sim).await?;
    h.wait_ready(n, Duration::from_secs(5)).await?;
    let mut ctl = AssemblyController::new(scenario, params, gate)?;
    let mut folder = RunFolder::create(runs_dir, &name)?;
    let mut lp = h.control_loop();
    lp.options.max_duration = max_duration;
    let summary = if let Some(hook) = hook.as_mut() {
        let start = tokio::time::Instant::now();
        let run = lp.run(&mut ctl, Some(&mut folder), None);
        tokio::pin!(run);
        let mut iv = tokio::time::interval(Duration::from_millis(100));
        loop {
            tokio::select! {
                s = &mut run => break s,
                _ = iv.tick() => hook(&h, start.elapsed().as_secs_f64()),
            }
        }
    } else {
        lp.run(&mut ctl, Some(&mut folder), None).await
    };
    write_events(&mut folder, &ctl)?;
    folder.finish()?;
    folder.write_json("summary.json", &summary)?;
    let report = report_of(&folder, &ctl, summary, &h.fleet.ground_truth());
    folder.write_json("assembly_report.json", &report)?;
    h.shutdown().await;
    Ok(report)
}

/// The simulated fleet `sim` on the ground `scenario` crosses ([`super::cross_step::ground_of`])
/// when its own terrain is the endless floor: the robots stand on the terrain before the
/// crossing as well, and a robot driven off an edge on the way falls there. A fleet with a
/// terrain of its own other than the crossing's is an error: one world has one ground.
fn on_its_ground(
    scenario: &AsmScenario,
    mut sim: puzzlebot_sim::Scenario,
) -> anyhow::Result<puzzlebot_sim::Scenario> {
    let terrains = super::cross_step::load_terrains(scenario)?;
    match super::cross_step::ground_of(scenario, &terrains) {
        Some(ground) if sim.terrain.platforms.is_empty() => sim.terrain = ground,
        Some(ground) if ground != sim.terrain => anyhow::bail!(
            "the simulated fleet has a terrain of its own ({} platforms) and scenario '{}' \
             crosses another ({} platforms): give the fleet none, it stands on the crossing's",
            sim.terrain.platforms.len(),
            scenario.name,
            ground.platforms.len()
        ),
        _ => {}
    }
    Ok(sim)
}

/// Mixed into the scenario's seed for the 3-D part's command jitter (the flat part's is
/// [`crate::lockstep`]'s).
const JITTER_SEED_3D: u64 = crate::lockstep::JITTER_SEED.rotate_left(17);

/// [`run_scenario`] with the host's controller stepped in lockstep with the simulator
/// ([`crate::lockstep`]: no sockets, no wall clock, the simulated motion capture as pose
/// input): deterministic, faster than real time. The run folder gets the same event files, the
/// trajectory plot and `telemetry.jsonl` with every robot's ground truth at 10 Hz (there is
/// no link telemetry).
pub fn run_scenario_lockstep(
    scenario: AsmScenario,
    sim: puzzlebot_sim::Scenario,
    runs_dir: &Path,
    max_duration: f64,
) -> anyhow::Result<AssemblyReport> {
    run_scenario_lockstep_with(scenario, sim, runs_dir, max_duration, Latency::default())
}

/// The controller's latency in a simulated run (ms): a fixed part and a uniform random part
/// on top, drawn from the scenario's seed.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Latency {
    /// Fixed part (ms).
    pub delay_ms: f64,
    /// Random part, uniform in [0, this) per tick (ms).
    pub jitter_ms: f64,
}

/// [`run_scenario_lockstep`] with the controller's commands acting `latency` after its
/// ticks, on the flat plant and in the 3-D world alike.
pub fn run_scenario_lockstep_with(
    scenario: AsmScenario,
    sim: puzzlebot_sim::Scenario,
    runs_dir: &Path,
    max_duration: f64,
    latency: Latency,
) -> anyhow::Result<AssemblyReport> {
    let sim = on_its_ground(&scenario, sim)?;
    let gate = GateConfig {
        terrain: sim.terrain.clone(),
        ..GateConfig::default()
    };
    let params = sim.params.clone();
    let name = format!("assembly-{}", scenario.name);
    let mut ls = crate::lockstep::Lockstep::new(&sim)?
        .command_delay(latency.delay_ms)
        .command_jitter(latency.jitter_ms);
    let mut ctl = AssemblyController::new(scenario, params, gate)?;
    ctl.hand_over_crossings = true;
    let mut folder = RunFolder::create(runs_dir, &name)?;
    // The simulator's ground-truth paths for the run folder's trajectory plot, at 10 Hz.
    let mut next = 0.0;
    let mut written = Ok(());
    let flat = ls.run(&mut ctl, max_duration, |w, t| {
        if t >= next {
            next = t + 0.1;
            for r in w.ground_truth().robots {
                let tr = folder.traces.entry(r.id).or_default();
                tr.actual.push((t, r.pose.x, r.pose.y));
                if written.is_ok() {
                    written = folder.telemetry(&TruthRecord::of(t, &r));
                }
            }
        }
    });
    let truth = ls.world.ground_truth();
    let crossed = match ctl.crossing_pending().map(std::path::Path::to_path_buf) {
        Some(file) => {
            let left = (max_duration - flat.t_end).max(0.0);
            let mut delay = crate::control::CommandDelay::new(sim.seed ^ JITTER_SEED_3D);
            delay.set_delay_ms(latency.delay_ms);
            delay.set_jitter_ms(latency.jitter_ms);
            let part = (flat.t_end, left);
            let w = cross_in_3d(&mut ctl, &sim, &truth, &file, part, &mut delay, |w, t| {
                crate::record::observe_3d(t, w);
                for r in w.states() {
                    let tr = folder.traces.entry(r.id).or_default();
                    tr.actual.push((t, r.position[0], r.position[1]));
                    if written.is_ok() {
                        written = folder.telemetry(&TruthRecord {
                            t,
                            robot: r.id,
                            truth: [r.position[0], r.position[1], r.rpy[2]],
                            v: r.speed,
                            omega: r.yaw_rate,
                            wheel_rpm: r.wheel_rpm,
                            duty: None,
                        });
                    }
                }
            })?;
            Some(w)
        }
        None => None,
    };
    written.context("writing telemetry.jsonl")?;
    write_events(&mut folder, &ctl)?;
    folder.finish()?;
    let mut report = report_of(&folder, &ctl, RunSummary::default(), &truth);
    if let Some(w) = &crossed {
        // The run ended in the 3-D world: its poses and falls are the run's.
        for r in w.states() {
            report
                .final_poses
                .insert(r.id, [r.position[0], r.position[1], r.rpy[2]]);
            if r.fallen && !report.fallen.contains(&r.id) {
                report.fallen.push(r.id);
            }
        }
        folder.write_json("crossings.json", &ctl.crossings)?;
    }
    folder.write_json("assembly_report.json", &report)?;
    Ok(report)
}

/// At a cross step the simulated robots move from the flat 2-D world into the 3-D world on
/// the step's terrain, with the poses, kinds and couplings they have there (the 3-D world
/// takes over where the assembly reaches terrain), and `ctl` goes on in it, its clock from
/// `t_flat` s, for up to `limit` s: the crossing and any steps after it, its commands acting
/// after `delay`. The 3-D world at the end.
fn cross_in_3d(
    ctl: &mut AssemblyController,
    sim: &puzzlebot_sim::Scenario,
    truth: &puzzlebot_sim::GroundTruth,
    file: &Path,
    (t_flat, limit): (f64, f64),
    delay: &mut crate::control::CommandDelay<crate::crossing::world_run::Sent>,
    hook: impl FnMut(&puzzlebot_sim::physics3d::World3d, f64),
) -> anyhow::Result<puzzlebot_sim::physics3d::World3d> {
    use puzzlebot_sim::physics3d::{Config3d, World3d};
    let terrain = ctl
        .terrain(file)
        .with_context(|| format!("terrain {} was not loaded", file.display()))?
        .clone();
    let robots = sim
        .robots
        .iter()
        .filter_map(|spec| {
            let r = truth.robot(spec.id).filter(|r| r.online && !r.fallen)?;
            Some(puzzlebot_sim::RobotSpec {
                pose: [r.pose.x, r.pose.y, r.pose.yaw],
                ..spec.clone()
            })
        })
        .collect();
    let couplings = truth
        .coupled
        .iter()
        .map(|&(a, b, kind)| puzzlebot_sim::CouplingSpec { kind, a, b })
        .collect();
    let s3 = puzzlebot_sim::Scenario {
        robots,
        couplings,
        terrain,
        ..sim.clone()
    };
    let mut w = World3d::new(&s3, Config3d::default())
        .map_err(|e| anyhow::anyhow!("the 3-D world at the cross step: {e}"))?;
    ctl.hand_over_crossings = false;
    crate::record::enter_3d(&s3.terrain);
    crate::crossing::world_run::run(&mut w, ctl, &sim.params, t_flat, limit, delay, hook);
    Ok(w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assemble::{parse_scenario, scattered_fleet};

    #[test]
    fn a_lockstep_run_records_every_robots_ground_truth_in_its_run_folder() {
        let runs = std::env::temp_dir().join(format!("pb-lockstep-{}", std::process::id()));
        let fleet = scattered_fleet(2, 0, 1);
        let text =
            "name = \"drive\"\n[[step]]\nmove = { velocity = [0.05, 0.0], duration_s = 2 }\n";
        let r = run_scenario_lockstep(parse_scenario("drive", text).unwrap(), fleet, &runs, 10.0)
            .unwrap();
        let lines: Vec<serde_json::Value> =
            std::fs::read_to_string(r.folder.join("telemetry.jsonl"))
                .unwrap()
                .lines()
                .map(|l| serde_json::from_str(l).unwrap())
                .collect();
        for id in [1, 2] {
            let mine: Vec<&serde_json::Value> = lines.iter().filter(|v| v["robot"] == id).collect();
            assert!(
                mine.len() >= 15,
                "robot {id}: {} records at 10 Hz over 2 s",
                mine.len()
            );
            // The records follow the robot: it drove forward, and the last one is where the
            // run ended.
            let end = mine.last().unwrap()["truth"].as_array().unwrap().clone();
            let end: Vec<f64> = end.iter().map(|x| x.as_f64().unwrap()).collect();
            let fin = r.final_poses[&id];
            assert!(
                (end[0] - fin[0]).hypot(end[1] - fin[1]) < 0.01,
                "{end:?} vs {fin:?}"
            );
            assert!(
                mine.iter().any(|v| v["v"].as_f64().unwrap() > 0.03),
                "robot {id} drove"
            );
        }
        let _ = std::fs::remove_dir_all(&runs);
    }
}
