//! Robots, shapes and formed assemblies shared by the coordinator's tests.

use super::*;

pub(super) fn np(id: RobotId, x: f64, y: f64, yaw: f64) -> RobotState {
    RobotState {
        id,
        kind: RobotKind::NonPilot,
        pose: Pose2::new(x, y, yaw),
    }
}

/// Four robots 0.3 m apart on a square, all facing +x.
pub(super) fn four_apart() -> Vec<RobotState> {
    vec![
        np(1, 0.0, 0.0, 0.0),
        np(2, 0.3, 0.0, 0.0),
        np(3, 0.0, 0.3, 0.0),
        np(4, 0.3, 0.3, 0.0),
    ]
}

/// Pilot 1 at the origin and three non-pilots scattered round it.
pub(super) fn pilot_and_three_scattered() -> Vec<RobotState> {
    let mut robots = vec![
        np(1, 0.0, 0.0, 0.0),
        np(2, 0.3, 0.2, 1.0),
        np(3, -0.3, 0.3, 2.0),
        np(4, 0.2, -0.3, -1.0),
    ];
    robots[0].kind = RobotKind::Pilot;
    robots
}

pub(super) fn coordinator() -> Coordinator {
    Coordinator::from_params(&FleetParams::default())
}

/// Robots standing exactly on their plan's goal poses.
pub(super) fn at_goals(c: &Coordinator, kinds: &BTreeMap<RobotId, RobotKind>) -> Vec<RobotState> {
    let plan = c.plan().unwrap();
    plan.slot_robot
        .iter()
        .zip(&plan.goal_poses)
        .map(|(&id, &pose)| RobotState {
            id,
            kind: kinds[&id],
            pose,
        })
        .collect()
}

/// [`four_apart`] forming a 2×2 mesh heading along +x: the coordinator, the robots and
/// their kinds.
pub(super) fn mesh_2x2_of_four_apart(
) -> (Coordinator, Vec<RobotState>, BTreeMap<RobotId, RobotKind>) {
    let mut c = coordinator();
    let robots = four_apart();
    let kinds = robots.iter().map(|r| (r.id, r.kind)).collect();
    c.form(0.0, ShapeSpec::Mesh { rows: 2 }, &robots, Some(0.0))
        .unwrap();
    (c, robots, kinds)
}

pub(super) fn role_of(tick: &Tick, id: RobotId) -> &Role {
    &tick.tasks.iter().find(|t| t.robot == id).unwrap().role
}

/// Two robots that formed a line by t = 0.5 s (no settling), standing at their goals.
pub(super) fn formed_pair() -> (Coordinator, Vec<RobotState>) {
    formed(
        ShapeSpec::Line,
        &[np(1, 0.0, 0.0, 0.0), np(2, 0.2, 0.0, 0.0)],
    )
}

/// Three non-pilots 0.1 m apart along the x axis, all facing +x (robot 1 ahead).
pub(super) fn line_of_three() -> [RobotState; 3] {
    [
        np(1, 0.0, 0.0, 0.0),
        np(2, -0.1, 0.0, 0.0),
        np(3, -0.2, 0.0, 0.0),
    ]
}

/// `robots` formed into `spec` (every robot on its goal, every pair connected).
pub(super) fn formed(spec: ShapeSpec, robots: &[RobotState]) -> (Coordinator, Vec<RobotState>) {
    let mut c = coordinator();
    c.cfg.form_settle_s = 0.0;
    let kinds: BTreeMap<_, _> = robots.iter().map(|r| (r.id, r.kind)).collect();
    c.form(0.0, spec, robots, Some(0.0)).unwrap();
    let goal = at_goals(&c, &kinds);
    let mut t = 0.0;
    while !c.tick(t, &goal).complete {
        t += 0.1;
        assert!(t < 5.0, "formed: {:?}", c.pairs());
    }
    (c, goal)
}
