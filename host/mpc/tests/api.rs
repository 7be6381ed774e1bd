//! Input validation, limits and API behaviour.

use puzzlebot_mpc::*;
use puzzlebot_params::{drive::Drive, RobotKind};

fn nonpilot() -> Limits {
    Limits::from_drive(&Drive::for_kind(RobotKind::NonPilot))
}

#[test]
fn butterfly_membership_per_robot_kind() {
    let np = nonpilot();
    let pilot = Limits::from_drive(&Drive::for_kind(RobotKind::Pilot));
    // Turning in place is outside for both kinds; stop is inside.
    assert!(!np.contains(Command::new(0.0, 0.5), 1e-9));
    assert!(!pilot.contains(Command::new(0.0, 0.1), 1e-9));
    assert!(np.contains(Command::STOP, 0.0) && pilot.contains(Command::STOP, 0.0));
    // Non-pilot: A = (0.037, 2.19) and its mirror are corners; B = (0.11, 0) the tip.
    assert!(np.contains(Command::new(0.037, 2.19), 1e-9));
    assert!(np.contains(Command::new(-0.037, -2.19), 1e-9));
    assert!(np.contains(Command::new(0.11, 0.0), 1e-9));
    assert!(!np.contains(Command::new(0.111, 0.0), 1e-9));
    // Pilots need forward speed to turn: (0.1, 0.5) is out, (0.34, 0.5) in.
    assert!(!pilot.contains(Command::new(0.1, 0.5), 1e-9));
    assert!(pilot.contains(Command::new(0.34, 0.5), 1e-9));
    assert!(!np.contains(Command::new(f64::NAN, 0.0), 1.0));
}

#[test]
fn pilot_plans_stay_in_its_butterfly() {
    let pilot = Limits::from_drive(&Drive::for_kind(RobotKind::Pilot));
    let mut mpc = DistributedMpc::with_threads(MpcConfig::default(), 1).unwrap();
    let mut pose = Pose::new(0.0, 0.0, 0.0);
    for _ in 0..30 {
        let r = RobotInput {
            id: 7,
            pose,
            limits: pilot,
            costs: vec![CostTerm::GoToGoal {
                goal: [0.3, 0.3],
                point: [0.0, 0.0],
                weights: StageWeights::default(),
            }],
        };
        let out = mpc.tick(&[r], &[]).unwrap();
        let o = &out.robots[0];
        assert!(o.status.is_solved(), "{:?}", o.status);
        assert!(
            o.plan.iter().all(|u| pilot.contains(*u, OUTPUT_TOLERANCE)),
            "{:?}",
            o.plan
        );
        pose = o.command.drive(&pose, 0.1);
    }
    assert!(
        pose.x.hypot(pose.y) > 0.05,
        "the pilot moved towards its goal: {pose:?}"
    );
}

#[test]
fn bad_inputs_are_named_errors() {
    let mut mpc = DistributedMpc::new(MpcConfig::default()).unwrap();
    let r = |id, pose| RobotInput {
        id,
        pose,
        limits: nonpilot(),
        costs: vec![],
    };
    let e = mpc
        .tick(&[r(1, Pose::default()), r(1, Pose::default())], &[])
        .unwrap_err();
    assert!(matches!(e, MpcError::InvalidInput { robot: 1, .. }), "{e}");
    let e = mpc
        .tick(&[r(2, Pose::new(f64::NAN, 0.0, 0.0))], &[])
        .unwrap_err();
    assert!(e.to_string().contains("robot 2"), "{e}");
    let pair = CoupledPair {
        anchor_robot: 1,
        opening_robot: 9,
    };
    let e = mpc.tick(&[r(1, Pose::default())], &[pair]).unwrap_err();
    assert!(matches!(e, MpcError::InvalidInput { robot: 9, .. }), "{e}");
    let lead = RobotInput {
        costs: vec![CostTerm::FollowLeader {
            leader: 5,
            offset: Pose::default(),
            weights: StageWeights::default(),
            heading: 0.0,
        }],
        ..r(3, Pose::default())
    };
    assert!(mpc.tick(&[lead], &[]).is_err());
    let mut bad = r(4, Pose::default());
    bad.limits.butterfly_b = [0.01, 0.0];
    let e = mpc.tick(&[bad], &[]).unwrap_err();
    assert!(e.to_string().contains("butterfly_b"), "{e}");
}

