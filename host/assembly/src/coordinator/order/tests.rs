//! Tests of `order`.

use super::*;
use crate::coordinator::fixtures::*;

#[test]
fn a_lone_robot_does_not_approach_through_a_robot_on_its_axis() {
    // A line of four: the rear pair is connected, the robot second from the front is
    // 30 mm off its place and the front robot stands at its own place, i.e. on the axis
    // along which the second robot would reverse its anchor into the rear pair.
    let mut c = coordinator();
    let robots: Vec<RobotState> = (0..4)
        .map(|k| np(k + 1, -0.06 * f64::from(k), 0.0, 0.0))
        .collect();
    let kinds: BTreeMap<_, _> = robots.iter().map(|r| (r.id, r.kind)).collect();
    c.form(0.0, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
    let mut poses = at_goals(&c, &kinds);
    poses.sort_by(|a, b| b.pose.x.total_cmp(&a.pose.x));
    let (front, second, third) = (poses[0].id, poses[1].id, poses[2].id);
    poses[1].pose.y += 0.03;
    for k in 0..5 {
        c.tick(0.1 * f64::from(k), &poses);
    }
    let pair = |a: RobotId, b: RobotId| {
        c.pairs()
            .iter()
            .position(|tp| (tp.pair.a, tp.pair.b) == (a, b) || (tp.pair.a, tp.pair.b) == (b, a))
            .unwrap()
    };
    let (join, ahead) = (pair(second, third), pair(front, second));
    assert_eq!(
        c.pairs()[join].pair.a,
        second,
        "the second robot's anchor: {:?}",
        c.pairs()
    );
    assert_eq!(c.pairs()[join].status, PairStatus::Decoupled);
    let segments = c.segments();
    assert!(
        c.approach_blocked(join, &segments),
        "the front robot is on the axis"
    );
    let tick = c.tick(0.5, &poses);
    assert!(
        tick.active.contains(&ahead) && !tick.active.contains(&join),
        "the pair with the front robot goes first: active {:?}",
        tick.active
    );
    // With the front robot out of the way the approach is free again.
    poses[0].pose.y += 0.1;
    c.tick(0.6, &poses);
    assert!(!c.approach_blocked(join, &c.segments()));
}
