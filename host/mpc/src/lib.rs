//! Distributed model predictive control of PuzzleBots (Clarabel, real-time iteration).
//!
//! One MPC problem per robot per 10 Hz tick, solved in parallel ([`DistributedMpc::tick`]),
//! after THESIS 4.3 and 5.4.4 (Algorithm 9, eqs. 5.19–5.24).
//!
//! **Model.** We use the chapter-5 model, THESIS 5.4.1: state x = (x, y, θ), input
//! u = (v, ω), Euler unicycle dynamics (5.2). Why not 4.3.1 (state with v, ω and
//! accelerations as input)? The chapter-5 model is the one THESIS ran on the ESP32 fleet,
//! its input is exactly what the host's drive mapper consumes (no extra delay step), it has
//! 40 % fewer variables (faster), and the butterfly set (THESIS 3.5.1) constrains the input
//! directly instead of a state. The acceleration box of 4.12 (set 𝒰) survives as an
//! optional rate box on consecutive inputs ([`Limits::accel_max`]).
//!
//! **Solution method.** Sequential linearisation (real-time iteration): every tick each
//! robot linearises dynamics, costs and coupling constraints around its previous plan,
//! shifted by one step and rolled out from its current pose, condenses the states out
//! (decision variables: the 2·H_m inputs), and solves one convex QP with Clarabel (more
//! with [`MpcConfig::sqp_iterations`]). Costs are Gauss–Newton least squares, so the QP is
//! convex by construction. The non-convex butterfly set is handled by selecting one convex
//! wing per step: the sign of the planned v at that step, or, when it is zero, the sign
//! that the cost gradient prefers. The QP pattern is fixed per problem shape, so the solver
//! (and its symbolic factorisation) is reused through in-place `update_*` calls (measured:
//! −25 % per solve). The condensed QP beat the sparse multiple-shooting QP
//! ([`MpcConfig::condensed`] = false) by about 22 % in instructions per solve.
//! Robots with established pairs get an extra damping towards the plan their neighbours
//! were told ([`MpcConfig::w_consistency`]), which keeps those predictions trustworthy.
//!
//! **Safety.** Only `Solved | AlmostSolved` plans are used, and then only if every input
//! lies in the robot's box and butterfly set ([`Limits::contains`]). Otherwise the robot
//! keeps executing its last accepted plan for at most [`MpcConfig::max_fallback_ticks`]
//! ticks and then stops (v = ω = 0).
//!
//! **Distribution.** Neighbours enter as numbers: their predicted trajectory from the
//! previous tick ([`NeighbourModel::Predicted`]) or their frozen current pose (THESIS,
//! [`NeighbourModel::Frozen`]).
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod dmpc;
mod problem;
mod robot;
pub mod scenario;
mod types;

pub use dmpc::DistributedMpc;
pub use problem::{CouplingInstance, PointTerm, ProblemInstance, Role, VelocityTerm};
pub use robot::{RobotController, OUTPUT_TOLERANCE};
pub use types::*;

/// Errors in the data given to the MPC (never solver trouble: that is a [`SolveStatus`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MpcError {
    /// A configuration field is out of range.
    #[error("invalid MPC config field `{field}`: {reason}")]
    InvalidConfig {
        /// The field.
        field: &'static str,
        /// Why.
        reason: String,
    },
    /// A robot's velocity limits are malformed.
    #[error("invalid limits field `{field}`: {reason}")]
    InvalidLimits {
        /// The field.
        field: &'static str,
        /// Why.
        reason: String,
    },
    /// Bad per-robot input (duplicate id, unknown partner, non-finite pose, …).
    #[error("robot {robot}: {reason}")]
    InvalidInput {
        /// The robot whose input is wrong.
        robot: RobotId,
        /// Why.
        reason: String,
    },
}
