//! Behaviour primitives that need no optimisation: the decoupling wiggle (THESIS (4.2), (5.7)),
//! rendezvous / anti-rendezvous (THESIS (2.3), (2.4)), the Jacobian pseudo-inverse point
//! controller (THESIS (3.2)) and trajectories for the tracking behaviour (THESIS (5.26)).

use crate::geom::{wrap_angle, Pose};
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

/// Wiggle parameters (THESIS 4.3.2 / 5.4.2 decoupling controller).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Wiggle {
    /// Forward bias v_bias (m/s); the anchor robot pulls away while wiggling.
    pub v_bias: f64,
    /// Turn rate amplitude ω_max (rad/s).
    pub w_max: f64,
    /// Period 2π/B (s) of the sinusoid; the square wave's longest stroke (its strokes end at
    /// the measured relative yaw, [`WiggleTurn`]).
    pub period_s: f64,
    /// Square wave sgn(sin(Bt)) as in THESIS (5.7), closed loop; false: sinusoid as in (4.2).
    pub square: bool,
}

impl Default for Wiggle {
    fn default() -> Self {
        // THESIS gives the form, not the numbers; these release the anchor within ~2 s in
        // THESIS Fig 5.4B's description ("within the first second ... by the end of two").
        Wiggle {
            v_bias: 0.01,
            w_max: 1.5,
            period_s: 0.5,
            square: true,
        }
    }
}

impl Wiggle {
    /// (v, ω) at time `t` since the wiggle started: THESIS (5.7) v = v_bias,
    /// ω = ω_max sgn(sin(Bt)) (or ω_max sin(Bt), (4.2)).
    pub fn command(&self, t: f64) -> (f64, f64) {
        let b = 2.0 * PI / self.period_s.max(1e-6);
        let s = (b * t).sin();
        let w = if self.square {
            if s > 0.0 {
                self.w_max
            } else if s < 0.0 {
                -self.w_max
            } else {
                0.0
            }
        } else {
            self.w_max * s
        };
        (self.v_bias, w)
    }

    /// The profile sampled every `dt` seconds for `duration` seconds: (t, v, ω) rows.
    pub fn profile(&self, duration: f64, dt: f64) -> Vec<(f64, f64, f64)> {
        if !dt.is_finite() || dt <= 0.0 || !duration.is_finite() || duration < 0.0 {
            return Vec::new();
        }
        let n = (duration / dt).floor() as usize;
        (0..=n)
            .map(|k| {
                let t = k as f64 * dt;
                let (v, w) = self.command(t);
                (t, v, w)
            })
            .collect()
    }
}

/// Fraction of the anchor's yaw range a closed-loop wiggle turns to before it turns back.
pub const WIGGLE_REACH: f64 = 0.9;

/// Turning sense of a closed-loop wiggle: the square wave of THESIS (5.7) with its edges set by
/// the measured relative yaw φ of the pair instead of the clock. Open loop, a stroke's swing
/// depends on how far the partner is dragged and on when the commands arrive: over loopback
/// under load φ swung between +0.18 and +0.50 rad for 25 s, never far enough back to pop the
/// second leg. Closed loop, every stroke goes from one side of the yaw range to the other.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WiggleTurn {
    sign: f64,
    since: f64,
}

impl WiggleTurn {
    /// A wiggle starting at time `t` (s), turning counter-clockwise first.
    pub fn new(t: f64) -> Self {
        WiggleTurn {
            sign: 1.0,
            since: t,
        }
    }

    /// Turn the other way once φ (wiggling robot's yaw minus its partner's, rad) reached
    /// `reach` on the side being turned to, or after `patience` s without reaching it (a
    /// robot that cannot turn further does not push for ever). Non-finite φ changes nothing.
    pub fn update(&mut self, t: f64, phi: f64, reach: f64, patience: f64) {
        let reached = phi.is_finite() && self.sign * phi >= reach;
        if reached || t - self.since >= patience {
            self.sign = -self.sign;
            self.since = t;
        }
    }

    /// +1 turning counter-clockwise, −1 clockwise.
    pub fn sign(&self) -> f64 {
        self.sign
    }
}

impl Wiggle {
    /// (v, ω) of the wiggle at `t` s since it started: the square wave follows `turn` (closed
    /// loop, [`WiggleTurn`]; a stroke lasts at most `period_s`), the sinusoid of THESIS (4.2)
    /// stays open loop.
    pub fn command_closed(&self, t: f64, turn: &WiggleTurn) -> (f64, f64) {
        if self.square {
            (self.v_bias, self.w_max * turn.sign())
        } else {
            self.command(t)
        }
    }
}

/// Rendezvous velocities (THESIS (2.3)): u_i = gain · (1/N) Σ_{j≠i} (x_j − x_i), in the plane.
/// With `anti`, the anti-rendezvous of THESIS (2.4) (the negative).
pub fn rendezvous(positions: &[[f64; 2]], gain: f64, anti: bool) -> Vec<[f64; 2]> {
    let n = positions.len();
    if n == 0 {
        return Vec::new();
    }
    let sign = if anti { -1.0 } else { 1.0 };
    let inv = 1.0 / n as f64;
    positions
        .iter()
        .map(|p| {
            let (sx, sy) = positions.iter().fold((0.0, 0.0), |(sx, sy), q| {
                (sx + q[0] - p[0], sy + q[1] - p[1])
            });
            [sign * gain * inv * sx, sign * gain * inv * sy]
        })
        .collect()
}

