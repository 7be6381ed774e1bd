//! The coupling experiment of THESIS 5.2.3: two robots, 25 start positions (5 × 5 grid,
//! 0.08–0.16 m apart along the heading, 0–0.08 m aside) × `runs` runs each. A pilot stands
//! still (not driven until coupled, THESIS 3.5.2); a non-pilot behind it aligns its front
//! opening with the pilot's anchor through the same [`AssemblyController`] the host uses
//! (coordinator → MPC), then inserts. t1 = time to "head aligned", t2 = time to "connected"
//! (Algorithm 8); success = coupled in the simulator's ground truth within 60 s.
//!
//! Runs use the simulator's lockstep world through [`Lockstep`] (no sockets, no wall clock):
//! the host's sessions, drive mapping and stabiliser at the command rate, the controller at
//! 10 Hz, poses from the simulator's ground truth (no motion-capture noise).

use std::path::{Path, PathBuf};

use plotters::prelude::*;
use puzzlebot_assembly::{EventKind, PairStatus, Scenario as AsmScenario};
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_sim::{EventKind as SimEventKind, RobotSpec, Scenario};
use serde::Serialize;

use crate::assemble::{AssemblyController, GateConfig};
use crate::lockstep::Lockstep;
use crate::report::RunFolder;

/// THESIS 5.2.3 figures.
pub const THESIS_ALIGNED_WITHIN_5S: f64 = 0.952;
/// THESIS 5.2.3: success within 60 s.
pub const THESIS_SUCCESS_WITHIN_60S: f64 = 0.944;
/// THESIS 5.2.3: mean coupling time (s).
pub const THESIS_MEAN_TIME_S: f64 = 9.38;
/// Time limit of one run (s).
pub const RUN_LIMIT_S: f64 = 60.0;

/// One run's outcome.
#[derive(Debug, Clone, Serialize)]
pub struct CouplingRun {
    /// Distance along the heading between the robot centres minus one body length (m).
    pub dx: f64,
    /// Lateral offset (m).
    pub dy: f64,
    /// Run index at this start position.
    pub run: usize,
    /// Time to head aligned (s).
    pub t1: Option<f64>,
    /// Time to connected (s).
    pub t2: Option<f64>,
    /// Coupled in the simulator's ground truth at the end.
    pub coupled: bool,
    /// Final pose of the non-pilot in the pilot's body frame (x, y m; yaw rad).
    pub final_relative: [f64; 3],
    /// Simulated seconds the run lasted.
    pub sim_s: f64,
}

/// Statistics of a batch.
#[derive(Debug, Clone, Serialize)]
pub struct CouplingStats {
    /// Runs.
    pub runs: Vec<CouplingRun>,
    /// Fraction aligned (t1) within 5 s.
    pub aligned_within_5s: f64,
    /// Fraction coupled within 60 s.
    pub success: f64,
    /// Mean t1 over aligned runs (s).
    pub mean_t1: f64,
    /// Mean t2 over successful runs (s).
    pub mean_t2: f64,
    /// Median t2 (s).
    pub median_t2: f64,
    /// Max t2 (s).
    pub max_t2: f64,
    /// Run folder.
    pub folder: Option<PathBuf>,
}

const FORM: &str =
    "name = \"coupling\"\n[[step]]\nform = { shape = \"line\", heading_deg = 0 }\ntimeout_s = 60\n";

