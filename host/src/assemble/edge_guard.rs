//! Keeping robots on their platform outside a cross step. The stability gate bounds how far
//! an assembly or a lone robot may advance straight along its heading; it does not see a robot
//! that turns (a non-pilot's turn on the spot is a pivot about a wheel, which moves its
//! centre), that docks with small back-and-forth corrections, or whose heading changes between
//! ticks, and its 4 mm margin is thin against `harsh` latency and capture noise: a pair driven
//! up to its limit and jostled there can fall in. Near a drop each of those can put a wheel
//! over the edge: a mesh formed a few body lengths from a gap can lose a docking robot into
//! it. So within a band around every drop, a group of coupled robots (or a lone robot) may
//! only drive straight away from the drop; any other command of the group is replaced by a
//! stop. Crossing a drop is the cross step's work, proven by the gate first
//! ([`super::cross_step`]).

use std::collections::{BTreeMap, BTreeSet};

use puzzlebot_assembly::RobotState;
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::messages::RobotId;

use crate::drive::Twist;

/// Spacing of the points at which the ground around a robot is probed (m): a drop narrower
/// than this can slip between them.
const PROBE_SPACING: f64 = 0.005;

/// The guard: the ground, and how far around a robot's centre its support may reach by the
/// time a command acts.
#[derive(Debug, Clone)]
pub struct EdgeGuard {
    terrain: Terrain,
    /// Half the body's diagonal plus the sideways shift of a pivot (half the wheel base)
    /// (m): the farthest a robot's wheels and casters lie from its centre, turning or not.
    body_reach: f64,
}

impl EdgeGuard {
    /// A guard over `terrain` for a fleet of `params`; `None` on the endless floor.
    pub fn new(terrain: &Terrain, params: &FleetParams) -> Option<Self> {
        if terrain.platforms.is_empty() {
            return None;
        }
        let reach = |kind: RobotKind| {
            let p = params.robot(kind);
            let g = &p.geometry;
            let half_diagonal = 0.5 * f64::from(g.length).hypot(f64::from(g.width));
            half_diagonal + 0.5 * f64::from(g.wheel_base)
        };
        let kinds = [RobotKind::Pilot, RobotKind::NonPilot];
        Some(EdgeGuard {
            terrain: terrain.clone(),
            body_reach: kinds.iter().map(|&k| reach(k)).fold(0.0, f64::max),
        })
    }

    /// The band around a drop (m) for a robot commanded at forward speed `v` (m/s), the
    /// command acting within `lookahead_s`: the body's reach plus the distance it drives
    /// meanwhile.
    pub fn band(&self, v: f64, lookahead_s: f64) -> f64 {
        self.body_reach + v.abs() * lookahead_s.max(0.0)
    }

    /// Distance (m) from `p` to the nearest probed point within `radius` whose ground is not
    /// the level under `p` (a drop, a step, a gap); `radius` when there is none.
    pub fn clearance(&self, p: [f64; 2], radius: f64) -> f64 {
        let Some((level, _)) = self.terrain.support_at(p) else {
            return 0.0;
        };
        let rings = (radius / PROBE_SPACING).ceil().max(1.0) as usize;
        for ring in 1..=rings {
            let r = radius * ring as f64 / rings as f64;
            let n = ((std::f64::consts::TAU * r / PROBE_SPACING).ceil() as usize).max(8);
            for k in 0..n {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                let q = [p[0] + r * a.cos(), p[1] + r * a.sin()];
                let same = self
                    .terrain
                    .support_at(q)
                    .is_some_and(|(h, _)| (h - level).abs() < 1e-9);
                if !same {
                    return r;
                }
            }
        }
        radius
    }

