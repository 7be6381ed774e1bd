//! PuzzleBot adapter: a rigid mesh advancing over a gap edge stops at the centre-of-mass bound.

use puzzlebot_params::formation::{self, Shape};
use puzzlebot_params::terrain::{Platform, Terrain};
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_stability::puzzlebot::*;
use puzzlebot_stability::{evaluate, Verdict};

fn params() -> FleetParams {
    let mut p = FleetParams::default();
    // Centre of mass a little ahead of the wheel axle (keeps the geometry non-degenerate).
    p.non_pilot.mass.com = [0.005, 0.0];
    p.pilot.mass.com = [0.005, 0.0];
    p
}

fn np(x: f64, y: f64) -> RobotPose {
    RobotPose {
        kind: RobotKind::NonPilot,
        x,
        y,
        yaw: 0.0,
    }
}

/// Platform ending at x = `edge`, nothing beyond (a wide gap).
/// Robots 0…n−1 joined in a line, each robot's anchor in the next one's opening.
fn anchor_chain(n: usize) -> Vec<Pair> {
    (0..n.saturating_sub(1))
        .map(|i| Pair {
            a: i,
            b: i + 1,
            kind: PairKind::Anchor,
            point: None,
        })
        .collect()
}

fn cliff(edge: f64) -> Terrain {
    Terrain {
        platforms: vec![Platform::rect("near", [-2.0, -1.0], [edge, 1.0], 0.0)],
    }
}

/// The centre-of-mass bound for a rigid assembly heading +x towards an edge at `edge`: it may
/// advance until the first contact at or ahead of the centre of mass reaches the edge.
fn com_bound(a: &PuzzleAssembly, p: &FleetParams, edge: f64) -> f64 {
    let mut mass = 0.0;
    let mut cx = 0.0;
    let mut xs = vec![];
    for r in &a.robots {
        let rp = p.robot(r.kind);
        mass += rp.mass.mass as f64;
        cx += rp.mass.mass as f64 * (r.x + rp.mass.com[0] as f64);
        for (b, _) in contact_points(r.kind, p) {
            xs.push(r.x + b[0]);
        }
    }
    cx /= mass;
    let ahead = xs
        .into_iter()
        .filter(|x| *x >= cx)
        .fold(f64::INFINITY, f64::min);
    edge - ahead
}

#[test]
fn rigid_row_over_a_gap_edge_stops_at_the_com_bound() {
    let p = params();
    // Three robots side by side, joined by knobs.
    let a = PuzzleAssembly {
        robots: vec![np(0.0, 0.0), np(0.0, 0.05), np(0.0, 0.10)],
        pairs: vec![
            Pair {
                a: 0,
                b: 1,
                kind: PairKind::Knob,
                point: None,
            },
            Pair {
                a: 1,
                b: 2,
                kind: PairKind::Knob,
                point: None,
            },
        ],
    };
    let edge = 0.3;
    let opt = AdvanceOptions {
        rigid_couplings: true,
        anchor_pitch_free: false,
        anchor_slides: false,
        knob_tilt_free: false,
        elastic: false,
        drive_accel: 0.0,
        max_drop: 0.0,
        transfer: None,
        settling: None,
        bridge_speed: 0.0,
        horizon: 1.0,
    };
    let adv = max_safe_advance_with(&a, &p, &cliff(edge), 0.0, 0.01, opt).unwrap();
    let bound = com_bound(&a, &p, edge);
    let caster = f64::from(p.non_pilot.plant.caster_offset);
    assert!((bound - (edge - caster)).abs() < 1e-9);
    assert!((adv.distance - bound).abs() < 1e-5, "{adv:?} vs {bound}");
    assert_eq!(adv.limited_by, LimitedBy::Tips);
}

