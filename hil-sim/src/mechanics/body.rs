//! Bodies and the robot shape as the mechanics sees them.

use crate::math::{norm, Frame, Pose, V2};
use puzzlebot_params::coupling::Coupling;
use puzzlebot_params::geometry::Geometry;

/// One body as the mechanics sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Pose.
    pub pose: Pose,
    /// Mass (kg).
    pub mass: f64,
    /// Yaw inertia (kg·m²).
    pub inertia: f64,
    /// Takes part in contacts (false: fallen or switched off the table).
    pub active: bool,
    /// sin, cos of `pose.yaw` (whoever turns the body keeps them in sync).
    pub trig: [f64; 2],
}

impl Body {
    /// A body at `pose`.
    pub fn new(pose: Pose, mass: f64, inertia: f64) -> Body {
        let (s, c) = pose.yaw.sin_cos();
        Body {
            pose,
            mass,
            inertia,
            active: true,
            trig: [s, c],
        }
    }

    pub(super) fn frame(&self) -> Frame {
        Frame {
            x: self.pose.x,
            y: self.pose.y,
            s: self.trig[0],
            c: self.trig[1],
        }
    }

    pub(super) fn retrig(&mut self) {
        let (s, c) = self.pose.yaw.sin_cos();
        self.trig = [s, c];
    }
}

/// Geometry numbers the mechanics needs (f64).
#[derive(Debug, Clone, Copy)]
pub struct Shape {
    pub(super) half: V2,
    pub(super) head: V2,
    pub(super) opening: V2,
    pub(super) knob: V2,
    /// x of the two connection points on each side (m).
    pub(super) side_x: f64,
    /// Depth the head sits inside the other body when fully in (m).
    pub(super) depth: f64,
    pub(super) radius: f64,
}

impl Shape {
    /// From the shared geometry.
    pub fn new(g: &Geometry) -> Shape {
        let half = [f64::from(g.length) * 0.5, f64::from(g.width) * 0.5];
        let head = [f64::from(g.anchor_head[0]), f64::from(g.anchor_head[1])];
        let opening = [
            f64::from(g.anchor_opening[0]),
            f64::from(g.anchor_opening[1]),
        ];
        let knob = [f64::from(g.knob_left[0]), f64::from(g.knob_left[1])];
        let depth = Coupling::anchor_depth(g);
        Shape {
            half,
            head,
            opening,
            knob,
            side_x: f64::from(g.side_point_x),
            depth,
            radius: norm(half).max(norm(head)),
        }
    }

    /// Where the head sits in the opening robot's frame when fully in, zero travel.
    pub(super) fn pin(&self) -> V2 {
        [self.opening[0] - self.depth, self.opening[1]]
    }
}
