//! The host's crossing behaviour as a [`Controller`]: it drives a formed assembly along the
//! planned heading at the crossing speed, re-checks the assembly it measures with the
//! stability gate at every `gate_every` of advance and stops it the moment the gate cannot
//! prove it, and through a stretch the plan proves only at speed asks the robots to keep
//! driving if the link falls silent. The same controller drives the 3-D world
//! ([`super::drive3d::cross`]) and a real fleet over the link ([`crate::control::ControlLoop`]):
//! it sees only measured poses and the couplings the host believes hold.

use std::collections::BTreeMap;

use puzzlebot_params::geometry::Geometry;
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::FleetParams;
use puzzlebot_protocol::RobotId;
use puzzlebot_sim::LinkKind;
use puzzlebot_stability::crossing::{platform_at, stands_across, Candidate, CrossingOptions};
use puzzlebot_stability::puzzlebot::{
    assembly_level, body_corners, build_model_with, judge_model, world, Pair, PairKind,
    PuzzleAssembly, RobotPose,
};
use serde::Serialize;

use super::drive3d::{crossing_options, CrossSettings};
use crate::control::{Controller, FleetView};
use crate::drive::{wrap_angle, Twist};
use puzzlebot_assembly::assign::mean_heading;
use puzzlebot_assembly::Pose;

/// Why a crossing drive stopped.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CrossStop {
    /// It advanced the plan's required distance and the overshoot, and every member stands
    /// across ([`stands_across`]).
    Reached,
    /// It advanced the plan's required distance and the overshoot, a robot still not
    /// across (the assembly drifted off its heading), and the gate could not prove the
    /// further advance that takes it across from where it stands
    /// ([`CrossingController::extension`]), or that advance left it short too.
    Short,
    /// The gate could not prove the measured assembly (its verdict).
    Gate(String),
    /// A robot of the assembly had no fresh pose.
    PoseLost(RobotId),
    /// It ran out of time: twice the time the advance takes at speed, and two seconds.
    TimedOut,
    /// Its members' mean heading left the plan's by more than an anchor's yaw range (rad,
    /// the error): the plan, and the gate's checks along its heading, no longer describe
    /// the motion, and a member hanging at an anchor cannot follow.
    OffHeading(f64),
}

/// Where a crossing drive is.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CrossProgress {
    /// Advance along the heading, averaged over the robots (m).
    pub advance: f64,
    /// Gate checks of the measured poses.
    pub gate_checks: usize,
    /// Host time the drive started (s), once it did.
    pub started_s: Option<f64>,
    /// Host time and advance it stopped at, and why.
    pub stopped: Option<(f64, f64, CrossStop)>,
    /// After a gate stop: the advance it backed off to, once back where it started (m).
    pub backed_off_to: Option<f64>,
}

/// The crossing behaviour (see the module doc).
pub struct CrossingController {
    plan: Candidate,
    terrain: Terrain,
    params: FleetParams,
    settings: CrossSettings,
    /// Robots of the assembly; others stand still.
    members: Vec<RobotId>,
    /// Couplings the host believes hold (kind, robot with the anchor / knob, other robot).
    links: Vec<(LinkKind, RobotId, RobotId)>,
    opt: CrossingOptions,
    /// Robots and where each stood when the drive started, in the order first seen.
    start: Vec<(RobotId, [f64; 2])>,
    /// Advance of the next gate check (m).
    next_check: f64,
    /// Hold of the latest commands (ms).
    hold: u16,
    /// Backing off to the start after a gate stop, since this host time (s).
    backing_since: Option<f64>,
    /// How often the host calls it (Hz).
    rate_hz: f64,
    /// Integral of the members' mean heading error while driving forward (rad·s): the heading
    /// hold's integral part ([`Self::twists`]).
    heading_integral: f64,
    /// Driving forward: the heading that steers back onto the planned path
    /// ([`Self::steer_to_path`]); `None`: the plan's heading.
    path_heading: Option<f64>,
    /// The advance the drive ends at once extended past the plan's
    /// ([`CrossingController::extension`], m).
    extended_to: Option<f64>,
    progress: CrossProgress,
}

