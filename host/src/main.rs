//! `puzzlebot`: the PuzzleBot host CLI. With no arguments it runs the demo.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, Subcommand, ValueEnum};
use puzzlebot_assembly::Scenario as AsmScenario;
use puzzlebot_host::{app, assemble, calibrate, config::Fleet};

#[derive(Parser)]
#[command(
    name = "puzzlebot",
    version,
    about = "PuzzleBot fleet host: link, poses, drive mapping, calibration"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Cmd>,
    /// Folder that receives run folders.
    #[arg(long, global = true, default_value = "runs")]
    runs_dir: PathBuf,
}

#[derive(Clone, Copy, ValueEnum)]
enum BehaviourArg {
    Line,
    Circle,
}

#[derive(Clone, Copy, ValueEnum)]
enum ModeArg {
    /// Wheel-speed pairs (RPM; the units the host drives with).
    Speed,
    /// Raw duty pairs (per-mille; THESIS 3.5.1's open-loop PWM calibration).
    Duty,
}

#[derive(Clone, Copy, ValueEnum)]
enum KindArg {
    /// Four wheels, climbs a platform edge, turns poorly.
    Pilot,
    /// Two wheels and casters, turns on the spot.
    NonPilot,
}

#[derive(Subcommand)]
enum FleetCmd {
    /// Write fleet.toml (commented, loopback addresses, no robots yet) and a fresh 256-bit
    /// fleet.key (owner-only) into DIR; never overwrites either.
    Init {
        /// Folder (created if missing).
        #[arg(default_value = ".")]
        dir: PathBuf,
    },
    /// List a robot in the fleet config (never twice; the rest of the file is kept).
    Add {
        /// Robot id (as provisioned).
        #[arg(long)]
        id: u16,
        /// Pilot or non-pilot.
        #[arg(long, value_enum)]
        kind: KindArg,
        /// Fleet config (TOML).
        #[arg(long, default_value = "fleet.toml")]
        fleet: PathBuf,
    },
    /// Check a fleet before a run: the config and key load, every listed robot is online
    /// with a session and announces the kind it is listed as, firmware versions agree.
    /// Exits non-zero with the problems otherwise.
    Check {
        /// Fleet config (TOML).
        #[arg(long, default_value = "fleet.toml")]
        fleet: PathBuf,
        /// Wait at most this long for the robots (s).
        #[arg(long, default_value_t = 3.0)]
        seconds: f64,
    },
    /// Write robot ID's provisioning record (id, kind, key, Wi-Fi, host address) as a blob
    /// for `espflash write-bin` (firmware/README.md). The Wi-Fi password comes from
    /// --password-file or PUZZLEBOT_WIFI_PASSWORD (none: an open network).
    Provision {
        /// Robot id (listed in the fleet config).
        #[arg(long)]
        id: u16,
        /// Wi-Fi network name.
        #[arg(long)]
        ssid: String,
        /// File whose first line is the Wi-Fi password.
        #[arg(long)]
        password_file: Option<PathBuf>,
        /// Host address the robot sends to, a.b.c.d[:port]; default: the config's link.bind.
        #[arg(long)]
        host: Option<String>,
        /// Output file (owner-only; it holds the robot key); default robot-ID.bin.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Fleet config (TOML).
        #[arg(long, default_value = "fleet.toml")]
        fleet: PathBuf,
    },
    /// Sign a firmware image with the fleet's update key and send it to the robots over
    /// their sessions; each installs it, restarts and announces the new version (or refuses
    /// it and keeps running its current firmware).
    Update {
        /// Firmware image (the .bin espflash save-image writes).
        #[arg(long)]
        image: PathBuf,
        /// Version of the image, X.Y.Z; default: from its ESP-IDF app descriptor.
        #[arg(long)]
        version: Option<String>,
        /// Robots to update (repeatable); default: every listed robot.
        #[arg(long = "id")]
        ids: Vec<u16>,
        /// Fleet config (TOML).
        #[arg(long, default_value = "fleet.toml")]
        fleet: PathBuf,
        /// Give up on a robot silent for this long (s).
        #[arg(long, default_value_t = 10.0)]
        seconds: f64,
    },
    /// Create the update signing key (update.key) of a fleet set up without one.
    UpdateKey {
        /// Fleet config (TOML).
        #[arg(long, default_value = "fleet.toml")]
        fleet: PathBuf,
    },
    /// Print the key robot ID is provisioned with (64 hex characters; see firmware/README.md).
    RobotKey {
        /// Robot id.
        id: u16,
        /// Fleet config (TOML).
        #[arg(long, default_value = "fleet.toml")]
        fleet: PathBuf,
    },
}

