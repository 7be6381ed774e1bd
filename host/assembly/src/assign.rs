//! Connection-pair assignment: THESIS Algorithm 1 (find existing pairs by a minimum spanning
//! tree over the distance graph and minimum-distance connection points), Algorithm 2 (align
//! the goal to the fleet's centre (3.9), convex-first ordering, Hungarian matching), 5.4.3.

use crate::geom::{wrap_angle, ConnPoint, PairType, Pose};
use crate::shape::{GoalPair, Shape, ShapeError, ShapeSpec};
use pathfinding::matrix::Matrix;
use puzzlebot_params::geometry::Geometry;
use puzzlebot_params::RobotKind;
use puzzlebot_protocol::messages::RobotId;
use serde::{Deserialize, Serialize};

mod existing_pairs;
#[cfg(test)]
mod props;
#[cfg(test)]
mod tests;

pub use existing_pairs::{closest_points, find_pairs, find_pairs_within};

/// A robot as the planner sees it: id, kind and measured pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobotState {
    /// Fleet id.
    pub id: RobotId,
    /// Pilot or non-pilot.
    pub kind: RobotKind,
    /// Measured pose (world frame).
    pub pose: Pose,
}

/// Distance bucket used for convex-first ordering (0.1 mm), so that numerically equal
/// distances compare equal.
pub fn distance_bucket(d: f64) -> i64 {
    (d * 1e4).round() as i64
}

/// Convex-first order (THESIS 3.3.3, 5.4.3): ascending distance between the slot centres,
/// so that line (front–back) pairs come before the side pairs that join rows into a mesh;
/// ties by type (anchor first) and slot index, for a deterministic queue.
pub fn sort_convex_first(pairs: &mut [GoalPair]) {
    pairs.sort_by_key(|p| {
        (
            distance_bucket(p.centre_distance),
            match p.kind {
                PairType::AnchorOpening => 0,
                PairType::KnobHole => 1,
            },
            p.a.min(p.b),
            p.a.max(p.b),
        )
    });
}

/// Shift goal poses so their centroid lies on the robots' centroid (THESIS (3.9):
/// p'_g = p_g − p̄_g + p̄); headings are kept.
pub fn align_center(goal: &[Pose], robots: &[Pose]) -> Vec<Pose> {
    if goal.is_empty() || robots.is_empty() {
        return goal.to_vec();
    }
    let [gx, gy] = mean_position(goal);
    let [rx, ry] = mean_position(robots);
    goal.iter()
        .map(|p| Pose::new(p.x - gx + rx, p.y - gy + ry, p.yaw))
        .collect()
}

/// Centroid of the poses' positions (m); the origin for an empty set.
pub fn mean_position(poses: &[Pose]) -> [f64; 2] {
    let n = poses.len().max(1) as f64;
    [
        poses.iter().map(|p| p.x).sum::<f64>() / n,
        poses.iter().map(|p| p.y).sum::<f64>() / n,
    ]
}

/// Circular mean of headings (rad); 0 for an empty or balanced set.
pub fn mean_heading(poses: &[Pose]) -> f64 {
    let (s, c) = poses
        .iter()
        .fold((0.0, 0.0), |(s, c), p| (s + p.yaw.sin(), c + p.yaw.cos()));
    if s.hypot(c) < 1e-9 {
        0.0
    } else {
        s.atan2(c)
    }
}

/// Cost of an infeasible slot–robot match (kind mismatch); large but overflow-safe for
/// thousands of slots.
const FORBIDDEN: i64 = 1_000_000_000_000_000;

/// Squared distance scaled to an integer cost (1e-9 m² resolution) for kuhn_munkres.
fn cost(d2: f64) -> i64 {
    (d2 * 1e9).round().min(1e14) as i64
}

