//! `puzzlebot experiment crossing`: THESIS's gap-crossing protocol (3.5.3, 5.2.4) in the 3-D
//! world. Lines and meshes of 1, 2, 4, 6, 8 and 9 robots with no pilot, one pilot in front or
//! at the back, or two (front and back); gaps of 10–105 mm in 5 mm steps between platforms of
//! equal height and with the far one 6 mm lower; descending steps in 6 mm increments; headings
//! 0–50° in 10°; 5 runs each with a seeded jitter of the start pose. Each series
//! (configuration × heading × obstacle kind) is searched by bisection for the largest
//! obstacle crossed with > 80 % completion. Each run is driven
//! through the firmware without the gate (the physics alone decides), and the gate's
//! prediction for the same start stands beside it ([`super::crossing_report`]).

use super::tip_point::{static_tip_point, TipSearch};
use super::workers::map_parallel;
use crate::crossing::drive3d::{self, CrossSettings};
use crate::crossing::formed::Formed;
use puzzlebot_params::formation::{self, Shape};
use puzzlebot_params::terrain::{Platform, Terrain};
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_sim::physics3d::{assembly::jitter, World3d};
use puzzlebot_sim::Scenario;
use puzzlebot_stability::crossing::Candidate;
use puzzlebot_stability::crossing::{formed, pilot_sets, plan_formed, CrossingOptions};
use puzzlebot_stability::puzzlebot::Advance;
use puzzlebot_stability::puzzlebot::{max_safe_advance_with, AdvanceOptions};
use serde::{Deserialize, Serialize};

/// Height difference of THESIS 3.5.3's gaps (m): the far platform 6 mm lower.
pub const GAP_DROP: f64 = 0.006;
/// Increment of the descending steps (m), THESIS 5.2.4.
pub const STEP_INCREMENT: f64 = 0.006;
/// Completion above which an obstacle counts as crossed (THESIS 5.2.4: > 80 %).
pub const CROSSED: f64 = 0.8;
/// Start-pose jitter of repeated runs: position (m) and heading (rad).
pub const JITTER: (f64, f64) = (0.002, 0.02);

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Robot counts.
    pub robots: Vec<usize>,
    /// Gap widths (m).
    pub gaps: Vec<f64>,
    /// Step heights (m).
    pub steps: Vec<f64>,
    /// Headings (degrees) for every configuration.
    pub headings: Vec<f64>,
    /// Headings (degrees) of the meshes over level gaps, where completion against heading is
    /// measured (THESIS Figure 5.7 C): finer, to find the optimum near α.
    pub mesh_headings: Vec<f64>,
    /// Runs per case.
    pub runs: usize,
    /// Worker threads (0: one per core).
    pub threads: usize,
    /// Base seed.
    pub seed: u64,
    /// The robots' parameters, for the physics and the gate alike.
    pub params: FleetParams,
}

impl Options {
    /// THESIS's whole protocol.
    pub fn full() -> Options {
        Options {
            robots: vec![1, 2, 4, 6, 8, 9],
            gaps: (0..20).map(|k| 0.010 + 0.005 * f64::from(k)).collect(),
            steps: (1..=10).map(|k| STEP_INCREMENT * f64::from(k)).collect(),
            headings: (0..6).map(|k| 10.0 * f64::from(k)).collect(),
            mesh_headings: (0..=10).map(|k| 5.0 * f64::from(k)).collect(),
            runs: 5,
            threads: 0,
            seed: 1,
            params: FleetParams::default(),
        }
    }

    /// A sample in minutes: gaps every 10 mm, steps up to 36 mm, headings 0°, 20° and 40°
    /// (meshes over level gaps every 5°), one run each.
    pub fn quick() -> Options {
        Options {
            gaps: (0..10).map(|k| 0.010 + 0.010 * f64::from(k)).collect(),
            steps: (1..=6).map(|k| STEP_INCREMENT * f64::from(k)).collect(),
            headings: vec![0.0, 20.0, 40.0],
            runs: 1,
            ..Options::full()
        }
    }
}