#[derive(Subcommand)]
enum Cmd {
    /// The main job on a simulated fleet: 6 robots (2 pilots set down in one lane, the rest
    /// scattered) form a 2-row mesh and drive it 0.5 m (host/assembly/data/scenarios/demo.toml
    /// up to its decoupling), the host's controller in lockstep with the simulator; then the
    /// mesh crosses a 40 mm gap a lone robot falls into, at the heading the stability gate
    /// proves, and comes apart on the far platform (3-D world, lockstep).
    Demo {
        /// The link demo instead: 4 robots over loopback UDP track lines and circles.
        #[arg(long, conflicts_with = "realtime")]
        tracking: bool,
        /// Run the assembly demo over loopback UDP in real time instead of in lockstep (the
        /// controller's own latency makes formation less reliable: see the README's Status).
        #[arg(long)]
        realtime: bool,
        /// The assembly demo (the default; accepted for scripts of earlier versions).
        #[arg(long, hide = true, conflicts_with = "tracking")]
        assembly: bool,
        /// Print the run's summary as JSON on stdout (the table otherwise).
        #[arg(long, conflicts_with = "tracking")]
        json: bool,
        /// Serve the run live in a browser on 127.0.0.1:PORT (without =PORT: any free port)
        /// while it goes; the address is printed.
        #[arg(long, value_name = "PORT", num_args = 0..=1, require_equals = true,
              default_missing_value = "0", conflicts_with = "tracking")]
        live: Option<u16>,
    },
    /// Write replay.html (a self-contained page that plays the run back in a browser) and
    /// milestones.svg (footprints at the milestones) into a run folder.
    Replay {
        /// Run folder (with run.mcap, or telemetry.jsonl and events.jsonl).
        folder: PathBuf,
    },
    /// Run an assembly scenario file on the robots of a fleet config (after the pre-flight
    /// check) or on a simulated fleet, or drive a fleet's robots through a behaviour.
    Run {
        /// Assembly scenario file (TOML, host/assembly README); runs on the robots of --fleet,
        /// or else on a simulated fleet.
        scenario: Option<PathBuf>,
        /// Simulator scenario (robots, terrain, couplings) for an assembly scenario; default:
        /// robots scattered at random (see --robots, --pilots, --seed).
        #[arg(long)]
        sim: Option<PathBuf>,
        /// Robots of the default scattered fleet.
        #[arg(long, default_value_t = 4)]
        robots: usize,
        /// Pilots among them (the lowest ids).
        #[arg(long, default_value_t = 0)]
        pilots: usize,
        /// Seed of the scattered fleet.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Time limit of an assembly run (s).
        #[arg(long, default_value_t = 300.0)]
        limit: f64,
        /// Run an assembly scenario with the controller in lockstep with the simulator
        /// (simulated time as fast as the machine computes it, no network) instead of in
        /// real time over loopback UDP.
        #[arg(long)]
        lockstep: bool,
        /// Fleet config (TOML).
        #[arg(long, required_unless_present = "scenario")]
        fleet: Option<PathBuf>,
        /// Behaviour each robot performs from its current pose.
        #[arg(long, value_enum, default_value = "line")]
        behaviour: BehaviourArg,
        /// Line length or circle radius (m).
        #[arg(long, default_value_t = 0.4)]
        size: f64,
        /// Cruise speed (m/s).
        #[arg(long, default_value_t = 0.05)]
        speed: f64,
        /// Seconds to wait for the listed robots.
        #[arg(long, default_value_t = 5.0)]
        wait: f64,
        /// Print an assembly run's summary as JSON on stdout (the table otherwise).
        #[arg(long)]
        json: bool,
        /// Terrain the fleet's assemblies move over (TOML, `[[platforms]]`), for the
        /// stability gate of an assembly scenario run with --fleet; default: flat floor.
        #[arg(long, requires = "fleet")]
        terrain: Option<PathBuf>,
        /// Start even when the pre-flight check fails (logged with the reasons).
        #[arg(long)]
        force: bool,
        /// Serve the run live in a browser on 127.0.0.1:PORT (without =PORT: any free port)
        /// while it goes; the address is printed.
        #[arg(long, value_name = "PORT", num_args = 0..=1, require_equals = true,
              default_missing_value = "0")]
        live: Option<u16>,
    },
    /// Run a simulated fleet for an external host (until Ctrl-C).
    Sim {
        /// Scenario file (TOML); default: 4 robots in a row.
        #[arg(long)]
        scenario: Option<PathBuf>,
        /// Fleet config: its key file, link address (robots send there) and pose address.
        #[arg(long)]
        fleet: PathBuf,
    },
    /// Set up a fleet: a config and its key, the key of each robot.
    Fleet {
        #[command(subcommand)]
        cmd: FleetCmd,
    },
    /// Live table of the fleet: robot, kind, link, battery, RTT, state.
    Status {
        /// Fleet config (TOML).
        #[arg(long)]
        fleet: PathBuf,
        /// Stop after this many seconds (default: until Ctrl-C).
        #[arg(long)]
        seconds: Option<f64>,
    },
    /// Calibrate one robot (THESIS 3.5.1): k_v, k_ω, M_min, butterfly A and B.
    Calibrate {
        /// Robot id.
        #[arg(long)]
        robot: u16,
        /// Fleet config (TOML); without it a simulated robot is calibrated.
        #[arg(long)]
        fleet: Option<PathBuf>,
        /// Command space.
        #[arg(long, value_enum, default_value = "speed")]
        mode: ModeArg,
        /// Parameter file to write (default: robot-<id>.toml in the run folder).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Experiments.
    Experiment {
        #[command(subcommand)]
        command: ExperimentCmd,
    },
    /// Stability gate (SOCP): verdict, margin, worst connections of an assembly file.
    Gate {
        /// Assembly file (JSON or TOML; see host/stability/README.md).
        file: PathBuf,
        /// Print JSON.
        #[arg(long)]
        json: bool,
        /// Write an SVG of the assembly coloured by connection load.
        #[arg(long)]
        picture: Option<PathBuf>,
    },
    /// Assembly shapes.
    Shape {
        #[command(subcommand)]
        command: ShapeCmd,
    },
    /// Plans checked by the stability gate before anything moves.
    Plan {
        #[command(subcommand)]
        command: PlanCmd,
    },
}

