//! The `puzzlebot` subcommands that run the simulator (feature `sim`): the demos, `sim`,
//! `experiment`, `run` on a simulated fleet and `calibrate` of a simulated robot.

use std::path::PathBuf;

use puzzlebot_assembly::Scenario as AsmScenario;
use puzzlebot_host::assemble;
use puzzlebot_host::config::Fleet;
use puzzlebot_host::live;
use puzzlebot_host::record::RunInfo;
use puzzlebot_sim::{Pace, Scenario, SimFleet, SimOptions};

use crate::cli::{Cmd, ExperimentCmd};
use crate::run_command::finish_assembly;

/// An assembly scenario on a simulated fleet: the controller in lockstep with the simulator
/// (on a blocking thread), or in real time over loopback UDP; with `live`, its live page on
/// that loopback port.
async fn run_assembly(
    scenario: AsmScenario,
    sim: Scenario,
    runs: &std::path::Path,
    limit: f64,
    lockstep: bool,
    live: Option<u16>,
) -> anyhow::Result<assemble::AssemblyReport> {
    let title = format!("assembly-{}", scenario.name);
    let live = live::serve_requested(live, || Ok(RunInfo::of_simulator(&sim)), &title).await?;
    let shown = puzzlebot_host::replay::progress::show();
    let crosses = scenario.steps.iter().any(|s| {
        matches!(
            s.behaviour,
            puzzlebot_host::assemble::assembly::scenario::Behaviour::Cross { .. }
        )
    });
    if crosses && !lockstep {
        tracing::info!(
            "the scenario crosses terrain: running in lockstep, where the 3-D world takes over \
             at the cross step"
        );
    }
    let report = if lockstep || crosses {
        let runs = runs.to_path_buf();
        let (report, _mcap) = tokio::task::spawn_blocking(move || {
            puzzlebot_host::record::run_scenario_lockstep(scenario, sim, &runs, limit)
        })
        .await??;
        report
    } else {
        assemble::run_scenario(scenario, sim, runs, limit, None).await?
    };
    drop(shown);
    live::finish(live).await;
    Ok(report)
}

