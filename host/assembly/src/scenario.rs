//! Scenario files (TOML): a chain of behaviours — form a shape, hold, move an assembly
//! (velocity, go-to-goal, trajectory), rendezvous / anti-rendezvous (THESIS 2.3.5), decouple by
//! wiggling (THESIS 4.3.2, 5.4.2) and disperse — and a runner that executes them on a
//! [`Coordinator`], deciding when each step is done.
//!
//! ```toml
//! name = "demo"
//!
//! [[step]]
//! form = { shape = "mesh", rows = 2 }   # grown around one robot; grow = false: in parallel
//! timeout_s = 120
//!
//! [[step]]
//! move = { go_to = [0.5, 0.0], tolerance = 0.02 }
//!
//! [[step]]
//! decouple = {}            # every coupled pair; the anchor robots wiggle
//!
//! [[step]]
//! disperse = { goal = [{ robot = 1, x = 0.2, y = 0.4 }, { robot = 2, ahead = 0.2 },
//!                       { robot = 3, away = 0.1 }] }
//! ```
//!
//! Errors name the file, line, column and field.

use crate::assign::RobotState;
use crate::behaviour::{Trajectory, Wiggle};
use crate::coordinator::{Coordinator, EventKind, Mode, Role, Tick};
use crate::geom::Pose;
use crate::pair::PairStatus;
use crate::shape::ShapeSpec;
use puzzlebot_params::RobotKind;
use puzzlebot_protocol::messages::RobotId;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// A scenario that could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// Unreadable file or malformed TOML / wrong field (file:line:column: message).
    #[error(transparent)]
    Load(#[from] puzzlebot_params::load::LoadError),
    /// Well-formed TOML that does not describe a usable scenario.
    #[error("{}:{line}:{column}: {field}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// The offending field, e.g. `step[2].move`.
        field: String,
        /// What was wrong.
        message: String,
    },
}

/// A duration or tolerance that must be finite and ≥ 0 (checked while parsing, so errors
/// carry the value's line).
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize)]
#[serde(try_from = "f64")]
pub struct NonNeg(pub f64);

impl TryFrom<f64> for NonNeg {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if v.is_finite() && v >= 0.0 {
            Ok(NonNeg(v))
        } else {
            Err(format!("must be a finite number ≥ 0, got {v}"))
        }
    }
}

/// A finite number (checked while parsing).
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Serialize, Deserialize)]
#[serde(try_from = "f64")]
pub struct Finite(pub f64);

impl TryFrom<f64> for Finite {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if v.is_finite() {
            Ok(Finite(v))
        } else {
            Err(format!("must be a finite number, got {v}"))
        }
    }
}

/// Default goal tolerance (m).
pub const DEFAULT_TOLERANCE: f64 = 0.02;

/// How a shape is grown around one robot (`form = { grow = true, seed = ID }`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Grow {
    /// The robot the shape is built around; default: the pilot, else the robot nearest the
    /// fleet's centre.
    pub seed: Option<RobotId>,
}