#[derive(Subcommand)]
enum ExperimentCmd {
    /// THESIS 5.2.3: 25 start positions x runs of two robots coupling, in the lockstep simulator.
    Coupling {
        /// Runs per start position.
        #[arg(long, default_value_t = 5)]
        runs: usize,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
    /// THESIS 3.5.3 and 5.2.4 in the 3-D world: lines and meshes of 1-9 robots with 0-2
    /// pilots over gaps (10-105 mm, level and 6 mm down), descending steps and headings
    /// 0-50°, each run driven by its firmware, the gate's prediction beside it: the widest gap
    /// and highest step crossed per configuration next to THESIS, plots in the run folder.
    Crossing {
        /// A sample in minutes (gaps every 10 mm, headings 0°, 20°, 40°, meshes over level
        /// gaps every 5°, one run each) instead of the whole protocol.
        #[arg(long)]
        quick: bool,
        /// Runs per case (default: 5, or 1 with --quick).
        #[arg(long)]
        runs: Option<usize>,
        /// Only these robot counts (comma-separated, e.g. 4,8).
        #[arg(long, value_delimiter = ',')]
        robots: Option<Vec<usize>>,
        /// Worker threads (0: one per core).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Keep the physics' runs of this earlier `crossing.json` and re-run only the gate's
        /// side (seconds instead of minutes, for work on the gate).
        #[arg(long)]
        regate: Option<std::path::PathBuf>,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Randomized assembly episodes (fleet size 2-12, line / mesh / custom shapes, 0-2
    /// pilots, scattered starts, a move, half dissolved and dispersed) in the lockstep
    /// simulator: success per bucket with 95 % intervals, formation times, failure taxonomy.
    Assemblies {
        /// Number of episodes.
        #[arg(long, default_value_t = 100)]
        episodes: usize,
        /// Impairment profile: ideal, lab (30 ± 20 ms, 2 % loss, ±10 % model mismatch) or
        /// harsh (80 ± 50 ms, 10 % loss, 3× noise, ±20 %).
        #[arg(long, default_value = "ideal")]
        profile: String,
        /// Seed of the first episode (episode i has seed + i); default: from the clock,
        /// printed, so no fixed set of seeds is tuned to.
        #[arg(long)]
        seed: Option<u64>,
        /// Re-run the episode of this seed alone and write its run folder.
        #[arg(long, conflicts_with = "seed")]
        replay: Option<u64>,
        /// Worker threads (default: one per core).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Folder of the custom shapes (default: host/assembly/data/shapes).
        #[arg(long)]
        shapes: Option<PathBuf>,
        /// Share of the episodes (0-1) that form their shape in parallel (`grow = false`,
        /// THESIS Algorithm 3) instead of growing it, the default formation.
        #[arg(long, default_value_t = 0.0)]
        parallel: f64,
        /// Largest fleet drawn (6-12).
        #[arg(long, default_value_t = 12)]
        max_robots: usize,
        /// Mean controller latency (ms) instead of the profile's; its jitter, loss, noise and
        /// mismatch stay (e.g. `--profile ideal --latency-ms 60`: a 60 ms link, nothing else).
        #[arg(long)]
        latency_ms: Option<f64>,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand)]
enum PlanCmd {
    /// Rank shapes (line, meshes), pilot places (front, back) and headings (0-50°) for
    /// crossing the gap ahead along +x by the gate's margin, and say which can cross.
    Crossing(puzzlebot_stability::crossing::CrossingArgs),
}

#[derive(Subcommand)]
enum ShapeCmd {
    /// Slots, connection pairs, diagonal angle α and best heading (THESIS 5.2.4).
    Info {
        /// `line`, `mesh`, or a shape file (.toml or .json).
        shape: String,
        /// Number of robots (line and mesh).
        #[arg(long, default_value_t = 4)]
        robots: usize,
        /// Number of rows (mesh).
        #[arg(long, default_value_t = 2)]
        rows: usize,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

impl From<ModeArg> for calibrate::Mode {
    fn from(m: ModeArg) -> calibrate::Mode {
        match m {
            ModeArg::Speed => calibrate::Mode::Speed,
            ModeArg::Duty => calibrate::Mode::Duty,
        }
    }
}

#[cfg(feature = "sim")]
mod sim_commands;

/// A build without the simulator (feature `sim` off): its subcommands say what they need.
#[cfg(not(feature = "sim"))]
mod sim_commands {
    use super::Cmd;

    /// Refuse a simulator subcommand, naming the feature it needs.
    pub async fn run(cmd: Cmd, _runs: std::path::PathBuf) -> anyhow::Result<()> {
        let what = match cmd {
            Cmd::Demo { .. } => "`puzzlebot demo`",
            Cmd::Sim { .. } => "`puzzlebot sim`",
            Cmd::Experiment { .. } => "`puzzlebot experiment`",
            Cmd::Run { .. } => "`puzzlebot run` without --fleet (a simulated fleet)",
            _ => "`puzzlebot calibrate` without --fleet (a simulated robot)",
        };
        anyhow::bail!(
            "{what} needs the simulator, and this puzzlebot was built without the `sim` \
             feature (build it with default features: cargo build --release -p puzzlebot-host)"
        )
    }
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn,puzzlebot_host=info")),
        )
        .with_writer(|| puzzlebot_host::replay::progress::LogWriter)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    let cli = Cli::parse();
    let rt = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("error: cannot start the async runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    match rt.block_on(run(cli)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// The end of an assembly run: replay.html and milestones.svg written into its folder, the
/// summary on stdout (a table, or JSON with `json`), an error unless the scenario finished.
fn finish_assembly(report: &assemble::AssemblyReport, json: bool) -> anyhow::Result<()> {
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

async fn run(cli: Cli) -> anyhow::Result<()> {
    let runs = cli.runs_dir;
    match cli.command.unwrap_or(Cmd::Demo {
        tracking: false,
        realtime: false,
        assembly: false,
        json: false,
        live: None,
    }) {
        cmd @ (Cmd::Demo { .. }
        | Cmd::Sim { .. }
        | Cmd::Experiment { .. }
        | Cmd::Run {
            scenario: Some(_),
            fleet: None,
            ..
        }
        | Cmd::Calibrate { fleet: None, .. }) => sim_commands::run(cmd, runs).await?,
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
        Cmd::Replay { folder } => {
            let w = puzzlebot_host::replay::write(&folder)?;
            println!("{}\n{}", w.page.display(), w.picture.display());
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
        Cmd::Fleet { cmd } => match cmd {
            FleetCmd::Init { dir } => {
                let (config, key) = puzzlebot_host::fleet_setup::init(&dir)?;
                println!(
                    "wrote {} and {} (owner-only; keep it off the robots and out of version control)",
                    config.display(),
                    key.display()
                );
            }
            FleetCmd::Add { id, kind, fleet } => {
                let kind = match kind {
                    KindArg::Pilot => puzzlebot_params::RobotKind::Pilot,
                    KindArg::NonPilot => puzzlebot_params::RobotKind::NonPilot,
                };
                puzzlebot_host::fleet_setup::add_robot(&fleet, id, kind)?;
                println!("{}: robot {id} ({kind:?}) listed", fleet.display());
            }
            FleetCmd::Check { fleet, seconds } => {
                let fleet = Fleet::load(&fleet)?;
                let (link, _poses) = app::start_host(&fleet).await?;
                let listed = &fleet.config.robots;
                let end = tokio::time::Instant::now() + Duration::from_secs_f64(seconds.max(0.0));
                let mut report =
                    puzzlebot_host::fleet_setup::check_report(listed, &link.statuses());
                while !report.1.is_empty() && tokio::time::Instant::now() < end {
                    tokio::time::sleep(Duration::from_millis(200)).await;
                    report = puzzlebot_host::fleet_setup::check_report(listed, &link.statuses());
                }
                link.shutdown().await;
                print!("{}", report.0);
                if !report.1.is_empty() {
                    anyhow::bail!("fleet not ready: {}", report.1.join("; "));
                }
                println!("{}: ready", fleet.path.display());
            }
            FleetCmd::Provision {
                id,
                ssid,
                password_file,
                host,
                out,
                fleet,
            } => {
                use puzzlebot_host::fleet_provision as prov;
                // The config and its key first: a bad one is reported before any note.
                Fleet::load(&fleet)?;
                let req = prov::Request {
                    id,
                    ssid,
                    password: prov::read_password(password_file.as_deref())?,
                    host,
                };
                let update_key = puzzlebot_host::fleet_update::verifying_key(&fleet)?;
                if update_key.is_none() {
                    eprintln!(
                        "note: {} has no update key; this robot will refuse over-the-air updates",
                        fleet.display()
                    );
                }
                let blob = prov::record(&fleet, &req, update_key)?;
                let out = out.unwrap_or_else(|| PathBuf::from(format!("robot-{id}.bin")));
                prov::write_blob(&out, &blob)?;
                println!(
                    "wrote {} ({} bytes, owner-only); flash it with:\n  espflash write-bin {:#x} {}",
                    out.display(),
                    blob.len(),
                    prov::PARTITION_OFFSET,
                    out.display()
                );
            }
            FleetCmd::UpdateKey { fleet } => {
                let path = puzzlebot_host::fleet_setup::add_update_key(&fleet)?;
                println!(
                    "wrote {} (owner-only); re-provision the robots to trust it",
                    path.display()
                );
            }
            FleetCmd::Update {
                image,
                version,
                ids,
                fleet,
                seconds,
            } => {
                let fleet = Fleet::load(&fleet)?;
                let patience = Duration::from_secs_f64(seconds.max(1.0));
                let ids = if ids.is_empty() {
                    fleet.config.robots.iter().map(|r| r.id).collect()
                } else {
                    ids
                };
                // Key and image first: a bad one is reported before any robot is touched.
                puzzlebot_host::fleet_update::read_signing_key(&fleet.path)?;
                puzzlebot_host::fleet_update::read_image(&image, version.as_deref())?;
                let (link, _poses) = app::start_host(&fleet).await?;
                let done = puzzlebot_host::fleet_update::run(
                    &link,
                    &fleet.path,
                    &image,
                    version.as_deref(),
                    &ids,
                    patience,
                )
                .await;
                link.shutdown().await;
                for line in done? {
                    println!("{line}");
                }
            }
            FleetCmd::RobotKey { id, fleet } => {
                println!(
                    "{}",
                    puzzlebot_host::fleet_setup::robot_key_hex(&fleet, id)?
                );
            }
        },
        Cmd::Status { fleet, seconds } => {
            let fleet = Fleet::load(&fleet)?;
            let (link, _poses) = app::start_host(&fleet).await?;
            let end = seconds.map(|s| tokio::time::Instant::now() + Duration::from_secs_f64(s));
            let mut tick = tokio::time::interval(Duration::from_millis(500));
            loop {
                tokio::select! {
                    _ = tick.tick() => {
                        // Clear the screen and redraw the table.
                        print!("\x1b[2J\x1b[H{}", app::status_table(&link.statuses()));
                        if end.is_some_and(|e| tokio::time::Instant::now() >= e) {
                            break;
                        }
                    }
                    _ = tokio::signal::ctrl_c() => break,
                }
            }
            link.shutdown().await;
        }
        Cmd::Calibrate {
            robot,
            fleet: Some(fleet),
            mode,
            out,
        } => {
            let fleet = Fleet::load(&fleet)?;
            let report =
                calibrate::run_cli(robot, &fleet, mode.into(), out.as_deref(), &runs).await?;
            print!("{report}");
        }
        Cmd::Plan {
            command: PlanCmd::Crossing(args),
        } => {
            // The plan covers the host's own crossing drive unless told otherwise.
            #[cfg(feature = "sim")]
            let args = {
                use puzzlebot_host::crossing::drive3d::{crossing_options, CrossSettings};
                let mut args = args;
                if args.drive_accel.is_none() {
                    let p = puzzlebot_params::FleetParams::default();
                    args.drive_accel =
                        Some(crossing_options(&CrossSettings::default(), &p).drive_accel);
                }
                args
            };
            let out = args.run()?;
            println!("{}", out.trim_end());
        }
        Cmd::Gate {
            file,
            json,
            picture,
        } => {
            let out = puzzlebot_stability::gate_command(&file, json, picture.as_deref())?;
            println!("{}", out.trim_end());
        }
        Cmd::Shape {
            command:
                ShapeCmd::Info {
                    shape,
                    robots,
                    rows,
                    json,
                },
        } => {
            print!("{}", assemble::shape_info_text(&shape, robots, rows, json)?);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn demo(args: &[&str]) -> Result<(bool, bool), String> {
        let cli = Cli::try_parse_from(std::iter::once("puzzlebot").chain(args.iter().copied()))
            .map_err(|e| e.to_string())?;
        match cli.command {
            Some(Cmd::Demo {
                tracking, realtime, ..
            }) => Ok((tracking, realtime)),
            _ => Err("not a demo".into()),
        }
    }

    #[test]
    fn demo_runs_the_assembly_by_default_and_the_link_demo_on_request() {
        assert_eq!(demo(&["demo"]), Ok((false, false)));
        assert_eq!(demo(&["demo", "--realtime"]), Ok((false, true)));
        assert_eq!(demo(&["demo", "--tracking"]), Ok((true, false)));
        // Scripts written for `demo --assembly` keep working.
        assert_eq!(
            demo(&["demo", "--assembly", "--realtime"]),
            Ok((false, true))
        );
        // The link demo has no real-time switch (it always is).
        let err = demo(&["demo", "--tracking", "--realtime"]).expect_err("conflict");
        assert!(err.contains("--realtime"), "{err}");
    }

    fn live_of(args: &[&str]) -> Option<u16> {
        let cli = Cli::try_parse_from(std::iter::once("puzzlebot").chain(args.iter().copied()))
            .expect("arguments parse");
        match cli.command {
            Some(Cmd::Demo { live, .. }) | Some(Cmd::Run { live, .. }) => live,
            _ => None,
        }
    }

    #[test]
    fn live_takes_an_optional_port_and_leaves_the_scenario_alone() {
        assert_eq!(live_of(&["demo", "--realtime"]), None);
        assert_eq!(live_of(&["demo", "--realtime", "--live"]), Some(0));
        assert_eq!(live_of(&["demo", "--live=8080"]), Some(8080));
        // `--live` before the scenario file does not take it for a port.
        let cli = Cli::try_parse_from(["puzzlebot", "run", "--live", "line.toml"]).unwrap();
        match cli.command {
            Some(Cmd::Run { scenario, live, .. }) => {
                assert_eq!(scenario, Some(PathBuf::from("line.toml")));
                assert_eq!(live, Some(0));
            }
            _ => panic!("not a run"),
        }
    }
}
