//! A short recorded lockstep run shared by the recording and replay tests: a non-pilot 0.1 m
//! in front of a pilot backs its anchor into the pilot's opening (≈ 1.5 s), then the line of
//! two drives 0.1 m ahead.

use std::path::PathBuf;

use puzzlebot_host::assemble::{parse_scenario, AssemblyReport};

/// The simulator scenario: pilot 1 at the origin, non-pilot 2 just in front, both facing +x.
pub const SIM: &str = r#"
seed = 1
[[robots]]
id = 1
kind = "Pilot"
pose = [0.0, 0.0, 0.0]
[[robots]]
id = 2
kind = "NonPilot"
pose = [0.1, 0.01, 0.1]
"#;

/// Form the line of two, then drive it.
pub const STEPS: &str = r#"
name = "pair"
[[step]]
form = { shape = "line", heading_deg = 0 }
timeout_s = 20
[[step]]
move = { velocity = [0.05, 0.0], duration_s = 2 }
"#;

/// Run it, recorded, into a fresh folder under the system's temp dir named after `test`.
pub fn run(test: &str) -> (AssemblyReport, PathBuf) {
    let runs = std::env::temp_dir().join(format!("pb-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&runs);
    let sim = puzzlebot_sim::Scenario::from_toml(std::path::Path::new("sim.toml"), SIM)
        .expect("simulator scenario");
    let steps = parse_scenario("pair.toml", STEPS).expect("assembly scenario");
    let (report, mcap) = puzzlebot_host::record::run_scenario_lockstep(steps, sim, &runs, 30.0)
        .expect("the recorded run");
    puzzlebot_host::assemble::ensure_finished(&report).expect("the short run finishes");
    (report, mcap)
}
