//! `puzzlebot experiment crossing` on a small sample: what one robot cannot cross a mesh
//! can, a pilot crosses wider than a non-pilot, the summary finds those widths, the gate
//! never calls safe an advance at which the physics failed, and re-running the gate's side of
//! the stored runs gives the same predictions.

use puzzlebot_host::experiment::crossing::{run, CrossingData, Options};
use puzzlebot_host::experiment::crossing_regate::regate;
use puzzlebot_host::experiment::crossing_report::{render, summarise};

#[test]
fn a_sample_of_the_crossing_protocol() {
    let opt = Options {
        robots: vec![1, 4],
        gaps: vec![0.02, 0.04],
        steps: vec![],
        headings: vec![40.0],
        mesh_headings: vec![],
        runs: 1,
        threads: 2,
        seed: 1,
    };
    let d = run(&opt, &|| {});
    assert!(d.skipped.is_empty(), "{:?}", d.skipped);
    let s = summarise(&d);
    let text = render(&s, &d);
    let level = |shape: &str, pilots: &str| {
        s.configs
            .iter()
            .find(|c| c.config.shape == shape && c.config.pilots == pilots)
            .and_then(|c| c.gap_level)
    };
    // THESIS 5.2.4: a lone non-pilot crosses 10 mm, a pilot 20 mm; neither crosses 40 mm.
    assert_eq!(level("line 1", "none"), None, "{text}");
    assert_eq!(level("line 1", "front"), Some(0.02), "{text}");
    // The 2 x 2 mesh crosses the 40 mm gap (THESIS 3.5.2).
    assert_eq!(level("mesh 2x2", "front"), Some(0.04), "{text}");
    assert_eq!(s.gate.overconfident, 0, "{text}");
    let json = serde_json::to_string(&d).expect("serialise");
    let mut again: CrossingData = serde_json::from_str(&json).expect("deserialise");
    regate(&mut again, 2, &|| {}).expect("regate");
    assert_eq!(again.runs.len(), d.runs.len());
    for (a, b) in again.runs.iter().zip(&d.runs) {
        assert_eq!(
            (a.gate_advance, &a.gate_limited_by, a.rigid_advance),
            (b.gate_advance, &b.gate_limited_by, b.rigid_advance)
        );
        assert_eq!(a.physics_fail, b.physics_fail);
    }
}

/// The gate judges each run from where it starts: moved along its heading towards the gap,
/// the same assembly is proven exactly that much less far.
#[test]
fn a_run_is_judged_from_its_own_start() {
    use puzzlebot_host::experiment::crossing::{
        configs, judge_start, predict, run_scenario, set_down, Obstacle,
    };
    use puzzlebot_params::FleetParams;
    let params = FleetParams::default();
    let cfgs = configs(&[4], &params);
    let cfg = cfgs
        .iter()
        .find(|c| c.shape == "mesh 2x2" && c.pilots == "front")
        .expect("the 2 x 2 mesh with a front pilot");
    let obstacle = Obstacle {
        width: 0.04,
        drop: 0.0,
    };
    let heading = 30.0f64;
    let (cand, _) = predict(cfg, obstacle, heading, &params).expect("a plan");
    let terrain = obstacle.terrain();
    let formed = set_down(cfg, &params).expect("a shape");
    // The planned start is judged as the planner judged it.
    let planned = run_scenario(&formed, &cand, &terrain, &params, 1, 0);
    let at_plan = judge_start(cfg, &cand, &planned, &terrain, &params).expect("gate");
    assert_eq!(at_plan.distance, cand.advance.distance);
    assert_eq!(at_plan.limited_by, cand.advance.limited_by);
    // 2 mm further along the heading: the same limit, 2 mm sooner.
    let mut moved = planned.clone();
    let (s, c) = heading.to_radians().sin_cos();
    for r in &mut moved.robots {
        r.pose[0] += 0.002 * c;
        r.pose[1] += 0.002 * s;
    }
    let nearer = judge_start(cfg, &cand, &moved, &terrain, &params).expect("gate");
    assert_eq!(nearer.limited_by, cand.advance.limited_by);
    assert!(
        (nearer.distance - (cand.advance.distance - 0.002)).abs() < 1e-4,
        "{} mm against {} mm planned",
        nearer.distance * 1e3,
        cand.advance.distance * 1e3
    );
}
