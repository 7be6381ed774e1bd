//! `puzzlebot run SCENARIO.toml --fleet fleet.toml`: the assembly controller, the MPC and the
//! stability gate on the robots and pose source of a fleet config (real robots, or
//! `puzzlebot sim` in another process), after the pre-flight check.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::Context;
use puzzlebot_assembly::Scenario as AsmScenario;
use puzzlebot_params::terrain::Terrain;

use super::controller::AssemblyController;
use super::gate::GateConfig;
use super::report::{report_measured, write_events, AssemblyReport};
use crate::config::Fleet;
use crate::control::ControlLoop;
use crate::preflight::{self, PreflightLimits};
use crate::report::RunFolder;

/// How a scenario runs on a fleet.
#[derive(Debug, Clone)]
pub struct FleetRunOptions {
    /// Terrain file (TOML, `[[platforms]]` as in a simulator scenario's `[terrain]`); none:
    /// flat floor, the gate idle.
    pub terrain: Option<PathBuf>,
    /// Longest run (s).
    pub max_duration: f64,
    /// Longest wait for the listed robots before the pre-flight check decides (s).
    pub wait_s: f64,
    /// Start even when the pre-flight check fails (logged with its reasons).
    pub force: bool,
    /// Pre-flight limits; default: [`PreflightLimits::for_fleet`].
    pub limits: Option<PreflightLimits>,
}

impl Default for FleetRunOptions {
    fn default() -> Self {
        FleetRunOptions {
            terrain: None,
            max_duration: 600.0,
            wait_s: 5.0,
            force: false,
            limits: None,
        }
    }
}

/// Read a terrain file; errors name the file, line and field.
pub fn load_terrain(path: &Path) -> anyhow::Result<Terrain> {
    let t: Terrain = puzzlebot_params::load::from_toml_file(path)?;
    t.validate()
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(t)
}

/// Run `scenario` on the robots of `fleet` (parameters and calibration files from it),
/// recording into a new run folder under `runs_dir`: the pre-flight table in `preflight.txt`,
/// every pair status change and gate stop in `events.jsonl`, the coordinator events in
/// `assembly_events.jsonl`, the loop summary and the report. Refuses to start when the
/// pre-flight check fails, unless `opts.force`.
pub async fn run_scenario_on_fleet(
    scenario: AsmScenario,
    fleet: &Fleet,
    runs_dir: &Path,
    opts: &FleetRunOptions,
) -> anyhow::Result<AssemblyReport> {
    let params = fleet.config.params.clone();
    let terrain = match &opts.terrain {
        Some(p) => load_terrain(p)?,
        None => Terrain::flat(),
    };
    let gate = GateConfig {
        terrain,
        ..GateConfig::default()
    };
    let (link, poses) = crate::app::start_host(fleet).await?;
    let limits = opts
        .limits
        .clone()
        .unwrap_or_else(|| PreflightLimits::for_fleet(&params));
    let listed = &fleet.config.robots;
    let (table, problems) = preflight::check(
        &link,
        &poses.table,
        listed,
        &params,
        &limits,
        Duration::from_secs_f64(opts.wait_s.max(0.0)),
    )
    .await;
    eprint!("{table}");
    if let Err(e) = preflight::decide(&problems, opts.force) {
        link.shutdown().await;
        return Err(e);
    }
    let name = format!("assembly-{}", scenario.name);
    let mut ctl = AssemblyController::new(scenario, params, gate)?;
    let mut folder = RunFolder::create(runs_dir, &name)?;
    let mut pre = table;
    for p in &problems {
        pre.push_str(&format!("forced past: {p}\n"));
    }
    std::fs::write(folder.dir().join("preflight.txt"), pre).context("writing preflight.txt")?;
    let f2 = fleet.clone();
    let mut lp = ControlLoop::new(link.clone(), poses.table.clone(), move |id, kind| {
        f2.params_for(id, kind)
    });
    lp.options.max_duration = opts.max_duration;
    let summary = lp.run(&mut ctl, Some(&mut folder), None).await;
    link.shutdown().await;
    write_events(&mut folder, &ctl)?;
    folder.finish()?;
    folder.write_json("summary.json", &summary)?;
    let final_poses: BTreeMap<_, _> = listed
        .iter()
        .filter_map(|r| {
            poses
                .table
                .latest(r.id)
                .map(|p| (r.id, [p.x, p.y, p.theta]))
        })
        .collect();
    let report = report_measured(&folder, &ctl, summary, final_poses);
    folder.write_json("assembly_report.json", &report)?;
    Ok(report)
}
