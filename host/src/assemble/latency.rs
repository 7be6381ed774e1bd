//! Pose prediction and latency: every robot's last pose brought to the controller's tick
//! time (motion capture delivers poses at different ages) and on to when the tick's commands
//! act (the link's measured latency). The host knows the commands it sent and when each
//! acts (sent + latency): a free robot's pose is carried along the exact unicycle arcs of
//! those commands (a Smith predictor); the measured velocity (a short window's mean, late by
//! half the window and noisy) carries a coupled robot, which goes where its partners take it.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

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
    /// Commands sent to each robot (time sent, twist), oldest first.
    sent: BTreeMap<RobotId, VecDeque<(f64, Twist)>>,
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
        // Commands are kept while they may still act on a kept pose: the oldest pose is at
        // most `horizon` old and a command acts at most `horizon` after it is sent.
        for q in self.sent.values_mut() {
            while q.len() > 1 && q[1].0 < view.t - 2.0 * horizon {
                q.pop_front();
            }
        }
    }

    /// The commands sent at time `t` (s): `commands` to the robots named, a stop to every
    /// other robot seen (the control loop stops a robot it has no command for).
    pub fn sent(&mut self, t: f64, commands: &BTreeMap<RobotId, Twist>) {
        for &id in self.last_seen.keys() {
            let w = commands.get(&id).copied().unwrap_or(Twist::ZERO);
            self.sent.entry(id).or_default().push_back((t, w));
        }
    }

    /// Whether robot `id` has a pose.
    pub fn contains(&self, id: RobotId) -> bool {
        self.last_seen.contains_key(&id)
    }

    /// Every robot's state at time `now` + `ahead` (s), each pose carried from when it was
    /// measured over its age plus `ahead`, at most `horizon` (s). A free robot is carried
    /// by the commands acting then, each `latency` (s) after it was sent
    /// ([`PoseHistory::sent`]): its velocity stabiliser makes it drive what it is sent. A
    /// robot in `moved_by_others` (coupled: its partners push and pull it, its commands say
    /// less of where it goes) is carried by its measured velocity, as is any robot before
    /// its first command.
    pub fn states_at(
        &self,
        now: f64,
        ahead: f64,
        horizon: f64,
        latency: f64,
        moved_by_others: &BTreeSet<RobotId>,
    ) -> Vec<RobotState> {
        self.last_seen
            .iter()
            .map(|(&id, &(kind, p, w))| {
                let dt = ((now - p.t).max(0.0) + ahead).min(horizon);
                let pose = Pose::new(p.x, p.y, p.theta);
                let pose = match self.sent.get(&id) {
                    Some(q) if !q.is_empty() && !moved_by_others.contains(&id) => {
                        along_commands(pose, q, p.t, dt, latency)
                    }
                    _ => w.map_or(pose, |w| predict(pose, w, dt)),
                };
                RobotState { id, kind, pose }
            })
            .collect()
    }
}

/// `pose`, measured at `t0`, carried for `dt` seconds by the commands `sent` (time sent,
/// twist), each acting from `latency` after it was sent until the next one acts (before the
/// first: standing still).
fn along_commands(
    pose: Pose,
    sent: &VecDeque<(f64, Twist)>,
    t0: f64,
    dt: f64,
    latency: f64,
) -> Pose {
    let end = t0 + dt;
    let mut pose = pose;
    let mut at = t0;
    let first = sent.partition_point(|&(s, _)| s + latency <= at);
    let mut twist = first.checked_sub(1).map_or(Twist::ZERO, |k| sent[k].1);
    for &(s, w) in sent.iter().skip(first) {
        let acts = s + latency;
        if acts >= end {
            break;
        }
        pose = predict(pose, twist, acts - at);
        at = acts;
        twist = w;
    }
    predict(pose, twist, end - at)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::RobotView;

    fn view(t: f64, x: f64, velocity: Option<Twist>) -> FleetView {
        FleetView {
            t,
            robots: vec![RobotView {
                id: 1,
                kind: RobotKind::NonPilot,
                pose: Some(PoseSample {
                    t,
                    x,
                    y: 0.0,
                    theta: 0.0,
                }),
                velocity,
            }],
            latency_s: 0.08,
        }
    }

    #[test]
    fn a_pose_is_carried_by_the_commands_sent_each_from_when_it_acts() {
        let mut h = PoseHistory::default();
        let free = BTreeSet::new();
        // Standing still and measured so; at t = 1.0 the host sends 0.1 m/s forward.
        h.observe(&view(1.0, 0.0, Some(Twist::ZERO)), 0.15);
        h.sent(1.0, &BTreeMap::from([(1, Twist::new(0.1, 0.0))]));
        // At t = 1.05 the pose (taken at 1.05) still shows the robot where it stood: the
        // command acts at 1.08. Predicted to when this tick's commands act (1.13), it has
        // moved for 0.05 s.
        h.observe(&view(1.05, 0.0, Some(Twist::ZERO)), 0.15);
        let now = h.states_at(1.05, 0.0, 0.15, 0.08, &free)[0].pose;
        assert!(now.x.abs() < 1e-12, "not acting yet: {now:?}");
        let then = h.states_at(1.05, 0.08, 0.15, 0.08, &free)[0].pose;
        assert!((then.x - 0.005).abs() < 1e-9, "{then:?}");
        // A stop sent at 1.05 acts at 1.13: the motion ends there however far ahead.
        h.sent(1.05, &BTreeMap::new());
        let later = h.states_at(1.05, 0.1, 0.15, 0.08, &free)[0].pose;
        assert!((later.x - 0.005).abs() < 1e-9, "{later:?}");
    }

    #[test]
    fn the_measured_velocity_carries_a_robot_before_its_first_command_or_when_coupled() {
        let mut h = PoseHistory::default();
        h.observe(&view(2.0, 0.3, Some(Twist::new(0.05, 0.0))), 0.15);
        let p = h.states_at(2.0, 0.1, 0.15, 0.08, &BTreeSet::new())[0].pose;
        assert!((p.x - 0.305).abs() < 1e-9, "{p:?}");
        // Sent a turn it cannot make (its partners hold it), it goes as measured.
        h.sent(2.0, &BTreeMap::from([(1, Twist::new(0.0, 1.0))]));
        let coupled = BTreeSet::from([1]);
        let p = h.states_at(2.0, 0.1, 0.15, 0.08, &coupled)[0].pose;
        assert!((p.x - 0.305).abs() < 1e-9 && p.yaw.abs() < 1e-12, "{p:?}");
    }
}
