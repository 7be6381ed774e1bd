//! `puzzlebot`: the PuzzleBot host CLI. With no arguments it runs the demo.

use std::process::ExitCode;
use std::time::Duration;

use clap::Parser;
use puzzlebot_host::{app, assemble, calibrate, config::Fleet};

mod cli;
mod fleet_commands;
mod run_command;

use cli::{Cli, Cmd, PlanCmd, ShapeCmd};

#[cfg(feature = "sim")]
mod sim_commands;

/// A build without the simulator (feature `sim` off): its subcommands say what they need.
#[cfg(not(feature = "sim"))]
mod sim_commands {
    use crate::cli::Cmd;

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
    // A closed pipe (`… | head`) ends the program quietly instead of panicking in print.
    sigpipe::reset();
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
        cmd @ Cmd::Run { .. } => run_command::run(cmd, runs).await?,
        Cmd::Replay { folder } => {
            let w = puzzlebot_host::replay::write(&folder)?;
            println!("{}\n{}", w.page.display(), w.picture.display());
        }
        Cmd::Fleet { cmd } => fleet_commands::run(cmd).await?,
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
                let host = crossing_options(&CrossSettings::default(), &args.fleet_params()?);
                args.drive_accel = args.drive_accel.or(Some(host.drive_accel));
                args.speed = args.speed.or(Some(host.bridge_speed));
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