#[test]
fn rigid_two_by_two_mesh_over_a_gap_edge_stops_at_the_com_bound() {
    let p = params();
    let back = -0.057; // anchor head (−0.032) into the opening (+0.025) of the robot behind
    let a = PuzzleAssembly {
        robots: vec![np(0.0, 0.0), np(0.0, 0.05), np(back, 0.0), np(back, 0.05)],
        pairs: vec![
            Pair {
                a: 0,
                b: 1,
                kind: PairKind::Knob,
                point: None,
            },
            Pair {
                a: 2,
                b: 3,
                kind: PairKind::Knob,
                point: None,
            },
            Pair {
                a: 0,
                b: 2,
                kind: PairKind::Anchor,
                point: None,
            },
            Pair {
                a: 1,
                b: 3,
                kind: PairKind::Anchor,
                point: None,
            },
        ],
    };
    let edge = 0.2;
    let opt = AdvanceOptions {
        rigid_couplings: true,
        anchor_pitch_free: false,
        anchor_slides: false,
        knob_tilt_free: false,
        elastic: false,
        drive_accel: 0.0,
        max_drop: 0.0,
        transfer: None,
        settling: None,
        bridge_speed: 0.0,
        horizon: 1.0,
    };
    let adv = max_safe_advance_with(&a, &p, &cliff(edge), 0.0, 0.01, opt).unwrap();
    let bound = com_bound(&a, &p, edge);
    assert!((adv.distance - bound).abs() < 1e-5, "{adv:?} vs {bound}");
    assert_eq!(adv.limited_by, LimitedBy::Tips);

    // With the measured coupling limits the advance can only be shorter, never longer.
    let measured = max_safe_advance(&a, &p, &cliff(edge), 0.0, 0.01).unwrap();
    assert!(measured.distance <= adv.distance + 1e-9, "{measured:?}");
}

#[test]
fn flat_floor_reaches_the_horizon_and_a_step_up_blocks() {
    let p = params();
    let a = PuzzleAssembly {
        robots: vec![np(0.0, 0.0), np(0.0, 0.05)],
        pairs: vec![Pair {
            a: 0,
            b: 1,
            kind: PairKind::Knob,
            point: None,
        }],
    };
    let adv = max_safe_advance(&a, &p, &Terrain::flat(), 0.0, 0.05).unwrap();
    assert_eq!(adv.limited_by, LimitedBy::Horizon);
    let mut t = cliff(0.5);
    t.platforms
        .push(Platform::rect("wall", [0.5, -1.0], [1.0, 1.0], 0.05));
    let adv = max_safe_advance(&a, &p, &t, 0.0, 0.05).unwrap();
    assert!(
        matches!(adv.limited_by, LimitedBy::StepUp { .. }),
        "{adv:?}"
    );
    // The front casters reach the wall.
    let caster = f64::from(p.non_pilot.plant.caster_offset);
    assert!((adv.distance - (0.5 - caster)).abs() < 1e-5, "{adv:?}");
}

#[test]
fn a_cantilevered_chain_breaks_its_anchor_before_it_tips() {
    // A line of robots heading +x, joined anchor to opening, pushed over a cliff: the front
    // robots hang from the anchors, which hold ≈ 4.9 N but only a small bending couple.
    let p = params();
    let robots: Vec<RobotPose> = (0..6).map(|i| np(-0.057 * i as f64, 0.0)).collect();
    let pairs = anchor_chain(6);
    let a = PuzzleAssembly { robots, pairs };
    let measured = max_safe_advance(&a, &p, &cliff(0.1), 0.0, 0.01).unwrap();
    let rigid = max_safe_advance_with(
        &a,
        &p,
        &cliff(0.1),
        0.0,
        0.01,
        AdvanceOptions {
            rigid_couplings: true,
            anchor_pitch_free: false,
            anchor_slides: false,
            knob_tilt_free: false,
            elastic: false,
            drive_accel: 0.0,
            max_drop: 0.0,
            transfer: None,
            settling: None,
            bridge_speed: 0.0,
            horizon: 1.0,
        },
    )
    .unwrap();
    assert_eq!(rigid.limited_by, LimitedBy::Tips);
    assert!(
        measured.distance < rigid.distance,
        "{measured:?} vs {rigid:?}"
    );
    match &measured.limited_by {
        LimitedBy::Connection { pairs } => assert!(!pairs.is_empty(), "{pairs:?}"),
        other => panic!("expected a connection limit, got {other:?}"),
    }
    // At rest on the floor the chain is stable with a positive margin.
    let m = build_model(&a, &p, &Terrain::flat(), 0.0, [0.0, 0.0], false).unwrap();
    let r = evaluate(&m).unwrap();
    assert_eq!(r.verdict, Verdict::Stable);
    assert!(r.margin.unwrap() > 0.0);
}

