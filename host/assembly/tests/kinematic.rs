//! Closed-loop check of the planning logic without the MPC: a kinematic fleet where every
//! connected segment moves as one rigid body driven by its leader, and each leader steers its
//! task point onto its partner's point with an off-centre point controller. The coordinator
//! alone must bring scattered robots into the planned shape, pass every pair through
//! decoupled → head aligned → head inserted → connected, and re-plan when a robot vanishes.
//! Direct commands (a lone robot's staged approach) are executed as given.

use puzzlebot_assembly::coordinator::{Coordinator, Role, Tick};
use puzzlebot_assembly::{EventKind, PairStatus, Pose, RobotState, ShapeSpec};
use puzzlebot_params::{FleetParams, RobotKind};
use std::collections::BTreeMap;

const DT: f64 = 0.05;
const V_MAX: f64 = 0.05;
const W_MAX: f64 = 2.0;

/// (v, ω) that moves body point `p` (body frame) of a robot at `pose` towards `target` (world)
/// at rate `k`: ṗ_w = R(θ)[v − ω p_y, ω p_x].
fn steer(pose: &Pose, p: [f64; 2], target: [f64; 2], k: f64, straight: bool) -> (f64, f64) {
    let w = pose.transform(p);
    let (s, c) = pose.yaw.sin_cos();
    let (ex, ey) = (k * (target[0] - w[0]), k * (target[1] - w[1]));
    let (bx, by) = (c * ex + s * ey, -s * ex + c * ey);
    if straight || p[0].abs() < 1e-6 {
        return (bx.clamp(-V_MAX, V_MAX), 0.0);
    }
    let om = (by / p[0]).clamp(-W_MAX, W_MAX);
    ((bx + om * p[1]).clamp(-V_MAX, V_MAX), om)
}

fn step_pose(p: &Pose, v: f64, w: f64) -> Pose {
    Pose::new(
        p.x + v * p.yaw.cos() * DT,
        p.y + v * p.yaw.sin() * DT,
        p.yaw + w * DT,
    )
}

/// Advance the fleet by one step from the tick's tasks.
fn advance(robots: &mut [RobotState], tick: &Tick) {
    let pose_of: BTreeMap<_, _> = robots.iter().map(|r| (r.id, r.pose)).collect();
    let mut cmd: BTreeMap<u16, (f64, f64)> = BTreeMap::new();
    for task in &tick.tasks {
        // A robot that vanished from the fleet still has a task until it is declared lost.
        let Some(&me) = pose_of.get(&task.robot) else {
            continue;
        };
        let c = match &task.role {
            Role::Align {
                partner,
                own_point,
                partner_point,
                ..
            } => {
                let Some(pp) = pose_of.get(partner) else {
                    cmd.insert(task.robot, (0.0, 0.0));
                    continue;
                };
                let target = pp.transform(*partner_point);
                // Each side covers half of the error: both leaders converge.
                steer(&me, *own_point, target, 1.0, task.straight_only)
            }
            Role::Velocity { v, w } => (*v, if task.straight_only { 0.0 } else { *w }),
            // Staged approaches: direct commands near the place, a point goal further out.
            Role::Dock { v, w, .. } | Role::Hitch { v, w, .. } => (*v, *w),
            Role::GoTo { goal, .. } => steer(&me, [0.02, 0.0], goal.xy(), 1.0, task.straight_only),
            _ => (0.0, 0.0),
        };
        cmd.insert(task.robot, c);
    }
    // Rigid segments: every member follows its leader's body motion.
    let mut seg_leader: BTreeMap<usize, u16> = BTreeMap::new();
    for t in &tick.tasks {
        if t.leader == Some(t.robot) {
            seg_leader.insert(t.segment, t.robot);
        }
    }
    let seg_of: BTreeMap<u16, usize> = tick.tasks.iter().map(|t| (t.robot, t.segment)).collect();
    for r in robots.iter_mut() {
        let Some(&seg) = seg_of.get(&r.id) else {
            continue;
        };
        match seg_leader.get(&seg) {
            Some(&leader) if pose_of.contains_key(&leader) => {
                let lp = pose_of[&leader];
                let (v, w) = cmd[&leader];
                let next = step_pose(&lp, v, w);
                // Member pose relative to the leader, carried along.
                let rel_p = lp.inverse_transform(r.pose.xy());
                let rel_yaw = r.pose.yaw - lp.yaw;
                let [x, y] = next.transform(rel_p);
                r.pose = Pose::new(x, y, next.yaw + rel_yaw);
            }
            _ => {
                let (v, w) = cmd.get(&r.id).copied().unwrap_or((0.0, 0.0));
                r.pose = step_pose(&r.pose, v, w);
            }
        }
    }
}

