//! `puzzlebot-shape info line|mesh|FILE [--robots N] [--rows R] [--json]`: facts about a shape
//! (slots, connection pairs, diagonal angle α and best heading, THESIS 5.2.4).

use clap::{Parser, Subcommand};
use puzzlebot_assembly::{shape_info, Shape};
use puzzlebot_params::FleetParams;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "puzzlebot-shape", about = "PuzzleBot assembly shapes")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Show slots, pairs, diagonal angle and best heading of a shape.
    Info {
        /// `line`, `mesh`, or a shape file (.toml or .json).
        shape: String,
        /// Number of robots (line and mesh).
        #[arg(long, default_value_t = 4)]
        robots: usize,
        /// Number of rows (mesh).
        #[arg(long, default_value_t = 2)]
        rows: usize,
        /// Fleet parameter file (TOML) for the body geometry.
        #[arg(long)]
        params: Option<PathBuf>,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<(), Box<dyn std::error::Error>> {
    match cli.command {
        Command::Info {
            shape,
            robots,
            rows,
            params,
            json,
        } => {
            let fleet = match params {
                Some(p) => FleetParams::from_file(&p)?,
                None => FleetParams::default(),
            };
            let g = fleet.non_pilot.geometry;
            let s = match shape.as_str() {
                "line" => Shape::line(robots, &g)?,
                "mesh" => Shape::mesh(robots, rows, &g)?,
                file => Shape::from_file(std::path::Path::new(file), &g)?,
            };
            let info = shape_info(&s, &g);
            if json {
                println!("{}", serde_json::to_string_pretty(&info)?);
            } else {
                print!("{info}");
            }
            Ok(())
        }
    }
}