/// A formed assembly of the protocol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Config {
    /// `line 4`, `mesh 2x2`.
    pub shape: String,
    /// Robots.
    pub robots: usize,
    /// Line or mesh.
    pub mesh: bool,
    /// `none`, `front`, `back`, `front+back`.
    pub pilots: String,
    /// Pilot places (row-major, front first).
    pub pilot_places: Vec<usize>,
    /// Length of the assembly along its rows (m).
    pub length: f64,
    /// Diagonal angle α (degrees).
    pub alpha_deg: f64,
    #[serde(skip)]
    shape_value: Option<Shape>,
}

/// The configurations of `robots` robots: a line and the 2-row mesh (3 × 3 for nine), each
/// with no pilot, one in front, one at the back, and two (front and back).
pub fn configs(robots: &[usize], params: &FleetParams) -> Vec<Config> {
    let g = &params.non_pilot.geometry;
    let mut out = Vec::new();
    for &n in robots {
        let mut shapes = vec![Shape::Line(n)];
        if n >= 4 {
            let rows = if n % 2 == 0 { 2 } else { 3 };
            if n % rows == 0 {
                shapes.push(Shape::Mesh {
                    rows,
                    per_row: n / rows,
                });
            }
        }
        for shape in shapes {
            let (_, per_row) = shape.rows();
            let mut sets: Vec<(String, Vec<usize>)> = vec![("none".into(), vec![])];
            sets.push(("front".into(), vec![0]));
            if per_row > 1 {
                sets.push(("back".into(), vec![per_row - 1]));
                let two = pilot_sets(shape, 2)
                    .into_iter()
                    .map(|(_, s)| s)
                    .find(|s| s.contains(&0) && s.contains(&(per_row - 1)))
                    .unwrap_or_else(|| vec![0, per_row - 1]);
                sets.push(("front+back".into(), two));
            }
            for (name, set) in sets {
                out.push(Config {
                    shape: shape.name(),
                    robots: n,
                    mesh: matches!(shape, Shape::Mesh { .. }),
                    pilots: name,
                    pilot_places: set,
                    length: formation::footprint(shape, g)[0],
                    alpha_deg: formation::diagonal_angle(shape, g).to_degrees(),
                    shape_value: Some(shape),
                });
            }
        }
    }
    out
}

/// An obstacle: a gap of `width` with the far platform `drop` lower (a step when the width
/// is nil).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Obstacle {
    /// Gap width (m).
    pub width: f64,
    /// How much lower the far platform is (m).
    pub drop: f64,
}

impl Obstacle {
    /// A descending step (the platforms 0.5 mm apart: they may not overlap).
    pub fn step(drop: f64) -> Obstacle {
        Obstacle { width: 0.0, drop }
    }

    /// Its terrain: the near platform up to x = 0, the far one beyond the gap.
    pub fn terrain(&self) -> Terrain {
        let w = self.width.max(0.0005);
        Terrain {
            platforms: vec![
                Platform::rect("near", [-1.5, -1.5], [0.0, 1.5], self.drop),
                Platform::rect("far", [w, -1.5], [w + 1.5, 1.5], 0.0),
            ],
        }
    }
}

/// One run's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CrossRun {
    /// Index into the configurations.
    pub config: usize,
    /// The obstacle.
    pub obstacle: Obstacle,
    /// Heading (degrees).
    pub heading_deg: f64,
    /// Run number.
    pub run: usize,
    /// Share of the robots on the far platform at the end.
    pub completion: f64,
    /// Advance the crossing needs (m).
    pub required: f64,
    /// The gate's proven advance from the run's own (jittered) start (m), measured couplings.
    pub gate_advance: f64,
    /// What limits the gate there.
    pub gate_limited_by: String,
    /// The farthest advance at which the gate lets the assembly stand still (m): the start
    /// of its first stretch proven only at speed ([`Advance::stop_limit`]); None: the whole
    /// advance.
    #[serde(default)]
    pub gate_stop_limit: Option<f64>,
    /// The gate's proven advance with unbreakable couplings (m).
    pub rigid_advance: f64,
    /// Advance at which a robot fell (in runs that end with robots short of the far
    /// platform) or a connector opened in the physics (m).
    pub physics_fail: Option<f64>,
    /// What failed first: `fell` or `broke`.
    pub fail_kind: Option<String>,
    /// The physics' static tipping point (m): the farthest advance at which the assembly,
    /// driven there and stopped, stands ([`super::tip_point`]); measured in the first run of
    /// each case of a mesh that fell (a search costs several runs).
    #[serde(default)]
    pub physics_tip: Option<f64>,
}

