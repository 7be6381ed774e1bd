//! Running a scenario: its steps one after the other on the coordinator, re-coupling pairs
//! that came apart, and the run state.

use super::*;

/// Where a running scenario stands.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RunState {
    /// Executing step `index`.
    Running {
        /// Current step.
        index: usize,
    },
    /// All steps done.
    Finished,
    /// A step failed; robots hold.
    Failed {
        /// Failed step.
        index: usize,
        /// Why.
        reason: String,
    },
}

/// Executes a [`Scenario`] on a [`Coordinator`]: call [`ScenarioRunner::tick`] every control
/// period with the measured robots; it starts each step, checks its completion and returns
/// the coordinator's tasks.
#[derive(Debug, Clone)]
pub struct ScenarioRunner {
    scenario: Scenario,
    coordinator: Coordinator,
    state: RunState,
    step_start: Option<f64>,
    /// A move interrupted by a pair that came apart, while that pair is coupled again.
    recoupling: Option<Recoupling>,
    /// Re-couplings so far, per step index.
    recouples: BTreeMap<usize, u32>,
    /// The host's result of the current cross step, once it has one.
    crossing: Option<Result<(), String>>,
}

/// Times a move step re-couples a pair that came apart before it fails.
pub const MAX_RECOUPLES: u32 = 2;
/// Time a re-coupling may take (s) before the move step fails.
pub const RECOUPLE_TIMEOUT_S: f64 = 30.0;

/// A move step waiting for a pair that came apart to be coupled again.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Recoupling {
    /// The pair's robots.
    pair: (RobotId, RobotId),
    /// When it came apart (s).
    since: f64,
    /// How long the step had run by then (s).
    elapsed: f64,
}

impl ScenarioRunner {
    /// A runner for `scenario`.
    pub fn new(scenario: Scenario, coordinator: Coordinator) -> Self {
        ScenarioRunner {
            scenario,
            coordinator,
            state: RunState::Running { index: 0 },
            step_start: None,
            recoupling: None,
            recouples: BTreeMap::new(),
            crossing: None,
        }
    }

    /// The terrain file of the cross step running now, while the host has not reported its
    /// result ([`ScenarioRunner::finish_crossing`]).
    pub fn crossing_due(&self) -> Option<&std::path::Path> {
        let RunState::Running { index } = self.state else {
            return None;
        };
        match &self.scenario.steps.get(index)?.behaviour {
            Behaviour::Cross { terrain }
                if self.step_start.is_some() && self.crossing.is_none() =>
            {
                Some(terrain)
            }
            _ => None,
        }
    }

    /// The host's result of the running cross step: across (`Ok`), or why not; the step
    /// finishes or fails on the next tick.
    pub fn finish_crossing(&mut self, result: Result<(), String>) {
        if self.crossing_due().is_some() {
            self.crossing = Some(result);
        }
    }

    /// The coordinator (plan, pairs, events).
    pub fn coordinator(&self) -> &Coordinator {
        &self.coordinator
    }

    /// Mutable coordinator (e.g. to mark a robot lost).
    pub fn coordinator_mut(&mut self) -> &mut Coordinator {
        &mut self.coordinator
    }

    /// Where the run stands.
    pub fn state(&self) -> &RunState {
        &self.state
    }

    /// The scenario.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// A connected pair that this tick saw come apart during a move of the assembly.
    fn came_apart_while_moving(step: &Step, tick: &Tick) -> Option<(RobotId, RobotId)> {
        if !matches!(
            step.behaviour,
            Behaviour::Velocity { .. } | Behaviour::GoTo { .. } | Behaviour::Trajectory { .. }
        ) {
            return None;
        }
        tick.events.iter().find_map(|e| match e.kind {
            EventKind::PairStatus {
                a,
                b,
                from: PairStatus::Connected,
                to: PairStatus::Decoupled,
                ..
            } => Some((a, b)),
            _ => None,
        })
    }

    fn fail(&mut self, t: f64, index: usize, reason: String) {
        self.coordinator.set_mode(t, Mode::Hold);
        self.coordinator.record(
            t,
            EventKind::StepFailed {
                index,
                reason: reason.clone(),
            },
        );
        self.state = RunState::Failed { index, reason };
    }

    fn start(&mut self, t: f64, index: usize, robots: &[RobotState]) -> Result<(), String> {
        let label = self.scenario.steps[index].label.clone();
        self.coordinator
            .record(t, EventKind::StepStarted { index, label });
        self.begin(t, index, robots, 0.0)
    }

