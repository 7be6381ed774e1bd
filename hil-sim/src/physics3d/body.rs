//! One robot as rigid bodies: the chassis (a box over the wheels, with the robot's mass and
//! inertia from the parameter set), driven wheels on revolute joints (a pilot's four geared
//! wheels, a non-pilot's two) and, on non-pilots, two ball casters under the chassis
//! (THESIS 3.4, 5.2.1).
//!
//! Body frame: origin on the ground plane under the body centre, x forward, y left, z up.

use super::config::Config3d;
use super::terrain::{ROBOT_GROUP, TERRAIN_GROUP};
use crate::math::Pose;
use puzzlebot_params::RobotParams;
use rapier3d_f64::prelude::*;

/// One driven wheel.
#[derive(Debug, Clone, Copy)]
pub struct Wheel {
    /// Its body.
    pub body: RigidBodyHandle,
    /// Revolute joint to the chassis (axis y, positive spin drives forward).
    pub joint: ImpulseJointHandle,
    /// 0 = left motor, 1 = right motor.
    pub side: usize,
}

/// The bodies of one robot.
#[derive(Debug, Clone)]
pub struct RobotBodies {
    /// Chassis.
    pub chassis: RigidBodyHandle,
    /// Driven wheels.
    pub wheels: Vec<Wheel>,
    /// Wheels per motor (pilot 2, non-pilot 1).
    pub wheels_per_side: usize,
}

/// Where the wheels sit in the body frame, x and y (pilot: two axles at ±`wheel_axle_offset`;
/// non-pilot: one axle at `wheel_axle_offset`), with their motor side.
pub fn wheel_points(p: &RobotParams) -> Vec<([f64; 2], usize)> {
    let half = f64::from(p.geometry.wheel_base) * 0.5;
    let d = f64::from(p.plant.wheel_axle_offset);
    let xs: &[f64] = if p.plant.four_wheels { &[d, -d] } else { &[d] };
    let mut out = Vec::new();
    for &x in xs {
        out.push(([x, half], 0));
        out.push(([x, -half], 1));
    }
    out
}

fn robot_groups() -> InteractionGroups {
    InteractionGroups::new(ROBOT_GROUP, TERRAIN_GROUP, InteractionTestMode::And)
}

/// Build the robot at `pose` standing on ground height `z0`.
pub fn build(
    p: &RobotParams,
    cfg: &Config3d,
    pose: Pose,
    z0: f64,
    bodies: &mut RigidBodySet,
    colliders: &mut ColliderSet,
    joints: &mut ImpulseJointSet,
) -> RobotBodies {
    let g = &p.geometry;
    let (len, wid, hgt) = (f64::from(g.length), f64::from(g.width), f64::from(g.height));
    let r = f64::from(g.wheel_radius);
    let wheels_at = wheel_points(p);
    let m_total = f64::from(p.mass.mass);
    let m_wheels = cfg.wheel_mass * wheels_at.len() as f64;
    let m_c = (m_total - m_wheels).max(0.1 * m_total);
    let box_h = (hgt - cfg.chassis_clearance).max(0.01);
    // Box inertia about x and y; the yaw inertia of the parameter set, chassis share.
    let inertia = vector![
        m_c * (wid * wid + hgt * hgt) / 12.0,
        m_c * (len * len + hgt * hgt) / 12.0,
        f64::from(p.plant.yaw_inertia) * m_c / m_total
    ];
    let com = point![
        f64::from(p.mass.com[0]),
        f64::from(p.mass.com[1]),
        f64::from(g.com_height)
    ];
    let iso = Isometry::new(vector![pose.x, pose.y, z0], vector![0.0, 0.0, pose.yaw]);
    let chassis = bodies.insert(
        RigidBodyBuilder::dynamic()
            .pose(iso)
            .additional_mass_properties(MassProperties::new(com, m_c, inertia))
            .can_sleep(false)
            .build(),
    );
    let chassis_col = ColliderBuilder::cuboid(len * 0.5, wid * 0.5, box_h * 0.5)
        .translation(vector![0.0, 0.0, cfg.chassis_clearance + box_h * 0.5])
        .density(0.0)
        .friction(cfg.chassis_friction)
        .friction_combine_rule(CoefficientCombineRule::Min)
        .collision_groups(robot_groups())
        .build();
    colliders.insert_with_parent(chassis_col, chassis, bodies);
    if !p.plant.four_wheels {
        let rc = f64::from(p.plant.caster_radius);
        let c = f64::from(p.plant.caster_offset);
        // The casters stand `plant.caster_lift` clear of the ground (the gate's contact model
        // reads the same parameter).
        let lift = f64::from(p.plant.caster_lift);
        for x in [c, -c] {
            let col = ColliderBuilder::ball(rc)
                .translation(vector![x, 0.0, rc + lift])
                .density(0.0)
                .friction(f64::from(p.plant.caster_friction))
                .friction_combine_rule(CoefficientCombineRule::Min)
                .collision_groups(robot_groups())
                .build();
            colliders.insert_with_parent(col, chassis, bodies);
        }
    }
    let wheels_per_side = if p.plant.four_wheels { 2 } else { 1 };
    // Reflected rotor inertia N²·J_rotor at the wheel, shared by the wheels of a motor.
    let n = f64::from(p.plant.gear_ratio);
    let j_axle = f64::from(p.plant.rotor_inertia) * n * n / wheels_per_side as f64
        + 0.5 * cfg.wheel_mass * r * r;
    let j_other = 0.25 * cfg.wheel_mass * r * r;
    let mut wheels = Vec::with_capacity(wheels_at.len());
    for ([x, y], side) in wheels_at {
        let local = point![x, y, r];
        let body = bodies.insert(
            RigidBodyBuilder::dynamic()
                .pose(iso * Isometry::translation(local.x, local.y, local.z))
                .additional_mass_properties(MassProperties::new(
                    Point::origin(),
                    cfg.wheel_mass,
                    vector![j_other, j_axle, j_other],
                ))
                .can_sleep(false)
                .build(),
        );
        let col = ColliderBuilder::ball(r)
            .density(0.0)
            .friction(f64::from(p.plant.wheel_friction))
            .friction_combine_rule(CoefficientCombineRule::Min)
            .collision_groups(robot_groups())
            .build();
        colliders.insert_with_parent(col, body, bodies);
        let joint = RevoluteJointBuilder::new(Vector::y_axis())
            .local_anchor1(local)
            .local_anchor2(Point::origin())
            .motor_model(MotorModel::ForceBased)
            .build();
        let joint = joints.insert(chassis, body, joint, true);
        wheels.push(Wheel { body, joint, side });
    }
    RobotBodies {
        chassis,
        wheels,
        wheels_per_side,
    }
}
