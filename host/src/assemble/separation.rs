//! Keeping robots that are not meant to touch apart: a control barrier function (CBF) filter
//! on the forward speed of every robot that drives alone, as the Robotarium's barrier
//! certificates keep its robots apart (Wang, Ames & Egerstedt, "Safety barrier certificates
//! for collisions-free multirobot systems", 2017).
//!
//! For robots i and j with centre distance d, the barrier is `h = d − D` (D: clearance
//! between centres) and the filter keeps `ḣ ≥ −γ·h` by letting robot i close the gap at most
//! at its share of `γ·h`: with `n` the unit vector from j to i and `e_i` i's heading,
//! `(n·e_i)·v_i ≥ −σ·γ·h`, σ = ½ when j is filtered too and 1 when j is not (an assembly or a
//! robot that holds). A unicycle's turn rate does not move its centre, so only `v` is limited:
//! each neighbour bounds it from one side, and the command keeps the speed closest to the
//! nominal one within the bounds. Robots already closer than D (just released from an
//! assembly) may only move apart.
//!
//! A robot that holds still where a filtered robot needs to pass makes way ([`make_way`]):
//! pulling out of a dissolving line, each robot's neighbours stand closer than the clearance,
//! so without it the pullers and the robots holding in front of them wait for each other.
//!
//! Robots that are meant to touch are exempt: members of one assembly (they move as one body
//! and are never filtered themselves), and the two sides of every pair being docked or coupled.
//! Robots told to wait or hold are not driven by the filter either. The assembly controller
//! applies it whenever robots move freely (moving, dissolving, spreading out, dispersing);
//! while an assembly forms, docking brings robots into contact on purpose.

use std::collections::{BTreeMap, BTreeSet};

use puzzlebot_assembly::RobotState;
use puzzlebot_params::geometry::Geometry;
use puzzlebot_protocol::messages::RobotId;

use crate::drive::Twist;

/// Settings of the separation filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeparationConfig {
    /// Centre distance below which two robots may touch (m): twice the radius of the circle
    /// about a robot's centre that holds its body and its anchor head.
    pub clearance: f64,
    /// Barrier rate γ (1/s): a robot closes a gap `h` beyond the clearance at most at `γ·h`
    /// (shared between two moving robots), so it starts slowing `v/γ` before the clearance.
    pub rate: f64,
    /// Neighbours farther than this beyond the clearance are not considered (m).
    pub range: f64,
}

impl SeparationConfig {
    /// The clearance from the robot's geometry; rate and range for the docking speeds.
    pub fn from_geometry(g: &Geometry) -> Self {
        let [hx, hy] = g.half_extents();
        let (hx, hy) = (f64::from(hx), f64::from(hy));
        let head = f64::from(g.anchor_head[0]).hypot(f64::from(g.anchor_head[1]));
        let radius = hx.hypot(hy).max(head);
        SeparationConfig {
            clearance: 2.0 * radius,
            rate: 2.0,
            range: 0.2,
        }
    }
}

/// Groups that may touch: `segment` labels each robot's assembly; `touching` lists pairs of
/// segments being docked or coupled to each other.
#[derive(Debug, Clone, Default)]
pub struct Exemptions {
    /// Assembly (segment) of each robot.
    pub segment: BTreeMap<RobotId, usize>,
    /// Pairs of segments that may touch (stored both ways round).
    pub touching: BTreeSet<(usize, usize)>,
}

impl Exemptions {
    /// Segments `a` and `b` may touch.
    pub fn allow(&mut self, a: usize, b: usize) {
        self.touching.insert((a, b));
        self.touching.insert((b, a));
    }

    fn may_touch(&self, i: RobotId, j: RobotId) -> bool {
        match (self.segment.get(&i), self.segment.get(&j)) {
            (Some(a), Some(b)) => a == b || self.touching.contains(&(*a, *b)),
            _ => false,
        }
    }
}