impl CrossingController {
    /// A crossing along `plan` over `terrain` of the robots `members` with `params`, coupled
    /// by `links`.
    pub fn new(
        plan: Candidate,
        terrain: Terrain,
        params: FleetParams,
        settings: CrossSettings,
        members: Vec<RobotId>,
        links: Vec<(LinkKind, RobotId, RobotId)>,
    ) -> Self {
        let opt = crossing_options(&settings, &params);
        CrossingController {
            plan,
            terrain,
            params,
            settings,
            members,
            links,
            opt,
            start: Vec::new(),
            next_check: 0.0,
            hold: 0,
            backing_since: None,
            rate_hz: 100.0,
            heading_integral: 0.0,
            path_heading: None,
            extended_to: None,
            progress: CrossProgress {
                advance: 0.0,
                gate_checks: 0,
                started_s: None,
                stopped: None,
                backed_off_to: None,
            },
        }
    }

    /// Called `hz` times a second (the default is 100 Hz, the 3-D world's host loop).
    pub fn with_rate(mut self, hz: f64) -> Self {
        if hz.is_finite() && hz > 0.0 {
            self.rate_hz = hz;
        }
        self
    }

    /// Advance at which the drive ends: the plan's required advance and the overshoot, or
    /// the extension's end once extended ([`Self::extension`]) (m).
    pub fn goal(&self) -> f64 {
        self.extended_to
            .unwrap_or(self.plan.required + self.settings.overshoot)
    }

    /// The members of `view` with a measured pose, as the gate pictures them.
    fn member_poses(&self, view: &FleetView) -> Vec<(RobotId, RobotPose)> {
        view.robots
            .iter()
            .filter(|r| self.members.contains(&r.id))
            .filter_map(|r| measured(r).map(|pose| (r.id, pose)))
            .collect()
    }

    /// Longest the drive may take (s): twice the time of its advance at speed, and two
    /// seconds to start and stop.
    pub fn time_limit_s(&self) -> f64 {
        2.0 * self.goal() / self.settings.speed + 2.0
    }

    /// Where the drive is.
    pub fn progress(&self) -> &CrossProgress {
        &self.progress
    }

    /// The drive has stopped.
    pub fn stopped(&self) -> bool {
        self.progress.stopped.is_some()
    }

    /// It is backing off to the start after a gate stop.
    pub fn backing(&self) -> bool {
        self.backing_since.is_some()
    }

    /// Advance of the robots of `view` since the drive started, along the heading (m): the
    /// mean over the robots with a pose (0 before the start).
    pub fn advance(&self, view: &FleetView) -> f64 {
        self.moved_along(view, self.direction()).unwrap_or(0.0)
    }

    /// How far the robots of `view` moved since the drive started along unit vector `dir`
    /// (m): the mean over the robots with a pose (`None`: none has one, or before the start).
    fn moved_along(&self, view: &FleetView, dir: [f64; 2]) -> Option<f64> {
        let (mut sum, mut n) = (0.0, 0usize);
        for r in &view.robots {
            let (Some(p), Some((_, p0))) = (r.pose, self.start.iter().find(|(id, _)| *id == r.id))
            else {
                continue;
            };
            sum += (p.x - p0[0]) * dir[0] + (p.y - p0[1]) * dir[1];
            n += 1;
        }
        (n > 0).then(|| sum / n as f64)
    }

    /// Adds one host period of the members' mean heading error to the heading hold's
    /// integral, bounded so that its part never turns harder than the proportional part at
    /// an error of one radian (|k_i · I| ≤ k_p).
    fn integrate_heading(&mut self, view: &FleetView) {
        let kp = self.settings.heading_gain;
        if kp <= 0.0 {
            return;
        }
        let heading = self.path_heading.unwrap_or_else(|| self.heading());
        let Some(mean) = self.mean_error(view, heading) else {
            return;
        };
        let bound = 4.0 / kp;
        self.heading_integral = (self.heading_integral + mean / self.rate_hz).clamp(-bound, bound);
    }

    /// The members' mean heading error from `heading` (rad, positive: turn left); `None`
    /// without poses.
    fn mean_error(&self, view: &FleetView, heading: f64) -> Option<f64> {
        let poses = self.member_poses(view);
        let sum: f64 = poses.iter().map(|(_, p)| wrap_angle(heading - p.yaw)).sum();
        (!poses.is_empty()).then(|| sum / poses.len() as f64)
    }

