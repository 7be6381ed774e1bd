//! The gate's check points: every advance at which a wheel or caster crosses a platform edge,
//! and the casters' lift in its contact model.

use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_stability::puzzlebot::*;

fn np(x: f64) -> RobotPose {
    RobotPose {
        kind: RobotKind::NonPilot,
        x,
        y: 0.0,
        yaw: 0.0,
    }
}

/// Centre of mass a little behind the wheel axle and off the casters' line: a lone robot
/// stands on its wheels and back caster, not on its casters alone (keeps the geometry
/// non-degenerate).
fn behind() -> FleetParams {
    let mut p = FleetParams::default();
    p.non_pilot.mass.com = [-0.005, 0.002];
    p
}

fn lone(x: f64) -> PuzzleAssembly {
    PuzzleAssembly {
        robots: vec![np(x)],
        pairs: vec![],
    }
}

#[test]
fn events_are_the_contacts_crossing_the_edges() {
    let p = FleetParams::default();
    let plant = &p.non_pilot.plant;
    let (c, w) = (
        f64::from(plant.caster_offset),
        f64::from(plant.wheel_axle_offset),
    );
    // A 40 mm gap at x = 0; the robot's centre 50 mm behind the edge, heading +x.
    let t = Terrain::gap(0.0, 0.04, 1.0, 1.0, 0.0);
    let ev = support_events(&lone(-0.05), &p, &t, 0.0, 0.2);
    let mut want: Vec<f64> = [c, w, -c]
        .iter()
        .flat_map(|&x| [0.05 - x, 0.09 - x])
        .collect();
    want.sort_by(f64::total_cmp);
    want.dedup();
    assert_eq!(ev.len(), want.len(), "{ev:?} vs {want:?}");
    for (e, w) in ev.iter().zip(&want) {
        assert!((e - w).abs() < 1e-9, "{ev:?} vs {want:?}");
    }
    // Driving at an angle to the body's axis the crossings stretch by 1 / cos.
    let h = 0.3_f64;
    let ev = support_events(&lone(-0.05), &p, &t, h, 0.2);
    let first = (0.05 - c) / h.cos();
    assert!((ev[0] - first).abs() < 1e-9, "{ev:?}");
    // Nothing ahead within the horizon: no events.
    assert!(support_events(&lone(-0.5), &p, &t, 0.0, 0.1).is_empty());
}

#[test]
fn a_support_lost_between_scan_steps_is_judged() {
    let p = behind();
    // A gap narrower than the scan step: the wheels hang over it for 3 mm of the advance,
    // between two samples of a 10 mm scan; on its collinear casters alone the robot tips.
    let t = Terrain::gap(0.0, 0.003, 1.0, 1.0, 0.0);
    let opt = AdvanceOptions {
        horizon: 0.1,
        ..AdvanceOptions::default()
    };
    let a = max_safe_advance_with(&lone(-0.0535), &p, &t, 0.0, 0.01, opt).unwrap();
    assert_eq!(a.limited_by, LimitedBy::Tips, "{a:?}");
    let axle = f64::from(p.non_pilot.plant.wheel_axle_offset);
    assert!((a.distance - (0.0535 - axle)).abs() < 1e-5, "{a:?}");
}

#[test]
fn a_robot_whose_caster_rolls_off_is_checked_right_after() {
    let p = behind();
    // A lone robot at a cliff: when its front caster leaves the platform it still stands on
    // wheels and back caster; when its wheels leave it tips. The gate stops right before the
    // wheels' event, whatever the scan step.
    let t = Terrain::gap(0.0, 1.0, 1.0, 1.0, 0.0);
    let axle = f64::from(p.non_pilot.plant.wheel_axle_offset);
    for step in [0.001, 0.05, 1.0] {
        let opt = AdvanceOptions {
            horizon: 0.2,
            ..AdvanceOptions::default()
        };
        let a = max_safe_advance_with(&lone(-0.05), &p, &t, 0.0, step, opt).unwrap();
        assert_eq!(a.limited_by, LimitedBy::Tips, "step {step}: {a:?}");
        let wheels_off = 0.05 - axle;
        assert!(
            a.distance <= wheels_off && a.distance > wheels_off - 1e-5,
            "step {step}: {a:?}"
        );
    }
}

#[test]
fn casters_stand_clear_by_their_lift() {
    let p = FleetParams::default();
    let t = Terrain::flat();
    let lift = f64::from(p.non_pilot.plant.caster_lift);
    assert!(lift > 0.0);
    let level = assembly_level(&lone(0.0), &p, &t).unwrap();
    let m = build_model(&lone(0.0), &p, &t, level, [0.0, 0.0], false).unwrap();
    // Two wheels touch, two casters stand clear by the lift.
    let mut gaps: Vec<f64> = m.contacts.iter().map(|k| k.gap).collect();
    gaps.sort_by(f64::total_cmp);
    assert_eq!(gaps.len(), 4);
    assert_eq!(&gaps[..2], &[0.0, 0.0]);
    assert!(
        gaps[2..].iter().all(|g| (g - lift).abs() < 1e-12),
        "{gaps:?}"
    );
    // A pilot stands on four wheels, none clear.
    let pilot = PuzzleAssembly {
        robots: vec![RobotPose {
            kind: RobotKind::Pilot,
            ..np(0.0)
        }],
        pairs: vec![],
    };
    let m = build_model(&pilot, &p, &t, level, [0.0, 0.0], false).unwrap();
    assert!(m.contacts.iter().all(|k| k.gap == 0.0));
}
