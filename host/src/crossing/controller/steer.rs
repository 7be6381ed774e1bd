//! The crossing drive's wheel commands: every member moves as one rigid body turning back
//! to the heading, each non-pilot also holding its own heading.

use std::collections::BTreeMap;

use puzzlebot_params::RobotKind;
use puzzlebot_protocol::RobotId;

use super::CrossingController;
use crate::control::FleetView;
use crate::drive::{wrap_angle, Twist};

impl CrossingController {
    /// Twists of every robot of `view` at `speed` along the heading (0: standing), steered
    /// back to the heading, or driving forward to the path's ([`Self::steer_to_path`]), by a
    /// proportional-integral heading hold, the integral part `integral` (rad·s). The gains
    /// make the hold critically damped on the heading's integrating dynamics, k_i = k_p² / 4:
    /// a pilot whose wheels pull it off the heading (plant mismatch) leaves no lasting error,
    /// where the proportional part alone leaves one of its pull over k_p.
    ///
    /// Driving forward, the members' forward speeds are those of one rigid body turning at
    /// the hold's rate for the members' mean heading error ([`Self::forward_speeds`]): a mesh whose
    /// robots each only turned on the spot would fight its own knobs, and one with pilots
    /// (which drive straight only, THESIS 5.4.1) could not turn at all. Each non-pilot also
    /// turns at the hold's rate for its own heading error: a line yaws freely at its anchors
    /// and is kept straight robot by robot.
    pub(super) fn twists(
        &self,
        view: &FleetView,
        steer: bool,
        speed: f64,
        integral: f64,
    ) -> BTreeMap<RobotId, Twist> {
        let heading = self.path_heading.unwrap_or_else(|| self.heading());
        let kp = self.settings.heading_gain;
        let ki = 0.25 * kp * kp;
        let forward = self.forward_speeds(view, steer, speed, heading, kp, ki * integral);
        view.robots
            .iter()
            .map(|r| {
                let member = self.members.contains(&r.id);
                let t = match (speed == 0.0 || !member, r.pose) {
                    (true, _) | (false, None) => Twist::new(0.0, 0.0),
                    (false, Some(p)) => {
                        let turn = if steer && r.kind != RobotKind::Pilot {
                            kp * wrap_angle(heading - p.theta) + ki * integral
                        } else {
                            0.0
                        };
                        Twist::new(forward.get(&r.id).copied().unwrap_or(speed), turn)
                    }
                };
                (r.id, t)
            })
            .collect()
    }

    /// Forward speed of every member with a pose, driving forward at `speed` and steered:
    /// those of a rigid body turning at the yaw rate `kp` · (mean heading error) + `bias`
    /// about the member innermost to the turn, so that none drives slower than `speed` (the
    /// gate proves the stretches bridged at speed), the rate capped so that none drives
    /// faster than `speed` · (1 + [`CrossSettings::max_speed_up`]). Empty otherwise.
    ///
    /// [`CrossSettings::max_speed_up`]: super::CrossSettings::max_speed_up
    fn forward_speeds(
        &self,
        view: &FleetView,
        steer: bool,
        speed: f64,
        heading: f64,
        kp: f64,
        bias: f64,
    ) -> BTreeMap<RobotId, f64> {
        let poses = self.member_poses(view);
        if !steer || speed <= 0.0 || poses.len() < 2 {
            return BTreeMap::new();
        }
        let Some(error) = self.mean_error(view, heading) else {
            return BTreeMap::new();
        };
        // Offsets to the left of the heading.
        let (s, c) = heading.sin_cos();
        let left: Vec<f64> = poses.iter().map(|(_, p)| -s * p.x + c * p.y).collect();
        let most = left.iter().copied().fold(f64::MIN, f64::max);
        let least = left.iter().copied().fold(f64::MAX, f64::min);
        let span = most - least;
        let limit = if span > 0.0 {
            self.settings.max_speed_up.max(0.0) * speed / span
        } else {
            0.0
        };
        let rate = (kp * error + bias).clamp(-limit, limit);
        // Turning left, the leftmost member is innermost; turning right, the rightmost.
        let inner = if rate > 0.0 { most } else { least };
        poses
            .iter()
            .zip(&left)
            .map(|((id, _), y)| (*id, speed + rate * (inner - y)))
            .collect()
    }
}
