//! `puzzlebot-sim`: run a simulated PuzzleBot fleet on loopback for an external host.
//!
//! ```text
//! puzzlebot-sim --robots 4 --host 127.0.0.1:47800 --key-file fleet.key [--scenario s.toml]
//!               [--seed S] [--realtime] [--pose 127.0.0.1:47810] [--duration SECONDS]
//! ```
//! The key file holds the fleet key as 64 hexadecimal characters.

use clap::Parser;
use puzzlebot_protocol::{pose::DEFAULT_POSE_PORT, FleetKey, DEFAULT_HOST_PORT};
use puzzlebot_sim::{Pace, Scenario, SimFleet, SimOptions};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Run a simulated PuzzleBot fleet (real firmware logic, real protocol) on 127.0.0.1.
#[derive(Parser, Debug)]
#[command(name = "puzzlebot-sim", version)]
struct Args {
    /// Number of robots (ids 1..=N, non-pilots in rows of ten) when no scenario is given.
    #[arg(long, default_value_t = 4)]
    robots: usize,
    /// Host UDP address the robots send to (loopback only).
    #[arg(long, default_value_t = SocketAddr::from(([127, 0, 0, 1], DEFAULT_HOST_PORT)))]
    host: SocketAddr,
    /// File with the fleet key (64 hex characters).
    #[arg(long)]
    key_file: PathBuf,
    /// Scenario file (TOML): robots, terrain, impairments, mocap, seed.
    #[arg(long)]
    scenario: Option<PathBuf>,
    /// Seed (overrides the scenario's).
    #[arg(long)]
    seed: Option<u64>,
    /// Run paced to the wall clock (default: as fast as possible).
    #[arg(long)]
    realtime: bool,
    /// Send motion-capture frames (pose stream) to this loopback address.
    #[arg(long)]
    pose: Option<SocketAddr>,
    /// Also send the pose stream to the default pose port on 127.0.0.1.
    #[arg(long, conflicts_with = "pose")]
    default_pose: bool,
    /// Stop after this many wall-clock seconds (default: run until killed).
    #[arg(long)]
    duration: Option<f64>,
}

fn main() -> ExitCode {
    // A closed pipe (`… | head`) ends the program quietly instead of panicking in print.
    sigpipe::reset();
    let args = Args::parse();
    match run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("puzzlebot-sim: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<(), String> {
    let text = std::fs::read_to_string(&args.key_file)
        .map_err(|e| format!("{}: cannot read: {e}", args.key_file.display()))?;
    let key = FleetKey::from_hex(&text).ok_or_else(|| {
        format!(
            "{}: expected the fleet key as 64 hexadecimal characters",
            args.key_file.display()
        )
    })?;
    let mut scenario = match &args.scenario {
        Some(p) => Scenario::from_file(p).map_err(|e| e.to_string())?,
        None => Scenario::grid(args.robots, 1),
    };
    if let Some(s) = args.seed {
        scenario.seed = s;
    }
    if let Some(d) = args.duration {
        if !(d.is_finite() && d > 0.0) {
            return Err(format!(
                "--duration: must be a positive number of seconds, got {d}"
            ));
        }
    }
    let pose_addr = args.pose.or(args
        .default_pose
        .then(|| SocketAddr::from(([127, 0, 0, 1], DEFAULT_POSE_PORT))));
    let pace = if args.realtime {
        Pace::RealTime
    } else {
        Pace::AsFastAsPossible
    };
    let fleet = SimFleet::start(
        scenario,
        SimOptions {
            fleet_key: key,
            host_addr: args.host,
            pose_addr,
            pace,
        },
    )
    .map_err(|e| e.to_string())?;
    for (id, addr) in fleet.robot_addrs() {
        println!("robot {id} {addr}");
    }
    println!("host {} pace {:?}", args.host, pace);
    let start = Instant::now();
    let mut last_report = Instant::now();
    loop {
        std::thread::sleep(Duration::from_millis(100));
        if let Some(d) = args.duration {
            if start.elapsed().as_secs_f64() >= d {
                break;
            }
        }
        if last_report.elapsed() >= Duration::from_secs(5) {
            last_report = Instant::now();
            let t = fleet.ground_truth();
            let online = t.robots.iter().filter(|r| r.online).count();
            let sessions = t
                .robots
                .iter()
                .filter(|r| r.firmware.is_some_and(|f| f.established))
                .count();
            println!(
                "t={:.1}s robots online {online} in session {sessions} coupled pairs {} events {}",
                t.time_us as f64 * 1e-6,
                t.coupled.len(),
                t.events.len()
            );
        }
    }
    fleet.stop();
    Ok(())
}