    /// Driving forward, the heading to steer to: the plan proves the assembly on the straight
    /// path from where it started along the heading, so the hold steers back onto that path,
    /// not only parallel to it — h − atan(e / L) for the members' mean offset e to the left of
    /// the path (m), with L = 3 v / k_p: the path's loop (time constant L / v) three times
    /// slower than the heading's (1 / k_p), so that the two do not interact.
    fn steer_to_path(&mut self, view: &FleetView) {
        let kp = self.settings.heading_gain;
        if kp <= 0.0 {
            return;
        }
        let h = self.heading();
        let Some(offset) = self.moved_along(view, [-h.sin(), h.cos()]) else {
            return;
        };
        let look_ahead = 3.0 * self.settings.speed / kp;
        self.path_heading = Some(h - (offset / look_ahead).atan());
    }

    /// Whether `test` holds for every member's measured pose in `view` with the index of the
    /// platform the plan starts on; `None` when no platform is under the plan's start.
    fn every_member(
        &self,
        view: &FleetView,
        test: impl Fn(&RobotPose, usize) -> bool,
    ) -> Option<bool> {
        let start = platform_at(&self.terrain, self.plan.start)?;
        Some(
            view.robots
                .iter()
                .filter(|r| self.members.contains(&r.id))
                .all(|r| measured(r).is_some_and(|pose| test(&pose, start))),
        )
    }

    /// Every member of `view` stands wholly off the platform the plan starts on, as the
    /// planner's required advance asks ([`stands_across`]): an assembly that drifted off
    /// its heading may not have crossed at the planned advance.
    fn across(&self, view: &FleetView) -> bool {
        self.every_member(view, |pose, start| {
            stands_across(pose, &self.params, &self.terrain, start)
        })
        .unwrap_or(true)
    }

    fn heading(&self) -> f64 {
        self.plan.heading_deg.to_radians()
    }

    /// Every member of `view` stands wholly on the platform the plan starts on: every
    /// underside corner over it.
    fn on_start(&self, view: &FleetView) -> bool {
        self.every_member(view, |p, start| {
            body_corners(p.kind, &self.params)
                .iter()
                .all(|&b| platform_at(&self.terrain, world(p, b)) == Some(start))
        })
        .unwrap_or(false)
    }

    /// The members' mean measured heading less the plan's (rad); `None` without poses.
    fn heading_error(&self, view: &FleetView) -> Option<f64> {
        let poses: Vec<Pose> = view
            .robots
            .iter()
            .filter(|r| self.members.contains(&r.id))
            .filter_map(|r| r.pose.map(|p| Pose::new(p.x, p.y, p.theta)))
            .collect();
        (!poses.is_empty()).then(|| wrap_angle(mean_heading(&poses) - self.heading()))
    }

    fn direction(&self) -> [f64; 2] {
        let h = self.heading();
        [h.cos(), h.sin()]
    }

    /// The stretch of the plan proven only at speed that advance `d` lies in, if any, widened
    /// by [`Self::slack`]: its start and end (m). No check stops the drive there: stopping is
    /// what would tip the assembly.
    fn stretch(&self, d: f64) -> Option<[f64; 2]> {
        let slack = self.slack();
        self.plan
            .advance
            .bridged
            .iter()
            .filter(|b| d >= b[0] - slack && d <= b[1] + slack)
            .map(|b| [b[0] - slack, b[1] + slack])
            .reduce(|a, b| [a[0].min(b[0]), a[1].max(b[1])])
    }

    /// The time (ms) the drive takes over `distance` at its speed.
    fn drive_ms(&self, distance: f64) -> u16 {
        (distance / self.settings.speed * 1e3)
            .ceil()
            .min(f64::from(u16::MAX)) as u16
    }

    /// How far the measured advance may lie from the plan's rigid translation (m): a
    /// check's spacing, and half the travel of every anchor sliding in its opening.
    fn slack(&self) -> f64 {
        let travel = f64::from(self.params.non_pilot.coupling.anchor_travel);
        let anchors = self
            .links
            .iter()
            .filter(|l| l.0 == LinkKind::Anchor)
            .count();
        self.settings.gate_every + 0.5 * travel * anchors as f64
    }

    /// How long the drive needs to leave the stretch `d` lies in (ms; 0 outside one).
    fn hold_ms_at(&self, d: f64) -> u16 {
        self.stretch(d).map_or(0, |s| self.drive_ms(s[1] - d))
    }

    fn stop(&mut self, t: f64, why: CrossStop) {
        self.hold = 0;
        // Backing off holds the plan's heading.
        self.path_heading = None;
        // A gate stop in the overshoot past the planned advance: the way back would run
        // over the whole gap again; it stands where the gate stopped it.
        let before_goal = self.progress.advance < self.goal();
        if self.settings.back_off && before_goal && matches!(why, CrossStop::Gate(_)) {
            self.backing_since = Some(t);
        }
        self.progress.stopped = Some((t, self.progress.advance, why));
    }

