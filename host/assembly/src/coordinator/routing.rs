//! Getting a robot somewhere: the next waypoint of a route round the other robots, and the
//! turn-then-drive point law near it.

use super::*;

/// Room kept between robots, from the body's size and [`CoordinatorConfig::spare`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Room {
    /// Centre distance a robot driving to the start of an approach keeps from every other
    /// robot (m): two bodies at any angle (their circumscribed radii) and the spare.
    pub(super) route_clearance: f64,
    /// Smallest centre distance of the start of an approach to another robot (m): a body
    /// width (beside an assembly's side, not closer).
    pub(super) approach_gap: f64,
    /// How far outside an approach corridor a robot that makes way for it stands (m): half
    /// a body and the spare, so its body clears the corridor's edge.
    pub(super) make_way_margin: f64,
    /// Half-width of a lane train's corridor that another robot's centre blocks (m): a body
    /// (two half bodies) and the spare.
    pub(super) lane_block_half_width: f64,
}

impl Coordinator {
    /// The room kept between robots ([`Room`]).
    pub(super) fn room(&self) -> Room {
        let [hx, hy] = self.geometry.half_extents();
        let (hx, hy) = (f64::from(hx), f64::from(hy));
        let spare = self.cfg.spare;
        Room {
            route_clearance: 2.0 * hx.hypot(hy) + spare,
            approach_gap: 2.0 * hy,
            make_way_margin: hy + spare,
            lane_block_half_width: 2.0 * hy + spare,
        }
    }

    /// Turn rate on the spot through the heading error `err` (rad, the turn still to make):
    /// proportional ([`DockConfig::k_theta`]), never slower than the wheels' dead-band
    /// allows ([`DockConfig::min_turn`]) nor faster than [`DockConfig::max_turn`].
    pub(super) fn spot_turn_rate(&self, err: f64) -> f64 {
        let d = self.cfg.dock;
        (d.k_theta * err.abs()).clamp(d.min_turn, d.max_turn) * err.signum()
    }

    /// (v, ω) towards point `goal` from `pose`: forwards or backwards, whichever needs less
    /// turning; turn on the spot first when the heading is off by more than 0.3 rad. Speeds
    /// stay above the wheels' dead-band ([`DockConfig::speed`], [`DockConfig::min_turn`]).
    pub(super) fn point_drive(&self, pose: &Pose2, goal: [f64; 2]) -> (f64, f64) {
        let d = self.cfg.dock;
        let (dx, dy) = (goal[0] - pose.x, goal[1] - pose.y);
        let mut e = wrap_angle(dy.atan2(dx) - pose.yaw);
        let mut dir = 1.0;
        if e.abs() > std::f64::consts::FRAC_PI_2 {
            e = wrap_angle(e + std::f64::consts::PI);
            dir = -1.0;
        }
        if e.abs() > 0.3 {
            let w = self.spot_turn_rate(e);
            return self.turn_in_place(pose, goal, w);
        }
        (dir * d.speed, d.k_theta * e)
    }

    /// (v, ω) turning at `w` (rad/s) while staying at point `at`. The butterfly (THESIS
    /// 3.10) has no turn without motion: asked to turn on the spot, a robot pivots on a
    /// circle of [`CoordinatorConfig::turn_radius`] and drifts up to twice that off
    /// (half a turn drifted a docking robot off its stand-off, it drove back, and turned
    /// again, for ever). So it turns at that radius forwards or backwards, whichever takes
    /// it back towards `at`: the two pivots drift it opposite ways, and it stays there.
    pub(super) fn turn_in_place(&self, pose: &Pose2, at: [f64; 2], w: f64) -> (f64, f64) {
        let (s, c) = pose.yaw.sin_cos();
        let ahead = (at[0] - pose.x) * c + (at[1] - pose.y) * s;
        let dir = if ahead >= 0.0 { 1.0 } else { -1.0 };
        (dir * w.abs() * self.cfg.turn_radius, w)
    }

