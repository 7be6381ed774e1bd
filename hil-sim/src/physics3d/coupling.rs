//! Couplings of a formed assembly as compliant joints between chassis, and their strength.
//!
//! * Soft anchor (THESIS 4.2.2, Fig 4.5–4.6, 5.3 D): robot `a`'s anchor head sits at the seat
//!   of robot `b`'s front opening; free in yaw (±`anchor_yaw_range`) and pitch (same range),
//!   sliding out over its travel (0…`anchor_travel`), with the TPU beams' damping; sideways,
//!   up/down and roll are held.
//! * Knob (THESIS 2.3.2, 2.4.1): robot `a`'s left knob in robot `b`'s right hole; rigid except
//!   a tilt about the shared face up to the angle at which the hooks catch
//!   (`Coupling::knob_tilt_limit`).
//!
//! Every axis is a stiff spring (engine joint motors, solved implicitly) that engages outside
//! the axis' free range: held axes have an empty range, free axes are slack inside their
//! limits. The connector's wrench is then the spring stiffness times the overshoot, read from
//! the relative pose of the two frames (the engine's reported joint impulses are those of its
//! last substep and do not give the moment about the connection point). A coupling breaks when
//! a component of that wrench stays over the connector's limits ([`Strength`], DESIGN §8, as
//! the stability gate models them) for `Config3d::break_after`.

use super::config::{Config3d, Strength};
use crate::math::Pose;
use crate::mechanics::LinkKind;
use puzzlebot_params::coupling::Coupling;
use puzzlebot_params::RobotParams;
use rapier3d_f64::prelude::*;

/// Axes of a joint in the engine's order: x, y, z translation, then rotation about x, y, z.
const AXES: [JointAxis; 6] = [
    JointAxis::LinX,
    JointAxis::LinY,
    JointAxis::LinZ,
    JointAxis::AngX,
    JointAxis::AngY,
    JointAxis::AngZ,
];

/// Geometry and compliance of one coupling: frame 1 on the robot with the opening / hole,
/// frame 2 on the robot with the anchor / knob; per axis the free range and the spring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointGeom {
    /// Frame on body 1 (robot `b`), body coordinates.
    pub frame1: Isometry<f64>,
    /// Frame on body 2 (robot `a`), body coordinates.
    pub frame2: Isometry<f64>,
    /// Free range per axis (m or rad); [0, 0] holds the axis.
    pub range: [[f64; 2]; 6],
    /// Spring stiffness per axis outside its range (N/m or N·m/rad). The springs carry no
    /// damper: the engine's soft-constraint spring is only as stiff as set when its damping
    /// is small against stiffness × substep, and the implicit solve damps it anyway.
    pub stiffness: [f64; 6],
    /// Damping per axis while slack (the TPU beams' internal friction).
    pub slack_damping: f64,
}

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
    /// Its geometry and springs.
    pub geom: JointGeom,
    /// Its limits.
    pub strength: Strength,
    /// Largest force component seen so far (N).
    pub peak_force: f64,
    /// Largest moment component seen so far (N·m), the anchor's free yaw excluded.
    pub peak_moment: f64,
    /// How long the wrench has been over the limits without a break (s).
    pub over_for: f64,
}

/// Spring stiffness per axis (`coupling.connector_stiffness`, `connector_angular_stiffness`).
fn springs(c: &Coupling) -> [f64; 6] {
    let (kl, ka) = (
        f64::from(c.connector_stiffness),
        f64::from(c.connector_angular_stiffness),
    );
    [kl, kl, kl, ka, ka, ka]
}

/// An anchor of robot `a` (params `p`) in the opening of robot `b`.
pub fn anchor(p: &RobotParams, cfg: &Config3d) -> JointGeom {
    let g = &p.geometry;
    let c: &Coupling = &p.coupling;
    let h = cfg.coupling_height(p);
    let seat_x = f64::from(g.anchor_opening[0]) - Coupling::anchor_depth(g);
    let yaw = f64::from(c.anchor_yaw_range);
    let stiffness = springs(&p.coupling);
    JointGeom {
        frame1: Isometry::translation(seat_x, f64::from(g.anchor_opening[1]), h),
        frame2: Isometry::translation(f64::from(g.anchor_head[0]), f64::from(g.anchor_head[1]), h),
        range: [
            [0.0, f64::from(c.anchor_travel)],
            [0.0; 2],
            [0.0; 2],
            [0.0; 2],
            [-yaw, yaw],
            [-yaw, yaw],
        ],
        stiffness,
        slack_damping: cfg.anchor_damping,
    }
}

