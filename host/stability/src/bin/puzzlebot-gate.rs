//! `puzzlebot-gate`: run the stability gate on an assembly file, or export benchmark problems.

use clap::{Parser, Subcommand};
use puzzlebot_stability::bench_problems::{thread_cpu_seconds, Family};
use puzzlebot_stability::{Formulation, Options};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(about = "Quasi-static stability gate (SOCP) for modular assemblies")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Check an assembly file (.json or .toml): verdict, margin, worst connections, solve time.
    Check {
        /// Assembly file.
        file: PathBuf,
        /// Print the full report as JSON.
        #[arg(long)]
        json: bool,
        /// Write an SVG picture coloured by connection load.
        #[arg(long)]
        picture: Option<PathBuf>,
    },
    /// Time the gate on files (load excluded, model construction included): best and median
    /// wall-clock time and median CPU time of the solving thread.
    Time {
        /// Assembly files.
        files: Vec<PathBuf>,
        /// Repetitions per file.
        #[arg(long, default_value_t = 5)]
        repeat: usize,
        /// How the relaxed program is solved: structured (default; our block interior-point
        /// method), dual (Clarabel on the dual form), direct (Clarabel on the direct form).
        #[arg(long, value_enum, default_value_t = Formulation::Structured)]
        form: Formulation,
    },
    /// Rank shapes, pilot places and headings for crossing the gap ahead along +x by the
    /// gate's margin, and say which can cross.
    Crossing(puzzlebot_stability::crossing::CrossingArgs),
    /// Write a benchmark problem as JSON (families: chain, mesh, tree-ground, tree-hanging).
    Export {
        /// Family name.
        family: String,
        /// Number of modules.
        n: usize,
        /// Output file.
        out: PathBuf,
        /// Random seed (trees).
        #[arg(long, default_value_t = 7)]
        seed: u64,
    },
}

fn main() -> ExitCode {
    // A closed pipe (`… | head`) ends the program quietly instead of panicking in print.
    sigpipe::reset();
    let cli = Cli::parse();
    match cli.cmd {
        Cmd::Check {
            file,
            json,
            picture,
        } => match puzzlebot_stability::gate_command(&file, json, picture.as_deref()) {
            Ok(s) => {
                print!("{s}");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(2)
            }
        },
        Cmd::Crossing(args) => match args.run() {
            Ok(s) => {
                print!("{s}");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(2)
            }
        },
        Cmd::Time {
            files,
            repeat,
            form,
        } => {
            let opt = Options {
                formulation: form,
                ..Options::default()
            };
            for f in files {
                let a = match puzzlebot_stability::load_assembly(&f) {
                    Ok(a) => a,
                    Err(e) => {
                        eprintln!("error: {e}");
                        return ExitCode::from(2);
                    }
                };
                let mut times = Vec::new();
                let mut cpu = Vec::new();
                let mut last = None;
                for _ in 0..repeat.max(1) {
                    let c0 = thread_cpu_seconds();
                    let t = std::time::Instant::now();
                    let r = match puzzlebot_stability::evaluate_with(&a, opt) {
                        Ok(r) => r,
                        Err(e) => {
                            eprintln!("error: {}: {e}", f.display());
                            return ExitCode::from(2);
                        }
                    };
                    times.push(t.elapsed().as_secs_f64());
                    if let (Some(a), Some(b)) = (c0, thread_cpu_seconds()) {
                        cpu.push(b - a);
                    }
                    last = Some(r);
                }
                times.sort_by(f64::total_cmp);
                cpu.sort_by(f64::total_cmp);
                let cpu_median = if cpu.is_empty() {
                    "n/a".to_string()
                } else {
                    format!("{:.3} ms", cpu[cpu.len() / 2] * 1e3)
                };
                let n = a.modules.len();
                if let Some(r) = last {
                    println!(
                        "{}: n={n} verdict={} w_max={:.6} best {:.3} ms median {:.3} ms cpu median {cpu_median} ({:.1} µs/module) path={:?} iters={} fallbacks={} factorisations={} solves={} products={}",
                        f.display(),
                        r.verdict.name(),
                        r.max_strength.unwrap_or(f64::NAN),
                        times[0] * 1e3,
                        times[times.len() / 2] * 1e3,
                        times[0] * 1e6 / n as f64,
                        r.stats.path,
                        r.stats.iterations,
                        r.stats.fallbacks,
                        r.stats.factorisations,
                        r.stats.normal_solves,
                        r.stats.normal_products
                    );
                }
            }
            ExitCode::SUCCESS
        }
        Cmd::Export {
            family,
            n,
            out,
            seed,
        } => {
            let Some(f) = Family::parse(&family) else {
                eprintln!(
                    "error: unknown family {family:?} (chain, mesh, tree-ground, tree-hanging)"
                );
                return ExitCode::from(2);
            };
            if n == 0 {
                eprintln!("error: n must be ≥ 1");
                return ExitCode::from(2);
            }
            let a = f.build(n, seed);
            let text = match serde_json::to_string(&a) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(2);
                }
            };
            if let Err(e) = std::fs::write(&out, text) {
                eprintln!("error: {}: {e}", out.display());
                return ExitCode::from(2);
            }
            ExitCode::SUCCESS
        }
    }
}
