//! Tests of the contact and coupling mechanics.

use super::*;
use crate::math::Pose;

fn body(x: f64, y: f64, yaw: f64) -> Body {
    Body::new(Pose::new(x, y, yaw), 0.1, 4.5e-5)
}

#[test]
fn an_entering_anchor_torn_away_sideways_lets_go_and_drags_nothing() {
    let mut m = Mechanics::new(&Geometry::default(), &Coupling::default());
    // Robot 0 (anchor) directly ahead of robot 1, its head 2 mm inside 1's opening.
    let mut b = vec![body(0.055, 0.0, 0.0), body(0.0, 0.0, 0.0)];
    let mut ev = Vec::new();
    m.resolve(&mut b, &mut ev);
    assert_eq!(m.links().len(), 1);
    assert_eq!(m.links()[0].state, LinkState::Inserting);
    // Knocked 20 mm sideways before it seated: the link goes, robot 1 stays put.
    b[0].pose.y = 0.02;
    b[0].retrig();
    m.resolve(&mut b, &mut ev);
    assert!(m.links().is_empty(), "{:?}", m.links());
    assert!(
        b[1].pose.x.abs() < 1e-9 && b[1].pose.y.abs() < 1e-9,
        "{:?}",
        b[1]
    );
}

#[test]
fn overlapping_robots_are_pushed_apart() {
    let mut m = Mechanics::new(&Geometry::default(), &Coupling::default());
    let mut b = vec![body(0.0, 0.0, 0.0), body(0.0, 0.04, 0.0)];
    let mut ev = Vec::new();
    m.resolve(&mut b, &mut ev);
    assert!(b[1].pose.y - b[0].pose.y >= 0.0499, "{:?}", b);
}