/// Limit the forward speed of the robots in `alone` (robots that drive by themselves) so that
/// no two robots that are not exempt close in on each other; returns how many were slowed.
pub fn separate(
    cfg: &SeparationConfig,
    states: &[RobotState],
    alone: &BTreeSet<RobotId>,
    exempt: &Exemptions,
    out: &mut BTreeMap<RobotId, Twist>,
) -> usize {
    let mut slowed = 0;
    for si in states.iter().filter(|s| alone.contains(&s.id)) {
        let Some(cmd) = out.get_mut(&si.id) else {
            continue;
        };
        let (lo, hi) = speed_bounds(cfg, si, states, alone, exempt);
        let v = if lo <= hi {
            cmd.v.clamp(lo, hi)
        } else {
            // Squeezed from both sides: the speed that violates both bounds least.
            0.5 * (lo + hi)
        };
        if v != cmd.v {
            cmd.v = v;
            slowed += 1;
        }
    }
    slowed
}

/// Smallest share of a robot's straight motion that must open the gap to a robot it makes
/// way for (cosine of 60°): a robot standing more sideways than that cannot clear the way by
/// driving straight and stays.
const MAKE_WAY_MIN_ALIGNMENT: f64 = 0.5;

/// [`separate`], after which every robot in `holders` (alone and told to stand still) that
/// keeps a robot in `alone` from its nominal speed drives straight away from it at that
/// speed and is filtered too, so a robot it then closes on makes way in turn. Returns the
/// robots that make way.
pub fn separate_making_way(
    cfg: &SeparationConfig,
    states: &[RobotState],
    alone: &BTreeSet<RobotId>,
    holders: &BTreeSet<RobotId>,
    exempt: &Exemptions,
    out: &mut BTreeMap<RobotId, Twist>,
) -> BTreeSet<RobotId> {
    let mut alone = alone.clone();
    let mut nominal = out.clone();
    let mut yielding = BTreeSet::new();
    // Each round adds at least one robot that makes way, so the cascade ends.
    loop {
        let mut trial = nominal.clone();
        separate(cfg, states, &alone, exempt, &mut trial);
        let new = make_way(cfg, states, &alone, holders, &yielding, exempt, &nominal);
        if new.is_empty() {
            *out = trial;
            return yielding;
        }
        for (id, twist) in new {
            alone.insert(id);
            yielding.insert(id);
            nominal.insert(id, twist);
        }
    }
}

/// The holding robots that keep a filtered robot from its nominal speed, each with the
/// straight command that takes it away from that robot at that speed.
fn make_way(
    cfg: &SeparationConfig,
    states: &[RobotState],
    alone: &BTreeSet<RobotId>,
    holders: &BTreeSet<RobotId>,
    yielding: &BTreeSet<RobotId>,
    exempt: &Exemptions,
    nominal: &BTreeMap<RobotId, Twist>,
) -> BTreeMap<RobotId, Twist> {
    let mut new = BTreeMap::new();
    for si in states.iter().filter(|s| alone.contains(&s.id)) {
        let Some(v) = nominal.get(&si.id).map(|t| t.v).filter(|v| *v != 0.0) else {
            continue;
        };
        for sj in states {
            let free =
                holders.contains(&sj.id) && !yielding.contains(&sj.id) && !new.contains_key(&sj.id);
            if !free || sj.id == si.id || exempt.may_touch(si.id, sj.id) {
                continue;
            }
            let Some((a, bound)) = neighbour_bound(cfg, si, sj, 1.0) else {
                continue;
            };
            let blocks = if a > 0.0 { v < bound } else { v > bound };
            if !blocks {
                continue;
            }
            // Unit vector from i to j along j's heading: j opens the gap driving that way.
            let d = (sj.pose.x - si.pose.x).hypot(sj.pose.y - si.pose.y);
            let (s, c) = sj.pose.yaw.sin_cos();
            let along = ((sj.pose.x - si.pose.x) * c + (sj.pose.y - si.pose.y) * s) / d;
            if along.abs() >= MAKE_WAY_MIN_ALIGNMENT {
                new.insert(sj.id, Twist::new(along.signum() * v.abs(), 0.0));
            }
        }
    }
    new
}

