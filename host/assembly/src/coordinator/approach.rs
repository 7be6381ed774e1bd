//! How a lone robot gets to its place: the staged approaches (side docking, anchor approach to
//! a partner that holds) and the lane train that brings a second pilot to a grown assembly.

use super::*;
use crate::assign::LANE_TOLERANCE;

/// Heading error (rad) at which the staged approach's turn on the spot at the stand-off is
/// done: the line follower going in steers out the rest.
pub(super) const APPROACH_TURN_DONE: f64 = 0.1;

/// A docking robot relative to its final pose (see [`Role::Dock`]).
pub(super) struct DockFrame {
    /// Final pose: the two connection points on each other.
    pub(super) fin: Pose2,
    /// The robot's position in the final pose's frame (m).
    pub(super) here: [f64; 2],
    /// Unit normal of its connection point, own frame (x, y).
    pub(super) normal: (f64, f64),
    /// Outward distance from the final line (the partner's side, extended) (m).
    pub(super) lat: f64,
}

/// Where a robot's direct-drive manoeuvre for a pair stands (kept between ticks, per pair).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Manoeuvre {
    /// Side docking: sweeping along the side in direction `dir` (±1), `passes` times over
    /// the place so far.
    Sweep {
        /// ±1.
        dir: f64,
        /// Reversals past the place without the knob clicking in.
        passes: u32,
        /// Direction of the first pass (±1): the robot came in from `−entry`.
        entry: f64,
    },
    /// Side docking: backing along the side, clear of it, to the start of the approach in
    /// direction `dir` (±1), to come in afresh (see [`DockConfig::max_passes`]).
    Retreat {
        /// ±1.
        dir: f64,
    },
    /// Anchor approach: at the stand-off, turning onto the axis.
    Turning,
    /// Anchor approach: driving along the axis (`dir` ±1: forwards / backwards), in or
    /// backing off; going in, the nearest it got (`best`, m out) and since when (s).
    In {
        /// ±1.
        dir: f64,
        /// Smallest distance out so far.
        best: f64,
        /// Time of the last progress.
        since: f64,
    },
}

impl Coordinator {
    /// Where docking robot `me` of side pair `i` is (see [`DockFrame`]).
    pub(super) fn dock_frame(&self, i: usize, me: RobotId) -> Option<DockFrame> {
        let p = &self.pairs.get(i)?.pair;
        let g = &self.geometry;
        let partner = if me == p.a { p.b } else { p.a };
        let (km, kp) = (self.robots.get(&me)?, self.robots.get(&partner)?);
        let (pa, pb) = (p.point_a.position(g), p.point_b.position(g));
        let (own, other, own_point, yaw) = if me == p.a {
            (pa, pb, p.point_a, kp.pose.yaw + p.relative_yaw)
        } else {
            (pb, pa, p.point_b, kp.pose.yaw - p.relative_yaw)
        };
        let target = kp.pose.transform(other);
        let (s, c) = yaw.sin_cos();
        let fin = Pose2::new(
            target[0] - (c * own[0] - s * own[1]),
            target[1] - (s * own[0] + c * own[1]),
            yaw,
        );
        let (ny, nx) = own_point.normal().sin_cos();
        let here = fin.inverse_transform(km.pose.xy());
        let lat = -(here[0] * nx + here[1] * ny);
        Some(DockFrame {
            fin,
            here,
            normal: (nx, ny),
            lat,
        })
    }

