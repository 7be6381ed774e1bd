//! `puzzlebot demo`'s crossing, in lockstep as the binary runs it: the demo's fleet forms its
//! mesh on the 2-D plant, the formed assembly is set down at a 40 mm gap in the 3-D world, a
//! lone non-pilot falls in, the gate proves the mesh's crossing at the planner's heading, the
//! mesh drives across with every robot on the far platform and none fallen or broken, and
//! comes apart there.

use puzzlebot_assembly::Scenario as AsmScenario;
use puzzlebot_host::assemble;
use puzzlebot_host::crossing::demo;
use puzzlebot_params::FleetParams;
use std::collections::BTreeMap;

#[test]
fn the_demo_mesh_crosses_a_gap_a_lone_robot_falls_into() {
    let t0 = std::time::Instant::now();
    let runs = std::env::temp_dir().join(format!("pb-demo-cross-{}", std::process::id()));
    let scenario = AsmScenario::from_toml_str(
        std::path::Path::new("demo.toml"),
        assemble::DEMO_SCENARIO,
        &FleetParams::default().non_pilot.geometry,
    )
    .expect("demo scenario");
    let sim = assemble::demo_fleet();
    let kinds: BTreeMap<_, _> = sim.robots.iter().map(|r| (r.id, r.kind)).collect();
    let report = assemble::run_scenario_lockstep(demo::formation_part(scenario), sim, &runs, 400.0)
        .expect("2-D run");
    assemble::ensure_finished(&report).expect("formed");
    let c = demo::run(&report, &kinds).expect("crossing");
    let text = c.render();
    assert!(c.lone.fell_after_s.is_some(), "{text}");
    assert!(c.lone.proven < c.lone.required, "{text}");
    assert_eq!(c.shape, "mesh 2x3", "{text}");
    let best = &c.plan[0];
    assert!(best.crosses(), "{text}");
    let x = c.crossing.as_ref().expect("driven");
    assert!(x.crossed, "{text}");
    assert!(x.gate_checks > 10, "{text}");
    let d = c.dissolve.as_ref().expect("dissolved");
    assert!(d.on_platform && d.spacing[1] > 1.5 * d.spacing[0], "{text}");
    assert!(c.ok(), "{text}");
    std::fs::remove_dir_all(&runs).ok();
    assert!(t0.elapsed().as_secs() < 60, "took {:?}", t0.elapsed());
    eprintln!("{text}took {:.1} s", t0.elapsed().as_secs_f64());
}
