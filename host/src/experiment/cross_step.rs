//! The scenario `cross` step from fresh starts (`puzzlebot experiment cross-step`): a fleet
//! of four robots unless told, the pilot set down facing the gap at a given heading and the
//! non-pilots scattered behind it, run `host/assembly/data/scenarios/cross_gap.toml` in
//! lockstep (grow a mesh of two rows on the 2-D plant, already on the gap's terrain, where a
//! robot driven off the edge falls; cross the 25 mm gap in the 3-D world),
//! each start drawn from its seed with the impairment profile's controller latency, link
//! loss, motion capture and plant mismatch; the formation's time limit scales with the fleet
//! as in `experiment assemblies` ([`super::episode::form_timeout_s`]). Counts how many cross,
//! back off after a gate stop, are refused before moving, stop elsewhere, fall or do not form.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context;
use puzzlebot_assembly::{RunState, Scenario as AsmScenario};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_sim::{Impairments, RobotSpec};
use rand::{Rng, SeedableRng};
use serde::Serialize;

use super::episode::{draw_mismatch, Profile};
use super::workers::map_parallel;
use crate::assemble::fleets::MIN_START_SPACING;

/// The scenario every start runs.
pub fn scenario_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assembly/data/scenarios/cross_gap.toml")
}

/// Where the non-pilots are scattered (m): x from, x to, half the width in y; and the least
/// distance between two robots' centres (m).
const AREA: ([f64; 2], f64) = ([-0.6, -0.12], 0.35);
/// Fleet sizes the start area holds (the pilot among them).
pub const ROBOTS: std::ops::RangeInclusive<usize> = 2..=8;
/// The pilot's place (m): 0.35 m before the gap's near edge of `gap25.toml`.
const PILOT_AT: [f64; 2] = [-0.05, 0.0];

/// The experiment's settings.
#[derive(Debug, Clone)]
pub struct Options {
    /// Number of starts.
    pub starts: usize,
    /// Seed of the first start (start i has seed + i).
    pub seed: u64,
    /// Link loss, motion capture and plant mismatch.
    pub profile: Profile,
    /// The pilot's heading from the crossing direction (degrees).
    pub heading_deg: f64,
    /// Robots in the fleet, the pilot among them ([`ROBOTS`]); they form a mesh of two
    /// rows, uneven for an odd number (3 + 2 for five).
    pub robots: usize,
    /// Worker threads (0: one per core).
    pub threads: usize,
    /// Keep every start's run folder (telemetry, events, the crossing) under
    /// `<runs_dir>/cross-step-<first seed>/<seed>/` instead of removing it.
    pub keep_runs: bool,
}

/// How one start ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Every robot on the far platform, none fell.
    Crossed,
    /// Stopped by the live gate and backed off to its start.
    BackedOff,
    /// Refused by the gate before it moved.
    Refused,
    /// Stopped otherwise (pose lost, time out) or left short of the far platform.
    Stopped,
    /// A robot fell.
    Fell,
    /// The mesh did not form.
    NotFormed,
}

/// One start's result.
#[derive(Debug, Clone, Serialize)]
pub struct StartResult {
    /// Its seed.
    pub seed: u64,
    /// How it ended.
    pub outcome: Outcome,
    /// The run's state (why it failed, if it did).
    pub state: String,
}