/// One behaviour of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "behaviour")]
pub enum Behaviour {
    /// Form a shape with every robot (THESIS Algorithms 2–8).
    Form {
        /// The shape.
        spec: ShapeSpec,
        /// Heading of the shape (rad); default: mean robot heading.
        heading: Option<f64>,
        /// Grow the shape around one robot, one lone robot joining at a time
        /// ([`crate::Coordinator::form_grown`]); the heading is the seed's.
        grow: Option<Grow>,
    },
    /// Stand still for a while, keeping couplings.
    Hold {
        /// Duration (s).
        duration_s: f64,
    },
    /// Every assembly fits a velocity for a while (THESIS (4.7)).
    Velocity {
        /// m/s.
        v: f64,
        /// rad/s.
        w: f64,
        /// Duration (s).
        duration_s: f64,
    },
    /// The shape centre goes to a goal (THESIS (4.6)).
    GoTo {
        /// Goal (yaw used when given).
        goal: Pose,
        /// Done within this distance (m).
        tolerance: f64,
    },
    /// The shape centre tracks a trajectory (THESIS (5.26)).
    Trajectory {
        /// Waypoints (times from the step start).
        trajectory: Trajectory,
    },
    /// Rendezvous (THESIS (2.3)) or anti-rendezvous ((2.4)).
    Rendezvous {
        /// Robots (default: all).
        robots: Option<Vec<RobotId>>,
        /// Gain (1/s).
        gain: f64,
        /// Anti-rendezvous.
        anti: bool,
        /// Stop after this long (s).
        duration_s: Option<f64>,
        /// Rendezvous: stop when every robot is this close to its nearest neighbour;
        /// anti: when every robot is at least this far from all others (m), each robot
        /// holding once it is (see `Mode::Rendezvous::until`).
        until_distance: Option<f64>,
    },
    /// Decouple pairs by wiggling the anchor robot (THESIS (5.7)).
    Decouple {
        /// Only pairs involving these robots (default: every coupled pair).
        robots: Option<Vec<RobotId>>,
        /// Wiggle profile.
        wiggle: Wiggle,
    },
    /// Every listed robot goes to its own goal (THESIS (4.6)).
    Disperse {
        /// Goals.
        goals: BTreeMap<RobotId, Goal>,
        /// Done within this distance (m).
        tolerance: f64,
    },
    /// The formed assembly crosses the terrain ahead of it, driven by the host along its
    /// heading once the stability gate proves the whole crossing (THESIS 3.5.2, SOCP §4);
    /// the coordinator holds meanwhile and the host reports the result
    /// ([`crate::ScenarioRunner::finish_crossing`]).
    Cross {
        /// Terrain file (`[[platforms]]`), relative paths resolved against the scenario's
        /// folder.
        terrain: std::path::PathBuf,
    },
}

/// A robot's own goal in a disperse step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Goal {
    /// A point (m).
    At {
        /// x (m).
        x: f64,
        /// y (m).
        y: f64,
    },
    /// This far (m) along the robot's heading at the step's start: a pilot alone drives
    /// only straight (THESIS 5.4.1), so its goal must lie on its axis.
    Ahead(f64),
    /// This far (m) further from the centre of the step's robots, along the line from that
    /// centre through the robot, where the step starts: robots leaving a group this way do not
    /// cross each other's paths (goals `ahead` of robots that ended facing each other made two
    /// robots swap places head-on, pushing until the step timed out). A robot that moves
    /// straight only goes along its axis, forwards or backwards, whichever leads away.
    Away(f64),
}

impl Goal {
    /// The goal point for a robot at `pose` when the step starts, the step's robots centred
    /// at `centre`; `straight_only`: the robot cannot turn (a pilot alone).
    pub fn resolve(&self, pose: &Pose, centre: [f64; 2], straight_only: bool) -> Pose {
        let (s, c) = pose.yaw.sin_cos();
        let ahead = |d: f64| Pose::new(pose.x + d * c, pose.y + d * s, pose.yaw);
        match *self {
            Goal::At { x, y } => Pose::new(x, y, 0.0),
            Goal::Ahead(d) => ahead(d),
            Goal::Away(d) => {
                let (dx, dy) = (pose.x - centre[0], pose.y - centre[1]);
                let r = dx.hypot(dy);
                if straight_only || r < 1e-3 {
                    // Along the axis, on the side away from the centre (ahead at the centre).
                    ahead(if dx * c + dy * s < 0.0 { -d } else { d })
                } else {
                    Pose::new(pose.x + d * dx / r, pose.y + d * dy / r, pose.yaw)
                }
            }
        }
    }
}

/// One step: a behaviour, an optional label and timeout.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Step {
    /// Label for logs (default: the behaviour's name).
    pub label: String,
    /// Fail the scenario when the step takes longer (s).
    pub timeout_s: Option<f64>,
    /// What to do.
    pub behaviour: Behaviour,
    /// Line of the step in the file.
    pub line: usize,
}

/// A parsed scenario.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scenario {
    /// Name (default: file stem).
    pub name: String,
    /// Steps, executed in order.
    pub steps: Vec<Step>,
}

mod parse;
mod runner;
pub use runner::{RunState, ScenarioRunner, MAX_RECOUPLES, RECOUPLE_TIMEOUT_S};

#[cfg(test)]
mod tests;