    /// Backing off after a gate stop: back along the heading over the advances the gate
    /// checked on the way in, to where the drive started (no checks: those states were
    /// proven, and standing where the gate stopped it is proven no better), holding through
    /// the stretches proven only at speed. Done at the start or after twice the time the
    /// way back takes at speed and two seconds.
    fn back_off(&mut self, view: &FleetView, since: f64) -> BTreeMap<RobotId, Twist> {
        let d = self.advance(view);
        self.progress.advance = d;
        let from = self.progress.stopped.as_ref().map_or(d, |s| s.1);
        let limit = 2.0 * from.max(0.0) / self.settings.speed + 2.0;
        if d <= 0.0 || view.t - since >= limit {
            self.backing_since = None;
            self.hold = 0;
            self.progress.backed_off_to = Some(d);
            return self.twists(view, false, 0.0, 0.0);
        }
        // Time to leave a stretch backwards: to its start.
        let period = (1e6 / self.rate_hz()).round() * 1e-6;
        let ahead = d - self.settings.speed * period;
        self.hold = if self.settings.hold_through_stretches {
            self.stretch(ahead)
                .map_or(0, |s| self.drive_ms(ahead - s[0]))
        } else {
            0
        };
        self.twists(
            view,
            self.settings.heading_gain > 0.0,
            -self.settings.speed,
            0.0,
        )
    }
}

impl Controller for CrossingController {
    fn name(&self) -> &str {
        "cross"
    }

    fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    fn update(&mut self, view: &FleetView) -> BTreeMap<RobotId, Twist> {
        if let Some(since) = self.backing_since {
            if view
                .robots
                .iter()
                .all(|r| r.pose.is_some() || !self.members.contains(&r.id))
            {
                return self.back_off(view, since);
            }
            // A robot without a pose: the back-off ends where it is.
            self.backing_since = None;
            self.hold = 0;
        }
        if self.stopped() {
            return self.twists(view, false, 0.0, 0.0);
        }
        let lost = self
            .members
            .iter()
            .find(|id| !view.robots.iter().any(|r| r.id == **id && r.pose.is_some()));
        if let Some(&id) = lost {
            self.stop(view.t, CrossStop::PoseLost(id));
            return self.twists(view, false, 0.0, 0.0);
        }
        let Some(t0) = self.progress.started_s else {
            // The first update sets the start: the drive starts from rest with equal wheel
            // speeds, the heading feedback acts from the next update on.
            self.start = view
                .robots
                .iter()
                .filter(|r| self.members.contains(&r.id))
                .filter_map(|r| r.pose.map(|p| (r.id, [p.x, p.y])))
                .collect();
            self.progress.started_s = Some(view.t);
            return self.twists(view, false, self.settings.speed, 0.0);
        };
        let d = self.advance(view);
        self.progress.advance = d;
        // The live gate checks along the plan's heading: off it, its checks say nothing. Still
        // wholly on the start platform, the drive stops there; once the assembly bridges the
        // edge, stopping astride is worse than driving on across, so it goes on.
        if let Some(err) = self.heading_error(view).filter(|_| self.settings.live_gate) {
            let range = f64::from(self.params.non_pilot.coupling.anchor_yaw_range);
            if err.abs() > range && self.on_start(view) {
                self.stop(view.t, CrossStop::OffHeading(err));
                return self.twists(view, false, 0.0, 0.0);
            }
        }
        if d >= self.goal() {
            // The gate proved the drive this far and no farther. An assembly that drifted
            // off its heading and still has a robot astride drives on once, as far as the
            // gate proves from where it stands takes every robot across; else it stops.
            if self.across(view) {
                self.stop(view.t, CrossStop::Reached);
                return self.twists(view, false, 0.0, 0.0);
            }
            match self
                .extended_to
                .is_none()
                .then(|| self.extension(view))
                .flatten()
            {
                Some(e) => self.extended_to = Some(d + e + self.settings.overshoot),
                None => {
                    self.stop(view.t, CrossStop::Short);
                    return self.twists(view, false, 0.0, 0.0);
                }
            }
        }
        if view.t - t0 >= self.time_limit_s() {
            self.stop(view.t, CrossStop::TimedOut);
            return self.twists(view, false, 0.0, 0.0);
        }
        // Looking one host period ahead: the hold must already run when the link fails.
        self.hold = if self.settings.hold_through_stretches {
            let period = (1e6 / self.rate_hz()).round() * 1e-6;
            self.hold_ms_at(d + self.settings.speed * period)
        } else {
            0
        };
        if self.settings.live_gate && d >= self.next_check && self.stretch(d).is_none() {
            self.progress.gate_checks += 1;
            let poses = self.member_poses(view);
            let verdict = gate_now(
                &poses,
                &self.links,
                &self.params,
                &self.terrain,
                &self.opt,
                self.heading(),
            );
            if let Some(why) = verdict {
                self.stop(view.t, CrossStop::Gate(why));
                return self.twists(view, false, 0.0, 0.0);
            }
            self.next_check = d + self.settings.gate_every;
        }
        self.steer_to_path(view);
        self.integrate_heading(view);
        let integral = self.heading_integral;
        self.twists(
            view,
            self.settings.heading_gain > 0.0,
            self.settings.speed,
            integral,
        )
    }