/// `a`'s left knob in `b`'s right hole, from their poses at formation: the knob point on `a`'s
/// left face nearest `b`, the relative pose as formed taken as the seated one.
pub fn knob(p: &RobotParams, cfg: &Config3d, a: Pose, b: Pose) -> JointGeom {
    let g = &p.geometry;
    let h = cfg.coupling_height(p);
    let side = f64::from(g.side_point_x);
    let bc = a.inverse_apply(b.pos());
    let on_a = [bc[0].clamp(-side, side), f64::from(g.width) * 0.5];
    let w = a.apply(on_a);
    let on_b = b.inverse_apply(w);
    let rel = crate::math::wrap(a.yaw - b.yaw);
    let tilt = p.coupling.knob_tilt_limit(g);
    let stiffness = springs(&p.coupling);
    let mut range = [[0.0; 2]; 6];
    range[3] = [-tilt, tilt];
    JointGeom {
        frame1: Isometry::new(vector![on_b[0], on_b[1], h], vector![0.0, 0.0, rel]),
        frame2: Isometry::translation(on_a[0], on_a[1], h),
        range,
        stiffness,
        slack_damping: 0.0,
    }
}

impl JointGeom {
    /// The engine joint: every axis free, driven by a force-based motor (set each step by
    /// [`JointGeom::drive`]); no contacts between the two chassis.
    pub fn joint(&self) -> GenericJoint {
        let mut b = GenericJointBuilder::new(JointAxesMask::empty())
            .local_frame1(self.frame1)
            .local_frame2(self.frame2)
            .contacts_enabled(false);
        for axis in AXES {
            b = b.motor_model(axis, MotorModel::ForceBased);
        }
        let mut j = b.build();
        self.drive(&mut j, &[0.0; 6]);
        j
    }

    /// Joint coordinates of frame 2 in frame 1 as the engine measures them: translation in
    /// frame 1's axes; rotation 2·asin of the relative quaternion's components.
    pub fn coords(&self, body1: &Isometry<f64>, body2: &Isometry<f64>) -> [f64; 6] {
        let f1 = body1 * self.frame1;
        let f2 = body2 * self.frame2;
        let d = f1.rotation.inverse() * (f2.translation.vector - f1.translation.vector);
        let mut q = f1.rotation.inverse() * f2.rotation;
        if q.w < 0.0 {
            q = rapier3d_f64::na::UnitQuaternion::new_unchecked(-q.into_inner());
        }
        let im = q.imag();
        let ang = |x: f64| 2.0 * x.clamp(-1.0, 1.0).asin();
        [d.x, d.y, d.z, ang(im.x), ang(im.y), ang(im.z)]
    }

    /// Set the motors for coordinates `q`: a spring to the nearest end of each axis' free
    /// range when outside it, slack (damping only) inside.
    pub fn drive(&self, j: &mut GenericJoint, q: &[f64; 6]) {
        for (i, axis) in AXES.into_iter().enumerate() {
            let [lo, hi] = self.range[i];
            if q[i] < lo || q[i] > hi || lo == hi {
                let target = q[i].clamp(lo, hi);
                j.set_motor(axis, target, 0.0, self.stiffness[i], 0.0);
            } else {
                j.set_motor(axis, q[i], 0.0, 0.0, self.slack_damping);
            }
        }
    }

    /// Force (N) and moment (N·m) the springs carry at coordinates `q`, in frame 1's axes.
    pub fn wrench(&self, q: &[f64; 6]) -> ([f64; 3], [f64; 3]) {
        let mut w = [0.0; 6];
        for i in 0..6 {
            let [lo, hi] = self.range[i];
            w[i] = self.stiffness[i] * (q[i].clamp(lo, hi) - q[i]);
        }
        ([w[0], w[1], w[2]], [w[3], w[4], w[5]])
    }
}

impl Joint3d {
    /// Update the peaks from the wrench at coordinates `q` after a step of `dt`; true when it
    /// must break: the wrench has been over the limits for `hold_time` s without a pause (the
    /// TPU parts ride out an impact of a few milliseconds).
    pub fn load(&mut self, q: &[f64; 6], dt: f64, hold_time: f64) -> bool {
        let (force, mut moment) = self.geom.wrench(q);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn springs_engage_outside_the_free_range_only() {
        let p = RobotParams::default();
        let cfg = Config3d::default();
        let g = anchor(&p, &cfg);
        // Seated, 3 mm out, 0.3 rad yawed: inside every range, no load.
        let (f, m) = g.wrench(&[0.003, 0.0, 0.0, 0.0, 0.0, 0.3]);
        assert_eq!((f, m), ([0.0; 3], [0.0; 3]));
        // 1 mm past the travel: a pull of k · 1 mm; 1 mm sideways: a side force.
        let k = f64::from(p.coupling.connector_stiffness);
        let (f, _) = g.wrench(&[0.006, 0.001, 0.0, 0.0, 0.0, 0.0]);
        assert!((f[0] + k * 0.001).abs() < 1e-3 * k * 0.001, "{f:?}");
        assert!((f[1] + k * 0.001).abs() < 1e-9, "{f:?}");
        // The coordinates of two frames as placed read back as zero.
        let id = Isometry::identity();
        let b2 = Isometry::translation(0.050, 0.0, 0.0);
        let q = g.coords(&id, &b2);
        assert!(q.iter().all(|v| v.abs() < 1e-8), "{q:?}");
    }
}
