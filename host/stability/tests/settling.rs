//! Supports that give ([`puzzlebot_stability::sag`]): a robot hanging over a gap sags into the
//! edge face of the platform ahead, and over a lower platform the connectors that hold an
//! overhang carry most on supports as soft as tyres, not in either limit.

use puzzlebot_params::formation::{layout, Shape};
use puzzlebot_params::terrain::{Platform, Terrain};
use puzzlebot_params::FleetParams;
use puzzlebot_stability::crossing::{formed, plan_formed, CrossingOptions};
use puzzlebot_stability::puzzlebot::{
    assembly_level, build_model_with, max_safe_advance_with, Advance, PuzzleAssembly,
};
use puzzlebot_stability::sag::{edge_stall, settle, Settling};
use puzzlebot_stability::LimitedBy;

/// The near platform up to x = 0, `drop` m higher than the far one beyond a `gap` m gap.
fn obstacle(gap: f64, drop: f64) -> Terrain {
    let w = gap.max(0.0005);
    Terrain {
        platforms: vec![
            Platform::rect("near", [-1.5, -1.5], [0.0, 1.5], drop),
            Platform::rect("far", [w, -1.5], [w + 1.5, 1.5], 0.0),
        ],
    }
}

/// `shape` with `pilots` where the planner starts it before `t`, heading `deg` degrees; the
/// gate's answer with and without `settling`.
fn crossing(
    shape: Shape,
    pilots: &[usize],
    t: &Terrain,
    deg: f64,
) -> (PuzzleAssembly, CrossingOptions, f64, Advance, Advance) {
    let p = FleetParams::default();
    let h = deg.to_radians();
    let opt = CrossingOptions {
        headings: vec![h],
        ..CrossingOptions::default()
    };
    let links = layout(shape, &p.non_pilot.geometry).1;
    let c = plan_formed(t, &p, shape, pilots, &links, &opt)
        .unwrap()
        .remove(0);
    let a = formed(shape, pilots, &p, c.start, h);
    let rigid_supports = max_safe_advance_with(
        &a,
        &p,
        t,
        h,
        opt.step,
        puzzlebot_stability::puzzlebot::AdvanceOptions {
            settling: None,
            ..opt.advance_options(c.required)
        },
    )
    .unwrap();
    (a, opt, c.required, c.advance, rigid_supports)
}

#[test]
fn a_hanging_robot_stalls_against_the_far_edge_before_the_gate_lets_it_on() {
    // A 2 × 3 mesh with a front pilot over a 70 mm gap between platforms of equal height,
    // heading 10°: the front robot of the second row leads, hangs over the gap, and as the
    // mesh nears its tipping line it sags more than its 5 mm clearance. In the 3-D physics
    // its body meets the far platform's face and a knob breaks (crossing experiment).
    let mesh = Shape::Mesh {
        rows: 2,
        per_row: 3,
    };
    let t = obstacle(0.07, 0.0);
    let (a, opt, required, settled, rigid) = crossing(mesh, &[0], &t, 10.0);
    assert!(
        matches!(settled.limited_by, LimitedBy::StepUp { robot: 3 }),
        "{settled:?}"
    );
    assert!(settled.distance < rigid.distance, "{settled:?} {rigid:?}");
    // Where the gate stops, the robot's front corner reaches the far platform with its
    // underside below the platform's top.
    let p = FleetParams::default();
    let level = assembly_level(&a, &p, &t).unwrap();
    let mopt = opt.advance_options(required);
    let s = Settling::default();
    let h = 10f64.to_radians();
    let stalls = |d: f64| {
        let off = |d: f64| [h.cos() * d, h.sin() * d];
        let m = build_model_with(&a, &p, &t, level, off(d + 1e-6), &mopt).unwrap();
        // Robot 3 is the one hanging there.
        let hanging: Vec<bool> = (0..a.robots.len()).map(|i| i == 3).collect();
        edge_stall(&a, &p, &t, level, [off(d), off(d + 1e-6)], &m, &hanging, &s)
    };
    assert_eq!(stalls(settled.distance), Some(3));
    // Its corner over the far platform already, nothing new meets an edge.
    assert_eq!(stalls(settled.distance + 0.002), None);
    // A front corner reaches the far edge there: 70 mm beyond the near one.
    let corner = a.robots[3].x + h.cos() * settled.distance + 0.025 * (h.cos() + h.sin());
    assert!((corner - 0.07).abs() < 1e-5, "{corner}");
}