impl CrossRun {
    /// The first advance at which the physics failed (m): the static tipping point where
    /// it was measured, else the advance of the first fall or opened connector.
    pub fn physics_limit(&self) -> Option<f64> {
        match (self.physics_tip, self.physics_fail) {
            (Some(t), Some(f)) => Some(t.min(f)),
            (t, f) => t.or(f),
        }
    }

    /// The gate called safe an advance at which the driven run failed.
    pub fn gate_overconfident(&self) -> bool {
        self.physics_fail
            .is_some_and(|f| self.gate_advance > f + 1e-3)
    }

    /// The gate called safe an advance past the physics' static tipping point (where
    /// measured): stopped there, the assembly falls.
    pub fn gate_past_tip(&self) -> bool {
        let stands = self.gate_stop_limit.unwrap_or(self.gate_advance);
        self.physics_tip.is_some_and(|t| stands > t + 1e-3)
    }
}

struct Case {
    config: usize,
    obstacle: Obstacle,
    heading_deg: f64,
}

/// Obstacles of one kind for one configuration and heading, smallest first: the experiment
/// looks for the largest it crosses by bisection.
struct Series {
    config: usize,
    heading_deg: f64,
    obstacles: Vec<Obstacle>,
}

/// Every series of `opt`: per configuration and heading, the gaps with the far platform
/// lower, the level gaps and the steps.
fn series(opt: &Options, configs: &[Config]) -> Vec<Series> {
    let gaps = |drop: f64| -> Vec<Obstacle> {
        opt.gaps
            .iter()
            .map(|&width| Obstacle { width, drop })
            .collect()
    };
    let steps: Vec<Obstacle> = opt.steps.iter().map(|&h| Obstacle::step(h)).collect();
    let mut out = Vec::new();
    for (c, cfg) in configs.iter().enumerate() {
        let mut push = |headings: &[f64], obstacles: &Vec<Obstacle>| {
            if obstacles.is_empty() {
                return;
            }
            for &h in headings {
                out.push(Series {
                    config: c,
                    heading_deg: h,
                    obstacles: obstacles.clone(),
                });
            }
        };
        push(&opt.headings, &gaps(GAP_DROP));
        let level = if cfg.mesh && !opt.mesh_headings.is_empty() {
            &opt.mesh_headings
        } else {
            &opt.headings
        };
        push(level, &gaps(0.0));
        push(&opt.headings, &steps);
    }
    out
}