/// Run a simulator subcommand (the CLI sends only those here).
pub async fn run(cmd: Cmd, runs: PathBuf) -> anyhow::Result<()> {
    match cmd {
        Cmd::Demo {
            tracking: false,
            realtime,
            json,
            live,
            ..
        } => {
            eprintln!(
                "puzzlebot demo: 6 simulated robots (2 pilots, set down in one lane; the others scattered) form a 2-row mesh and drive it 0.5 m ({}); the mesh then crosses a 40 mm gap one robot falls into, and comes apart on the far side (3-D world, lockstep)",
                if realtime {
                    "over loopback UDP in real time"
                } else {
                    "host controller in lockstep with the simulator"
                }
            );
            let t0 = std::time::Instant::now();
            let scenario = AsmScenario::from_toml_str(
                std::path::Path::new("demo.toml"),
                assemble::DEMO_SCENARIO,
                &puzzlebot_params::FleetParams::default().non_pilot.geometry,
            )?;
            let scenario = puzzlebot_host::crossing::demo::formation_part(scenario);
            let sim = assemble::demo_fleet();
            let kinds = sim.robots.iter().map(|r| (r.id, r.kind)).collect();
            let report = run_assembly(scenario, sim, &runs, 400.0, !realtime, live).await?;
            finish_assembly(&report, json)?;
            eprintln!("the formed mesh at a 40 mm gap in the 3-D world (the lab sets it down, a lone robot goes first)");
            let (crossing, folder) = tokio::task::spawn_blocking(move || {
                puzzlebot_host::crossing::demo::run(&report, &kinds).map(|c| (c, report.folder))
            })
            .await?
            .map_err(|e| anyhow::anyhow!("crossing: {e}"))?;
            let file = folder.join("crossing.json");
            std::fs::write(&file, serde_json::to_string_pretty(&crossing)?)?;
            if json {
                eprint!("{}", crossing.render());
            } else {
                print!("{}", crossing.render());
                println!("crossing   {}", file.display());
            }
            eprintln!("took {:.1} s", t0.elapsed().as_secs_f64());
            if !crossing.ok() {
                anyhow::bail!("the demo's crossing did not complete (see above)");
            }
        }
        Cmd::Run {
            scenario: Some(path),
            sim,
            robots,
            pilots,
            seed,
            limit,
            lockstep,
            json,
            live,
            ..
        } => {
            let params = puzzlebot_params::FleetParams::default();
            let scenario = AsmScenario::from_file(&path, &params.non_pilot.geometry)?;
            let sim = match sim {
                Some(p) => Scenario::from_file(&p)?,
                None => assemble::scattered_fleet(robots, pilots, seed),
            };
            let report = run_assembly(scenario, sim, &runs, limit, lockstep, live).await?;
            finish_assembly(&report, json)?;
        }
        Cmd::Experiment {
            command: ExperimentCmd::Coupling { runs: n, json },
        } => {
            let t0 = std::time::Instant::now();
            let stats = tokio::task::spawn_blocking(move || {
                puzzlebot_host::experiment::coupling_command(n, &runs)
            })
            .await??;
            if json {
                println!("{}", serde_json::to_string_pretty(&stats)?);
            } else {
                print!("{}", puzzlebot_host::experiment::describe(&stats));
                println!("finished in {:.1} s", t0.elapsed().as_secs_f64());
            }
        }
        Cmd::Experiment {
            command:
                ExperimentCmd::Crossing {
                    quick,
                    runs: n,
                    robots,
                    threads,
                    regate,
                    params,
                    json,
                },
        } => {
            use puzzlebot_host::experiment::{crossing, crossing_report};
            let mut opt = if quick {
                crossing::Options::quick()
            } else {
                crossing::Options::full()
            };
            if let Some(n) = n {
                if n == 0 {
                    anyhow::bail!("--runs: at least 1");
                }
                opt.runs = n;
            }
            if let Some(r) = robots {
                if r.is_empty() || r.iter().any(|&k| k == 0 || k > 12) {
                    anyhow::bail!("--robots: counts within 1..=12, got {r:?}");
                }
                opt.robots = r;
            }
            opt.threads = threads;
            if let Some(file) = params {
                opt.params = puzzlebot_params::FleetParams::from_file(&file)?;
            }
            let (s, text, dir) = tokio::task::spawn_blocking(move || {
                crossing_report::command(&opt, regate.as_deref(), &runs, !json)
            })
            .await??;
            if json {
                println!("{}", serde_json::to_string_pretty(&s)?);
            } else {
                print!("{text}");
                println!("folder     {}", dir.display());
            }
        }
        Cmd::Experiment {
            command:
                ExperimentCmd::CrossStep {
                    starts,
                    seed,
                    profile,
                    heading_deg,
                    robots,
                    threads,
                    keep_runs,
                    json,
                },
        } => {
            use puzzlebot_host::experiment::{cross_step, episode};
            let max = puzzlebot_stability::crossing::MAX_HEADING.to_degrees();
            if !(heading_deg.is_finite() && heading_deg.abs() < max) {
                anyhow::bail!("--heading-deg: within ±{max:.0}°, got {heading_deg}");
            }
            if !cross_step::ROBOTS.contains(&robots) {
                anyhow::bail!(
                    "--robots: {}-{} robots fit the start area, got {robots}",
                    cross_step::ROBOTS.start(),
                    cross_step::ROBOTS.end()
                );
            }
            let seed = seed.unwrap_or_else(|| {
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(1, |d| d.as_secs())
            });
            let opts = cross_step::Options {
                starts,
                seed,
                profile: episode::Profile::parse(&profile)?,
                heading_deg,
                robots,
                threads,
                keep_runs,
            };
            let t0 = std::time::Instant::now();
            let o = opts.clone();
            let results = tokio::task::spawn_blocking(move || cross_step::run(&o, &runs)).await??;
            if json {
                println!("{}", serde_json::to_string_pretty(&results)?);
            } else {
                print!("{}", cross_step::render(&opts, &results));
                println!("finished in {:.1} s", t0.elapsed().as_secs_f64());
            }
        }
        Cmd::Experiment {
            command:
                ExperimentCmd::Assemblies {
                    episodes,
                    profile,
                    seed,
                    replay,
                    threads,
                    shapes,
                    parallel,
                    max_robots,
                    latency_ms,
                    json,
                },
        } => {
            use puzzlebot_host::experiment::{assemblies, episode};
            let profile = episode::Profile::parse(&profile)?;
            let shapes_dir = shapes.unwrap_or_else(episode::default_shapes_dir);
            if !(0.0..=1.0).contains(&parallel) {
                anyhow::bail!("--parallel: a share within 0..=1, got {parallel}");
            }
            if let Some(ms) =
                latency_ms.filter(|ms| !(ms.is_finite() && (0.0..=1000.0).contains(ms)))
            {
                anyhow::bail!("--latency-ms: a mean latency within 0..=1000 ms, got {ms}");
            }
            let mut opts = assemblies::Options {
                episodes,
                profile,
                seed: 0,
                threads,
                shapes_dir,
                progress: !json,
                parallel,
                max_robots,
                latency_ms,
            };
            if let Some(seed) = replay {
                let o = tokio::task::spawn_blocking(move || assemblies::replay(&opts, seed, &runs))
                    .await??;
                if json {
                    println!("{}", serde_json::to_string_pretty(&o)?);
                }
                return Ok(());
            }
            opts.seed = seed.unwrap_or_else(|| {
                let s = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(1, |d| d.as_secs());
                eprintln!("seed {s} (from the clock; --seed {s} runs this batch again)");
                s
            });
            let s =
                tokio::task::spawn_blocking(move || assemblies::command(&opts, &runs)).await??;
            if json {
                println!("{}", serde_json::to_string_pretty(&s)?);
            }
        }
        Cmd::Demo { tracking: true, .. } => {
            println!("puzzlebot demo --tracking: 4 simulated robots over loopback UDP (2 lines of 0.4 m, 2 circles of r = 0.1 m)");
            let t0 = std::time::Instant::now();
            let report = puzzlebot_host::simulated::tracking::demo(&runs, true).await?;
            print!("{}", puzzlebot_host::app::describe(&report));
            println!("finished in {:.1} s", t0.elapsed().as_secs_f64());
        }
        Cmd::Sim { scenario, fleet } => {
            let fleet = Fleet::load(&fleet)?;
            let scenario = match scenario {
                Some(p) => Scenario::from_file(&p)?,
                None => Scenario::grid(4, 1),
            };
            let sim = SimFleet::start(
                scenario,
                SimOptions {
                    fleet_key: fleet.key.clone(),
                    host_addr: fleet.config.link.bind,
                    pose_addr: Some(fleet.config.pose.bind),
                    pace: Pace::RealTime,
                },
            )?;
            // The robots trust updates signed with the fleet's update key, as provisioned.
            sim.set_update_key(puzzlebot_host::fleet_update::verifying_key(&fleet.path)?);
            for (id, addr) in sim.robot_addrs() {
                println!("robot {id} on {addr}");
            }
            println!(
                "sending to host {} and poses to {}; Ctrl-C stops",
                fleet.config.link.bind, fleet.config.pose.bind
            );
            tokio::signal::ctrl_c().await?;
            sim.stop();
        }
        Cmd::Calibrate {
            robot, mode, out, ..
        } => {
            let report = puzzlebot_host::simulated::calibrate::run_cli(
                robot,
                mode.into(),
                out.as_deref(),
                &runs,
            )
            .await?;
            print!("{report}");
        }
        _ => anyhow::bail!("not a simulator subcommand"),
    }
    Ok(())
}