    /// Set the coordinator going on step `index`, `elapsed` s into it (a trajectory goes on
    /// from there; other behaviours start from where the robots are).
    fn begin(
        &mut self,
        t: f64,
        index: usize,
        robots: &[RobotState],
        elapsed: f64,
    ) -> Result<(), String> {
        let step = self.scenario.steps[index].clone();
        let c = &mut self.coordinator;
        match step.behaviour {
            Behaviour::Form {
                spec,
                heading,
                grow: None,
            } => {
                c.form(t, spec, robots, heading)
                    .map_err(|e| e.to_string())?;
            }
            Behaviour::Form {
                spec,
                grow: Some(g),
                ..
            } => {
                c.form_grown(t, spec, robots, g.seed)
                    .map_err(|e| e.to_string())?;
            }
            Behaviour::Hold { .. } => c.set_mode(t, Mode::Hold),
            Behaviour::Cross { .. } => {
                self.crossing = None;
                c.set_mode(t, Mode::Hold)
            }
            Behaviour::Velocity { v, w, .. } => c.set_mode(t, Mode::Velocity { v, w }),
            Behaviour::GoTo { goal, .. } => {
                let heading = c.plan().map_or(0.0, |p| p.heading);
                let goal = Pose::new(
                    goal.x,
                    goal.y,
                    if goal.yaw.is_finite() {
                        goal.yaw
                    } else {
                        heading
                    },
                );
                c.set_mode(t, Mode::GoTo { goal })
            }
            Behaviour::Trajectory { trajectory } => c.set_mode(
                t,
                Mode::Track {
                    trajectory,
                    start: t - elapsed,
                },
            ),
            Behaviour::Rendezvous {
                robots: ids,
                gain,
                anti,
                until_distance,
                ..
            } => {
                let ids = ids.unwrap_or_else(|| c.robot_ids());
                c.set_mode(
                    t,
                    Mode::Rendezvous {
                        robots: ids,
                        gain,
                        anti,
                        until: until_distance,
                    },
                )
            }
            Behaviour::Decouple {
                robots: ids,
                wiggle,
            } => {
                let pairs = match ids {
                    None => c.coupled_pairs(),
                    Some(ids) => {
                        let mut p: Vec<usize> = ids
                            .iter()
                            .flat_map(|&id| c.connected_pairs_of(id))
                            .collect();
                        p.sort_unstable();
                        p.dedup();
                        p
                    }
                };
                c.set_mode(
                    t,
                    Mode::Decouple {
                        pairs,
                        wiggle,
                        start: t,
                    },
                )
            }
            Behaviour::Disperse { goals, tolerance } => {
                // Lost robots get no goal; one never seen is an error in the scenario.
                let mut resolved = BTreeMap::new();
                let pose_of = |id: RobotId| {
                    let seen = robots.iter().find(|r| r.id == id).map(|r| r.pose);
                    seen.or_else(|| c.pose(id))
                };
                let known: Vec<Pose> = goals
                    .keys()
                    .filter(|id| !c.lost().contains(id))
                    .filter_map(|&id| pose_of(id))
                    .collect();
                let centre = crate::assign::mean_position(&known);
                for (&id, g) in &goals {
                    match pose_of(id) {
                        _ if c.lost().contains(&id) => {}
                        Some(p) => {
                            let kind = robots
                                .iter()
                                .find(|r| r.id == id)
                                .map_or_else(|| c.kind_of(id), |r| r.kind);
                            let straight = kind == RobotKind::Pilot;
                            resolved.insert(id, g.resolve(&p, centre, straight));
                        }
                        None => {
                            return Err(format!(
                                "step '{}' (line {}): disperse goal for robot {id}, which is \
                                 not in the fleet",
                                step.label, step.line
                            ))
                        }
                    }
                }
                c.set_mode(
                    t,
                    Mode::Disperse {
                        goals: resolved,
                        tolerance,
                    },
                )
            }
        }
        Ok(())
    }