    /// The docking role of robot `me` for side pair `i` (see [`Role::Dock`]): its final pose
    /// puts the two connection points on each other; the approach line starts `run_in`
    /// behind (or ahead of, whichever is nearer) that pose and `offset` outside it.
    pub(super) fn dock_role(&self, i: usize, me: RobotId) -> Option<Role> {
        let DockFrame {
            fin,
            here,
            normal: (nx, ny),
            lat,
        } = self.dock_frame(i, me)?;
        let km = self.robots.get(&me)?;
        let yaw = fin.yaw;
        let d = self.cfg.dock;
        // Approach from behind unless clearly ahead (a margin against flipping at the end).
        let sigma = if here[0] <= d.run_in * 0.5 { 1.0 } else { -1.0 };
        // The distance still to go along the final line.
        let to_go = -sigma * here[0];
        let yaw_rel = wrap_angle(km.pose.yaw - yaw);
        let approach = to_go <= d.run_in + d.capture
            && lat <= d.offset + d.capture
            && lat >= -0.002
            && yaw_rel.abs() <= 0.3;
        if !approach {
            // Drive to the start of the approach, `run_in` behind (ahead of) the final place
            // and `offset` outside it (a point goal for the MPC: a unicycle cannot be parked
            // sideways; the approach law takes over anywhere near it).
            // The start of the approach from the nearer end, or from the other end when the
            // nearer one is blocked by a robot; reached round the other robots.
            let pre = |sg: f64| {
                fin.compose(&Pose2::new(
                    -sg * d.run_in - nx * d.offset,
                    -ny * d.offset,
                    0.0,
                ))
            };
            let others = self.others(me);
            let field = Field {
                obstacles: &others,
                clearance: self.room().route_clearance,
            };
            let field_gap = |p: &Pose2| field.nearest(p.xy());
            let mut goal = pre(sigma);
            if field_gap(&goal) < self.room().approach_gap
                && field_gap(&pre(-sigma)) > field_gap(&goal)
            {
                goal = pre(-sigma);
            }
            let dist = (goal.x - km.pose.x).hypot(goal.y - km.pose.y);
            if dist > d.capture {
                let Some(next) = self.route_step(me, goal.xy()) else {
                    return Some(Role::Hold);
                };
                return Some(self.drive_to(i, &km.pose, next));
            }
            // There: turn on the spot to the approach heading.
            let w = self.spot_turn_rate(-yaw_rel);
            let (v, w) = self.turn_in_place(&km.pose, goal.xy(), w);
            return Some(Role::Dock { pair: i, v, w });
        }
        // Converge on the partner's side with the heading proportional to the lateral
        // distance: at k_lat · half a body length < 1 the front corner never reaches the
        // side before the robot is flush, and the lateral distance decays over 1/k_lat of
        // travel; the knob clicks in once within 1 mm along, 1.5 mm across and 0.04 rad.
        // Never slower than the wheels' dead-band allows (fine steering needs both wheels
        // turning): the robot drives through the place, and back after `overshoot`, until
        // the knob clicks in.
        let (dir, retreat) = {
            let mut dirs = self.dock_dir.borrow_mut();
            let fresh = Manoeuvre::Sweep {
                dir: sigma,
                passes: 0,
                entry: sigma,
            };
            let state = dirs.entry(i).or_insert(fresh);
            let next = match *state {
                // Back at the start of the approach: in afresh, the partner's assembly
                // allowed to straighten again (it may have been pushed round meanwhile).
                Manoeuvre::Retreat { dir } if dir * here[0] >= d.run_in => {
                    self.straighten_from.borrow_mut().remove(&i);
                    Manoeuvre::Sweep {
                        dir: -dir,
                        passes: 0,
                        entry: -dir,
                    }
                }
                // Past the place: back over it, or back out the way it came once it has
                // passed over it `max_passes` times.
                Manoeuvre::Sweep { dir, passes, entry } if -dir * here[0] < -d.overshoot => {
                    if passes + 1 >= d.max_passes {
                        Manoeuvre::Retreat { dir: -entry }
                    } else {
                        Manoeuvre::Sweep {
                            dir: -dir,
                            passes: passes + 1,
                            entry,
                        }
                    }
                }
                Manoeuvre::Sweep { .. } | Manoeuvre::Retreat { .. } => *state,
                _ => fresh,
            };
            *state = next;
            match next {
                Manoeuvre::Retreat { dir } => (dir, true),
                Manoeuvre::Sweep { dir, .. } => (dir, false),
                _ => (sigma, false),
            }
        };
        let v = dir * d.speed;
        // The turning sense that moves the robot towards the partner in this direction.
        let toward = (dir * ny).signum();
        // Until the last `converge` before the place the robot keeps `hold` off
        // the side: converging all the way, it came within the seat gap where its knob
        // passes the wrong hole (25 mm before the place) and clicked in there.
        // Retreating, it steers out to the approach's offset: off the side, where the
        // partner's row may straighten ([`DockConfig::clearance`]) before it comes in again.
        let hold = if retreat {
            d.offset + d.press
        } else if -dir * here[0] > d.converge {
            d.hold
        } else {
            0.0
        };
        let target =
            toward * (d.k_lat * (lat + d.press - hold)).clamp(-d.max_heading, d.max_heading);
        let err = wrap_angle(yaw_rel - target);
        if hold > 0.0 && !retreat && err.abs() > d.turn_first {
            // Still turning (the turn onto the approach line carries on past its end):
            // driving now would close the hold at once (flush with the side at the wrong
            // hole). Only on the way in: sweeping over the place, turns on the spot at each
            // reversal would keep robots from clicking in.
            let w = self.spot_turn_rate(-err);
            return Some(Role::Dock { pair: i, v: 0.0, w });
        }
        Some(Role::Dock {
            pair: i,
            v,
            w: -d.k_theta * err,
        })
    }