/// The fleet of start `seed`: the pilot and `robots` − 1 non-pilots.
pub fn fleet(
    seed: u64,
    heading_deg: f64,
    profile: Profile,
    robots: usize,
) -> puzzlebot_sim::Scenario {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut poses = vec![[PILOT_AT[0], PILOT_AT[1], heading_deg.to_radians()]];
    while poses.len() < robots {
        let x = rng.random_range(AREA.0[0]..AREA.0[1]);
        let y = rng.random_range(-AREA.1..AREA.1);
        if poses
            .iter()
            .all(|p| (p[0] - x).hypot(p[1] - y) > MIN_START_SPACING)
        {
            let yaw = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
            poses.push([x, y, yaw]);
        }
    }
    let imp = profile.impairment();
    let robots = poses
        .iter()
        .enumerate()
        .map(|(k, &pose)| RobotSpec {
            id: k as u16 + 1,
            kind: if k == 0 {
                RobotKind::Pilot
            } else {
                RobotKind::NonPilot
            },
            pose,
            impairments: None,
            offline: false,
            mismatch: draw_mismatch(&mut rng, imp.mismatch),
        })
        .collect();
    puzzlebot_sim::Scenario {
        seed,
        robots,
        impairments: Impairments {
            loss: imp.loss,
            ..Impairments::NONE
        },
        mocap: imp.mocap(),
        ..puzzlebot_sim::Scenario::default()
    }
}

/// Run every start; the scenario's run folders go to a temporary folder under `runs_dir`
/// and are removed, or with [`Options::keep_runs`] to `runs_dir/cross-step-<first seed>`.
pub fn run(opts: &Options, runs_dir: &Path) -> anyhow::Result<Vec<StartResult>> {
    let g = FleetParams::default().non_pilot.geometry;
    let file = scenario_file();
    let mut scenario = AsmScenario::from_file(&file, &g)?;
    // The formation's time limit scales with the fleet, as in `experiment assemblies`.
    for step in &mut scenario.steps {
        if matches!(
            step.behaviour,
            puzzlebot_assembly::scenario::Behaviour::Form { .. }
        ) {
            step.timeout_s = Some(super::episode::form_timeout_s(opts.robots));
        }
    }
    // Every step's time limit or hold, and a second per step to hand over to the next.
    let run_limit: f64 = scenario
        .steps
        .iter()
        .map(|s| match s.behaviour {
            puzzlebot_assembly::scenario::Behaviour::Hold { duration_s } => duration_s,
            _ => s.timeout_s.unwrap_or(0.0),
        } + 1.0)
        .sum();
    let terrain_file = scenario
        .steps
        .iter()
        .find_map(|s| match &s.behaviour {
            puzzlebot_assembly::scenario::Behaviour::Cross { terrain } => Some(terrain.clone()),
            _ => None,
        })
        .context("the scenario has no cross step")?;
    let terrain = puzzlebot_stability::crossing::load_terrain(&terrain_file)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let seeds: Vec<u64> = (0..opts.starts as u64).map(|i| opts.seed + i).collect();
    let bar = indicatif::ProgressBar::new(seeds.len() as u64);
    let tmp = if opts.keep_runs {
        runs_dir.join(format!("cross-step-{}", opts.seed))
    } else {
        runs_dir.join(format!(".cross-step-{}", std::process::id()))
    };
    let results = map_parallel(
        &seeds,
        opts.threads,
        &|&seed| {
            let sim = fleet(seed, opts.heading_deg, opts.profile, opts.robots);
            let dir = tmp.join(seed.to_string());
            let imp = opts.profile.impairment();
            let latency = crate::assemble::Latency {
                delay_ms: imp.delay_ms(),
                jitter_ms: imp.jitter_ms(),
            };
            let r = crate::assemble::run_scenario_lockstep_with(
                scenario.clone(),
                sim,
                &dir,
                run_limit,
                latency,
            );
            if !opts.keep_runs {
                std::fs::remove_dir_all(&dir).ok();
            }
            r.map(|r| classify(seed, &r, &terrain))
                .map_err(|e| format!("seed {seed}: {e:#}"))
        },
        &|| bar.inc(1),
    );
    bar.finish_and_clear();
    if opts.keep_runs {
        eprintln!("run folders kept in {}", tmp.display());
    } else {
        std::fs::remove_dir_all(&tmp).ok();
    }
    results
        .into_iter()
        .collect::<Result<Vec<_>, String>>()
        .map_err(|e| anyhow::anyhow!(e))
}

