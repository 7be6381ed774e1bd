//! The shipped shape and scenario files load.

use puzzlebot_assembly::{shape_info, Behaviour, PairType, Scenario, Shape, SlotKind};
use puzzlebot_params::geometry::Geometry;
use std::path::Path;

fn data(p: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(p)
}

#[test]
fn tee_shape_loads() {
    let g = Geometry::default();
    let s = Shape::from_file(&data("shapes/tee.toml"), &g).unwrap();
    assert_eq!(s.len(), 4);
    assert_eq!(
        s.slots.iter().filter(|x| x.kind == SlotKind::Pilot).count(),
        1
    );
    let info = shape_info(&s, &g);
    assert_eq!(info.anchor_pairs, 2);
    assert_eq!(info.knob_pairs, 1);
    assert!(info.pairs.iter().any(|p| p.kind == PairType::KnobHole));
}

#[test]
fn demo_scenario_loads() {
    let s = Scenario::from_file(&data("scenarios/demo.toml"), &Geometry::default()).unwrap();
    assert_eq!(s.steps.len(), 7);
    // Grown around the front pilot (two pilots in a lane).
    assert!(matches!(
        s.steps[0].behaviour,
        Behaviour::Form { grow: Some(_), .. }
    ));
    match &s.steps[6].behaviour {
        Behaviour::Disperse { goals, .. } => assert_eq!(goals.len(), 6),
        other => panic!("{other:?}"),
    }
}