/// Hungarian matching of goal slots to robots (THESIS Algorithm 2 line 6, d_ij = ‖p'_gi − p_j‖²),
/// with the `pathfinding` crate's `kuhn_munkres_min`. Returns, for each slot, the index of the
/// robot in `robots`, and the total squared distance. Slots with a kind accept only matching
/// robots.
pub fn hungarian(
    goal: &[Pose],
    kinds: &[crate::shape::SlotKind],
    robots: &[RobotState],
) -> Result<(Vec<usize>, f64), PlanError> {
    if goal.len() > robots.len() {
        return Err(PlanError::NotEnoughRobots {
            needed: goal.len(),
            available: robots.len(),
        });
    }
    if goal.is_empty() {
        return Ok((Vec::new(), 0.0));
    }
    let mut data = Vec::with_capacity(goal.len() * robots.len());
    for (i, gp) in goal.iter().enumerate() {
        for r in robots {
            let d2 = (gp.x - r.pose.x).powi(2) + (gp.y - r.pose.y).powi(2);
            let ok = kinds.get(i).is_none_or(|k| k.accepts(r.kind));
            data.push(if ok { cost(d2) } else { FORBIDDEN });
        }
    }
    let m = Matrix::from_vec(goal.len(), robots.len(), data).expect("sizes match");
    let (_, assignment) = pathfinding::kuhn_munkres::kuhn_munkres_min(&m);
    let mut total = 0.0;
    for (i, &r) in assignment.iter().enumerate() {
        if !kinds.get(i).is_none_or(|k| k.accepts(robots[r].kind)) {
            return Err(PlanError::KindsUnsatisfiable);
        }
        total += (goal[i].x - robots[r].pose.x).powi(2) + (goal[i].y - robots[r].pose.y).powi(2);
    }
    Ok((assignment, total))
}

/// A planned connection pair between two robots (a goal pair mapped onto robots).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PlannedPair {
    /// Position in the convex-first queue (0 first).
    pub order: usize,
    /// Robot carrying the anchor (back) or knob (left side): THESIS `anchor_index`.
    pub a: RobotId,
    /// Its connection point.
    pub point_a: ConnPoint,
    /// Robot with the opening or hole (THESIS `body_index`).
    pub b: RobotId,
    /// Its connection point.
    pub point_b: ConnPoint,
    /// Anchor–opening or knob–hole.
    pub kind: PairType,
    /// Goal slot of `a`.
    pub slot_a: usize,
    /// Goal slot of `b`.
    pub slot_b: usize,
    /// Target yaw of `a` minus yaw of `b` when coupled (rad).
    pub relative_yaw: f64,
    /// Distance between the goal slot centres (m), the convex-first key.
    pub centre_distance: f64,
}

impl PlannedPair {
    /// Identity of a pair independent of its place in a plan.
    pub fn key(&self) -> (RobotId, ConnPoint, RobotId, ConnPoint) {
        (self.a, self.point_a, self.b, self.point_b)
    }

    /// True when `robot` is one of the two robots.
    pub fn involves(&self, robot: RobotId) -> bool {
        self.a == robot || self.b == robot
    }
}

/// Result of THESIS Algorithm 2 for one shape and fleet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// How the shape was built (kept for re-planning).
    pub spec: ShapeSpec,
    /// The shape (slots centred on their centroid).
    pub shape: Shape,
    /// Heading the shape was placed with (rad).
    pub heading: f64,
    /// World goal pose of each slot (after (3.9) and the heading).
    pub goal_poses: Vec<Pose>,
    /// Robot filling each slot.
    pub slot_robot: Vec<RobotId>,
    /// Pairs in convex-first order.
    pub pairs: Vec<PlannedPair>,
    /// Sum of squared distances of the matching (m²).
    pub matching_cost: f64,
    /// Pairs between two pilots: they can only couple once one pilot is part of an assembly
    /// with a non-pilot (THESIS 3.5.2).
    pub pilot_pilot_pairs: Vec<usize>,
}

impl Plan {
    /// Slot of `robot`, if it is in the plan.
    pub fn slot_of(&self, robot: RobotId) -> Option<usize> {
        self.slot_robot.iter().position(|&r| r == robot)
    }

    /// World goal pose of `robot`, if it is in the plan.
    pub fn goal_of(&self, robot: RobotId) -> Option<Pose> {
        self.slot_of(robot).map(|s| self.goal_poses[s])
    }
}