    /// The stand-off pose of a staged anchor approach to the place `fin` (on its axis,
    /// facing its way), and its distance out ([`Coordinator::approach_standoff`]).
    pub(super) fn approach_standoff_pose(&self, fin: &Pose2, s: f64, me: RobotId) -> (Pose2, f64) {
        let standoff = self.approach_standoff(fin, s, me);
        (fin.compose(&Pose2::new(-s * standoff, 0.0, 0.0)), standoff)
    }

    /// The stand-off of a staged anchor approach to the place `fin` (m out along its axis,
    /// `s` the side of the robot's connection point): the nearest point from
    /// [`DockConfig::standoff`] out that is clear of every other robot by
    /// [`Room::route_clearance`](super::routing::Room) (beside an assembly the axis may run between robots). When the
    /// axis runs between robots, the line follower gets up to [`DockConfig::flush_run_in`] more to
    /// converge before the robot slides in beside them (askew, it would push them): as much
    /// of it as keeps the stand-off clear (the full run-in can put the stand-off beside a
    /// waiting robot, where the route refuses to go and the robot would hold for good).
    pub(super) fn approach_standoff(&self, fin: &Pose2, s: f64, me: RobotId) -> f64 {
        let d = self.cfg.dock;
        let others = self.others(me);
        let field = Field {
            obstacles: &others,
            clearance: self.room().route_clearance,
        };
        let clear = |sd: f64| {
            let p = fin.compose(&Pose2::new(-s * sd, 0.0, 0.0));
            field.nearest(p.xy()) >= self.room().route_clearance
        };
        let Some(sd) = (0..=12)
            .map(|k| d.standoff + d.standoff_step * k as f64)
            .find(|&sd| clear(sd))
        else {
            return d.standoff;
        };
        if sd <= d.standoff {
            return sd;
        }
        let steps = (d.flush_run_in / d.standoff_step).round() as usize;
        (0..=steps)
            .map(|k| sd + d.flush_run_in - d.standoff_step * k as f64)
            .find(|&e| clear(e))
            .unwrap_or(sd)
    }

