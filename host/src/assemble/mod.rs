//! The assembly controller: the assembly [`Coordinator`] (through a [`ScenarioRunner`])
//! assigns each robot a task every 10 Hz tick, each task becomes cost terms of that robot's
//! MPC problem ([`DistributedMpc`], THESIS Algorithm 9, 5.19–5.26), and coupled pairs become
//! the MPC's coupling constraints. Over terrain, the stability gate bounds every coupled
//! assembly's advance along its heading ([`puzzlebot_stability::max_safe_advance`], SOCP
//! paper §4, DESIGN.md §7): the host never commands an assembly past the safe distance; it
//! stops the assembly and records why. Outside a cross step, no robot drives towards a
//! drop ([`edge_guard`]).
//!
//! Also: `puzzlebot run SCENARIO.toml` ([`run_scenario`]) and `puzzlebot shape info`.
//!
//! Modules: [`controller`] (the controller loop), [`costs`] (task → MPC cost terms),
//! [`gate`] (stability gate), [`edge_guard`] (keeping robots on their platform), [`latency`] (pose prediction over pose age and command
//! latency), [`slow_steps`] (scenario speed warnings), [`report`] (run report and event
//! files), [`fleet_run`] (running a scenario on a fleet config's robots); with the simulator
//! (feature `sim`): `fleets` (simulated start fleets), `run` (running a scenario on a
//! simulated fleet) and `truth` (its report against the simulator's ground truth).

use std::path::Path;

use puzzlebot_assembly::{shape_info, Mode, RunState, Scenario as AsmScenario, Shape};
use puzzlebot_params::FleetParams;

pub mod controller;
pub mod costs;
#[cfg(feature = "sim")]
pub mod cross_step;
pub mod edge_guard;
pub mod fleet_run;
#[cfg(feature = "sim")]
pub mod fleets;
pub mod gate;
pub mod latency;
pub mod report;
#[cfg(feature = "sim")]
pub mod run;
pub mod separation;
pub mod slow_steps;
#[cfg(feature = "sim")]
pub mod truth;

pub use controller::AssemblyController;
pub use costs::{HANG_HEADING, KEEP_HEADING, MAINTAIN_HEADING_FORM, MAINTAIN_HEADING_HOLD};
pub use fleet_run::{load_terrain, run_scenario_on_fleet, FleetRunOptions};
#[cfg(feature = "sim")]
pub use fleets::{
    demo_fleet, grow_demo_fleet, scattered_fleet, scattered_fleet_in, DEMO_SCENARIO,
    GROW_DEMO_SCENARIO, LANE_GAP, MIN_START_SPACING,
};
pub use gate::{GateConfig, GateStop};
pub use latency::{predict, FLEET_WAIT_S, MAX_PREDICTION_S};
pub use report::{describe, AssemblyReport, TruthCoupling, TruthRecord};
#[cfg(feature = "sim")]
pub use run::{run_scenario, run_scenario_lockstep, run_scenario_lockstep_with, Latency, RunHook};
pub use slow_steps::{slow_step_warnings, slowest_steady_speed};

/// `puzzlebot shape info`: the text (or JSON) of [`shape_info`] for `line`, `mesh` or a file.
pub fn shape_info_text(
    shape: &str,
    robots: usize,
    rows: usize,
    json: bool,
) -> anyhow::Result<String> {
    let g = FleetParams::default().non_pilot.geometry;
    let s = match shape {
        "line" => Shape::line(robots, &g)?,
        "mesh" => Shape::mesh(robots, rows, &g)?,
        file => Shape::from_file(Path::new(file), &g)?,
    };
    let info = shape_info(&s, &g);
    Ok(if json {
        format!("{}\n", serde_json::to_string_pretty(&info)?)
    } else {
        info.to_string()
    })
}

/// Coordinator mode name (for logs).
pub fn mode_name(m: &Mode) -> &'static str {
    match m {
        Mode::Hold => "hold",
        Mode::Form => "form",
        Mode::Velocity { .. } => "velocity",
        Mode::GoTo { .. } => "go_to",
        Mode::Track { .. } => "track",
        Mode::Rendezvous { .. } => "rendezvous",
        Mode::Decouple { .. } => "decouple",
        Mode::Disperse { .. } => "disperse",
    }
}

/// The assembly library, for callers of this module (tests, tools).
pub use puzzlebot_assembly as assembly;

/// Parse an assembly scenario from TOML text (`name` labels errors) with the default geometry.
pub fn parse_scenario(name: &str, text: &str) -> anyhow::Result<AsmScenario> {
    let g = FleetParams::default().non_pilot.geometry;
    Ok(AsmScenario::from_toml_str(Path::new(name), text, &g)?)
}

/// An error unless the scenario of `r` finished (for the CLI's exit status).
pub fn ensure_finished(r: &AssemblyReport) -> anyhow::Result<()> {
    match &r.state {
        RunState::Finished => Ok(()),
        other => anyhow::bail!("the assembly scenario did not finish: {other:?}"),
    }
}