/// How the run `r` of start `seed` ended over `terrain`.
fn classify(seed: u64, r: &crate::assemble::AssemblyReport, terrain: &Terrain) -> StartResult {
    let under = |p: &[f64; 3]| {
        terrain
            .platforms
            .iter()
            .position(|pl| pl.contains([p[0], p[1]]))
    };
    let start = under(&[PILOT_AT[0], PILOT_AT[1], 0.0]);
    let across = r
        .final_poses
        .values()
        .all(|p| under(p).is_some_and(|i| Some(i) != start));
    let (outcome, state) = match &r.state {
        _ if !r.fallen.is_empty() => (Outcome::Fell, format!("{:?}", r.state)),
        RunState::Finished if across => (Outcome::Crossed, "finished".into()),
        RunState::Failed { index, reason } if *index < 2 => (Outcome::NotFormed, reason.clone()),
        RunState::Failed { reason, .. } if reason.contains("refused") => {
            (Outcome::Refused, reason.clone())
        }
        RunState::Failed { reason, .. } if reason.contains("backed off") => {
            (Outcome::BackedOff, reason.clone())
        }
        other => (Outcome::Stopped, format!("{other:?}")),
    };
    StartResult {
        seed,
        outcome,
        state,
    }
}

/// The counts per outcome, and every start that did not cross.
pub fn render(opts: &Options, results: &[StartResult]) -> String {
    let mut counts: BTreeMap<Outcome, usize> = BTreeMap::new();
    for r in results {
        *counts.entry(r.outcome).or_default() += 1;
    }
    let mut s = format!(
        "cross step: {} starts of {} robots from seed {}, profile {}, pilot at {}°\n",
        results.len(),
        opts.robots,
        opts.seed,
        opts.profile.name(),
        opts.heading_deg
    );
    for (o, n) in &counts {
        s += &format!("  {:<11} {n}\n", format!("{o:?}"));
    }
    for r in results.iter().filter(|r| r.outcome != Outcome::Crossed) {
        s += &format!("  seed {}: {:?}: {}\n", r.seed, r.outcome, r.state);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_sim::PlantMismatch;

    #[test]
    fn a_start_is_drawn_from_its_seed_with_the_pilot_facing_the_gap() {
        let a = fleet(7, 50.0, Profile::Lab, 4);
        assert_eq!(a.robots.len(), 4);
        assert_eq!(a.robots[0].kind, RobotKind::Pilot);
        assert!((a.robots[0].pose[2] - 50f64.to_radians()).abs() < 1e-12);
        for (i, r) in a.robots.iter().enumerate() {
            for q in &a.robots[i + 1..] {
                let d = (r.pose[0] - q.pose[0]).hypot(r.pose[1] - q.pose[1]);
                assert!(d > MIN_START_SPACING, "{d}");
            }
            let m = r.mismatch.motor_gain;
            assert!((0.9..=1.1).contains(&m) && m != 1.0, "{m}");
        }
        let b = fleet(7, 50.0, Profile::Lab, 4);
        assert_eq!(
            a.robots.iter().map(|r| r.pose).collect::<Vec<_>>(),
            b.robots.iter().map(|r| r.pose).collect::<Vec<_>>()
        );
        assert_ne!(
            a.robots[1].pose,
            fleet(8, 50.0, Profile::Lab, 4).robots[1].pose
        );
        assert_eq!(
            fleet(7, 50.0, Profile::Ideal, 4).robots[1].mismatch,
            PlantMismatch::NONE
        );
        // The largest fleet fits the start area, spaced, one pilot among non-pilots.
        let big = fleet(7, 50.0, Profile::Lab, *ROBOTS.end());
        assert_eq!(big.robots.len(), *ROBOTS.end());
        assert_eq!(
            big.robots
                .iter()
                .filter(|r| r.kind == RobotKind::Pilot)
                .count(),
            1
        );
        for (i, r) in big.robots.iter().enumerate() {
            for q in &big.robots[i + 1..] {
                assert!((r.pose[0] - q.pose[0]).hypot(r.pose[1] - q.pose[1]) > MIN_START_SPACING);
            }
        }
    }
}
