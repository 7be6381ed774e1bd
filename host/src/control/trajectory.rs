//! Reference trajectories: line and circle paths driven with a trapezoidal speed profile.

use serde::Serialize;

use crate::drive::wrap_angle;

/// A reference path with a trapezoidal speed profile.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Path {
    /// Straight segment from `start` along `heading` (rad) for `length` m.
    Line {
        /// Start point (m).
        start: [f64; 2],
        /// Heading (rad).
        heading: f64,
        /// Length (m).
        length: f64,
    },
    /// Full circle of `radius` about `center`, starting at angle `phase` (rad), CCW if `ccw`.
    Circle {
        /// Centre (m).
        center: [f64; 2],
        /// Radius (m).
        radius: f64,
        /// Start angle on the circle (rad).
        phase: f64,
        /// Counter-clockwise.
        ccw: bool,
    },
}

/// A reference state: position, heading, speed and turn rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RefState {
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Heading (rad).
    pub theta: f64,
    /// Speed (m/s).
    pub v: f64,
    /// Turn rate (rad/s).
    pub omega: f64,
}

/// A path driven with a trapezoidal speed profile (accelerate, cruise, brake).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Trajectory {
    /// The path.
    pub path: Path,
    /// Cruise speed (m/s).
    pub speed: f64,
    /// Acceleration (m/s²).
    pub accel: f64,
}

impl Path {
    /// Length (m).
    pub fn length(&self) -> f64 {
        match *self {
            Path::Line { length, .. } => length,
            Path::Circle { radius, .. } => 2.0 * std::f64::consts::PI * radius,
        }
    }

    /// Pose at arc length `s`; curvature.
    fn at(&self, s: f64) -> ([f64; 3], f64) {
        match *self {
            Path::Line { start, heading, .. } => (
                [
                    start[0] + s * heading.cos(),
                    start[1] + s * heading.sin(),
                    heading,
                ],
                0.0,
            ),
            Path::Circle {
                center,
                radius,
                phase,
                ccw,
            } => {
                let dir = if ccw { 1.0 } else { -1.0 };
                let a = phase + dir * s / radius;
                (
                    [
                        center[0] + radius * a.cos(),
                        center[1] + radius * a.sin(),
                        wrap_angle(a + dir * std::f64::consts::FRAC_PI_2),
                    ],
                    dir / radius,
                )
            }
        }
    }

    /// Start pose [x, y, θ].
    pub fn start_pose(&self) -> [f64; 3] {
        self.at(0.0).0
    }
}

impl Trajectory {
    /// Total duration (s).
    pub fn duration(&self) -> f64 {
        let len = self.path.length();
        let ta = self.speed / self.accel;
        let da = 0.5 * self.accel * ta * ta;
        if 2.0 * da >= len {
            2.0 * (len / self.accel).sqrt()
        } else {
            2.0 * ta + (len - 2.0 * da) / self.speed
        }
    }

    /// Reference at time `t` (held at the end after the duration).
    pub fn at(&self, t: f64) -> RefState {
        let len = self.path.length();
        let a = self.accel;
        let total = self.duration();
        let vpk = self.speed.min((a * len).sqrt());
        let ta = vpk / a;
        let t = t.clamp(0.0, total);
        let (s, v) = if t < ta {
            (0.5 * a * t * t, a * t)
        } else if t > total - ta {
            let r = total - t;
            (len - 0.5 * a * r * r, a * r)
        } else {
            (0.5 * a * ta * ta + vpk * (t - ta), vpk)
        };
        let (p, kappa) = self.path.at(s);
        RefState {
            x: p[0],
            y: p[1],
            theta: p[2],
            v,
            omega: v * kappa,
        }
    }
}