/// The interval of forward speeds that keeps robot `si` clear of its neighbours.
fn speed_bounds(
    cfg: &SeparationConfig,
    si: &RobotState,
    states: &[RobotState],
    alone: &BTreeSet<RobotId>,
    exempt: &Exemptions,
) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    for sj in states {
        if sj.id == si.id || exempt.may_touch(si.id, sj.id) {
            continue;
        }
        let share = if alone.contains(&sj.id) { 0.5 } else { 1.0 };
        let Some((a, bound)) = neighbour_bound(cfg, si, sj, share) else {
            continue;
        };
        if a > 0.0 {
            lo = lo.max(bound);
        } else {
            hi = hi.min(bound);
        }
    }
    (lo, hi)
}

/// Robot `sj`'s bound on robot `si`'s forward speed, when `sj` is in range and `si`'s speed
/// changes their distance: `(n·e_i, bound)`, a lower bound when `n·e_i > 0` and an upper one
/// otherwise; `share` is `si`'s part of the barrier rate.
fn neighbour_bound(
    cfg: &SeparationConfig,
    si: &RobotState,
    sj: &RobotState,
    share: f64,
) -> Option<(f64, f64)> {
    let (s, c) = si.pose.yaw.sin_cos();
    let (dx, dy) = (si.pose.x - sj.pose.x, si.pose.y - sj.pose.y);
    let d = dx.hypot(dy);
    let h = d - cfg.clearance;
    if h > cfg.range || d < 1e-9 {
        return None;
    }
    // n·e_i: how much forward speed changes the distance.
    let a = (dx * c + dy * s) / d;
    if a.abs() < 1e-3 {
        return None; // moving sideways to the neighbour: the distance does not change
    }
    Some((a, -share * cfg.rate * h / a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_assembly::Pose;
    use puzzlebot_params::RobotKind;

    fn state(id: RobotId, x: f64, y: f64, yaw: f64) -> RobotState {
        RobotState {
            id,
            kind: RobotKind::NonPilot,
            pose: Pose::new(x, y, yaw),
        }
    }

    fn cfg() -> SeparationConfig {
        SeparationConfig::from_geometry(&Geometry::default())
    }

    /// Simulate unicycles under the filter for `secs`; returns the final states.
    fn run(
        mut states: Vec<RobotState>,
        cmds: &[Twist],
        exempt: &Exemptions,
        secs: f64,
    ) -> Vec<RobotState> {
        let alone: BTreeSet<RobotId> = states.iter().map(|s| s.id).collect();
        let dt = 0.02;
        for _ in 0..(secs / dt) as usize {
            let mut out: BTreeMap<RobotId, Twist> =
                states.iter().zip(cmds).map(|(s, c)| (s.id, *c)).collect();
            separate(&cfg(), &states, &alone, exempt, &mut out);
            for s in &mut states {
                let c = out[&s.id];
                s.pose.x += c.v * s.pose.yaw.cos() * dt;
                s.pose.y += c.v * s.pose.yaw.sin() * dt;
                s.pose.yaw += c.omega * dt;
            }
        }
        states
    }

    fn dist(a: &RobotState, b: &RobotState) -> f64 {
        (a.pose.x - b.pose.x).hypot(a.pose.y - b.pose.y)
    }

    #[test]
    fn robots_driving_head_on_stop_short_of_each_other() {
        let s = vec![
            state(1, 0.0, 0.0, 0.0),
            state(2, 0.3, 0.0, std::f64::consts::PI),
        ];
        let go = Twist::new(0.1, 0.0);
        let end = run(s, &[go, go], &Exemptions::default(), 10.0);
        let d = dist(&end[0], &end[1]);
        assert!(d >= cfg().clearance - 1e-3, "came within {d:.4} m");
        assert!(
            d < cfg().clearance + 0.01,
            "stopped {d:.4} m apart: too early"
        );
    }

    #[test]
    fn a_robot_driving_into_a_standing_one_stops_and_one_driving_away_is_not_slowed() {
        let s = vec![state(1, 0.0, 0.0, 0.0), state(2, 0.2, 0.0, 0.0)];
        let end = run(
            s.clone(),
            &[Twist::new(0.1, 0.0), Twist::new(0.0, 0.0)],
            &Exemptions::default(),
            10.0,
        );
        assert!(dist(&end[0], &end[1]) >= cfg().clearance - 1e-3);
        // Robots just released side by side (closer than the clearance) drive apart freely.
        let s = vec![state(1, 0.0, 0.0, 0.0), state(2, -0.05, 0.0, 0.0)];
        let mut out = BTreeMap::from([(1, Twist::new(0.1, 0.0)), (2, Twist::new(0.0, 0.0))]);
        let alone = BTreeSet::from([1]);
        assert_eq!(
            separate(&cfg(), &s, &alone, &Exemptions::default(), &mut out),
            0
        );
        assert_eq!(out[&1].v, 0.1);
    }

    #[test]
    fn robots_holding_in_a_pullers_way_make_way_in_turn() {
        // A released line: robot 1 pulls forward, robots 2 and 3 hold in front of it,
        // touching; robot 4 holds beside the line, out of the way.
        let gap = 0.069;
        let mut states = vec![
            state(1, 0.0, 0.0, 0.0),
            state(2, gap, 0.0, std::f64::consts::PI),
            state(3, 2.0 * gap, 0.0, 0.0),
            state(4, gap, 0.2, 0.0),
        ];
        let alone = BTreeSet::from([1]);
        let holders = BTreeSet::from([2, 3, 4]);
        let dt = 0.02;
        let mut made_way = BTreeSet::new();
        for _ in 0..(6.0 / dt) as usize {
            let mut out: BTreeMap<RobotId, Twist> = states
                .iter()
                .map(|s| (s.id, Twist::new(0.0, 0.0)))
                .collect();
            out.insert(1, Twist::new(0.02, 0.0));
            let exempt = Exemptions::default();
            made_way.extend(separate_making_way(
                &cfg(),
                &states,
                &alone,
                &holders,
                &exempt,
                &mut out,
            ));
            for s in &mut states {
                let c = out[&s.id];
                s.pose.x += c.v * s.pose.yaw.cos() * dt;
                s.pose.y += c.v * s.pose.yaw.sin() * dt;
            }
        }
        assert_eq!(made_way, BTreeSet::from([2, 3]));
        assert!(
            states[0].pose.x > 0.04,
            "the puller stayed at {:.3} m",
            states[0].pose.x
        );
        assert_eq!(states[3].pose.x, gap, "the robot beside the line moved");
        // Nobody was pushed: each gap stayed at least what it was.
        assert!(dist(&states[0], &states[1]) >= gap - 1e-3);
        assert!(dist(&states[1], &states[2]) >= gap - 1e-3);
    }

    #[test]
    fn robots_of_one_assembly_or_docking_each_other_are_not_held_apart() {
        let s = vec![state(1, 0.0, 0.0, 0.0), state(2, 0.2, 0.0, 0.0)];
        let mut exempt = Exemptions {
            segment: BTreeMap::from([(1, 0), (2, 1)]),
            ..Exemptions::default()
        };
        exempt.allow(0, 1);
        let end = run(
            s,
            &[Twist::new(0.1, 0.0), Twist::new(0.0, 0.0)],
            &exempt,
            1.5,
        );
        assert!(
            dist(&end[0], &end[1]) < 0.06,
            "a docking robot was held off"
        );
    }
}