/// Why a plan could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// Fewer robots than slots.
    #[error("the shape needs {needed} robots, {available} available")]
    NotEnoughRobots {
        /// Slots.
        needed: usize,
        /// Robots.
        available: usize,
    },
    /// Slot kinds (pilot / non-pilot) cannot be met by this fleet.
    #[error("the fleet's pilot / non-pilot mix cannot fill the shape's slot kinds")]
    KindsUnsatisfiable,
    /// The shape could not be built.
    #[error(transparent)]
    Shape(#[from] ShapeError),
    /// A robot pose is not finite.
    #[error("robot {0}: pose is not finite")]
    BadPose(RobotId),
    /// Two robots share an id.
    #[error("robot id {0} appears twice")]
    DuplicateRobot(RobotId),
    /// More than two pilots for a grown shape, or a seed other than the front pilot: lone
    /// pilots are not driven (THESIS 3.5.2) and a second one is brought in by a train driving
    /// straight along its lane; turning one is out (a pilot turns no tighter than its
    /// butterfly allows).
    #[error("{pilots} pilots: a shape grown around one robot takes in the seed pilot and at most one more, set down in its lane, the seed being the front one (lone pilots are not driven, THESIS 3.5.2; any other would have to be turned by a train, and a pilot turns no tighter than {radius:.2} m, THESIS 3.5.1 — no such manoeuvre is implemented)")]
    GrowPilots {
        /// Pilots in the fleet (at least 2: a seed other than the pilot counts as one more).
        pilots: usize,
        /// The pilot's smallest turning radius (m).
        radius: f64,
    },
    /// Two pilots that do not stand in one lane (THESIS 5.4.1: pilots move straight only).
    #[error("pilots {seed} and {pilot} do not stand in one lane: pilot {pilot} is {lateral:.3} m off pilot {seed}'s axis and turned {yaw:.2} rad from it (at most {max_lateral} m and {max_yaw} rad; pilots drive straight only, THESIS 5.4.1: set the second one down behind the first, facing the same way)")]
    PilotsNotInLane {
        /// The front pilot (the seed).
        seed: RobotId,
        /// The other one.
        pilot: RobotId,
        /// Its distance from the seed's axis (m).
        lateral: f64,
        /// Its heading relative to the seed's (rad).
        yaw: f64,
        /// [`LANE_TOLERANCE`].0.
        max_lateral: f64,
        /// [`LANE_TOLERANCE`].1.
        max_yaw: f64,
    },
    /// No placement of the shape on the seed puts the lane pilot's slot ahead of it on its
    /// axis with a non-pilot slot linking the two.
    #[error("the shape has no placement on pilot {seed} with a slot ahead of pilot {pilot} on its axis, linked to pilot {seed}'s through one non-pilot's anchor pairs")]
    NoLanePlace {
        /// The seed pilot.
        seed: RobotId,
        /// The lane pilot.
        pilot: RobotId,
    },
    /// The robot to grow the shape around is not in the fleet.
    #[error("seed robot {0} is not in the fleet")]
    UnknownSeed(RobotId),
}

/// THESIS Algorithm 2 (AssignConnectionPairs): build the shape for the fleet, place it on the
/// fleet's centre (3.9) with `heading` (default: the circular mean of the robots' headings),
/// find its pairs (Algorithm 1), sort them convex-first, match robots to slots (Hungarian) and
/// map the pairs onto robots. All robots in `robots` take part.
pub fn assign_connection_pairs(
    spec: &ShapeSpec,
    robots: &[RobotState],
    heading: Option<f64>,
    g: &Geometry,
) -> Result<Plan, PlanError> {
    check_robots(robots)?;
    let shape = spec.build(robots.len(), g)?;
    let poses: Vec<Pose> = robots.iter().map(|r| r.pose).collect();
    let heading = heading.unwrap_or_else(|| mean_heading(&poses));
    let oriented = shape.placed([0.0, 0.0], heading);
    let goal = align_center(&oriented, &poses);
    let kinds: Vec<_> = shape.slots.iter().map(|s| s.kind).collect();
    let (assign, total) = hungarian(&goal, &kinds, robots)?;
    Ok(plan_from(
        spec, shape, heading, goal, &assign, total, robots, g,
    ))
}