#[test]
fn bad_pairs_are_rejected() {
    let p = params();
    let a = PuzzleAssembly {
        robots: vec![np(0.0, 0.0)],
        pairs: vec![Pair {
            a: 0,
            b: 3,
            kind: PairKind::Knob,
            point: None,
        }],
    };
    assert_eq!(
        max_safe_advance(&a, &p, &Terrain::flat(), 0.0, 0.01).unwrap_err(),
        AdapterError::BadPair(0)
    );
}

#[test]
fn offset_rows_joined_at_side_points_stand_stable() {
    // Rows offset by half a body: r0's front-left knob sits in r1's back-right hole.
    let p = params();
    let sx = p.non_pilot.geometry.side_point_x as f64;
    let a = PuzzleAssembly {
        robots: vec![np(0.0, 0.0), np(0.025, 0.05)],
        pairs: vec![Pair {
            a: 0,
            b: 1,
            kind: PairKind::Knob,
            point: Some([sx, 0.025]),
        }],
    };
    let m = build_model(&a, &p, &Terrain::flat(), 0.0, [0.0, 0.0], false).unwrap();
    assert!((m.connections[0].point[0] - sx).abs() < 1e-12);
    let r = evaluate(&m).unwrap();
    assert_eq!(r.verdict, Verdict::Stable);
    assert!(r.margin.unwrap() > 0.0);
}

/// A lone pilot heading 40° towards an edge: once its leading wheel is over the edge, its
/// centre of mass stands exactly over the diagonal of the other three. Quasi-statically that
/// passes as stable until the next wheel leaves; covering the drive's braking, the gate stops
/// where the leading wheel leaves.
#[test]
fn a_pilot_on_three_wheels_is_not_proven_under_the_drive_s_braking() {
    let p = FleetParams::default();
    let heading = 40f64.to_radians();
    let a = PuzzleAssembly {
        robots: vec![RobotPose {
            kind: RobotKind::Pilot,
            x: 0.0,
            y: 0.0,
            yaw: heading,
        }],
        pairs: vec![],
    };
    let edge = 0.1;
    // Contacts' x, leading first; the advance at which each reaches the edge.
    let mut xs: Vec<f64> = contact_points(RobotKind::Pilot, &p)
        .iter()
        .map(|(b, _)| b[0] * heading.cos() - b[1] * heading.sin())
        .collect();
    xs.sort_by(|a, b| b.total_cmp(a));
    let leaves = |x: f64| (edge - x) / heading.cos();
    let (first, second) = (leaves(xs[0]), leaves(xs[1]));
    assert!(second - first > 0.02, "{xs:?}");
    let step = 0.002;
    let advance = |drive_accel: f64| {
        let opt = AdvanceOptions {
            drive_accel,
            ..AdvanceOptions::default()
        };
        max_safe_advance_with(&a, &p, &cliff(edge), heading, step, opt).unwrap()
    };
    let quasi = advance(0.0);
    assert!(quasi.distance > first + 0.01, "{quasi:?}: {first} {second}");
    let braking = advance(1.0);
    assert!(
        braking.distance <= first + step && braking.distance > first - 0.005,
        "{braking:?}: {first}"
    );
    assert_eq!(braking.limited_by, LimitedBy::Tips);
}

