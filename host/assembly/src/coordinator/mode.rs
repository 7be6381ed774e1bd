//! The behaviour the coordinator executes, and switching between behaviours.

use super::*;

/// The behaviour the coordinator is executing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Stand still, keep couplings.
    Hold,
    /// Form the planned shape (pairs from [`Coordinator::form`]).
    Form,
    /// Assemblies follow a velocity (leader fits it, others follow).
    Velocity {
        /// m/s.
        v: f64,
        /// rad/s.
        w: f64,
    },
    /// Each assembly moves so that the plan's shape centre reaches `goal` (leaders go to their
    /// slot placed at the goal; others follow).
    GoTo {
        /// Goal of the shape centre and heading.
        goal: Pose2,
    },
    /// Leaders track a trajectory of the shape centre (started at `start`).
    Track {
        /// The trajectory (times relative to `start`).
        trajectory: Trajectory,
        /// Start time (s).
        start: f64,
    },
    /// Rendezvous (THESIS (2.3)) or anti-rendezvous ((2.4)) of the given robots.
    Rendezvous {
        /// Robots taking part (others hold).
        robots: Vec<RobotId>,
        /// Gain on the consensus velocity (1/s).
        gain: f64,
        /// Anti-rendezvous.
        anti: bool,
        /// Anti-rendezvous: a robot whose nearest neighbour is this far (m) stops (THESIS
        /// (2.4) grows every distance exponentially: left to run, a robot that has already
        /// separated drives on far while another is still close to its neighbour).
        #[serde(default)]
        until: Option<f64>,
    },
    /// The anchor robots of the given pairs wiggle (THESIS (5.7)) until decoupled.
    Decouple {
        /// Pairs (by index) to release.
        pairs: Vec<usize>,
        /// Wiggle profile.
        wiggle: Wiggle,
        /// Start time (s).
        start: f64,
    },
    /// Every listed robot goes to its own goal (THESIS (4.6)).
    Disperse {
        /// Goals.
        goals: BTreeMap<RobotId, Pose2>,
        /// A robot this near its goal has arrived (m; the step's tolerance).
        tolerance: f64,
    },
}

impl Coordinator {
    /// Switch behaviour (formation is started with [`Coordinator::form`]).
    pub fn set_mode(&mut self, t: f64, mode: Mode) {
        let name = match &mode {
            Mode::Hold => "hold",
            Mode::Form => "form",
            Mode::Velocity { .. } => "velocity",
            Mode::GoTo { .. } => "go_to",
            Mode::Track { .. } => "trajectory",
            Mode::Rendezvous { anti: false, .. } => "rendezvous",
            Mode::Rendezvous { anti: true, .. } => "anti_rendezvous",
            Mode::Decouple { .. } => "decouple",
            Mode::Disperse { .. } => "disperse",
        };
        self.trains.get_mut().clear();
        match (&self.mode, &mode) {
            // A velocity behaviour right after another: each reference goes on from where
            // the previous one is now, at its (v, ω), so the assembly does not stop between
            // the steps (and the members keep their offsets).
            (Mode::Velocity { v, w }, Mode::Velocity { .. }) => {
                let to = [*v, *w];
                for m in self.motion_start.values_mut() {
                    *m = MotionStart {
                        pose: ramp_pose(m, to, t - m.t0),
                        t0: t,
                        from: ramp_velocity(m, to, t - m.t0),
                    };
                }
            }
            _ => {
                self.motion_start.clear();
                self.motion_offsets.clear();
            }
        }
        self.mode = mode;
        self.push(t, EventKind::BehaviourStarted { name: name.into() });
        if let Mode::Decouple { pairs, .. } = &self.mode {
            let knobs: Vec<(RobotId, RobotId)> = pairs
                .iter()
                .filter_map(|&i| self.pairs.get(i))
                .filter(|p| p.pair.kind == PairType::KnobHole)
                .map(|p| (p.pair.a, p.pair.b))
                .collect();
            if !knobs.is_empty() {
                let mut robots: Vec<RobotId> = pairs
                    .iter()
                    .filter_map(|&i| self.pairs.get(i))
                    .flat_map(|p| [p.pair.a, p.pair.b])
                    .collect();
                robots.sort_unstable();
                robots.dedup();
                self.push(
                    t,
                    EventKind::LiftKnobs {
                        robots,
                        pairs: knobs,
                    },
                );
            }
        }
    }
}