/// Run a series by bisection: the largest obstacle crossed with more than [`CROSSED`]
/// completion, taking completion to fall as the obstacle grows; ⌈log2(n + 1)⌉ cases of n.
fn run_series(
    s: &Series,
    cfg: &Config,
    opt: &Options,
    params: &FleetParams,
) -> (Vec<CrossRun>, Vec<String>) {
    let (mut runs, mut skipped) = (Vec::new(), Vec::new());
    // Indices: `lo` crossed (−1: none known), `hi` not crossed (n: none known).
    let (mut lo, mut hi) = (-1i64, s.obstacles.len() as i64);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        let case = Case {
            config: s.config,
            obstacle: s.obstacles[mid as usize],
            heading_deg: s.heading_deg,
        };
        match run_case(&case, cfg, opt.runs.max(1), opt.seed, params) {
            Ok(v) => {
                let mean = v.iter().map(|r| r.completion).sum::<f64>() / v.len().max(1) as f64;
                runs.extend(v);
                if mean > CROSSED {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            Err(e) => {
                skipped.push(format!(
                    "{} {} w {:.0} mm drop {:.0} mm θ {}°: {e}",
                    cfg.shape,
                    cfg.pilots,
                    case.obstacle.width * 1e3,
                    case.obstacle.drop * 1e3,
                    case.heading_deg
                ));
                hi = mid;
            }
        }
    }
    (runs, skipped)
}

/// The gate's prediction for one case: the planner's candidate (measured coupling limits)
/// and the advance it proves with unbreakable couplings.
pub fn predict(
    cfg: &Config,
    obstacle: Obstacle,
    heading_deg: f64,
    params: &FleetParams,
) -> Result<(Candidate, Advance), String> {
    let shape = cfg.shape_value.ok_or("configuration without a shape")?;
    let links = formation::layout(shape, &params.non_pilot.geometry).1;
    let terrain = obstacle.terrain();
    let heading = heading_deg.to_radians();
    let opt = CrossingOptions {
        headings: vec![heading],
        ..drive3d::crossing_options(&settings(), params)
    };
    let cand = plan_formed(&terrain, params, shape, &cfg.pilot_places, &links, &opt)
        .map_err(|e| e.to_string())?
        .remove(0);
    let a = formed(shape, &cfg.pilot_places, params, cand.start, heading);
    let rigid = max_safe_advance_with(
        &a,
        params,
        &terrain,
        heading,
        opt.step,
        // Unbreakable couplings with the same hinges as the planner's gate (and the physics).
        // It stands at every advance it proves (no bridged stretches): the static tipping point.
        AdvanceOptions {
            rigid_couplings: true,
            bridge_speed: 0.0,
            ..opt.advance_options(cand.required)
        },
    )
    .map_err(|e| e.to_string())?;
    Ok((cand, rigid))
}

/// The gate's proven advance for run scenario `s` of a case planned as `cand`, from where the
/// run actually starts: the planner's gate for the assembly set down at the scenario's
/// (jittered) front pose, along the heading it drives, its own. It differs from the planned
/// heading by at most the jitter's yaw, so the advance along it and along the planned heading
/// (the physics' measure) differ by less than 0.02 % ([`JITTER`]).
pub fn judge_start(
    cfg: &Config,
    cand: &Candidate,
    s: &Scenario,
    terrain: &Terrain,
    params: &FleetParams,
) -> Result<Advance, String> {
    let shape = cfg.shape_value.ok_or("configuration without a shape")?;
    let front = s.robots.first().ok_or("a scenario without robots")?.pose;
    let a = formed(
        shape,
        &cfg.pilot_places,
        params,
        [front[0], front[1]],
        front[2],
    );
    let opt = drive3d::crossing_options(&settings(), params);
    max_safe_advance_with(
        &a,
        params,
        terrain,
        front[2],
        opt.step,
        opt.advance_options(cand.required),
    )
    .map_err(|e| e.to_string())
}

/// How the experiment drives: every run to its end, the gate's side predicted beforehand.
/// Settings of the experiment's physics runs: the gate is not consulted live and a run goes
/// on after a failure (the physics' verdict is what is measured).
pub fn settings() -> CrossSettings {
    CrossSettings {
        live_gate: false,
        stop_on_failure: false,
        ..CrossSettings::default()
    }
}

/// The assembly of configuration `cfg` as the lab sets it down before a crossing: its
/// shape's layout, robots 1…n, pilots at the configuration's places.
pub fn set_down(cfg: &Config, params: &FleetParams) -> Result<Formed, String> {
    let shape = cfg.shape_value.ok_or("configuration without a shape")?;
    let links = formation::layout(shape, &params.non_pilot.geometry).1;
    let n = shape.count();
    Ok(Formed {
        shape,
        ids: (1..=n as u16).collect(),
        kinds: (0..n)
            .map(|k| {
                if cfg.pilot_places.contains(&k) {
                    RobotKind::Pilot
                } else {
                    RobotKind::NonPilot
                }
            })
            .collect(),
        links,
        fit_error: 0.0,
    })
}

/// The 3-D scenario of run `run` of a case: the assembly where `cand` starts, its start
/// pose jittered from the second run on.
pub fn run_scenario(
    formed_asm: &Formed,
    cand: &Candidate,
    terrain: &Terrain,
    params: &FleetParams,
    seed: u64,
    run: usize,
) -> Scenario {
    let mut s = drive3d::scenario(formed_asm, cand, terrain, params, seed + run as u64);
    if run > 0 {
        jitter(&mut s, JITTER.0, JITTER.1);
    }
    s
}

/// Run one case: the gate's prediction once, then `runs` jittered physics runs.
fn run_case(
    case: &Case,
    cfg: &Config,
    runs: usize,
    seed: u64,
    params: &FleetParams,
) -> Result<Vec<CrossRun>, String> {
    let formed_asm = set_down(cfg, params)?;
    let n = formed_asm.ids.len();
    let terrain = case.obstacle.terrain();
    let (cand, rigid) = predict(cfg, case.obstacle, case.heading_deg, params)?;
    let settings = settings();
    let mut out = Vec::with_capacity(runs);
    for run in 0..runs {
        let s = run_scenario(&formed_asm, &cand, &terrain, params, seed, run);
        let mut w = World3d::new(&s, settings.world).map_err(|e| e.to_string())?;
        // The gate judges each run from where it starts: a jittered start stands up to
        // [`JITTER`] closer to the edge than planned.
        let gate = if run == 0 {
            cand.advance.clone()
        } else {
            judge_start(cfg, &cand, &s, &terrain, params)?
        };
        let o = drive3d::cross(&mut w, &cand, &terrain, params, &settings);
        // A robot that dips below the platform and climbs back out (a front pilot) has not
        // failed: a fall counts when the run ends with robots short of the far platform.
        let fell = o.fell.first().map(|f| f.1).filter(|_| o.across < n);
        let broke = o.broke.first().map(|b| b.advance);
        let (physics_fail, fail_kind) = match (fell, broke) {
            (Some(f), Some(b)) if b < f => (Some(b), Some("broke")),
            (Some(f), _) => (Some(f), Some("fell")),
            (None, Some(b)) => (Some(b), Some("broke")),
            (None, None) => (None, None),
        };
        out.push(CrossRun {
            config: case.config,
            obstacle: case.obstacle,
            heading_deg: case.heading_deg,
            run,
            completion: o.across as f64 / n as f64,
            required: cand.required,
            gate_advance: gate.distance,
            gate_limited_by: format!("{:?}", gate.limited_by),
            gate_stop_limit: Some(gate.stop_limit()),
            rigid_advance: rigid.distance,
            physics_tip: match (physics_fail, fail_kind) {
                (Some(f), Some("fell")) if cfg.mesh && run == 0 => {
                    let search = TipSearch::default();
                    static_tip_point(&s, &cand, &terrain, params, &settings, &search, f)?
                }
                _ => None,
            },
            physics_fail,
            fail_kind: fail_kind.map(str::to_string),
        });
    }
    Ok(out)
}

/// Every run of the experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CrossingData {
    /// Configurations.
    pub configs: Vec<Config>,
    /// Runs.
    pub runs: Vec<CrossRun>,
    /// Cases the planner could not start (no start platform, bad input), with the reason.
    pub skipped: Vec<String>,
    /// Wall time (s).
    pub wall_s: f64,
    /// Base seed of the runs.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// The robots' parameters the runs were made with (stored without: the defaults).
    #[serde(default)]
    pub params: FleetParams,
}