/// Algorithm 2 with the shape grown around robot `seed`, which stays where it is: for every
/// slot the seed may fill, the shape is placed with that slot on the seed's pose and the
/// other robots are matched to the other slots (Hungarian); the cheapest placement wins.
/// Every other robot then joins the seed's assembly alone (a lone pilot is not driven,
/// THESIS 3.5.2, so a pilot seed is the one robot that need not move).
pub fn assign_around(
    spec: &ShapeSpec,
    robots: &[RobotState],
    seed: RobotId,
    g: &Geometry,
) -> Result<Plan, PlanError> {
    assign_around_lane(spec, robots, seed, None, g)
}

/// How far a second pilot may stand off the seed pilot's axis (m) and how far its heading may
/// differ (rad) for [`assign_around_lane`]: it is brought in by a train that drives straight
/// along its axis (a pilot turns no tighter than 0.61 m, THESIS 3.5.1).
pub const LANE_TOLERANCE: (f64, f64) = (0.012, 0.06);

/// [`assign_around`] with a second pilot `lane` set down in the seed's lane (on its axis,
/// facing the same way, behind it): its slot must lie ahead of it on its own axis and behind
/// the seed's, with one non-pilot slot linking it to the seed's slot by anchor pairs (that
/// robot couples to the waiting pilot, then the two drive straight up to the seed; THESIS
/// 5.4.1: pilots move straight, back and forth).
pub fn assign_around_lane(
    spec: &ShapeSpec,
    robots: &[RobotState],
    seed: RobotId,
    lane: Option<RobotId>,
    g: &Geometry,
) -> Result<Plan, PlanError> {
    check_robots(robots)?;
    let si = robots
        .iter()
        .position(|r| r.id == seed)
        .ok_or(PlanError::UnknownSeed(seed))?;
    let shape = spec.build(robots.len(), g)?;
    let kinds: Vec<_> = shape.slots.iter().map(|s| s.kind).collect();
    let sp = robots[si].pose;
    let li = match lane {
        Some(id) => Some(
            robots
                .iter()
                .position(|r| r.id == id)
                .ok_or(PlanError::UnknownSeed(id))?,
        ),
        None => None,
    };
    let pairs = shape.pairs(g);
    let anchored = |a: usize, b: usize| {
        pairs.iter().any(|p| {
            p.kind == PairType::AnchorOpening && ((p.a, p.b) == (a, b) || (p.a, p.b) == (b, a))
        })
    };
    let mut best: Option<(f64, Vec<Pose>, Vec<usize>, f64)> = None;
    for (slot, spose) in shape.slots.iter().enumerate() {
        if !kinds[slot].accepts(robots[si].kind) {
            continue;
        }
        // Shape frame F with F ∘ slot = seed pose.
        let frame = sp.compose(&spose.pose.inverse());
        let goal: Vec<Pose> = shape.slots.iter().map(|x| frame.compose(&x.pose)).collect();
        // The lane pilot's slots: ahead of it on its axis, linked to the seed's slot through
        // one slot by anchor pairs.
        let lane_slots: Vec<Option<usize>> = match li {
            None => vec![None],
            Some(l) => {
                let lp = robots[l].pose;
                (0..goal.len())
                    .filter(|&k| k != slot && kinds[k].accepts(robots[l].kind))
                    .filter(|&k| {
                        // Ahead of it, behind the seed's place: the train drives up to the
                        // seed, not past it.
                        let d = lp.inverse_transform(goal[k].xy());
                        let seed_d = lp.inverse_transform(goal[slot].xy());
                        d[0] > -0.005
                            && d[0] < seed_d[0]
                            && d[1].abs() <= LANE_TOLERANCE.0
                            && wrap_angle(goal[k].yaw - lp.yaw).abs() <= LANE_TOLERANCE.1
                    })
                    .filter(|&k| {
                        (0..goal.len()).any(|m| {
                            m != k
                                && m != slot
                                && kinds[m].accepts(RobotKind::NonPilot)
                                && anchored(m, k)
                                && anchored(m, slot)
                        })
                    })
                    .map(Some)
                    .collect()
            }
        };
        for lane_slot in lane_slots {
            let fixed: Vec<(usize, usize)> = std::iter::once((slot, si))
                .chain(lane_slot.zip(li))
                .collect();
            let rest: Vec<usize> = (0..goal.len())
                .filter(|&k| fixed.iter().all(|f| f.0 != k))
                .collect();
            let free: Vec<usize> = (0..robots.len())
                .filter(|&r| fixed.iter().all(|f| f.1 != r))
                .collect();
            let free_robots: Vec<RobotState> = free.iter().map(|&r| robots[r]).collect();
            let rest_goal: Vec<Pose> = rest.iter().map(|&k| goal[k]).collect();
            let rest_kinds: Vec<_> = rest.iter().map(|&k| kinds[k]).collect();
            let Ok((sub, total)) = hungarian(&rest_goal, &rest_kinds, &free_robots) else {
                continue;
            };
            if best.as_ref().is_some_and(|b| b.0 <= total) {
                continue;
            }
            let mut assign = vec![si; goal.len()];
            for &(k, r) in &fixed {
                assign[k] = r;
            }
            for (n, &k) in rest.iter().enumerate() {
                assign[k] = free[sub[n]];
            }
            best = Some((total, goal.clone(), assign, frame.yaw));
        }
    }
    let (total, goal, assign, heading) = best.ok_or(match lane {
        Some(l) => PlanError::NoLanePlace { seed, pilot: l },
        None => PlanError::KindsUnsatisfiable,
    })?;
    Ok(plan_from(
        spec, shape, heading, goal, &assign, total, robots, g,
    ))
}

