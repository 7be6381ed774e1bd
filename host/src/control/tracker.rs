//! Trajectory tracking: the unicycle tracking law and a controller that has each robot
//! follow its own trajectory.

use std::collections::BTreeMap;

use puzzlebot_protocol::messages::RobotId;
use serde::Serialize;

use crate::drive::{wrap_angle, PoseSample, Twist};

use super::{Controller, FleetView, RefState, Trajectory};

/// Gains of the trajectory tracker.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrackerGains {
    /// Along-track gain (1/s).
    pub k_x: f64,
    /// Cross-track natural frequency (rad/s).
    pub omega_n: f64,
    /// Cross-track damping ratio.
    pub zeta: f64,
}

impl Default for TrackerGains {
    fn default() -> Self {
        TrackerGains {
            k_x: 3.0,
            omega_n: 3.0,
            zeta: 0.9,
        }
    }
}

/// Kanayama-style unicycle tracking with reference feed-forward; cross-track gains are
/// scheduled on the reference speed so the error dynamics keep their natural frequency.
pub fn track(reference: RefState, pose: PoseSample, g: TrackerGains) -> Twist {
    let (dx, dy) = (reference.x - pose.x, reference.y - pose.y);
    let (s, c) = pose.theta.sin_cos();
    let ex = c * dx + s * dy;
    let ey = -s * dx + c * dy;
    let eth = wrap_angle(reference.theta - pose.theta);
    let vr = reference.v.abs().max(0.02);
    let v = reference.v * eth.cos() + g.k_x * ex;
    let omega = reference.omega
        + g.omega_n * g.omega_n / vr * ey * reference.v.signum().max(0.0)
        + 2.0 * g.zeta * g.omega_n * eth.sin();
    Twist::new(v, omega)
}

/// Each robot follows its own trajectory.
#[derive(Debug, Clone)]
pub struct TrajectoryFollower {
    /// Trajectory per robot.
    pub plans: BTreeMap<RobotId, Trajectory>,
    /// Gains.
    pub gains: TrackerGains,
    /// Extra time after the longest trajectory before [`Controller::done`] (s).
    pub settle: f64,
    t0: Option<f64>,
}

impl TrajectoryFollower {
    /// A follower for `plans`.
    pub fn new(plans: BTreeMap<RobotId, Trajectory>) -> Self {
        TrajectoryFollower {
            plans,
            gains: TrackerGains::default(),
            settle: 0.5,
            t0: None,
        }
    }

    /// Longest trajectory (s).
    pub fn duration(&self) -> f64 {
        self.plans
            .values()
            .map(Trajectory::duration)
            .fold(0.0, f64::max)
    }
}

impl Controller for TrajectoryFollower {
    fn name(&self) -> &str {
        "trajectory"
    }

    fn update(&mut self, view: &FleetView) -> BTreeMap<RobotId, Twist> {
        let t0 = *self.t0.get_or_insert(view.t);
        let t = view.t - t0;
        let mut out = BTreeMap::new();
        for r in &view.robots {
            if let (Some(plan), Some(pose)) = (self.plans.get(&r.id), r.pose) {
                let rf = plan.at(t);
                let cmd = if t >= plan.duration() + self.settle {
                    Twist::ZERO
                } else {
                    track(rf, pose, self.gains)
                };
                out.insert(r.id, cmd);
            }
        }
        out
    }

    fn reference(&self, id: RobotId, t: f64) -> Option<[f64; 2]> {
        self.plans.get(&id).map(|p| {
            let r = p.at(t);
            [r.x, r.y]
        })
    }

    fn done(&self, t: f64) -> bool {
        t >= self.duration() + self.settle
    }
}