    /// Anchor pair `i` between a waiting pilot and robot `me` (alone): stand off on the
    /// pilot's axis (a point goal), turn on the spot to its heading, then drive straight in
    /// along the axis, steering the lateral offset out (the line follower of
    /// [`Coordinator::dock_role`]). An MPC pose goal next to a robot that cannot move away
    /// pushes it, or turns the wrong end to it (the pilot's anchor in this robot's opening).
    pub(super) fn anchor_approach_role(&self, i: usize, me: RobotId) -> Option<Role> {
        let DockFrame {
            fin,
            here,
            normal: (nx, _),
            ..
        } = self.dock_frame(i, me)?;
        let km = self.robots.get(&me)?;
        let d = self.cfg.dock;
        // Own connection point at the front (nx = 1: drive forward in) or back (reverse in).
        let s = nx.signum();
        // Distance out along the axis, lateral offset, heading error.
        let out = -s * here[0];
        let lat = here[1];
        let yaw_rel = wrap_angle(km.pose.yaw - fin.yaw);
        // None: getting to the stand-off (see [`Manoeuvre`]).
        let mut phase = self.dock_dir.borrow_mut();
        // In: the line follower steers out twice the stand-off's tolerance (turning on the
        // spot drifts by about a centimetre).
        let on_axis = lat.abs() <= 2.0 * d.capture && out >= -0.002;
        let (pre, standoff) = self.approach_standoff_pose(&fin, s, me);
        let dist = (km.pose.x - pre.x).hypot(km.pose.y - pre.y);
        match phase.get(&i).copied() {
            None if dist > d.capture => {
                // Round every other robot (the MPC's point goal goes straight and would push
                // the partner), with a turn-then-drive point law (the MPC's point goal stalls
                // when the point is beside the robot: a unicycle local minimum).
                let Some(next) = self.route_step(me, pre.xy()) else {
                    return Some(Role::Hold);
                };
                return Some(self.drive_to(i, &km.pose, next));
            }
            None => {
                phase.insert(i, Manoeuvre::Turning);
                return Some(Role::Hold);
            }
            Some(Manoeuvre::Turning) if dist > 2.5 * d.capture => {
                phase.remove(&i);
                return Some(Role::Hold);
            }
            Some(Manoeuvre::Turning) if yaw_rel.abs() > APPROACH_TURN_DONE => {
                // Turn on the spot, never slower than the wheels' dead-band allows.
                let w = self.spot_turn_rate(-yaw_rel);
                let (v, w) = self.turn_in_place(&km.pose, pre.xy(), w);
                return Some(Role::Dock { pair: i, v, w });
            }
            Some(Manoeuvre::Turning) => {
                phase.insert(
                    i,
                    Manoeuvre::In {
                        dir: s,
                        best: out,
                        since: self.now,
                    },
                );
            }
            Some(Manoeuvre::In { .. } | Manoeuvre::Sweep { .. } | Manoeuvre::Retreat { .. })
                if !on_axis || yaw_rel.abs() > 0.35 =>
            {
                // Lost the axis: start over from the stand-off.
                phase.remove(&i);
                return Some(Role::Hold);
            }
            Some(Manoeuvre::In { .. } | Manoeuvre::Sweep { .. } | Manoeuvre::Retreat { .. }) => {}
        }
        // Going in (dir = s), or backing off (dir = −s) when the robot is about to touch
        // the partner still off the axis or askew (it would push it, not couple), until it
        // is back at the stand-off.
        let (mut dir, mut best, mut since) = match phase.get(&i) {
            Some(Manoeuvre::In { dir, best, since }) => (*dir, *best, *since),
            _ => (s, out, self.now),
        };
        if out < best - d.in_progress {
            (best, since) = (out, self.now);
        }
        // Only towards a lone partner: beside an assembly the robot slides along its side,
        // where a knob may click in on the way (it is right once the robot is in place),
        // and backing off would drag the assembly.
        let lone_partner = self.pairs.get(i).is_some_and(|tp| {
            let partner = if tp.pair.a == me {
                tp.pair.b
            } else {
                tp.pair.a
            };
            self.connected_pairs_of(partner).iter().all(|&k| k == i)
        });
        let askew = lone_partner
            && out < d.in_check
            && (lat.abs() > d.in_lateral || yaw_rel.abs() > d.in_yaw);
        // Stalled: pressing against the partner's edge instead of entering its opening.
        let stalled = self.now - since > d.in_stall_s;
        if dir == s && (askew || stalled) {
            dir = -s;
        } else if dir != s && out >= standoff {
            (dir, best, since) = (s, out, self.now);
        }
        phase.insert(i, Manoeuvre::In { dir, best, since });
        // Line follower along the axis: heading towards the axis in proportion to the
        // lateral offset (moving forward: θ = −k·lat; reversing: θ = +k·lat).
        // Beside other robots (the axis runs along an assembly's side) the robot keeps
        // `flush_offset` away from them until the last `flush_converge`: sliding flush, its
        // knobs would click into their holes at the wrong place.
        let partner = self.pairs.get(i).map(|tp| {
            if tp.pair.a == me {
                tp.pair.b
            } else {
                tp.pair.a
            }
        });
        // Measured from the robots themselves, not from the axis: the place is computed from
        // the partner, and a row a few hundredths of a radian off its neighbour's heading
        // stands millimetres nearer the axis at its far end (flush there, a knob would
        // click in beside the wrong robot).
        let width = f64::from(self.geometry.width);
        let (mut low, mut high) = (f64::NEG_INFINITY, f64::INFINITY);
        for o in self
            .robots
            .iter()
            .filter(|(id, _)| **id != me && Some(**id) != partner && !self.lost.contains(id))
            .map(|(_, k)| fin.inverse_transform(k.pose.xy()))
            .filter(|o| o[1].abs() < 0.08 && -s * o[0] > -0.05 && -s * o[0] < out + 0.05)
        {
            if o[1] < 0.0 {
                low = low.max(o[1] + width + d.flush_offset);
            } else {
                high = high.min(o[1] - width - d.flush_offset);
            }
        }
        let lat_goal = if out <= d.flush_converge {
            0.0
        } else if low > high {
            // Between robots on both sides: the middle.
            0.5 * (low + high)
        } else {
            0.0f64.max(low).min(high)
        };
        let target = (-dir * d.k_lat * (lat - lat_goal)).clamp(-d.max_heading, d.max_heading);
        let w = -d.k_theta * wrap_angle(yaw_rel - target);
        Some(Role::Dock {
            pair: i,
            v: dir * d.speed,
            w,
        })
    }

