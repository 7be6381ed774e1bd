//! `puzzlebot run --fleet FILE`: an assembly scenario or a simple behaviour on a fleet
//! config's robots, and the summary of an assembly run.

use std::path::PathBuf;
use std::time::Duration;

use puzzlebot_assembly::Scenario as AsmScenario;
use puzzlebot_host::config::Fleet;
use puzzlebot_host::{app, assemble};

use crate::cli::{BehaviourArg, Cmd};

/// The end of an assembly run: replay.html and milestones.svg written into its folder, the
/// summary on stdout (a table, or JSON with `json`), an error unless the scenario finished.
pub(crate) fn finish_assembly(report: &assemble::AssemblyReport, json: bool) -> anyhow::Result<()> {
    use puzzlebot_host::replay;
    let mut files = Vec::new();
    let timeline = match replay::write(&report.folder) {
        Ok(w) => {
            files.push(("replay".to_string(), w.page));
            files.push(("pictures".to_string(), w.picture));
            Some(w.timeline)
        }
        Err(e) => {
            tracing::warn!("no replay page: {e:#}");
            None
        }
    };
    let mcap = report.folder.join(puzzlebot_host::record::RUN_MCAP);
    if mcap.is_file() {
        files.push(("recording".to_string(), mcap));
    }
    let summary = replay::Summary::new(report, timeline.as_ref(), files);
    if json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        print!("{}", summary.table());
    }
    assemble::ensure_finished(report)
}

/// Run `puzzlebot run` on a fleet config's robots (the CLI sends only those here).
pub(crate) async fn run(cmd: Cmd, runs: PathBuf) -> anyhow::Result<()> {
    match cmd {
        Cmd::Run {
            scenario: Some(path),
            fleet: Some(fleet),
            terrain,
            force,
            limit,
            wait,
            json,
            live,
            ..
        } => {
            let fleet = Fleet::load(&fleet)?;
            let scenario = AsmScenario::from_file(&path, &fleet.config.params.non_pilot.geometry)?;
            let title = format!("assembly-{}", scenario.name);
            let info = || puzzlebot_host::live::info_of_fleet(&fleet, terrain.as_deref());
            let live = puzzlebot_host::live::serve_requested(live, info, &title).await?;
            let opts = assemble::FleetRunOptions {
                terrain,
                max_duration: limit,
                wait_s: wait,
                force,
                limits: None,
            };
            let report = assemble::run_scenario_on_fleet(scenario, &fleet, &runs, &opts).await;
            puzzlebot_host::live::finish(live).await;
            finish_assembly(&report?, json)?;
        }
        Cmd::Run {
            fleet,
            behaviour,
            size,
            speed,
            wait,
            force,
            live,
            ..
        } => {
            let Some(fleet) = fleet else {
                anyhow::bail!("`run` needs --fleet FILE or an assembly SCENARIO file");
            };
            let fleet = Fleet::load(&fleet)?;
            let info = || puzzlebot_host::live::info_of_fleet(&fleet, None);
            let live =
                puzzlebot_host::live::serve_requested(live, info, &fleet.config.name).await?;
            let b = match behaviour {
                BehaviourArg::Line => app::Behaviour::Line { length: size },
                BehaviourArg::Circle => app::Behaviour::Circle { radius: size },
            };
            let report = app::run_fleet(
                &fleet,
                b,
                speed,
                Duration::from_secs_f64(wait),
                &runs,
                force,
            )
            .await;
            puzzlebot_host::live::finish(live).await;
            print!("{}", app::describe(&report?));
        }
        _ => anyhow::bail!("not a run on a fleet"),
    }
    Ok(())
}
