//! The `puzzlebot` command line: its subcommands and their arguments.

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};
use puzzlebot_host::calibrate;

#[derive(Parser)]
#[command(
    name = "puzzlebot",
    version,
    about = "PuzzleBot fleet host: link, poses, drive mapping, calibration"
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Option<Cmd>,
    /// Folder that receives run folders.
    #[arg(long, global = true, default_value = "runs")]
    pub(crate) runs_dir: PathBuf,
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum BehaviourArg {
    Line,
    Circle,
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum ModeArg {
    /// Wheel-speed pairs (RPM; the units the host drives with).
    Speed,
    /// Raw duty pairs (per-mille; THESIS 3.5.1's open-loop PWM calibration).
    Duty,
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum KindArg {
    /// Four wheels, climbs a platform edge, turns poorly.
    Pilot,
    /// Two wheels and casters, turns on the spot.
    NonPilot,
}

#[derive(Subcommand)]
pub(crate) enum FleetCmd {
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
pub(crate) enum Cmd {
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
pub(crate) enum ExperimentCmd {
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
        /// side (seconds instead of minutes, for work on the gate), with the parameters
        /// stored with the runs.
        #[arg(long, conflicts_with = "params")]
        regate: Option<std::path::PathBuf>,
        /// The robots' parameters (TOML, any fields of the parameter set; the rest default),
        /// for the physics and the gate alike: your own robots, or a sensitivity study.
        #[arg(long)]
        params: Option<std::path::PathBuf>,
        /// Print the summary as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The scenario cross step from fresh starts: four robots unless told (the pilot set
    /// down facing a 25 mm gap, the non-pilots scattered behind it) grow a mesh of two rows
    /// and cross (host/assembly/data/scenarios/cross_gap.toml) in lockstep; counts of
    /// crossed, backed off after a gate stop, refused, stopped, fallen, not formed.
    CrossStep {
        /// Number of starts.
        #[arg(long, default_value_t = 30)]
        starts: usize,
        /// Seed of the first start (start i has seed + i); default: from the clock, printed.
        #[arg(long)]
        seed: Option<u64>,
        /// Impairment profile: ideal, lab or harsh (controller latency, link loss, motion
        /// capture, plant mismatch as for `experiment assemblies`).
        #[arg(long, default_value = "ideal")]
        profile: String,
        /// The pilot's heading from the crossing direction (degrees).
        #[arg(long, default_value_t = 50.0)]
        heading_deg: f64,
        /// Robots, the pilot among them (2-8): they grow a mesh of two rows (of 3 and 2
        /// for 5 robots, 4 and 3 for 7).
        #[arg(long, default_value_t = 4)]
        robots: usize,
        /// Worker threads (0: one per core).
        #[arg(long, default_value_t = 0)]
        threads: usize,
        /// Keep every start's run folder under <runs-dir>/cross-step-<seed>/ (for
        /// `puzzlebot replay`), instead of removing it.
        #[arg(long)]
        keep_runs: bool,
        /// Print the results as JSON.
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
pub(crate) enum PlanCmd {
    /// Rank shapes (line, meshes), pilot places (front, back) and headings (0-50°) for
    /// crossing the gap ahead along +x by the gate's margin, and say which can cross.
    Crossing(puzzlebot_stability::crossing::CrossingArgs),
}

#[derive(Subcommand)]
pub(crate) enum ShapeCmd {
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