/// One run: the pilot (id 2) at the origin facing +x, the non-pilot (id 1) `dx` behind the
/// coupled position and `dy` aside, with a seeded heading error of up to ±0.2 rad.
pub fn run_once(dx: f64, dy: f64, run: usize, seed: u64) -> anyhow::Result<CouplingRun> {
    let params = FleetParams::default();
    let length = f64::from(params.non_pilot.geometry.length);
    let yaw0 = {
        // Deterministic spread of initial headings per run (golden-ratio sequence).
        let u = ((seed as f64) * 0.618_033_988_75).fract();
        (u - 0.5) * 0.4
    };
    let scenario = Scenario {
        seed,
        robots: vec![
            RobotSpec {
                id: 1,
                kind: RobotKind::NonPilot,
                pose: [-(length + dx), dy, yaw0],
                impairments: None,
                offline: false,
                mismatch: puzzlebot_sim::PlantMismatch::NONE,
            },
            RobotSpec {
                id: 2,
                kind: RobotKind::Pilot,
                pose: [0.0, 0.0, 0.0],
                impairments: None,
                offline: false,
                mismatch: puzzlebot_sim::PlantMismatch::NONE,
            },
        ],
        params: params.clone(),
        ..Scenario::default()
    };
    let mut ls = Lockstep::new(&scenario)?;
    let asm =
        AsmScenario::from_toml_str(Path::new("coupling.toml"), FORM, &params.non_pilot.geometry)?;
    let mut ctl = AssemblyController::new(asm, params.clone(), GateConfig::default())?;
    ctl.settle = 0.0;
    ctl.log_milestones = false;
    let ls_run = ls.run(&mut ctl, RUN_LIMIT_S, |_, _| {});
    let w = &ls.world;
    let coupled_at = ls_run.sim_events.iter().find_map(|e| match e.kind {
        SimEventKind::Coupled { .. } if e.t_us >= ls_run.start_us => {
            Some((e.t_us - ls_run.start_us) as f64 * 1e-6)
        }
        _ => None,
    });
    let truth = w.ground_truth();
    let coupled = truth.are_coupled(2, 1);
    let final_relative = match (truth.robot(1), truth.robot(2)) {
        (Some(a), Some(b)) => {
            let (dx, dy) = (a.pose.x - b.pose.x, a.pose.y - b.pose.y);
            let (s, c) = b.pose.yaw.sin_cos();
            [c * dx + s * dy, -s * dx + c * dy, a.pose.yaw - b.pose.yaw]
        }
        _ => [f64::NAN; 3],
    };
    let sim_s = ls_run.t_end;
    let first = |s: PairStatus| {
        ctl.events.iter().find_map(|e| match &e.kind {
            EventKind::PairStatus { to, .. } if *to == s => Some(e.t),
            _ => None,
        })
    };
    let t1 = first(PairStatus::HeadAligned).or(first(PairStatus::Connected));
    let t2 = first(PairStatus::Connected)
        .filter(|_| coupled)
        .or(coupled_at.filter(|_| coupled));
    Ok(CouplingRun {
        dx,
        dy,
        run,
        t1,
        t2,
        coupled,
        final_relative,
        sim_s,
    })
}

