//! Coupling mechanics driven by the real firmware: insertion needs alignment, no straight
//! pull-out, release by wiggling (THESIS 4.2.2, 4.3.2, 5.2.2, 5.4.2).

mod common;

use common::{connect, drive, key, speed, MiniHost};
use puzzlebot_protocol::HostMsg;
use puzzlebot_sim::{CouplingSpec, EventKind, LinkKind, RobotSpec, Scenario, World};

/// Robot 1 (opening) behind robot 2 (anchor on its back), both facing +x; 2 is `gap` m
/// ahead of the coupled position and `dy` m aside.
fn pair(gap: f64, dy: f64, coupled: bool) -> Scenario {
    let mut s = Scenario::grid(0, 5);
    s.robots = vec![
        RobotSpec {
            id: 1,
            kind: puzzlebot_protocol::RobotKind::NonPilot,
            pose: [0.0, 0.0, 0.0],
            impairments: None,
            offline: false,
            mismatch: puzzlebot_sim::PlantMismatch::NONE,
        },
        RobotSpec {
            id: 2,
            kind: puzzlebot_protocol::RobotKind::NonPilot,
            pose: [0.05 + gap, dy, 0.0],
            impairments: None,
            offline: false,
            mismatch: puzzlebot_sim::PlantMismatch::NONE,
        },
    ];
    if coupled {
        s.couplings = vec![CouplingSpec {
            kind: LinkKind::Anchor,
            a: 2,
            b: 1,
        }];
    }
    s
}

fn approach(dy: f64) -> World {
    approach_from(pair(0.02, dy, false))
}

fn approach_from(s: Scenario) -> World {
    let mut w = World::new(&s, &key()).expect("world");
    let mut host = MiniHost::new(key());
    connect(&mut w, &mut host, 2.0);
    // Robot 1 drives forward into robot 2's anchor; robot 2 holds still; both stop once
    // coupled (pushing on through the anchor's pivot would jackknife the pair).
    for _ in 0..40 {
        drive(&mut w, &mut host, 0.05, |_, id| {
            Some(if id == 1 {
                speed(60.0, 60.0)
            } else {
                speed(0.0, 0.0)
            })
        });
        if w.ground_truth().are_coupled(2, 1) {
            break;
        }
    }
    drive(&mut w, &mut host, 0.3, |_, _| Some(HostMsg::Stop));
    w
}

#[test]
fn aligned_robots_couple_when_driven_together() {
    let w = approach(0.002);
    let t = w.ground_truth();
    assert!(t.are_coupled(2, 1), "links {:?}", w.links());
    assert!(t.events.iter().any(|e| e.kind
        == EventKind::Coupled {
            kind: LinkKind::Anchor,
            a: 2,
            b: 1
        }));
    // Anchor fully in: centres one body length apart (within the 5 mm travel), in line.
    let (p1, p2) = (t.robot(1).unwrap().pose, t.robot(2).unwrap().pose);
    let d = ((p2.x - p1.x).powi(2) + (p2.y - p1.y).powi(2)).sqrt();
    assert!((0.0495..0.0556).contains(&d), "{p1:?} {p2:?}");
}

#[test]
fn robots_misaligned_by_5_mm_do_not_couple_and_do_not_overlap() {
    let w = approach(0.005);
    let t = w.ground_truth();
    assert!(!t.are_coupled(2, 1), "links {:?}", w.links());
    let (p1, p2) = (t.robot(1).unwrap().pose, t.robot(2).unwrap().pose);
    // The anchor head (7 mm) stops on robot 1's front face: the bodies stay ≥ 7 mm apart,
    // and robot 1 pushes robot 2 ahead of it.
    assert!(p2.x - p1.x > 0.056, "{p1:?} {p2:?}");
    assert!(p2.x > 0.0705, "robot 2 was pushed: {p2:?}");
}

#[test]
fn coupled_pair_holds_a_straight_pull_but_separates_within_2_s_of_wiggling() {
    let mut w = World::new(&pair(0.0, 0.0, true), &key()).expect("world");
    let mut host = MiniHost::new(key());
    connect(&mut w, &mut host, 2.0);
    assert!(w.ground_truth().are_coupled(2, 1));
    // Drive straight apart for 3 s: robot 2 forward, robot 1 backward.
    drive(&mut w, &mut host, 3.0, |_, id| {
        Some(if id == 2 {
            speed(200.0, 200.0)
        } else {
            speed(-200.0, -200.0)
        })
    });
    let t = w.ground_truth();
    assert!(
        t.are_coupled(2, 1),
        "a straight pull must not release the anchor"
    );
    let (p1, p2) = (t.robot(1).unwrap().pose, t.robot(2).unwrap().pose);
    let sep = ((p2.x - p1.x).powi(2) + (p2.y - p1.y).powi(2)).sqrt();
    assert!(
        sep < 0.05 + 0.0055,
        "separation {sep} within the 5 mm travel"
    );
    // Push back together, then the anchor robot wiggles (THESIS 5.7): v_bias forward,
    // ω = ω_max·sgn(sin(B t)), period 1 s; robot 1 stays put.
    drive(&mut w, &mut host, 0.5, |_, id| {
        Some(if id == 1 {
            speed(60.0, 60.0)
        } else {
            speed(0.0, 0.0)
        })
    });
    let start = w.time_us();
    let r = 0.017;
    let half_base = 0.02;
    let rpm = |v: f64| (v / r * 60.0 / std::f64::consts::TAU) as f32;
    let t0 = start as f64 * 1e-6;
    drive(&mut w, &mut host, 2.0, |t, id| {
        if id == 1 {
            return Some(HostMsg::Stop);
        }
        let (v_bias, w_max) = (0.08, 6.0);
        let om = w_max * (std::f64::consts::TAU * (t - t0)).sin().signum();
        Some(speed(
            rpm(v_bias - om * half_base),
            rpm(v_bias + om * half_base),
        ))
    });
    let released = w.events().iter().find(|e| {
        e.kind
            == EventKind::Decoupled {
                kind: LinkKind::Anchor,
                a: 2,
                b: 1,
            }
    });
    let released = released.expect("the wiggle releases the anchor");
    let after = (released.t_us - start) as f64 * 1e-6;
    println!("released after {after:.2} s of wiggling");
    assert!(after <= 2.0);
    assert!(!w.ground_truth().are_coupled(2, 1));
}