#[test]
fn bad_config_is_rejected_with_field_name() {
    let c = MpcConfig {
        constraint_horizon: 11,
        ..MpcConfig::default()
    };
    let e = DistributedMpc::new(c).unwrap_err();
    assert!(e.to_string().contains("constraint_horizon"), "{e}");
    let mut c = MpcConfig::default();
    c.geometry.anchor_polygon.reverse();
    let e = DistributedMpc::new(c).unwrap_err();
    assert!(e.to_string().contains("anchor_polygon"), "{e}");
    let c = MpcConfig {
        dt: 0.0,
        ..MpcConfig::default()
    };
    assert!(DistributedMpc::new(c).is_err());
}

#[test]
fn go_to_goal_and_velocity_fitting_behave() {
    let mut mpc = DistributedMpc::with_threads(MpcConfig::default(), 1).unwrap();
    let mut pose = Pose::new(0.0, 0.0, 0.0);
    for _ in 0..100 {
        let r = RobotInput {
            id: 1,
            pose,
            limits: nonpilot(),
            costs: vec![CostTerm::GoToGoal {
                goal: [0.2, 0.1],
                point: [0.0, 0.0],
                weights: StageWeights::default(),
            }],
        };
        let out = mpc.tick(&[r], &[]).unwrap();
        pose = out.robots[0].command.drive(&pose, 0.1);
    }
    assert!(
        (pose.x - 0.2).hypot(pose.y - 0.1) < 0.005,
        "goal not reached: {pose:?}"
    );
    // Velocity fitting settles on the commanded (v, ω) when it is feasible.
    let mut mpc = DistributedMpc::with_threads(MpcConfig::default(), 1).unwrap();
    let target = Command::new(0.05, 0.5);
    let mut last = Command::STOP;
    for _ in 0..30 {
        let r = RobotInput {
            id: 1,
            pose,
            limits: nonpilot(),
            costs: vec![CostTerm::FitVelocity {
                target,
                w_v: 1e3,
                w_omega: 10.0,
            }],
        };
        last = mpc.tick(&[r], &[]).unwrap().robots[0].command;
        pose = last.drive(&pose, 0.1);
    }
    assert!(
        (last.v - target.v).abs() < 2e-3 && (last.omega - target.omega).abs() < 2e-2,
        "{last:?}"
    );
}

/// THESIS 4.12's acceleration box (optional): every handed-out command and every plan
/// respects |Δv| ≤ a_v·dt, |Δω| ≤ a_ω·dt against the previous command.
#[test]
fn acceleration_box_is_respected() {
    let mut limits = nonpilot();
    limits.accel_max = Some([0.2, 3.0]);
    let dt = MpcConfig::default().dt;
    let mut mpc = DistributedMpc::with_threads(MpcConfig::default(), 1).unwrap();
    let mut pose = Pose::new(0.0, 0.0, 0.0);
    let mut prev = Command::STOP;
    let mut max_dv: f64 = 0.0;
    for _ in 0..60 {
        let r = RobotInput {
            id: 1,
            pose,
            limits,
            costs: vec![CostTerm::GoToGoal {
                goal: [-0.1, 0.15],
                point: [0.0, 0.0],
                weights: StageWeights::default(),
            }],
        };
        let o = mpc.tick(&[r], &[]).unwrap().robots.remove(0);
        assert!(o.status.is_solved(), "{:?}", o.status);
        let mut p = prev;
        for u in &o.plan {
            assert!(
                (u.v - p.v).abs() <= 0.2 * dt + 1e-6,
                "Δv {} > {}",
                (u.v - p.v).abs(),
                0.2 * dt
            );
            assert!((u.omega - p.omega).abs() <= 3.0 * dt + 1e-6);
            p = *u;
        }
        max_dv = max_dv.max((o.command.v - prev.v).abs());
        prev = o.command;
        pose = o.command.drive(&pose, dt);
    }
    assert!(
        max_dv > 0.9 * 0.2 * dt,
        "the box was active at least once ({max_dv})"
    );
    assert!((pose.x + 0.1).hypot(pose.y - 0.15) < 0.02, "{pose:?}");
}