fn check_robots(robots: &[RobotState]) -> Result<(), PlanError> {
    let mut seen = std::collections::HashSet::new();
    for r in robots {
        if !r.pose.is_finite() {
            return Err(PlanError::BadPose(r.id));
        }
        if !seen.insert(r.id) {
            return Err(PlanError::DuplicateRobot(r.id));
        }
    }
    Ok(())
}

/// The plan for `shape` placed at `goal`, slot `k` filled by `robots[assign[k]]`.
#[allow(clippy::too_many_arguments)]
fn plan_from(
    spec: &ShapeSpec,
    shape: crate::shape::Shape,
    heading: f64,
    goal: Vec<Pose>,
    assign: &[usize],
    total: f64,
    robots: &[RobotState],
    g: &Geometry,
) -> Plan {
    let slot_robot: Vec<RobotId> = assign.iter().map(|&r| robots[r].id).collect();
    let kind_of = |slot: usize| robots[assign[slot]].kind;
    let goal_pairs = shape.pairs(g);
    let mut pairs = Vec::with_capacity(goal_pairs.len());
    let mut pilot_pilot = Vec::new();
    for (order, gp) in goal_pairs.iter().enumerate() {
        if kind_of(gp.a) == RobotKind::Pilot && kind_of(gp.b) == RobotKind::Pilot {
            pilot_pilot.push(order);
        }
        pairs.push(PlannedPair {
            order,
            a: slot_robot[gp.a],
            point_a: gp.point_a,
            b: slot_robot[gp.b],
            point_b: gp.point_b,
            kind: gp.kind,
            slot_a: gp.a,
            slot_b: gp.b,
            relative_yaw: wrap_angle(shape.slots[gp.a].pose.yaw - shape.slots[gp.b].pose.yaw),
            centre_distance: gp.centre_distance,
        });
    }
    Plan {
        spec: spec.clone(),
        shape,
        heading,
        goal_poses: goal,
        slot_robot,
        pairs,
        matching_cost: total,
        pilot_pilot_pairs: pilot_pilot,
    }
}