    fn done(&self, t: f64, start: f64, step: &Step, tick: &Tick) -> bool {
        let c = &self.coordinator;
        let elapsed = t - start;
        match &step.behaviour {
            Behaviour::Form { .. } => tick.complete,
            Behaviour::Hold { duration_s } | Behaviour::Velocity { duration_s, .. } => {
                elapsed >= *duration_s
            }
            Behaviour::GoTo { goal, tolerance } => match c.plan() {
                Some(plan) => {
                    let ids = &plan.slot_robot;
                    let pts: Vec<Pose> = ids.iter().filter_map(|&id| c.pose(id)).collect();
                    if pts.is_empty() {
                        return false;
                    }
                    let [cx, cy] = crate::assign::mean_position(&pts);
                    (cx - goal.x).hypot(cy - goal.y) <= *tolerance
                }
                None => c
                    .robot_ids()
                    .iter()
                    .filter_map(|&id| c.pose(id))
                    .all(|p| (p.x - goal.x).hypot(p.y - goal.y) <= *tolerance),
            },
            Behaviour::Trajectory { trajectory } => elapsed >= trajectory.end_time(),
            Behaviour::Rendezvous {
                robots,
                anti,
                duration_s,
                until_distance,
                ..
            } => {
                if duration_s.is_some_and(|d| elapsed >= d) {
                    return true;
                }
                let Some(limit) = until_distance else {
                    return false;
                };
                let ids = robots.clone().unwrap_or_else(|| c.robot_ids());
                let pts: Vec<Pose> = ids.iter().filter_map(|&id| c.pose(id)).collect();
                if pts.len() < 2 {
                    return true;
                }
                pts.iter().enumerate().all(|(i, p)| {
                    let nearest = pts
                        .iter()
                        .enumerate()
                        .filter(|(j, _)| *j != i)
                        .map(|(_, q)| p.distance(q))
                        .fold(f64::INFINITY, f64::min);
                    if *anti {
                        nearest >= *limit
                    } else {
                        nearest <= *limit
                    }
                })
            }
            Behaviour::Decouple { .. } => c.decouple_done(),
            Behaviour::Cross { .. } => matches!(self.crossing, Some(Ok(()))),
            Behaviour::Disperse { tolerance, .. } => match c.mode() {
                Mode::Disperse { goals, .. } => goals.iter().all(|(id, g)| {
                    c.lost().contains(id)
                        || c.pose(*id)
                            .is_some_and(|p| (p.x - g.x).hypot(p.y - g.y) <= *tolerance)
                }),
                _ => true,
            },
        }
    }

    /// One control tick.
    pub fn tick(&mut self, t: f64, robots: &[RobotState]) -> Tick {
        if let RunState::Running { index } = self.state {
            if self.step_start.is_none() {
                self.step_start = Some(t);
                if let Err(reason) = self.start(t, index, robots) {
                    self.fail(t, index, reason);
                }
            }
        }
        let mut tick = self.coordinator.tick(t, robots);
        if let RunState::Running { index } = self.state {
            let step = self.scenario.steps[index].clone();
            let start = self.step_start.unwrap_or(t);
            if let Some(r) = self.recoupling {
                let (a, b) = r.pair;
                if tick.complete {
                    // Every pair of the plan is coupled again: the move goes on for what
                    // was left of it.
                    self.recoupling = None;
                    self.coordinator.record(t, EventKind::Recoupled { a, b });
                    self.step_start = Some(t - r.elapsed);
                    if let Err(reason) = self.begin(t, index, robots, r.elapsed) {
                        self.fail(t, index, reason);
                    }
                } else if t - r.since > RECOUPLE_TIMEOUT_S {
                    self.fail(
                        t,
                        index,
                        format!(
                            "pair {a}-{b} came apart while moving in step '{}' and was not \
                             coupled again within {RECOUPLE_TIMEOUT_S} s",
                            step.label
                        ),
                    );
                }
            } else if let Some((a, b)) = Self::came_apart_while_moving(&step, &tick) {
                // An assembly that lost a coupling is not the assembly the move was planned
                // (and gated) for: it stops and couples the pair again (the plan's
                // formation), then goes on; after `MAX_RECOUPLES` the step fails saying why.
                let n = self.recouples.get(&index).copied().unwrap_or(0);
                if n < MAX_RECOUPLES && self.coordinator.plan().is_some() {
                    self.recouples.insert(index, n + 1);
                    self.recoupling = Some(Recoupling {
                        pair: (a, b),
                        since: t,
                        elapsed: t - start,
                    });
                    self.coordinator
                        .record(t, EventKind::Recoupling { a, b, index });
                    self.coordinator.set_mode(t, Mode::Form);
                } else {
                    self.fail(
                        t,
                        index,
                        format!(
                            "pair {a}-{b} came apart while moving in step '{}' ({} times)",
                            step.label,
                            n + 1
                        ),
                    );
                }
                // This tick's tasks were the move's: they hold instead.
                for task in &mut tick.tasks {
                    task.role = Role::Hold;
                }
            } else if let (Behaviour::Cross { .. }, Some(Err(why))) =
                (&step.behaviour, self.crossing.clone())
            {
                self.fail(t, index, format!("step '{}': {why}", step.label));
            } else if self.done(t, start, &step, &tick) {
                self.coordinator
                    .record(t, EventKind::StepFinished { index });
                self.step_start = None;
                self.state = if index + 1 < self.scenario.steps.len() {
                    RunState::Running { index: index + 1 }
                } else {
                    self.coordinator.set_mode(t, Mode::Hold);
                    RunState::Finished
                };
            } else if step.timeout_s.is_some_and(|to| t - start > to) {
                self.fail(t, index, format!("step '{}' timed out", step.label));
            }
            // Events recorded after the coordinator's tick reach the caller now.
            let late = self.coordinator.tick_events();
            tick.events.extend(late);
        }
        tick
    }
}