#[test]
fn coupled_groups_move_together() {
    let mut w = World::new(&pair(0.0, 0.0, true), &key()).expect("world");
    let mut host = MiniHost::new(key());
    connect(&mut w, &mut host, 2.0);
    drive(&mut w, &mut host, 2.0, |_, _| Some(speed(150.0, 150.0)));
    let t = w.ground_truth();
    assert!(t.are_coupled(2, 1));
    let (p1, p2) = (t.robot(1).unwrap().pose, t.robot(2).unwrap().pose);
    assert!(p1.x > 0.3, "the pair drove: {p1:?}");
    assert!(
        (p2.x - p1.x - 0.05).abs() < 0.006 && (p2.y - p1.y).abs() < 0.003,
        "{p1:?} {p2:?}"
    );
}

#[test]
fn an_anchor_yawed_within_the_entry_angle_still_seats() {
    // Robot 2 turned by 0.2 rad about its anchor head, the head 1 mm aside of the opening
    // axis: the front corner of robot 1 would touch robot 2's back face 5 mm before the
    // seat if the bodies blocked each other; the anchor's guide governs instead.
    let mut s = pair(0.02, 0.0, false);
    let yaw: f64 = 0.2;
    let head = [0.05 + 0.02 - 0.032, 0.001];
    s.robots[1].pose = [
        head[0] + 0.032 * yaw.cos(),
        head[1] + 0.032 * yaw.sin(),
        yaw,
    ];
    let w = approach_from(s);
    assert!(w.ground_truth().are_coupled(2, 1), "links {:?}", w.links());
}

/// Robot 2 pressed onto robot 1's left side, shifted `dx` forward.
fn side_by_side(dx: f64) -> World {
    let mut s = pair(0.0, 0.0, false);
    s.robots[1].pose = [dx, 0.0505, 0.0];
    let mut w = World::new(&s, &key()).expect("world");
    // Pressed together by hand (robots cannot drive sideways).
    w.place(2, puzzlebot_sim::Pose::new(dx, 0.0499, 0.0));
    w.run_for(50_000);
    w
}

#[test]
fn a_half_body_offset_puts_one_knob_into_one_hole_as_in_a_mesh() {
    // THESIS 5.2.2: mesh rows are offset by half a body; robot 1's front-left knob meets
    // robot 2's back-right hole (THESIS Fig 5.12 connection points at ±12.5 mm).
    let mut w = side_by_side(0.0255);
    assert!(w.ground_truth().are_coupled(1, 2), "{:?}", w.links());
    // Rigid at the offset once in: pushing robot 2 back along x does not slide it.
    w.run_for(200_000);
    let t = w.ground_truth();
    let (p1, p2) = (t.robot(1).unwrap().pose, t.robot(2).unwrap().pose);
    let rel = p1.inverse_transform(p2.xy());
    assert!(
        (rel[0] - 0.025).abs() < 1e-3 && (rel[1] - 0.05).abs() < 1e-3,
        "{rel:?}"
    );
    // Between the connection points (6 mm off either): no knob fits.
    assert!(!side_by_side(0.019).ground_truth().are_coupled(1, 2));
}

#[test]
fn robots_placed_overlapping_are_pushed_apart_not_thrown() {
    // Repairing an overlap the robots already had moves them apart but gives them no speed:
    // the projection never adds kinetic energy (`world/feedback.rs`).
    let mut w = World::new(&pair(0.0, 0.0, false), &key()).expect("world");
    // Robot 2 dropped 20 mm into robot 1's side (by hand: robots cannot drive sideways).
    w.place(2, puzzlebot_sim::Pose::new(0.0, 0.03, 0.0));
    w.run_for(2_000_000);
    let t = w.ground_truth();
    let (p1, p2) = (t.robot(1).unwrap().pose, t.robot(2).unwrap().pose);
    let apart = (p2.x - p1.x).hypot(p2.y - p1.y);
    assert!(
        apart >= 0.049,
        "still overlapping: centres {apart:.4} m apart"
    );
    // Sides just touching (50 mm between centres), each moved about half the overlap.
    assert!(apart < 0.053, "pushed {apart:.4} m apart: thrown");
    for (p, y0) in [(p1, 0.0), (p2, 0.03)] {
        assert!(
            p.x.hypot(p.y - y0) < 0.015,
            "a robot was thrown from (0, {y0}) to ({:.3}, {:.3})",
            p.x,
            p.y
        );
    }
}
