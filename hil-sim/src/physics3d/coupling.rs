//! Couplings of a formed assembly as joints between chassis, and their strength.
//!
//! * Soft anchor (THESIS 4.2.2, Fig 4.5–4.6, 5.3 D): robot `a`'s anchor head sits at the seat
//!   of robot `b`'s front opening; free in yaw (±`anchor_yaw_range`) and pitch (same range),
//!   sliding out over its travel (0…`anchor_travel`), with the TPU beams' damping; sideways,
//!   up/down and roll are held.
//! * Knob (THESIS 2.3.2, 2.4.1): robot `a`'s left knob in robot `b`'s right hole; rigid except
//!   a tilt about the shared face up to the angle at which the hooks catch
//!   ([`Config3d::knob_tilt_limit`]).
//!
//! A coupling breaks when a component of its wrench stays over the connector's limits
//! ([`Strength`], DESIGN §8, as the stability gate models them) for `Config3d::break_after`.

use super::config::{Config3d, Strength};
use crate::math::Pose;
use crate::mechanics::LinkKind;
use puzzlebot_params::coupling::Coupling;
use puzzlebot_params::RobotParams;
use rapier3d_f64::prelude::*;

/// A coupling in the world.
#[derive(Debug, Clone, Copy)]
pub struct Joint3d {
    /// Anchor or knob.
    pub kind: LinkKind,
    /// Robot index with the anchor / knob.
    pub a: usize,
    /// Robot index with the opening / hole.
    pub b: usize,
    /// Engine joint (None once broken).
    pub handle: Option<ImpulseJointHandle>,
    /// Its limits.
    pub strength: Strength,
    /// Largest force component seen so far (N).
    pub peak_force: f64,
    /// Largest moment component seen so far (N·m), the anchor's free yaw excluded.
    pub peak_moment: f64,
    /// How long the wrench has been over the limits without a break (s).
    pub over_for: f64,
}

/// The joint for an anchor of `pa` (robot a, params `p`) in the opening of `pb`.
pub fn anchor_joint(p: &RobotParams, cfg: &Config3d) -> GenericJoint {
    let g = &p.geometry;
    let c: &Coupling = &p.coupling;
    let h = cfg.coupling_height(p);
    let seat_x = f64::from(g.anchor_opening[0]) - Coupling::anchor_depth(g);
    let yaw = f64::from(c.anchor_yaw_range);
    let damp = cfg.anchor_damping;
    let mut b = GenericJointBuilder::new(
        JointAxesMask::LIN_Y | JointAxesMask::LIN_Z | JointAxesMask::ANG_X,
    )
    .local_anchor1(point![seat_x, f64::from(g.anchor_opening[1]), h])
    .local_anchor2(point![
        f64::from(g.anchor_head[0]),
        f64::from(g.anchor_head[1]),
        h
    ])
    .limits(JointAxis::LinX, [0.0, f64::from(c.anchor_travel)])
    .limits(JointAxis::AngY, [-yaw, yaw])
    .limits(JointAxis::AngZ, [-yaw, yaw]);
    for axis in [JointAxis::LinX, JointAxis::AngY, JointAxis::AngZ] {
        b = b
            .motor_model(axis, MotorModel::ForceBased)
            .set_motor(axis, 0.0, 0.0, 0.0, damp);
    }
    b.build()
}

/// The joint for `a`'s left knob in `b`'s right hole, from their poses at formation: the knob
/// point on `a`'s left face nearest `b`, the relative pose as formed taken as the seated one.
pub fn knob_joint(p: &RobotParams, cfg: &Config3d, a: Pose, b: Pose) -> GenericJoint {
    let g = &p.geometry;
    let h = cfg.coupling_height(p);
    let side = f64::from(g.side_point_x);
    let bc = a.inverse_apply(b.pos());
    let on_a = [bc[0].clamp(-side, side), f64::from(g.width) * 0.5];
    let w = a.apply(on_a);
    let on_b = b.inverse_apply(w);
    let rel = crate::math::wrap(a.yaw - b.yaw);
    let tilt = cfg.knob_tilt_limit(p);
    let frame1 = Isometry::new(vector![on_b[0], on_b[1], h], vector![0.0, 0.0, rel]);
    let frame2 = Isometry::translation(on_a[0], on_a[1], h);
    GenericJointBuilder::new(JointAxesMask::LOCKED_REVOLUTE_AXES)
        .local_frame1(frame1)
        .local_frame2(frame2)
        .limits(JointAxis::AngX, [-tilt, tilt])
        .build()
}

impl Joint3d {
    /// Update the peaks from the joint's impulses of the last substep (the engine stores the
    /// last of its `substeps` substeps of a step of `dt`); true when it must break: the wrench
    /// has been over the limits for `hold_time` s without a pause (the TPU parts ride out an
    /// impact of a few milliseconds).
    pub fn load(&mut self, j: &ImpulseJoint, dt: f64, substeps: usize, hold_time: f64) -> bool {
        let im = j.impulses * substeps as f64;
        let force = [im[0] / dt, im[1] / dt, im[2] / dt];
        let mut moment = [im[3] / dt, im[4] / dt, im[5] / dt];
        if self.kind == LinkKind::Anchor {
            moment[2] = 0.0; // free yaw (the gate releases it too)
        }
        let fmax = force.iter().fold(0.0f64, |m, f| m.max(f.abs()));
        let mmax = moment.iter().fold(0.0f64, |m, f| m.max(f.abs()));
        self.peak_force = self.peak_force.max(fmax);
        self.peak_moment = self.peak_moment.max(mmax);
        if self.strength.exceeded(force, moment) {
            self.over_for += dt;
        } else {
            self.over_for = 0.0;
        }
        self.over_for >= hold_time
    }
}