    /// Growing with a pilot in the seed's lane ([`Coordinator::lane_link`]): when pair `i`
    /// joins the train holding that pilot to the seed's assembly, both train members' direct
    /// commands. The train drives straight along the lane (the axis of its robot's final
    /// place) as tractor and trailer (below; the MPC's pair alignment took the pilot 20 mm
    /// off the lane), waits while a robot in the lane ahead makes way, and backs off along
    /// the lane and comes in again when it stalls against the seed's edge.
    pub(super) fn lane_train_roles(
        &self,
        i: usize,
        segments: &BTreeMap<RobotId, usize>,
    ) -> Option<Vec<(RobotId, Role)>> {
        let pilot = self.grow_lane?;
        let (me, _) = self.lane_train_pair(i, segments)?;
        let tp = self.pairs.get(i)?;
        let DockFrame {
            fin,
            here,
            normal: (nx, _),
            ..
        } = self.dock_frame(i, me)?;
        let d = self.cfg.dock;
        let s = nx.signum();
        let out = -s * here[0];
        // Someone stands in the lane ahead: the train waits while it makes way
        // ([`Coordinator::make_way`]; pushed into, it deflected the train off the lane).
        if self.approach_blocked(i, segments) {
            let hold = |m| {
                (
                    m,
                    Role::Dock {
                        pair: i,
                        v: 0.0,
                        w: 0.0,
                    },
                )
            };
            let mut held = vec![hold(me)];
            if pilot != me {
                held.push(hold(pilot));
            }
            return Some(held);
        }
        // The pilot alone (its link popped after the train had joined): it can only drive
        // straight back in along the lane, so only while it still stands on it. Leading the
        // train, it is not alone: the train backs off and comes in again (below).
        let alone = segments
            .values()
            .filter(|&s| segments.get(&me) == Some(s))
            .count()
            == 1;
        if me == pilot && alone {
            let k = self.robots.get(&pilot)?.pose;
            let lat = fin.inverse_transform(k.xy())[1];
            if lat.abs() > LANE_TOLERANCE.0 || wrap_angle(k.yaw - fin.yaw).abs() > LANE_TOLERANCE.1
            {
                return Some(vec![(
                    pilot,
                    Role::Dock {
                        pair: i,
                        v: 0.0,
                        w: 0.0,
                    },
                )]);
            }
        }
        let mut phase = self.dock_dir.borrow_mut();
        let (mut dir, mut best, mut since) = match phase.get(&i) {
            Some(Manoeuvre::In { dir, best, since }) => (*dir, *best, *since),
            _ => (s, out, self.now),
        };
        if out < best - d.in_progress {
            (best, since) = (out, self.now);
        }
        if dir == s && self.now - since > d.in_stall_s && tp.status != PairStatus::HeadInserted {
            dir = -s;
        } else if dir != s && out >= d.standoff {
            (dir, best, since) = (s, out, self.now);
        }
        phase.insert(i, Manoeuvre::In { dir, best, since });
        // A tractor and its trailer: the robot in front in the direction of travel leads,
        // following the lane with the line follower; the one hitched behind it at the
        // anchor (a pivot) drives straight a little slower, so the leader pulls it (THESIS
        // 5.4.1 drives a pilot by its linear velocity only). At equal speeds the trailer
        // pushes the leader round the pivot and the bend grows; each steering itself, or
        // both given the one turn rate, the train jackknifes; with the trailer slower the
        // bend stays within a few hundredths of a radian. A pilot leading turns no tighter
        // than its butterfly (3.5.1).
        let lead = if dir == s { me } else { pilot };
        let follow = if lead == me { pilot } else { me };
        let kl = self.robots.get(&lead)?.pose;
        let w_max = if lead == pilot {
            0.9 * d.speed / self.cfg.pilot_turn_radius
        } else {
            d.lane_turn
        };
        let lat = fin.inverse_transform(kl.xy())[1];
        let yaw_rel = wrap_angle(kl.yaw - fin.yaw);
        let target = (-dir * d.k_lat * lat).clamp(-d.max_heading, d.max_heading);
        let w_lead = (-d.k_theta * wrap_angle(yaw_rel - target)).clamp(-w_max, w_max);
        let v_lead = dir * d.speed;
        let mut roles = vec![(
            lead,
            Role::Dock {
                pair: i,
                v: v_lead,
                w: w_lead,
            },
        )];
        // The pilot alone (its link to the non-pilot popped later on): it drives straight
        // back along the lane by itself.
        if follow != lead {
            roles.push((
                follow,
                Role::Dock {
                    pair: i,
                    v: d.lane_trail * v_lead,
                    w: 0.0,
                },
            ));
        }
        Some(roles)
    }

