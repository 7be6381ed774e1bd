//! Assembly shapes, connection-pair task assignment and pair status machines
//! (THESIS Algorithms 1–8, 3.2, 3.3.2, 5.2.2, 5.2.4, 5.4.2–5.4.3, 5.5.5, 5.5.9).
//!
//! Plain data in, plain data out: the host feeds measured poses, this crate answers which
//! connection pair each robot works on, who leads each assembly segment and which pairs are
//! coupled; the distributed MPC (`puzzlebot-mpc`) turns those tasks into costs.
//!
//! - [`geom`]: poses, the six connection points (Fig 5.12) and pair types.
//! - [`shape`]: line, mesh, custom shapes from TOML/JSON (poses or an assembly graph).
//! - [`info`]: diagonal angle α, best heading, projected length (5.2.4), [`info::shape_info`].
//! - [`assign`]: Algorithms 1–2 (MST, closest points, convex-first, Hungarian).
//! - [`coordinator`]: per-tick tasks, segment leaders, events, re-planning.
//! - [`behaviour`]: wiggle, rendezvous, point controller, trajectories.
//! - [`scenario`]: TOML scenario files chaining behaviours, and their runner.
//! - [`pair`]: Algorithm 7 augmentation and the Algorithm 8 status machine with hysteresis.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod assign;
pub mod behaviour;
pub mod coordinator;
pub mod geom;
pub mod info;
pub mod pair;
pub mod route;
pub mod scenario;
pub mod shape;

pub use assign::{
    assign_around, assign_connection_pairs, Plan, PlanError, PlannedPair, RobotState,
};
pub use coordinator::{
    Coordinator, CoordinatorConfig, Event, EventKind, MaintainPair, Mode, RobotTask, Role, Tick,
};
pub use geom::{ConnPoint, PairType, Pose};
pub use info::{shape_info, ShapeInfo};
pub use pair::{PairStatus, PairTolerances, TrackedPair, Transition};
pub use puzzlebot_protocol::messages::RobotId;
pub use scenario::{
    Behaviour, Goal, Grow, RunState, Scenario, ScenarioError, ScenarioRunner, Step,
};
pub use shape::{GoalPair, Shape, ShapeError, ShapeSpec, SlotKind};
