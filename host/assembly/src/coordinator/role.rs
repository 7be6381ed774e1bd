//! What one robot is told to do this tick: its role and the task that carries it.

use super::*;

/// What one robot should do this tick.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "role")]
pub enum Role {
    /// Stand still (no task; keep existing couplings).
    Hold,
    /// Stand still at `pose`, turning back to it when pushed (an MPC pose goal): a member
    /// of the assembly being grown while a robot joins it ([`Coordinator::keep_grown`]).
    Keep {
        /// Its planned place relative to the seed (the seed: where it was first held).
        pose: Pose2,
    },
    /// Not driven: a pilot that is not yet part of an assembly with a non-pilot (THESIS 3.5.2),
    /// or a robot whose pair must wait (convex-first).
    Wait,
    /// Segment leader aligning a connection pair (THESIS (4.5), (5.19)): bring `own_point`
    /// (body frame) onto the partner's `partner_point` (its body frame), with own yaw minus
    /// partner yaw → `relative_yaw`. For `puzzlebot_mpc::CostTerm::AlignPair`: own point
    /// angle 0, partner point angle `relative_yaw`.
    Align {
        /// Index of the pair in [`Coordinator::pairs`].
        pair: usize,
        /// The other robot.
        partner: RobotId,
        /// Point on this robot (m, body frame): the augmented head while decoupled.
        own_point: [f64; 2],
        /// Point on the partner (m, its body frame).
        partner_point: [f64; 2],
        /// Target own yaw − partner yaw (rad).
        relative_yaw: f64,
        /// Anchor–opening or knob–hole.
        kind: PairType,
        /// Current status of the pair (the phase).
        phase: PairStatus,
    },
    /// Follow the segment leader (THESIS (5.25)): stay at `offset` in the leader's body frame
    /// (`puzzlebot_mpc::CostTerm::FollowLeader`), with a smaller weight than the leader's.
    Follow {
        /// Leader of this robot's segment.
        leader: RobotId,
        /// This robot's pose in the leader's body frame: from the planned shape when both are
        /// in the plan, else as measured.
        offset: Pose2,
    },
    /// Fit a velocity command (THESIS (4.7)).
    Velocity {
        /// Linear velocity (m/s).
        v: f64,
        /// Angular velocity (rad/s).
        w: f64,
    },
    /// Go to a goal pose (THESIS (4.6)); `yaw` matters only when `use_yaw`.
    GoTo {
        /// Goal.
        goal: Pose2,
        /// Whether the heading is part of the goal.
        use_yaw: bool,
    },
    /// Track a reference trajectory (THESIS (5.26)): reference poses at t, t + dt, ….
    Track {
        /// Reference samples over the MPC horizon.
        reference: Vec<Pose2>,
    },
    /// Dock a side (knob–hole) connection (THESIS (3.2) θ_bias, 5.2.2): a lone robot on the
    /// approach line beside an assembly drives `(v, w)` directly (a geometric line follower;
    /// the MPC's pose tracking leaves millimetres of lateral error where the knob needs
    /// less than one). It converges on the partner's side at a shallow angle, presses its
    /// corner on it and straightens into the 0.04 rad fit while sliding onto the hole.
    /// Also the last stage of an anchor pair with a waiting pilot (it cannot make room):
    /// the robot turns on the spot to the pilot's axis, then drives straight in along it.
    Dock {
        /// Index of the pair in [`Coordinator::pairs`].
        pair: usize,
        /// Linear velocity (m/s).
        v: f64,
        /// Angular velocity (rad/s).
        w: f64,
    },
    /// A member hanging at an anchor while its train follows a reference: it drives `(v, w)`
    /// directly so that its connection point moves with its neighbour's, as a trailer behind
    /// its hitch ([`Coordinator::hitch_commands`]; with the MPC's pair alignment and its weak
    /// heading term the followers overshoot their leader's yaw in turns under late ticks).
    Hitch {
        /// Index of the pair in [`Coordinator::pairs`] that holds it to its neighbour.
        pair: usize,
        /// Linear velocity (m/s).
        v: f64,
        /// Angular velocity (rad/s).
        w: f64,
    },
    /// Drive `(v, w)` directly: a lone robot's turn-then-drive point law
    /// ([`Coordinator::point_drive`]), whose speeds stay above the wheels' dead-band. Near a
    /// goal the MPC's point goal asks for a turn too small for the wheels and the robot
    /// stands still short of it.
    Drive {
        /// Linear velocity (m/s).
        v: f64,
        /// Angular velocity (rad/s).
        w: f64,
    },
}

/// One robot's task.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotTask {
    /// Robot.
    pub robot: RobotId,
    /// What to do.
    pub role: Role,
    /// Only straight motion allowed (a lone pilot, THESIS 5.4.1): the MPC must keep ω = 0.
    pub straight_only: bool,
    /// Leader of this robot's segment (itself when leading; `None` when alone and idle).
    pub leader: Option<RobotId>,
    /// Segment (connected assembly) index this tick.
    pub segment: usize,
}