/// THESIS (3.2): u = J⁺ [Δx, Δy, Δθ] with Δθ = atan(Δy/Δx) − θ wrapped into (−π/2, π/2]
/// (so the robot may back up instead of turning round). Returns (v, ω).
pub fn point_command(pose: &Pose, dx: f64, dy: f64, heading_gain: f64) -> (f64, f64) {
    let (s, c) = pose.yaw.sin_cos();
    let v = c * dx + s * dy;
    if dx.hypot(dy) < 1e-12 {
        return (0.0, 0.0);
    }
    let mut dth = wrap_angle(dy.atan2(dx) - pose.yaw);
    if dth > FRAC_PI_2 {
        dth -= PI;
    } else if dth <= -FRAC_PI_2 {
        dth += PI;
    }
    (v, heading_gain * dth)
}

/// A reference trajectory: poses at given times, linearly interpolated (THESIS (5.26) x^ref).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    /// (t, pose) waypoints, t strictly increasing (s, relative to the start of the behaviour).
    pub waypoints: Vec<(f64, Pose)>,
}

impl Trajectory {
    /// Reference pose at time `t` (clamped to the ends).
    pub fn sample(&self, t: f64) -> Option<Pose> {
        let w = &self.waypoints;
        let first = w.first()?;
        if t <= first.0 {
            return Some(first.1);
        }
        for pair in w.windows(2) {
            let (t0, p0) = pair[0];
            let (t1, p1) = pair[1];
            if t <= t1 {
                let s = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
                return Some(Pose::new(
                    p0.x + s * (p1.x - p0.x),
                    p0.y + s * (p1.y - p0.y),
                    wrap_angle(p0.yaw + s * wrap_angle(p1.yaw - p0.yaw)),
                ));
            }
        }
        w.last().map(|l| l.1)
    }

    /// Time of the last waypoint (s).
    pub fn end_time(&self) -> f64 {
        self.waypoints.last().map_or(0.0, |w| w.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wiggle_is_a_square_wave_with_bias() {
        let w = Wiggle {
            v_bias: 0.02,
            w_max: 2.0,
            period_s: 1.0,
            square: true,
        };
        assert_eq!(w.command(0.25), (0.02, 2.0));
        assert_eq!(w.command(0.75), (0.02, -2.0));
        let p = w.profile(1.0, 0.1);
        assert_eq!(p.len(), 11);
        let mean_w: f64 = p[1..10].iter().map(|r| r.2).sum::<f64>() / 9.0;
        assert!(mean_w.abs() < 0.5, "wiggle has no net turn: {mean_w}");
        let sine = Wiggle { square: false, ..w };
        assert!((sine.command(0.25).1 - 2.0).abs() < 1e-9);
        assert!(sine.command(0.125).1 < 2.0);
    }

    #[test]
    fn a_closed_loop_wiggle_turns_back_at_the_measured_yaw_or_after_its_patience() {
        let w = Wiggle::default();
        let mut turn = WiggleTurn::new(0.0);
        assert_eq!(w.command_closed(0.0, &turn), (w.v_bias, w.w_max));
        // Short of the reach: keeps turning; reached: turns back.
        turn.update(0.1, 0.40, 0.45, 1.0);
        assert_eq!(turn.sign(), 1.0);
        turn.update(0.2, 0.46, 0.45, 1.0);
        assert_eq!(turn.sign(), -1.0);
        assert_eq!(w.command_closed(0.2, &turn), (w.v_bias, -w.w_max));
        // On the far side of the turn the old reach does not count, the other one does.
        turn.update(0.3, 0.46, 0.45, 1.0);
        assert_eq!(turn.sign(), -1.0);
        turn.update(0.4, -0.45, 0.45, 1.0);
        assert_eq!(turn.sign(), 1.0);
        // A blocked robot (or no pose) turns back after its patience only.
        turn.update(1.3, f64::NAN, 0.45, 1.0);
        assert_eq!(turn.sign(), 1.0);
        turn.update(1.5, f64::NAN, 0.45, 1.0);
        assert_eq!(turn.sign(), -1.0);
        // The sinusoid of (4.2) stays open loop.
        let sine = Wiggle {
            square: false,
            ..Wiggle::default()
        };
        assert_eq!(sine.command_closed(0.3, &turn), sine.command(0.3));
    }

    #[test]
    fn rendezvous_pulls_together_and_anti_pushes_apart() {
        let p = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let u = rendezvous(&p, 1.0, false);
        assert!(u[0][0] > 0.0 && u[0][1] > 0.0);
        assert!(u[1][0] < 0.0);
        let sum: f64 = u.iter().map(|v| v[0] + v[1]).sum();
        assert!(sum.abs() < 1e-12, "consensus keeps the centroid");
        let a = rendezvous(&p, 1.0, true);
        assert!(a[0][0] < 0.0 && a[1][0] > 0.0);
    }

    #[test]
    fn point_command_backs_up_rather_than_turning_round() {
        let pose = Pose::new(0.0, 0.0, 0.0);
        let (v, w) = point_command(&pose, -0.1, 0.0, 1.0);
        assert!(v < 0.0 && w.abs() < 1e-12);
        let (v, w) = point_command(&pose, 0.1, 0.1, 1.0);
        assert!(v > 0.0 && (w - PI / 4.0).abs() < 1e-12);
    }

    #[test]
    fn trajectory_interpolates_and_clamps() {
        let tr = Trajectory {
            waypoints: vec![
                (0.0, Pose::new(0.0, 0.0, 0.0)),
                (2.0, Pose::new(1.0, 0.0, 0.0)),
            ],
        };
        assert!((tr.sample(1.0).unwrap().x - 0.5).abs() < 1e-12);
        assert!((tr.sample(5.0).unwrap().x - 1.0).abs() < 1e-12);
        assert_eq!(tr.end_time(), 2.0);
    }
}
