//! Pose prediction and latency: every robot's last pose brought to the controller's tick
//! time (motion capture delivers poses at different ages) and on to when the tick's commands
//! act (the link's measured latency), by the exact unicycle arc of its measured velocity.

use std::collections::BTreeMap;

use puzzlebot_assembly::{Pose, RobotState};
use puzzlebot_params::RobotKind;
use puzzlebot_protocol::messages::RobotId;

use crate::control::FleetView;
use crate::drive::{PoseSample, Twist};

/// Default [`super::AssemblyController::max_prediction_s`] (s): the harsh profile's worst latency
/// (130 ms) plus a pose period.
pub const MAX_PREDICTION_S: f64 = 0.15;

/// Default [`super::AssemblyController::fleet_wait_s`] (s): a hundred frames of the 100 Hz motion
/// capture, where a first pose lost to a dropout arrives in the next.
pub const FLEET_WAIT_S: f64 = 1.0;

/// `pose` moved on for `dt` seconds at the constant twist `w` (exact unicycle arc).
pub fn predict(pose: Pose, w: Twist, dt: f64) -> Pose {
    if dt <= 0.0 {
        return pose;
    }
    let th = pose.yaw + w.omega * dt;
    let (dx, dy) = if w.omega.abs() < 1e-6 {
        (w.v * dt * pose.yaw.cos(), w.v * dt * pose.yaw.sin())
    } else {
        let r = w.v / w.omega;
        (
            r * (th.sin() - pose.yaw.sin()),
            -r * (th.cos() - pose.yaw.cos()),
        )
    };
    Pose::new(
        pose.x + dx,
        pose.y + dy,
        puzzlebot_assembly::geom::wrap_angle(th),
    )
}

/// Every robot's last pose and velocity, kept for up to the prediction horizon: a robot
/// missing from a view (a motion-capture dropout) keeps its last pose and velocity.
#[derive(Debug, Clone, Default)]
pub struct PoseHistory {
    last_seen: BTreeMap<RobotId, (RobotKind, PoseSample, Option<Twist>)>,
}

impl PoseHistory {
    /// Take the poses of `view` and drop those older than `horizon` (s).
    pub fn observe(&mut self, view: &FleetView, horizon: f64) {
        for r in &view.robots {
            if let Some(p) = r.pose {
                let last = self.last_seen.get(&r.id).and_then(|l| l.2);
                self.last_seen
                    .insert(r.id, (r.kind, p, r.velocity.or(last)));
            }
        }
        self.last_seen
            .retain(|_, (_, p, _)| view.t - p.t <= horizon);
    }

    /// Whether robot `id` has a pose.
    pub fn contains(&self, id: RobotId) -> bool {
        self.last_seen.contains_key(&id)
    }

    /// Every robot's state at time `now` + `ahead` (s), each pose predicted from its
    /// measured velocity for its age plus `ahead`, at most `horizon` (s).
    pub fn states_at(&self, now: f64, ahead: f64, horizon: f64) -> Vec<RobotState> {
        self.last_seen
            .iter()
            .map(|(&id, &(kind, p, w))| {
                let dt = ((now - p.t).max(0.0) + ahead).min(horizon);
                let pose = Pose::new(p.x, p.y, p.theta);
                RobotState {
                    id,
                    kind,
                    pose: w.map_or(pose, |w| predict(pose, w, dt)),
                }
            })
            .collect()
    }
}