fn run(
    c: &mut Coordinator,
    robots: &mut Vec<RobotState>,
    until: f64,
    lose: Option<(u16, f64)>,
) -> f64 {
    let mut t = 0.0;
    while t < until {
        if let Some((id, at)) = lose {
            if t >= at {
                robots.retain(|r| r.id != id);
            }
        }
        let tick = c.tick(t, robots);
        if tick.complete {
            return t;
        }
        advance(robots, &tick);
        t += DT;
    }
    f64::INFINITY
}

fn np(id: u16, x: f64, y: f64, yaw: f64) -> RobotState {
    RobotState {
        id,
        kind: RobotKind::NonPilot,
        pose: Pose::new(x, y, yaw),
    }
}

#[test]
fn four_scattered_robots_form_a_line() {
    let mut c = Coordinator::from_params(&FleetParams::default());
    let mut robots = vec![
        np(1, 0.00, 0.02, 0.1),
        np(2, 0.12, -0.03, -0.1),
        np(3, 0.24, 0.04, 0.05),
        np(4, 0.36, 0.00, 0.0),
    ];
    c.form(0.0, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
    let done = run(&mut c, &mut robots, 120.0, None);
    assert!(
        done.is_finite(),
        "line not formed; pairs: {:?}",
        c.pairs().iter().map(|p| p.status).collect::<Vec<_>>()
    );
    // Every pair passed through the THESIS sequence.
    for i in 0..3 {
        let seq: Vec<PairStatus> = c
            .events()
            .iter()
            .filter_map(|e| match e.kind {
                EventKind::PairStatus { pair, to, .. } if pair == i => Some(to),
                _ => None,
            })
            .collect();
        assert_eq!(
            seq.last(),
            Some(&PairStatus::Connected),
            "pair {i}: {seq:?}"
        );
        assert!(seq.contains(&PairStatus::HeadAligned) && seq.contains(&PairStatus::HeadInserted));
    }
    // The assembled robots are one body length apart, front to back.
    let mut xs: Vec<f64> = robots.iter().map(|r| r.pose.x).collect();
    xs.sort_by(f64::total_cmp);
    for w in xs.windows(2) {
        assert!((w[1] - w[0] - 0.05).abs() < 0.006, "{xs:?}");
    }
}

#[test]
fn pilot_is_only_driven_once_coupled() {
    let mut c = Coordinator::from_params(&FleetParams::default());
    let mut robots = vec![
        np(1, 0.0, 0.0, 0.0),
        np(2, 0.13, 0.01, 0.0),
        np(3, 0.26, 0.0, 0.0),
    ];
    robots[2].kind = RobotKind::Pilot;
    c.form(0.0, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
    let mut t = 0.0;
    let mut moved_before_coupled = false;
    while t < 120.0 {
        let tick = c.tick(t, &robots);
        if tick.complete {
            break;
        }
        let pilot_coupled = c
            .pairs()
            .iter()
            .any(|p| p.pair.involves(3) && p.status == PairStatus::Connected);
        let before = robots[2].pose;
        advance(&mut robots, &tick);
        if !pilot_coupled && robots[2].pose.distance(&before) > 1e-12 {
            moved_before_coupled = true;
        }
        t += DT;
    }
    assert!(c.is_complete(), "not formed");
    assert!(
        !moved_before_coupled,
        "the pilot moved before it was coupled"
    );
}

#[test]
fn robot_lost_mid_formation_is_replanned_out() {
    let mut c = Coordinator::from_params(&FleetParams::default());
    let mut robots = vec![
        np(1, 0.00, 0.02, 0.0),
        np(2, 0.12, -0.03, 0.0),
        np(3, 0.24, 0.04, 0.0),
        np(4, 0.36, 0.00, 0.0),
    ];
    c.form(0.0, ShapeSpec::Line, &robots, Some(0.0)).unwrap();
    let done = run(&mut c, &mut robots, 120.0, Some((4, 2.0)));
    assert!(done.is_finite(), "three robots did not form after the loss");
    assert!(c
        .events()
        .iter()
        .any(|e| e.kind == EventKind::RobotLost { robot: 4 }));
    let plan = c.plan().unwrap();
    assert_eq!(plan.slot_robot.len(), 3);
    assert_eq!(plan.pairs.len(), 2);
}
