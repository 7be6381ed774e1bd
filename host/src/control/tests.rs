//! Tests of the reference trajectories and the tracker.

use super::*;

#[test]
fn trajectory_profile_reaches_the_end_with_feed_forward() {
    let tr = Trajectory {
        path: Path::Circle {
            center: [0.0, 0.0],
            radius: 0.1,
            phase: -std::f64::consts::FRAC_PI_2,
            ccw: true,
        },
        speed: 0.05,
        accel: 0.1,
    };
    let d = tr.duration();
    assert!(
        (d - (2.0 * std::f64::consts::PI * 0.1 / 0.05 + 0.5)).abs() < 1e-9,
        "{d}"
    );
    let s0 = tr.at(0.0);
    assert!((s0.x - 0.0).abs() < 1e-12 && (s0.y + 0.1).abs() < 1e-12 && s0.theta.abs() < 1e-12);
    let mid = tr.at(d / 2.0);
    assert!((mid.omega - 0.5).abs() < 1e-9 && (mid.v - 0.05).abs() < 1e-9);
    let end = tr.at(d + 1.0);
    assert!(end.v.abs() < 1e-12 && (end.y + 0.1).abs() < 1e-9);
}

#[test]
fn tracker_converges_on_an_ideal_unicycle() {
    let tr = Trajectory {
        path: Path::Line {
            start: [0.0, 0.0],
            heading: 0.3,
            length: 0.4,
        },
        speed: 0.06,
        accel: 0.1,
    };
    // Start 1 cm off the line and 0.1 rad off heading.
    let mut p = PoseSample {
        t: 0.0,
        x: 0.0,
        y: 0.01,
        theta: 0.4,
    };
    let dt = 1.0 / 30.0;
    let mut err = 0.0;
    while p.t < tr.duration() {
        let u = track(tr.at(p.t), p, TrackerGains::default());
        p.x += u.v * p.theta.cos() * dt;
        p.y += u.v * p.theta.sin() * dt;
        p.theta += u.omega * dt;
        p.t += dt;
        let r = tr.at(p.t);
        err = ((r.x - p.x).powi(2) + (r.y - p.y).powi(2)).sqrt();
    }
    assert!(err < 1e-3, "final error {err}");
}