/// The seed of data stored before it was recorded: the protocol's.
fn default_seed() -> u64 {
    Options::full().seed
}

/// Run the experiment on `threads` workers; `on_series` after each series of obstacles.
pub fn run(opt: &Options, on_series: &(dyn Fn() + Sync)) -> CrossingData {
    let params = opt.params.clone();
    let configs = configs(&opt.robots, &params);
    let all = series(opt, &configs);
    let t0 = std::time::Instant::now();
    let done = map_parallel(
        &all,
        opt.threads,
        &|se| run_series(se, &configs[se.config], opt, &params),
        on_series,
    );
    let (mut runs, mut skipped) = (Vec::new(), Vec::new());
    for (r, k) in done {
        runs.extend(r);
        skipped.extend(k);
    }
    runs.sort_by(|a, b| {
        (
            a.config,
            a.obstacle.drop.to_bits(),
            a.obstacle.width.to_bits(),
        )
            .cmp(&(
                b.config,
                b.obstacle.drop.to_bits(),
                b.obstacle.width.to_bits(),
            ))
            .then(a.heading_deg.total_cmp(&b.heading_deg))
            .then(a.run.cmp(&b.run))
    });
    CrossingData {
        configs,
        runs,
        skipped,
        wall_s: t0.elapsed().as_secs_f64(),
        seed: opt.seed,
        params,
    }
}

/// Number of series (progress bar length of [`run`]).
pub fn series_count(opt: &Options) -> usize {
    series(opt, &configs(&opt.robots, &opt.params)).len()
}