#[test]
fn a_level_crossing_settles_without_stalling() {
    // A 2 × 2 mesh with a front pilot over 20 mm: no robot ever hangs, the gate proves the
    // crossing with and without the supports' settling alike.
    let mesh = Shape::Mesh {
        rows: 2,
        per_row: 2,
    };
    let (_, _, required, settled, rigid) = crossing(mesh, &[0], &obstacle(0.02, 0.0), 20.0);
    assert!(settled.distance >= required, "{settled:?}");
    assert!(rigid.distance >= required, "{rigid:?}");
}

#[test]
fn an_overhang_above_a_lower_platform_loads_its_knobs_most_on_tyre_soft_supports() {
    // A 2 × 4 mesh with a front pilot down a 6 mm step at 20°: the front robots leave the
    // upper platform and hang 6 mm above the lower one on the knobs to the robots behind.
    // On rigid supports the knobs share their weight; on very soft ones the whole mesh sinks
    // onto the lower platform; on supports as soft as tyres the robots behind pitch forward
    // while the gap stays open, and the knobs of the overhang carry most (in the 3-D physics
    // one breaks after 74 mm).
    let mesh = Shape::Mesh {
        rows: 2,
        per_row: 4,
    };
    let (_, _, _, settled, rigid) = crossing(mesh, &[0], &obstacle(0.0, 0.006), 20.0);
    assert!(
        matches!(settled.limited_by, LimitedBy::Connection { .. }),
        "{settled:?}"
    );
    assert!(
        settled.distance + 0.01 < rigid.distance,
        "{settled:?} {rigid:?}"
    );
    assert!(settled.distance < 0.074, "{settled:?}");
}

#[test]
fn an_assembly_past_its_tipping_line_cannot_settle_level() {
    // A 2 × 3 mesh set down with its front half beyond the near edge: its settling pitches
    // it forward, the sink at the front exceeding the rear's.
    let mesh = Shape::Mesh {
        rows: 2,
        per_row: 3,
    };
    let p = FleetParams::default();
    let t = obstacle(0.07, 0.0);
    let a = formed(mesh, &[0], &p, [0.02, 0.0], 0.0);
    let level = assembly_level(&a, &p, &t).unwrap();
    let m = build_model_with(
        &a,
        &p,
        &t,
        level,
        [0.0, 0.0],
        &puzzlebot_stability::puzzlebot::AdvanceOptions::default(),
    )
    .unwrap();
    let s = settle(&m, &Settling::default()).unwrap();
    assert!(s.b > 0.0, "{s:?}");
}

#[test]
fn a_hanging_robot_that_sags_past_the_fall_depth_has_fallen() {
    // A 3 × 3 mesh with a front pilot over a 90 mm gap at 30°: nearing its tipping line on
    // supports that give, the mesh pitches forward and its front robot's corner sinks more
    // than 10 mm below the platform top before the rigid-support gate's tipping point (the
    // 3-D physics, whose wheels give more, counts it fallen after 102.6 mm).
    let mesh = Shape::Mesh {
        rows: 3,
        per_row: 3,
    };
    let (_, _, _, settled, rigid) = crossing(mesh, &[0], &obstacle(0.09, 0.0), 30.0);
    assert!(matches!(settled.limited_by, LimitedBy::Tips), "{settled:?}");
    assert!(settled.distance < rigid.distance, "{settled:?} {rigid:?}");
}

#[test]
fn a_line_without_pilots_stalls_on_its_casters_down_a_step() {
    // Two non-pilots at 30° down a 6 mm step: the front robot's wheels sit between its front
    // caster on the lower platform and its rear caster on the upper one, and the robot behind
    // pitches back onto its rear caster. No wheel bears, nothing drives: the 3-D physics stops
    // there (crossing experiment). A front pilot's four wheels reach the lower platform.
    let t = obstacle(0.0, 0.006);
    let (_, _, required, settled, _) = crossing(Shape::Line(2), &[], &t, 30.0);
    assert_eq!(settled.limited_by, LimitedBy::Stalls, "{settled:?}");
    assert!(settled.distance < required, "{settled:?}");
    let (_, _, _, piloted, _) = crossing(Shape::Line(2), &[0], &t, 30.0);
    assert_ne!(piloted.limited_by, LimitedBy::Stalls, "{piloted:?}");
    // A 2 × 2 mesh with a back pilot over a 30 mm gap 6 mm down at 20°: where its front
    // robots reach the far platform it pitches onto their casters, one of the pilot's wheels
    // just touching. The physics drives it across.
    let mesh = Shape::Mesh {
        rows: 2,
        per_row: 2,
    };
    let (_, _, required, pitched, _) = crossing(mesh, &[1], &obstacle(0.03, 0.006), 20.0);
    assert!(pitched.distance >= required, "{pitched:?}");
}