    /// Stop every group of `groups` (coupled robots, or one lone robot) with a member within
    /// the band of a drop, unless its command drives every such member straight away from
    /// it; commands act within `lookahead_s`. Returns the robots stopped.
    pub fn apply(
        &self,
        states: &[RobotState],
        groups: &BTreeMap<usize, Vec<RobotId>>,
        lookahead_s: f64,
        out: &mut BTreeMap<RobotId, Twist>,
    ) -> BTreeSet<RobotId> {
        let mut stopped = BTreeSet::new();
        for members in groups.values() {
            let moving = members
                .iter()
                .any(|id| out.get(id).is_some_and(|c| c.v != 0.0 || c.omega != 0.0));
            if !moving {
                continue;
            }
            // Every member's band from the fastest command of its group: a coupled group
            // moves together.
            let v = members
                .iter()
                .filter_map(|id| out.get(id))
                .map(|c| c.v.abs())
                .fold(0.0, f64::max);
            let band = self.band(v, lookahead_s);
            // The members near a drop, each with its clearance.
            let near: Vec<(&RobotState, f64)> = members
                .iter()
                .filter_map(|id| states.iter().find(|s| s.id == *id))
                .map(|s| (s, self.clearance(s.pose.xy(), band)))
                .filter(|&(_, clear)| clear < band)
                .collect();
            if near.is_empty() {
                continue;
            }
            // Away from the drop: straight (a turn may pivot the robot towards it), and
            // every member near it ends the look-ahead with more clearance than it has.
            let away = near.iter().all(|&(s, clear)| {
                let Some(c) = out.get(&s.id) else {
                    return true;
                };
                if c.omega != 0.0 {
                    return false;
                }
                let d = c.v * lookahead_s.max(1e-3);
                let (sn, cs) = s.pose.yaw.sin_cos();
                let to = [s.pose.x + d * cs, s.pose.y + d * sn];
                self.clearance(to, band) > clear
            });
            if away {
                continue;
            }
            for id in members {
                if out.contains_key(id) {
                    out.insert(*id, Twist::new(0.0, 0.0));
                    stopped.insert(*id);
                }
            }
        }
        stopped
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_assembly::Pose;

    fn at(id: RobotId, x: f64, y: f64, yaw: f64) -> RobotState {
        RobotState {
            id,
            kind: RobotKind::NonPilot,
            pose: Pose::new(x, y, yaw),
        }
    }

    #[test]
    fn near_a_gap_a_robot_may_only_back_away_and_far_from_it_anything_goes() {
        let params = FleetParams::default();
        // A 25 mm gap whose near edge is at x = 0.30 m.
        let terrain = Terrain::gap(0.30, 0.025, 1.0, 2.0, 0.0);
        let guard = EdgeGuard::new(&terrain, &params).unwrap();
        assert!(EdgeGuard::new(&Terrain::flat(), &params).is_none());
        let look = 0.2;
        let band = guard.band(0.05, look);
        assert!(band > 0.045 && band < 0.08, "{band}");
        let groups: BTreeMap<usize, Vec<RobotId>> = [(0, vec![1]), (1, vec![2])].into();
        // Robot 1 faces the gap 40 mm before it; robot 2 stands 0.5 m back.
        let states = [at(1, 0.26, 0.0, 0.0), at(2, -0.2, 0.0, 0.0)];
        let run = |c1: Twist, c2: Twist| {
            let mut out: BTreeMap<RobotId, Twist> = [(1, c1), (2, c2)].into();
            let stopped = guard.apply(&states, &groups, look, &mut out);
            (out, stopped)
        };
        let fwd = Twist::new(0.05, 0.0);
        let (out, stopped) = run(fwd, fwd);
        assert_eq!(stopped, [1].into(), "towards the gap");
        assert_eq!((out[&1].v, out[&1].omega), (0.0, 0.0));
        assert_eq!(out[&2].v, 0.05, "far from it");
        // Turning on the spot pivots it: stopped too. Backing straight away: allowed.
        assert_eq!(run(Twist::new(0.0, 1.0), fwd).1, [1].into());
        let (out, stopped) = run(Twist::new(-0.05, 0.0), Twist::new(0.0, 1.0));
        assert!(stopped.is_empty(), "{stopped:?}");
        assert_eq!((out[&1].v, out[&2].omega), (-0.05, 1.0));
        // A robot over the gap has no clearance at all.
        assert_eq!(guard.clearance([0.31, 0.0], band), 0.0);
        assert!((guard.clearance([0.26, 0.0], band) - 0.04).abs() <= PROBE_SPACING);
    }

    #[test]
    fn a_coupled_group_with_one_member_near_the_edge_stops_together() {
        let params = FleetParams::default();
        let terrain = Terrain::gap(0.30, 0.025, 1.0, 2.0, 0.0);
        let guard = EdgeGuard::new(&terrain, &params).unwrap();
        let groups: BTreeMap<usize, Vec<RobotId>> = [(0, vec![1, 2])].into();
        let states = [at(1, 0.27, 0.0, 0.0), at(2, 0.22, 0.0, 0.0)];
        let mut out: BTreeMap<RobotId, Twist> =
            [(1, Twist::new(0.0, 0.3)), (2, Twist::new(0.02, 0.0))].into();
        let stopped = guard.apply(&states, &groups, 0.2, &mut out);
        assert_eq!(stopped, [1, 2].into());
        assert!(out.values().all(|c| c.v == 0.0 && c.omega == 0.0));
    }
}
