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
