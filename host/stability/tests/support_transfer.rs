//! The connectors' loads across a mesh hanging over a gap, against the 3-D physics
//! (`host/examples/crossing_probe.rs`): the settled loads of the elastic distribution, and
//! their peak when a support rolls off the edge.

use puzzlebot_params::formation::Shape;
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::FleetParams;
use puzzlebot_stability::crossing::{formed, plan_formed, CrossingOptions};
use puzzlebot_stability::elastic::{distribution, use_of_limits, Compliance};
use puzzlebot_stability::puzzlebot::{
    assembly_level, build_model_with, max_safe_advance_with, support_events, AdvanceOptions,
    LoadTransfer, PuzzleAssembly, EVENT_EPS, SOFT_SUPPORTS,
};
use puzzlebot_stability::transfer::transfer_limit;
use puzzlebot_stability::LimitedBy;

const MESH: Shape = Shape::Mesh {
    rows: 2,
    per_row: 3,
};
/// Knob of robot 2 (index 1) in the hole of robot 5 (index 4) in the layout's pairs.
const KNOB_2_5: usize = 6;

/// A 2 × 3 mesh without pilots where the crossing planner starts it before a `gap` m wide
/// gap, heading `deg` degrees; its crossing options.
fn mesh_at_gap(gap: f64, deg: f64) -> (PuzzleAssembly, Terrain, CrossingOptions, f64) {
    let p = FleetParams::default();
    let t = Terrain::gap(0.0, gap, 1.5, 3.0, 0.0);
    let h = deg.to_radians();
    let opt = CrossingOptions {
        headings: vec![h],
        ..CrossingOptions::default()
    };
    let links = puzzlebot_params::formation::layout(MESH, &p.non_pilot.geometry).1;
    let c = plan_formed(&t, &p, MESH, &[], &links, &opt)
        .unwrap()
        .remove(0);
    (formed(MESH, &[], &p, c.start, h), t, opt, c.required)
}

#[test]
fn friction_does_not_relieve_the_knob_of_a_hanging_robot() {
    // 68 mm into an 80 mm gap the two front robots hang over it. Set down there, the 3-D
    // physics loads knob 2–5 to 77 % of its limits (crossing_probe, START_AT=68). Friction
    // free to take whatever relieves the connectors holds it to 67 % on soft supports; friction
    // that costs the supports' work as their normal forces do does not.
    let (a, t, opt, required) = mesh_at_gap(0.08, 0.0);
    let p = FleetParams::default();
    let level = assembly_level(&a, &p, &t).unwrap();
    let m = build_model_with(
        &a,
        &p,
        &t,
        level,
        [0.068, 0.0],
        &opt.advance_options(required),
    )
    .unwrap();
    let r = m.resolve().unwrap();
    let c = &p.non_pilot.coupling;
    let force = 1.0 / f64::from(c.connector_stiffness);
    let soft = Compliance {
        force,
        couple: 1.0 / f64::from(c.connector_angular_stiffness),
        support: SOFT_SUPPORTS * force,
    };
    let w = distribution(&r, soft).unwrap().unwrap();
    let u = use_of_limits(&r, &w)[KNOB_2_5].unwrap();
    assert!(u > 0.75 && u < 0.9, "knob 2–5 at {u}");
}

#[test]
fn a_support_lost_loads_the_knob_up_to_twice_the_change() {
    // At 20° into a 60 mm gap, robot 5's front caster leaves the edge at about 71.6 mm and
    // knob 2–5 takes over its share: settled 65 % → 85 % of its limits (the 3-D physics
    // settles at 85 % too, crossing_probe SETTLE=1). Driven across, the physics' load
    // overshoots past 100 % and the knob breaks at 74 mm: undamped, the peak is the settled
    // load plus the change again.
    let (a, t, opt, required) = mesh_at_gap(0.06, 20.0);
    let p = FleetParams::default();
    let h = 20f64.to_radians();
    let aopt = opt.advance_options(required);
    let level = assembly_level(&a, &p, &t).unwrap();
    let event = support_events(&a, &p, &t, h, 0.1)
        .into_iter()
        .find(|&e| (e - 0.0716).abs() < 0.001)
        .expect("the caster's event");
    let at =
        |d: f64| build_model_with(&a, &p, &t, level, [d * h.cos(), d * h.sin()], &aopt).unwrap();
    let (before, after) = (at(event - EVENT_EPS), at(event + EVENT_EPS));
    let undamped = LoadTransfer {
        damping_ratio: 0.0,
        ..LoadTransfer::default()
    };
    let critical = LoadTransfer {
        damping_ratio: 1.0,
        ..LoadTransfer::default()
    };
    match transfer_limit(&before, &after, &p, undamped).unwrap() {
        Some(LimitedBy::Connection { pairs }) => assert!(pairs.contains(&KNOB_2_5), "{pairs:?}"),
        other => panic!("undamped: {other:?}"),
    }
    // Critically damped: the settled loads, within the limits.
    assert_eq!(transfer_limit(&before, &after, &p, critical).unwrap(), None);

    // The gate stops before that event with the undamped transfer, and drives past it on
    // the settled loads alone.
    let advance = |transfer| {
        let o = AdvanceOptions {
            transfer,
            settling: None,
            ..aopt
        };
        max_safe_advance_with(&a, &p, &t, h, 0.005, o).unwrap()
    };
    let settled = advance(None);
    let peaked = advance(Some(undamped));
    assert!(settled.distance > event + 0.005, "{settled:?}");
    assert!(peaked.distance < event, "{peaked:?}");
    assert!(
        matches!(peaked.limited_by, LimitedBy::Connection { .. }),
        "{peaked:?}"
    );
    assert_eq!(advance(Some(critical)), settled);
}