    fn done(&self, _t: f64) -> bool {
        self.stopped() && self.backing_since.is_none()
    }

    /// Coupled robots move as the assembly does: no velocity stabiliser.
    fn stabilise(&self, _id: RobotId) -> bool {
        false
    }

    fn hold_ms(&self, _id: RobotId) -> u16 {
        self.hold
    }
}

/// Robot `r` where it is measured, as the gate pictures it (`None`: no pose).
fn measured(r: &crate::control::RobotView) -> Option<RobotPose> {
    r.pose.map(|p| RobotPose {
        kind: r.kind,
        x: p.x,
        y: p.y,
        yaw: p.theta,
    })
}

/// The gate's verdict on the assembly of robots `poses` (in their order) coupled by `held`,
/// travelling along `heading` (rad) with the planner's options `opt` (`None`: stable).
pub fn gate_now(
    poses: &[(RobotId, RobotPose)],
    held: &[(LinkKind, RobotId, RobotId)],
    params: &FleetParams,
    terrain: &Terrain,
    opt: &CrossingOptions,
    heading: f64,
) -> Option<String> {
    let a = assembly_of(poses, held, &params.non_pilot.geometry);
    let Some(level) = assembly_level(&a, params, terrain) else {
        return Some("no support under any robot".into());
    };
    let opt = opt.advance_options(0.0);
    match build_model_with(&a, params, terrain, level, [0.0, 0.0], &opt)
        .and_then(|m| judge_model(&m, params, &opt, heading))
    {
        Ok(None) => None,
        Ok(Some(why)) => Some(format!("{why:?}")),
        Err(e) => Some(e.to_string()),
    }
}

/// The gate's picture of robots `poses` (in their order) coupled by `links` (kind, robot with
/// the anchor / knob, robot with the opening / hole); couplings of robots not among `poses`
/// are left out.
pub fn assembly_of(
    poses: &[(RobotId, RobotPose)],
    links: &[(LinkKind, RobotId, RobotId)],
    g: &Geometry,
) -> PuzzleAssembly {
    let robots: Vec<RobotPose> = poses.iter().map(|p| p.1).collect();
    let index = |id: RobotId| poses.iter().position(|p| p.0 == id);
    let pairs = links
        .iter()
        .filter_map(|&(k, a, b)| {
            let (ia, ib) = (index(a)?, index(b)?);
            Some(match k {
                LinkKind::Anchor => Pair {
                    a: ia,
                    b: ib,
                    kind: PairKind::Anchor,
                    point: None,
                },
                LinkKind::Knob => Pair {
                    a: ia,
                    b: ib,
                    kind: PairKind::Knob,
                    point: Some(knob_point(&robots[ia], &robots[ib], g)),
                },
            })
        })
        .collect();
    PuzzleAssembly { robots, pairs }
}

/// Where the knob of robot `a` holding robot `b` sits in `a`'s frame: the side point of `a`
/// nearest `b`, as the planner places it.
fn knob_point(a: &RobotPose, b: &RobotPose, g: &Geometry) -> [f64; 2] {
    let side = f64::from(g.side_point_x);
    let (s, c) = a.yaw.sin_cos();
    let fwd = c * (b.x - a.x) + s * (b.y - a.y);
    [fwd.clamp(-side, side), 0.5 * f64::from(g.width)]
}

mod extension;
mod steer;

#[cfg(test)]
mod tests;
