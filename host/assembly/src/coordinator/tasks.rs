//! Every robot's task for one tick, per mode: formation (Algorithm 8 pairs, approaches,
//! docking), moving, decoupling, dispersing.

use super::*;

impl Coordinator {
    pub(super) fn align_role(&self, i: usize, me: RobotId) -> Role {
        let tp = &self.pairs[i];
        let p: &PlannedPair = &tp.pair;
        let g = &self.geometry;
        // Decoupled: bring the augmented head to the opening / hole (THESIS 5.2.3 stage 1);
        // afterwards the connection points themselves (stage 2, insertion).
        let a_point = if tp.status == PairStatus::Decoupled {
            p.point_a.head(g)
        } else {
            p.point_a.position(g)
        };
        let b_point = p.point_b.position(g);
        if me == p.a {
            Role::Align {
                pair: i,
                partner: p.b,
                own_point: a_point,
                partner_point: b_point,
                relative_yaw: p.relative_yaw,
                kind: p.kind,
                phase: tp.status,
            }
        } else {
            Role::Align {
                pair: i,
                partner: p.a,
                own_point: b_point,
                partner_point: a_point,
                relative_yaw: -p.relative_yaw,
                kind: p.kind,
                phase: tp.status,
            }
        }
    }

    pub(super) fn tasks(
        &self,
        t: f64,
        segments: &BTreeMap<RobotId, usize>,
    ) -> (Vec<RobotTask>, Vec<usize>) {
        let members = Self::members(segments);
        let mut roles: BTreeMap<RobotId, (Role, Option<RobotId>)> = BTreeMap::new();
        let mut active = Vec::new();
        // When the leader's role is a pose reference: a chain of anchors moves like a train
        // (every member keeps its connection to the neighbour towards the leader, so it
        // follows the leader's path within the anchors' yaw play; a rigid line cannot turn,
        // its rear would have to move sideways), a rigid segment (knob pairs) moves as one
        // body (every member tracks the reference composed with its offset in the shape).
        // Otherwise members follow the leader (THESIS 5.5.9, FollowLeader).
        let lead_segment = |roles: &mut BTreeMap<RobotId, (Role, Option<RobotId>)>,
                            seg: usize,
                            leader: RobotId,
                            role: Role| {
            let moving = matches!(
                role,
                Role::Track { .. } | Role::GoTo { use_yaw: true, .. } | Role::Align { .. }
            );
            // Moving: the leader's rigid part (knobs) moves as one body; a member hanging
            // at an anchor keeps that connection (a train: it follows its neighbour's path
            // within the anchor's play, and a bent row straightens behind it); a member
            // knob-locked to such a member follows that one rigidly.
            let (rigid, via) = if moving {
                self.links_towards(&members[&seg], leader)
            } else {
                (BTreeSet::new(), BTreeMap::new())
            };
            // A train (a chain of anchors, no knobs) moved by a velocity or trajectory
            // behaviour: the members behind the leader drive as trailers, so no follower
            // ends a turn ahead of its leader. Not in a mesh, whose members hanging at
            // anchors stand beside others (as trailers they push into them), and not while
            // forming, where a bent train straightens behind its head.
            let train = self
                .live_pairs(&members[&seg])
                .iter()
                .all(|&i| self.pairs[i].pair.kind == PairType::AnchorOpening);
            // A train in a velocity behaviour follows its leader's path ([`train`]).
            let paths = if train && moving && matches!(self.mode, Mode::Velocity { .. }) {
                self.train_references(&members[&seg], leader, t)
            } else {
                None
            };
            let hitched = match &role {
                Role::Track { reference }
                    if train && paths.is_none() && !matches!(self.mode, Mode::Form) =>
                {
                    self.hitch_commands(leader, reference, &via)
                }
                _ => BTreeMap::new(),
            };
            for &m in &members[&seg] {
                if m == leader {
                    roles.insert(m, (role.clone(), Some(leader)));
                    continue;
                }
                if let Some(reference) = paths.as_ref().and_then(|p| p.get(&m)) {
                    let own = Role::Track {
                        reference: reference.clone(),
                    };
                    roles.insert(m, (own, Some(leader)));
                    continue;
                }
                // A mesh in a velocity behaviour moves as one body: a member hanging at an
                // anchor tracks its place in the mesh as measured when the motion started,
                // like the knob-locked ones (aligning its pair after its neighbour, it lags
                // and swings until the anchor pops).
                let mesh_body = !train && matches!(self.mode, Mode::Velocity { .. });
                if moving && !rigid.contains(&m) && !mesh_body {
                    if let Some(&(i, next)) = via.get(&m) {
                        let own = if let Some(&[v, w]) = hitched.get(&m) {
                            Role::Hitch { pair: i, v, w }
                        } else if self.pairs[i].pair.kind == PairType::AnchorOpening {
                            self.align_role(i, m)
                        } else {
                            Role::Follow {
                                leader: next,
                                offset: self.follow_offset(m, next),
                            }
                        };
                        roles.insert(m, (own, Some(leader)));
                        continue;
                    }
                }
                let offset = self
                    .motion_offsets
                    .get(&m)
                    .copied()
                    .unwrap_or_else(|| self.follow_offset(m, leader));
                let own = match &role {
                    Role::Track { reference } => Role::Track {
                        reference: reference.iter().map(|p| p.compose(&offset)).collect(),
                    },
                    Role::GoTo {
                        goal,
                        use_yaw: true,
                    } => Role::GoTo {
                        goal: goal.compose(&offset),
                        use_yaw: true,
                    },
                    _ => Role::Follow { leader, offset },
                };
                roles.insert(m, (own, Some(leader)));
            }
        };
        match &self.mode {
            Mode::Hold => {}
            Mode::Form => {
                active = self.choose_active(segments);
                for &i in &active {
                    let p = self.pairs[i].pair;
                    // A knob is rigid once in: both sides stand still until it is confirmed.
                    if p.kind == PairType::KnobHole
                        && self.pairs[i].status == PairStatus::HeadInserted
                    {
                        for side in [p.a, p.b] {
                            for &m in &members[&segments[&side]] {
                                roles.insert(m, (Role::Hold, None));
                            }
                        }
                        continue;
                    }
                    if let Some(me) = self.docking_robot(i, segments) {
                        let other = if me == p.a { p.b } else { p.a };
                        let seg = segments[&other];
                        // Only while the docking robot is clear of the side: the row would
                        // slide its holes past the robot's knobs (a click at the wrong place).
                        let near = self
                            .dock_frame(i, me)
                            .is_none_or(|f| f.lat < self.cfg.dock.clearance);
                        // Growing, for at most `grow_straighten` per pair (a pilot in the
                        // assembly may keep it bent, and it would drive on and on).
                        let straighten_left = self.grow.is_none()
                            || self.robots.get(&other).is_some_and(|k| {
                                let mut from = self.straighten_from.borrow_mut();
                                let o = *from.entry(i).or_insert(k.pose.xy());
                                (k.pose.x - o[0]).hypot(k.pose.y - o[1])
                                    < self.cfg.dock.grow_straighten
                            });
                        if !near
                            && straighten_left
                            && self.chain_bend(&members[&seg]) > self.cfg.dock.max_bend
                        {
                            // A bent chain's corners block the approach lane: the assembly
                            // first drives straight, led by its robot at the end it drives
                            // towards (a train straightens behind its head; pushed from
                            // behind it jackknifes); the docking robot waits. It drives
                            // back when it stands ahead of where the formation started, so
                            // straightening does not carry it off towards whatever lies
                            // ahead.
                            let head = self.robots.get(&other).map(|k| k.pose).and_then(|po| {
                                let sense = if self.straighten_backwards(&members[&seg], po.yaw) {
                                    -1.0
                                } else {
                                    1.0
                                };
                                let (s, c) = po.yaw.sin_cos();
                                members[&seg]
                                    .iter()
                                    .filter_map(|id| self.robots.get(id).map(|k| (*id, k.pose)))
                                    .max_by(|a, b| {
                                        let f = |p: &Pose2| sense * (p.x * c + p.y * s);
                                        f(&a.1).total_cmp(&f(&b.1))
                                    })
                                    .map(|(id, k)| (id, k, sense))
                            });
                            if let Some((lead, k, sense)) = head {
                                let ahead = (0..=self.cfg.horizon_steps)
                                    .map(|j| {
                                        let x = 0.01 + j as f64 * self.cfg.dock.speed * self.cfg.dt;
                                        k.compose(&Pose2::new(sense * x, 0.0, 0.0))
                                    })
                                    .collect();
                                lead_segment(
                                    &mut roles,
                                    seg,
                                    lead,
                                    Role::Track { reference: ahead },
                                );
                            }
                            roles.insert(me, (Role::Hold, None));
                            continue;
                        }
                        if let Some(role) = self.dock_role(i, me) {
                            roles.insert(me, (role, Some(me)));
                            for &m in &members[&seg] {
                                roles.insert(m, (Role::Hold, None));
                            }
                            continue;
                        }
                    }
                    let home = self
                        .grow_home(segments)
                        .and_then(|seed| segments.get(&seed).copied());
                    if let Some(train) = self.lane_train_roles(i, segments) {
                        // The lane pilot's train drives straight up to the seed's assembly,
                        // which holds.
                        for &m in home.and_then(|h| members.get(&h)).into_iter().flatten() {
                            roles.insert(m, (Role::Hold, None));
                        }
                        for (m, role) in train {
                            roles.insert(m, (role, Some(m)));
                        }
                        continue;
                    }
                    // An assembly joined at its anchor by a lone non-pilot holds still, as a
                    // growing one does: the lone robot makes the staged anchor approach. Moved
                    // by the MPC, a coupled segment bends its joints and drags its members.
                    let lone_joins = self
                        .lone_approach(i, segments)
                        .is_some_and(|(_, partner)| members[&segments[&partner]].len() > 1);
                    for me in [p.a, p.b] {
                        let seg = segments[&me];
                        if home == Some(seg) || (lone_joins && members[&seg].len() > 1) {
                            // Growing (or joined by a lone robot): the assembly holds still
                            // while a robot joins it.
                            for &m in &members[&seg] {
                                roles.insert(m, (Role::Hold, None));
                            }
                            continue;
                        }
                        let alone_pilot = members[&seg]
                            .iter()
                            .all(|&m| self.kind_of(m) == RobotKind::Pilot);
                        if alone_pilot {
                            // THESIS 3.5.2: pilots are not driven until coupled.
                            for &m in &members[&seg] {
                                roles.insert(m, (Role::Wait, None));
                            }
                        } else {
                            let other = if me == p.a { p.b } else { p.a };
                            // The staged approach of a lone robot whose partner holds: the
                            // assembly being grown, or (`lone_approach`) any assembly or pilots.
                            let staged = (p.kind == PairType::AnchorOpening
                                && home == Some(segments[&other])
                                && members[&seg].len() == 1)
                                || self.lone_approach(i, segments) == Some((me, other));
                            let approach = (staged
                                && matches!(
                                    self.pairs[i].status,
                                    PairStatus::Decoupled | PairStatus::HeadAligned
                                ))
                            .then(|| self.anchor_approach_role(i, me))
                            .flatten();
                            let role = approach.unwrap_or_else(|| self.align_role(i, me));
                            lead_segment(&mut roles, seg, me, role);
                        }
                    }
                }
                // Unplanned couplings come apart first: the anchor robot wiggles forward
                // (THESIS 5.7), or the opening robot backwards when the anchor is a pilot's.
                for w in self.wigglers() {
                    let (v, om) = self.wiggle_command(&w, t);
                    roles.insert(w.robot, (Role::Velocity { v, w: om }, Some(w.robot)));
                    let held = segments.get(&w.partner).and_then(|s| members.get(s));
                    for &m in held.into_iter().flatten() {
                        if m != w.robot {
                            roles.insert(m, (Role::Hold, None));
                        }
                    }
                }
                // While the grown assembly is busy, the robot that joins it next stages.
                if let Some((i, me)) = self.next_to_stage(&active, segments) {
                    if let std::collections::btree_map::Entry::Vacant(e) = roles.entry(me) {
                        if let Some(role) = self.staging_role(i, me, &active, segments) {
                            e.insert((role, Some(me)));
                        }
                    }
                }
                // Robots with unfinished pairs that could not start wait.
                for (i, tp) in self.pairs.iter().enumerate() {
                    if tp.status != PairStatus::Connected && !self.released.contains(&i) {
                        for me in [tp.pair.a, tp.pair.b] {
                            roles.entry(me).or_insert((Role::Wait, None));
                        }
                    }
                }
            }
            Mode::Velocity { v, w } => {
                for (&seg, m) in &members {
                    let leader = self.motion_leader(m);
                    // The commanded (v, ω) integrated from where the leader was when the
                    // motion started: a reference that does not drift with tracking errors.
                    let to = self.feasible_twist(m, [*v, *w]);
                    let role = match self.motion_start.get(&leader) {
                        Some(m) => Role::Track {
                            reference: (0..=self.cfg.horizon_steps)
                                .map(|k| ramp_pose(m, to, t - m.t0 + k as f64 * self.cfg.dt))
                                .collect(),
                        },
                        None => Role::Velocity { v: *v, w: *w },
                    };
                    lead_segment(&mut roles, seg, leader, role);
                }
            }
            Mode::GoTo { goal } => {
                for (&seg, m) in &members {
                    let leader = self.motion_leader(m);
                    let target = self.leader_goal(leader, goal);
                    lead_segment(
                        &mut roles,
                        seg,
                        leader,
                        Role::GoTo {
                            goal: target,
                            use_yaw: true,
                        },
                    );
                }
            }
            Mode::Track { trajectory, start } => {
                for (&seg, m) in &members {
                    let leader = self.motion_leader(m);
                    let reference = (0..=self.cfg.horizon_steps)
                        .filter_map(|k| trajectory.sample(t - start + k as f64 * self.cfg.dt))
                        .map(|c| self.leader_goal(leader, &c))
                        .collect();
                    lead_segment(&mut roles, seg, leader, Role::Track { reference });
                }
            }
            Mode::Rendezvous {
                robots,
                gain,
                anti,
                until,
            } => {
                let part: Vec<(RobotId, Pose2)> = robots
                    .iter()
                    .filter_map(|id| {
                        self.robots
                            .get(id)
                            .filter(|_| !self.lost.contains(id))
                            .map(|k| (*id, k.pose))
                    })
                    .collect();
                let pos: Vec<[f64; 2]> = part.iter().map(|(_, p)| p.xy()).collect();
                let u = rendezvous(&pos, *gain, *anti);
                for (i, ((id, pose), u)) in part.iter().zip(u).enumerate() {
                    let nearest = pos
                        .iter()
                        .enumerate()
                        .filter(|(j, _)| *j != i)
                        .map(|(_, q)| (q[0] - pose.x).hypot(q[1] - pose.y))
                        .fold(f64::INFINITY, f64::min);
                    if *anti && until.is_some_and(|d| nearest >= d) {
                        roles.insert(*id, (Role::Hold, None));
                        continue;
                    }
                    let (v, w) = point_command(pose, u[0], u[1], self.cfg.heading_gain);
                    let (v, w) = if self.kind_of(*id) == RobotKind::Pilot {
                        (v, 0.0)
                    } else {
                        (v, w)
                    };
                    roles.insert(*id, (Role::Velocity { v, w }, Some(*id)));
                }
            }
            Mode::Decouple { .. } => {
                // The robot with the anchor wiggles (THESIS 4.3.2); its partner holds, or,
                // a pilot pulling its anchor out, drives straight ahead.
                for w in self.wigglers() {
                    let (v, om) = self.wiggle_command(&w, t);
                    roles.insert(w.robot, (Role::Velocity { v, w: om }, Some(w.robot)));
                    if let Some(p) = w.puller {
                        let v = self.pull_speed(&w);
                        roles.insert(p, (Role::Velocity { v, w: 0.0 }, Some(p)));
                    }
                    // A released pair drives apart from both ends: its partner backs away as
                    // the clearing robot pulls (in a line the robot ahead of the clearing one
                    // may stand still, and the pair would never get clear).
                    let partner_role = if w.clearing && w.puller.is_none() {
                        let v = -self.wiggle_command(&w, t).0;
                        Role::Velocity { v, w: 0.0 }
                    } else {
                        Role::Hold
                    };
                    roles.entry(w.partner).or_insert((partner_role, None));
                }
            }
            Mode::Disperse { goals, tolerance } => {
                for (id, goal) in goals {
                    // A non-pilot drives round the others (the MPC has no obstacle terms: two
                    // robots whose goals lie behind each other would push head-on) by the
                    // point law, which keeps its wheels above the dead-band to the goal; a
                    // pilot drives straight (THESIS 5.4.1). Both of two robots near each
                    // other go round: letting one of them wait instead finishes fewer
                    // dispersals.
                    let role = match self.robots.get(id) {
                        Some(k) if self.kind_of(*id) == RobotKind::NonPilot => {
                            let here = k.pose;
                            // Within half the tolerance: pose noise does not carry it
                            // back out of the step's tolerance.
                            if (goal.x - here.x).hypot(goal.y - here.y) <= 0.5 * tolerance {
                                Role::Hold
                            } else {
                                let to = self.disperse_step(*id, goal.xy()).unwrap_or(goal.xy());
                                let (v, w) = self.point_drive(&here, to);
                                Role::Drive { v, w }
                            }
                        }
                        _ => Role::GoTo {
                            goal: *goal,
                            use_yaw: false,
                        },
                    };
                    roles.insert(*id, (role, Some(*id)));
                }
            }
        }
        let tasks = segments
            .iter()
            .map(|(&id, &segment)| {
                let (role, leader) = roles.remove(&id).unwrap_or((Role::Hold, None));
                RobotTask {
                    robot: id,
                    role,
                    // A pilot alone moves straight only (THESIS 5.4.1: it turns imprecisely);
                    // coupled, it turns with its assembly within its own v–ω limits (THESIS
                    // 3.4, Fig. 3.13): held straight, it would fight the non-pilots steering
                    // the train until the anchor's yaw play runs out and it comes loose.
                    straight_only: self.kind_of(id) == RobotKind::Pilot
                        && members.get(&segment).is_none_or(|m| m.len() == 1),
                    leader,
                    segment,
                }
            })
            .collect();
        (tasks, active)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::coordinator::fixtures::*;

    #[test]
    fn spreading_out_a_robot_already_clear_of_the_others_stops_while_close_ones_go_on() {
        // THESIS (2.4) pushes every robot away from the centre, faster the further it is:
        // with `until_distance` a robot whose nearest neighbour is that far stops.
        let robots = vec![
            np(1, 0.0, 0.0, 0.0),
            np(2, 0.03, 0.0, 0.0),
            np(3, 0.5, 0.0, 0.0),
        ];
        for until in [Some(0.1), None] {
            let mut c = coordinator();
            c.set_mode(
                0.0,
                Mode::Rendezvous {
                    robots: vec![1, 2, 3],
                    gain: 0.5,
                    anti: true,
                    until,
                },
            );
            let tick = c.tick(0.0, &robots);
            for id in [1, 2] {
                assert!(
                    matches!(role_of(&tick, id), Role::Velocity { v, .. } if v.abs() > 1e-3),
                    "robot {id} moves away: {:?}",
                    role_of(&tick, id)
                );
            }
            match until {
                Some(_) => assert_eq!(role_of(&tick, 3), &Role::Hold),
                None => assert!(
                    matches!(role_of(&tick, 3), Role::Velocity { v, .. } if *v > 0.1),
                    "{:?}",
                    role_of(&tick, 3)
                ),
            }
        }
    }

    #[test]
    fn dispersing_robots_drive_round_each_other_with_commands_the_wheels_make() {
        // Robot 1's goal lies beyond robot 2 and robot 2's beyond robot 1 (the MPC has no
        // obstacle terms: straight at their goals they pushed head-on until the step timed
        // out); a robot with a free way heads straight for its goal; a robot whose goal lies
        // a few centimetres to its side turns on the spot at a rate its wheels make (the
        // MPC's point goal asked for less than the dead-band there, and it stood still short
        // of its goal), at the smallest radius its butterfly allows (it has no turn without
        // motion); a robot at its goal holds.
        let mut c = coordinator();
        let robots = vec![
            np(1, 0.0, 0.0, 0.0),
            np(2, 0.08, 0.0, std::f64::consts::PI),
            np(3, 0.0, 0.5, 0.0),
            np(4, 0.5, 0.0, 0.0),
            np(5, -0.5, 0.0, 0.0),
        ];
        let goals: BTreeMap<RobotId, Pose2> = [
            (1, Pose2::new(0.2, 0.0, 0.0)),
            (2, Pose2::new(-0.12, 0.0, 0.0)),
            (3, Pose2::new(0.2, 0.5, 0.0)),
            (4, Pose2::new(0.5, 0.04, 0.0)),
            (5, Pose2::new(-0.5, 0.005, 0.0)),
        ]
        .into();
        c.set_mode(
            0.0,
            Mode::Disperse {
                goals,
                tolerance: 0.02,
            },
        );
        let tick = c.tick(0.0, &robots);
        let drive = |id| match role_of(&tick, id) {
            Role::Drive { v, w } => (*v, *w),
            other => panic!("robot {id}: {other:?}"),
        };
        let d = DockConfig::default();
        let on_the_spot = |v: f64, w: f64| (v.abs() - w.abs() * c.cfg.turn_radius).abs() < 1e-12;
        for id in [1, 2] {
            let (v, w) = drive(id);
            assert!(
                w.abs() >= d.min_turn && on_the_spot(v, w),
                "robot {id} turns off the line between them first: {v}, {w}"
            );
        }
        let (v3, w3) = drive(3);
        assert!(v3 >= d.speed && w3.abs() < 1e-9, "{v3}, {w3}");
        let (v4, w4) = drive(4);
        assert!(on_the_spot(v4, w4) && w4 >= d.min_turn, "{v4}, {w4}");
        assert_eq!(role_of(&tick, 5), &Role::Hold);
    }
}