    /// Pair `i` joins the train holding the lane pilot to the seed's assembly (growing with
    /// two pilots, [`Coordinator::lane_link`]): (the train's robot in the pair, its partner
    /// in the seed's assembly).
    pub(super) fn lane_train_pair(
        &self,
        i: usize,
        segments: &BTreeMap<RobotId, usize>,
    ) -> Option<(RobotId, RobotId)> {
        let pilot = self.grow_lane?;
        let home = segments.get(&self.grow_home(segments)?)?;
        let own = segments.get(&pilot)?;
        let tp = self.pairs.get(i)?;
        if own == home
            || tp.pair.kind != PairType::AnchorOpening
            || !matches!(
                tp.status,
                PairStatus::Decoupled | PairStatus::HeadAligned | PairStatus::HeadInserted
            )
        {
            return None;
        }
        let (me, other) = if segments.get(&tp.pair.a) == Some(own) {
            (tp.pair.a, tp.pair.b)
        } else {
            (tp.pair.b, tp.pair.a)
        };
        (segments.get(&me) == Some(own) && segments.get(&other) == Some(home))
            .then_some((me, other))
    }

    /// For a side pair with a lone non-pilot on one side: that robot (it docks; the other
    /// side holds still). The lone robot whose partner's assembly is larger goes first.
    pub(super) fn docking_robot(
        &self,
        i: usize,
        segments: &BTreeMap<RobotId, usize>,
    ) -> Option<RobotId> {
        let tp = self.pairs.get(i)?;
        if tp.pair.kind != PairType::KnobHole
            || !matches!(tp.status, PairStatus::Decoupled | PairStatus::HeadAligned)
        {
            return None;
        }
        let size = |id: RobotId| {
            let s = segments.get(&id);
            segments.values().filter(|&x| Some(x) == s).count()
        };
        [(tp.pair.a, tp.pair.b), (tp.pair.b, tp.pair.a)]
            .into_iter()
            .filter(|&(me, _)| size(me) == 1 && self.kind_of(me) == RobotKind::NonPilot)
            .max_by_key(|&(_, other)| size(other))
            .map(|(me, _)| me)
    }
}