    /// Towards waypoint `p`: the MPC's point goal when it is far (faster), the turn-then-drive
    /// point law near it (the MPC's point goal stalls beside the robot).
    pub(super) fn drive_to(&self, i: usize, pose: &Pose2, p: [f64; 2]) -> Role {
        if (p[0] - pose.x).hypot(p[1] - pose.y) > 0.15 {
            return Role::GoTo {
                goal: Pose2::new(p[0], p[1], pose.yaw),
                use_yaw: false,
            };
        }
        let (v, w) = self.point_drive(pose, p);
        Role::Dock { pair: i, v, w }
    }

    /// Centres of every live robot but `me`.
    pub(super) fn others(&self, me: RobotId) -> Vec<[f64; 2]> {
        self.robots
            .iter()
            .filter(|(id, _)| **id != me && !self.lost.contains(id))
            .map(|(_, k)| k.pose.xy())
            .collect()
    }

    /// The next waypoint of robot `me` on its way to `goal` round every other robot
    /// ([`crate::route`]); None when there is no way (it waits).
    pub(super) fn route_step(&self, me: RobotId, goal: [f64; 2]) -> Option<[f64; 2]> {
        self.next_waypoint(me, goal, self.room().approach_gap)
    }

    /// The next waypoint of dispersing robot `me` on its way to `goal` round every other
    /// robot. Unlike [`Self::route_step`] a goal beside another robot is allowed (robots
    /// dispersing from an assembly start and end close together), so this only answers None
    /// when no way is found; the robot then heads for its goal directly.
    pub(super) fn disperse_step(&self, me: RobotId, goal: [f64; 2]) -> Option<[f64; 2]> {
        self.next_waypoint(me, goal, 0.0)
    }

    /// First waypoint of [`route`] for `me` round every other robot, the goal at least
    /// `goal_gap` from any of them.
    fn next_waypoint(&self, me: RobotId, goal: [f64; 2], goal_gap: f64) -> Option<[f64; 2]> {
        let start = self.robots.get(&me)?.pose.xy();
        let obstacles = self.others(me);
        let field = Field {
            obstacles: &obstacles,
            clearance: self.room().route_clearance,
        };
        route(start, goal, &field, goal_gap, self.cfg.dock.route_margin)?
            .first()
            .copied()
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::coordinator;
    use crate::geom::Pose2;

    #[test]
    fn a_robot_turning_half_a_turn_on_the_spot_stays_where_it_turns() {
        // Half a turn at the smallest radius, always forwards, drifts the robot 2ρ away
        // (34 mm: off a docking stand-off); turning forwards or backwards towards its
        // point, it stays within a fraction of ρ of it.
        let c = coordinator();
        let rho = c.cfg.turn_radius;
        let at = [0.3, -0.2];
        let mut pose = Pose2::new(at[0], at[1], 0.4);
        let goal = pose.yaw + std::f64::consts::PI;
        let (dt, mut worst) = (c.cfg.dt, 0.0f64);
        for _ in 0..200 {
            let e = crate::geom::wrap_angle(goal - pose.yaw);
            if e.abs() < 0.1 {
                break;
            }
            let (v, w) = c.turn_in_place(&pose, at, 1.5 * e.signum());
            assert!(
                (v.abs() - 1.5 * rho).abs() < 1e-12,
                "at the smallest radius: {v}"
            );
            // The unicycle's exact arc over one tick.
            let th = pose.yaw + w * dt;
            let r = v / w;
            pose = Pose2::new(
                pose.x + r * (th.sin() - pose.yaw.sin()),
                pose.y - r * (th.cos() - pose.yaw.cos()),
                th,
            );
            worst = worst.max((pose.x - at[0]).hypot(pose.y - at[1]));
        }
        let e = crate::geom::wrap_angle(goal - pose.yaw);
        assert!(e.abs() < 0.1, "turned: {e}");
        assert!(
            worst < 0.5 * rho,
            "stayed within {worst} m of its point (ρ = {rho})"
        );
    }
}