#[test]
fn a_front_pilot_tips_when_its_front_wheels_leave_unless_the_anchor_holds_a_pull() {
    // A pilot leading three non-pilots on soft anchors, driven over a cliff. With its front wheels
    // past the edge the pilot stands on its rear axle with its centre of mass ahead of it:
    // only a couple holds it level. A free-pitch anchor gives none by itself, but a pull at
    // the anchor's height (the pilot's tail held back) against its rear wheels' friction
    // does; the printed anchor slides out over its travel instead (THESIS 4.2.2), so with
    // `anchor_slides` the gate stops where the front wheels leave the edge.
    let p = params();
    let pilot = RobotPose {
        kind: RobotKind::Pilot,
        ..np(0.0, 0.0)
    };
    let pitch = puzzlebot_params::formation::anchor_pitch(&p.non_pilot.geometry);
    let mut robots = vec![pilot];
    robots.extend((1..4).map(|i| np(-pitch * f64::from(i), 0.0)));
    let pairs = anchor_chain(4);
    let a = PuzzleAssembly { robots, pairs };
    let edge = 0.05;
    let front_wheels = contact_points(RobotKind::Pilot, &p)
        .iter()
        .map(|(b, _)| b[0])
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(
        (front_wheels - f64::from(p.pilot.plant.wheel_axle_offset)).abs() < 1e-9,
        "the gate's wheels are the physics' ({front_wheels})"
    );
    let advance = |anchor_slides: bool| {
        let opt = AdvanceOptions {
            anchor_pitch_free: true,
            anchor_slides,
            horizon: 0.2,
            ..AdvanceOptions::default()
        };
        max_safe_advance_with(&a, &p, &cliff(edge), 0.0, 0.002, opt).unwrap()
    };
    let slides = advance(true);
    assert_eq!(slides.limited_by, LimitedBy::Tips, "{slides:?}");
    assert!(
        (slides.distance - (edge - front_wheels)).abs() < 1e-5,
        "{slides:?}: the front wheels leave at {}",
        edge - front_wheels
    );
    let pulls = advance(false);
    assert!(
        pulls.distance > slides.distance + 0.01,
        "{pulls:?} vs {slides:?}"
    );
}

/// A line of six, its pilot at the back, 40° to a 30 mm gap whose far platform is 6 mm lower,
/// stands on nothing that holds it for a few millimetres where a caster leaves the edge
/// before the next contact arrives. The gate proves that stretch at a crossing speed of
/// 44.6 mm/s (the drive braking at v / τ, τ = 50 ms, as the host's) and lists it; at 20 mm/s
/// the line tips further before it lands, and the gate stops where the stretch begins.
#[test]
fn a_stretch_without_support_is_proven_only_at_speed() {
    let terrain = Terrain {
        platforms: vec![
            Platform::rect("near", [-1.0, -1.0], [0.3, 1.0], 0.006),
            Platform::rect("far", [0.33, -1.0], [1.6, 1.0], 0.0),
        ],
    };
    let tau = 0.05;
    let line = |speed: f64| {
        let opt = puzzlebot_stability::crossing::CrossingOptions {
            headings: vec![40f64.to_radians()],
            drive_accel: 0.0446 / tau,
            bridge_speed: speed,
            ..Default::default()
        };
        let params = FleetParams::default();
        let shape = Shape::Line(6);
        let links = formation::layout(shape, &params.non_pilot.geometry).1;
        puzzlebot_stability::crossing::plan_formed(&terrain, &params, shape, &[5], &links, &opt)
            .expect("plan")
            .remove(0)
    };
    let fast = line(0.0446);
    assert!(
        fast.crosses() && !fast.advance.bridged.is_empty(),
        "{fast:?}"
    );
    for b in &fast.advance.bridged {
        assert!(b[0] < b[1] && b[1] - b[0] < 0.01, "{b:?}");
    }
    let stop = fast.advance.stop_limit();
    assert!(stop < fast.required);
    let slow = line(0.02);
    assert!(
        !slow.crosses() && slow.advance.bridged.is_empty(),
        "{slow:?}"
    );
    assert!(
        (slow.advance.distance - stop).abs() < 0.005,
        "{slow:?} vs {stop}"
    );
}