/// The 5 × 5 grid × `runs` (THESIS 5.2.3), run on `threads` threads; `on_run` is called after
/// each run (progress).
pub fn run_all(
    runs: usize,
    threads: usize,
    on_run: &(dyn Fn() + Sync),
) -> anyhow::Result<Vec<CouplingRun>> {
    let mut jobs = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            for r in 0..runs {
                let dx = 0.08 + 0.02 * i as f64;
                jobs.push((
                    dx,
                    0.02 * j as f64,
                    r,
                    (i * 5 + j) as u64 * 1000 + r as u64 + 1,
                ));
            }
        }
    }
    let threads = threads.max(1);
    let chunks: Vec<Vec<(f64, f64, usize, u64)>> = (0..threads)
        .map(|k| jobs.iter().copied().skip(k).step_by(threads).collect())
        .collect();
    let results: Vec<anyhow::Result<Vec<CouplingRun>>> = std::thread::scope(|s| {
        let hs: Vec<_> = chunks
            .iter()
            .map(|c| {
                s.spawn(move || {
                    c.iter()
                        .map(|&(dx, dy, r, seed)| {
                            let run = run_once(dx, dy, r, seed);
                            on_run();
                            run
                        })
                        .collect::<anyhow::Result<Vec<_>>>()
                })
            })
            .collect();
        hs.into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err(anyhow::anyhow!("an experiment thread panicked")))
            })
            .collect()
    });
    let mut out = Vec::new();
    for r in results {
        out.extend(r?);
    }
    out.sort_by(|a, b| {
        (a.dx, a.dy, a.run)
            .partial_cmp(&(b.dx, b.dy, b.run))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    Ok(out)
}

/// Statistics of `runs`.
pub fn stats(runs: Vec<CouplingRun>) -> CouplingStats {
    let n = runs.len().max(1) as f64;
    let aligned = runs
        .iter()
        .filter(|r| r.t1.is_some_and(|t| t <= 5.0))
        .count() as f64;
    let t1: Vec<f64> = runs.iter().filter_map(|r| r.t1).collect();
    let mut t2: Vec<f64> = runs.iter().filter_map(|r| r.t2).collect();
    t2.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    let mean = |v: &[f64]| {
        if v.is_empty() {
            f64::NAN
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    };
    CouplingStats {
        aligned_within_5s: aligned / n,
        success: runs.iter().filter(|r| r.t2.is_some()).count() as f64 / n,
        mean_t1: mean(&t1),
        mean_t2: mean(&t2),
        median_t2: t2.get(t2.len() / 2).copied().unwrap_or(f64::NAN),
        max_t2: t2.last().copied().unwrap_or(f64::NAN),
        runs,
        folder: None,
    }
}

/// Text table next to THESIS's figures.
pub fn describe(s: &CouplingStats) -> String {
    let mut o = String::new();
    o.push_str(&format!(
        "coupling experiment (THESIS 5.2.3): {} runs\n",
        s.runs.len()
    ));
    o.push_str("                         this run    THESIS\n");
    o.push_str(&format!(
        "  aligned within 5 s     {:7.1} %   {:6.1} %\n",
        s.aligned_within_5s * 100.0,
        THESIS_ALIGNED_WITHIN_5S * 100.0
    ));
    o.push_str(&format!(
        "  success within 60 s    {:7.1} %   {:6.1} %\n",
        s.success * 100.0,
        THESIS_SUCCESS_WITHIN_60S * 100.0
    ));
    o.push_str(&format!(
        "  mean coupling time t2  {:7.2} s   {:6.2} s\n",
        s.mean_t2, THESIS_MEAN_TIME_S
    ));
    o.push_str(&format!(
        "  mean alignment t1      {:7.2} s\n  median / max t2        {:.2} / {:.2} s\n",
        s.mean_t1, s.median_t2, s.max_t2
    ));
    if let Some(f) = &s.folder {
        o.push_str(&format!("run folder: {}\n", f.display()));
    }
    o
}

/// Run the experiment, write `coupling.json` and `coupling.svg` (t1, t2 per start position)
/// into a new run folder.
pub fn coupling_command(runs: usize, runs_dir: &Path) -> anyhow::Result<CouplingStats> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let pb = crate::app::progress_bar((25 * runs) as f64, "runs");
    let result = run_all(runs, threads, &|| pb.inc(1));
    pb.finish_and_clear();
    let mut s = stats(result?);
    let folder = RunFolder::create(runs_dir, "coupling")?;
    folder.write_json("coupling.json", &s)?;
    plot(&folder.dir().join("coupling.svg"), &s).map_err(anyhow::Error::msg)?;
    s.folder = Some(folder.dir().to_path_buf());
    Ok(s)
}

fn plot(path: &Path, s: &CouplingStats) -> Result<(), String> {
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let n = s.runs.len() as f64;
    let tmax = s.runs.iter().filter_map(|r| r.t2).fold(5.0_f64, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Coupling experiment (THESIS 5.2.3): t1 alignment, t2 insertion",
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..n.max(1.0), 0.0..tmax)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("run (start positions dx, dy in order)")
        .y_desc("time (s)")
        .draw()
        .map_err(|e| e.to_string())?;
    let pts = |f: fn(&CouplingRun) -> Option<f64>| {
        s.runs
            .iter()
            .enumerate()
            .filter_map(move |(i, r)| f(r).map(|t| (i as f64, t)))
            .collect::<Vec<_>>()
    };
    chart
        .draw_series(
            pts(|r| r.t1)
                .into_iter()
                .map(|p| Circle::new(p, 3, BLUE.filled())),
        )
        .map_err(|e| e.to_string())?
        .label("t1 head aligned")
        .legend(|(x, y)| Circle::new((x, y), 3, BLUE.filled()));
    chart
        .draw_series(
            pts(|r| r.t2)
                .into_iter()
                .map(|p| Circle::new(p, 3, RED.filled())),
        )
        .map_err(|e| e.to_string())?
        .label("t2 connected")
        .legend(|(x, y)| Circle::new((x, y), 3, RED.filled()));
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coupling_experiment_meets_the_thesis_rates() {
        // One run per start position (25 runs) keeps the test quick; the command runs 5.
        let s = stats(run_all(1, 2, &|| {}).expect("experiment runs"));
        assert_eq!(s.runs.len(), 25);
        assert!(
            s.aligned_within_5s >= THESIS_ALIGNED_WITHIN_5S,
            "{}",
            describe(&s)
        );
        assert!(s.success >= THESIS_SUCCESS_WITHIN_60S, "{}", describe(&s));
        // Every success is a coupling in the simulator's ground truth, reached after t1.
        for r in s.runs.iter().filter(|r| r.t2.is_some()) {
            assert!(
                r.coupled && r.t1.is_some_and(|t1| t1 <= r.t2.unwrap_or(0.0)),
                "{r:?}"
            );
        }
    }
}
