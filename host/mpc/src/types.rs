//! Public plain-data types of the MPC: what goes into a tick and what comes out.

use puzzlebot_params::drive::Drive;
use puzzlebot_params::geometry::Geometry;
use serde::{Deserialize, Serialize};

/// Robot identifier (the protocol's id).
pub use puzzlebot_protocol::messages::RobotId;

/// Planar pose of a robot body frame in the world frame (m, m, rad); the heading of
/// predicted trajectories is not wrapped.
pub use puzzlebot_params::pose::Pose;

/// Body velocity command (v in m/s, ω in rad/s): the MPC input, THESIS 5.4.1.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Command {
    /// Linear velocity v (m/s).
    pub v: f64,
    /// Angular velocity ω (rad/s).
    pub omega: f64,
}

impl Command {
    /// The zero command (stop); it lies in every butterfly set.
    pub const STOP: Command = Command { v: 0.0, omega: 0.0 };

    /// A command from its parts.
    pub const fn new(v: f64, omega: f64) -> Self {
        Command { v, omega }
    }

    /// The pose after driving this command for `dt` (s) from `from`: one Euler step of the
    /// unicycle, THESIS (5.2).
    pub fn drive(self, from: &Pose, dt: f64) -> Pose {
        from.unicycle_step(self.v, self.omega, dt)
    }
}

/// Velocity limits of one robot: the butterfly set of THESIS 3.5.1 / 4.3.4 intersected
/// with a velocity box, and an optional acceleration (rate) box between steps.
///
/// The butterfly set is the union of two convex "wings": the quadrilateral O, A', B, A
/// (O = origin, A = (a_v, −a_ω), A' = (a_v, a_ω), B = (b_v, 0)) for v ≥ 0 and its mirror
/// image for v ≤ 0. At v = 0 only ω = 0 is feasible: the robot needs forward (or backward)
/// speed to turn, far more so for pilots (A = (0.34, −0.561)) than non-pilots.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Butterfly corner A = (v, ω) (THESIS 3.5.1); the sign of ω is ignored.
    pub butterfly_a: [f64; 2],
    /// Butterfly tip B = (v, 0) (THESIS 3.5.1).
    pub butterfly_b: [f64; 2],
    /// Velocity box |v| ≤ v_max (m/s); cuts the butterfly when smaller than B.
    pub v_max: f64,
    /// Velocity box |ω| ≤ ω_max (rad/s); cuts the butterfly when smaller than |A_ω|.
    pub omega_max: f64,
    /// Acceleration box |Δv|/dt ≤ a\[0\] (m/s²), |Δω|/dt ≤ a\[1\] (rad/s²) between consecutive
    /// inputs, the first one against the last applied command (THESIS 4.12, set 𝒰).
    pub accel_max: Option<[f64; 2]>,
}

impl Limits {
    /// Limits from the shared drive calibration: butterfly, box at its extent, no
    /// acceleration box (THESIS 5.19–5.24 rely on the smoothness cost; set
    /// [`Limits::accel_max`] to add the 4.12 box).
    pub fn from_drive(d: &Drive) -> Self {
        let a = [f64::from(d.butterfly_a[0]), f64::from(d.butterfly_a[1])];
        let b = [f64::from(d.butterfly_b[0]), f64::from(d.butterfly_b[1])];
        Limits {
            butterfly_a: a,
            butterfly_b: b,
            v_max: b[0],
            omega_max: a[1].abs(),
            accel_max: None,
        }
    }

    /// Whether `u` lies in the butterfly set and the velocity box (with tolerance `tol`).
    pub fn contains(&self, u: Command, tol: f64) -> bool {
        if !(u.v.is_finite() && u.omega.is_finite()) {
            return false;
        }
        if u.v.abs() > self.v_max + tol || u.omega.abs() > self.omega_max + tol {
            return false;
        }
        let (av, aw, bv) = (
            self.butterfly_a[0],
            self.butterfly_a[1].abs(),
            self.butterfly_b[0],
        );
        let v = u.v.abs();
        let w = u.omega.abs();
        // Edge O–A: |ω| ≤ (a_ω/a_v)|v|; edge A–B: |ω| ≤ a_ω (b_v − |v|)/(b_v − a_v).
        let s1 = aw / av;
        let s2 = aw / (bv - av);
        w <= s1 * v + tol * (1.0 + s1) && w <= s2 * (bv - v) + tol * (1.0 + s2)
    }

    /// Checks the numbers describe a proper butterfly; the error names the bad field.
    pub fn validate(&self) -> Result<(), crate::MpcError> {
        let bad = |field: &'static str, why: &str| {
            Err(crate::MpcError::InvalidLimits {
                field,
                reason: why.to_string(),
            })
        };
        let [av, aw] = self.butterfly_a;
        let bv = self.butterfly_b[0];
        if !(av.is_finite() && aw.is_finite() && bv.is_finite()) {
            return bad("butterfly", "not finite");
        }
        if av <= 0.0 {
            return bad("butterfly_a", "A_v must be > 0");
        }
        if aw == 0.0 {
            return bad("butterfly_a", "A_ω must be non-zero");
        }
        if bv <= av {
            return bad("butterfly_b", "B_v must exceed A_v");
        }
        if !(self.v_max > 0.0 && self.v_max.is_finite()) {
            return bad("v_max", "must be finite and > 0");
        }
        if !(self.omega_max > 0.0 && self.omega_max.is_finite()) {
            return bad("omega_max", "must be finite and > 0");
        }
        if let Some([a, b]) = self.accel_max {
            if !(a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite()) {
                return bad("accel_max", "both entries must be finite and > 0");
            }
        }
        Ok(())
    }
}

/// A connection point: a frame fixed on a robot body (THESIS 4.4, g_{B C}).
///
/// Angles are chosen so that a pair is aligned when Δθ = θ_i + θ_Ci − (θ_j + θ_Cj) = 0
/// (mod 2π); e.g. both 0 for an anchor and an opening of two robots heading the same way.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ConnectionPoint {
    /// Position in the body frame (m).
    pub pos: [f64; 2],
    /// Orientation in the body frame (rad).
    pub angle: f64,
}

/// Stage/terminal weights of a behaviour cost: W_m for k < H_m and W_f at k = H_m (THESIS 4.8).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StageWeights {
    /// Stage weight W_m (k = 1 … H_m − 1).
    pub stage: f64,
    /// Terminal weight W_f (k = H_m).
    pub terminal: f64,
}

impl Default for StageWeights {
    fn default() -> Self {
        StageWeights {
            stage: 1.0e2,
            terminal: 1.0e4,
        }
    }
}

/// One composable behaviour cost term of a robot (THESIS 4.5–4.7, 5.19, 5.25, 5.26).
///
/// Position errors are in metres, headings enter as tan²(Δθ/2) (THESIS 4.5) so that
/// angles wrap correctly; `heading` weighs that term relative to the position term.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum CostTerm {
    /// Connection-pair alignment, THESIS (4.5): bring `own` onto `partner_point` of robot
    /// `partner` (its predicted trajectory, or its frozen pose in frozen mode).
    AlignPair {
        /// The other robot of the pair.
        partner: RobotId,
        /// Connection point on this robot.
        own: ConnectionPoint,
        /// Connection point on the partner.
        partner_point: ConnectionPoint,
        /// W_m, W_f multiplying ‖Δp‖² + heading·tan²(Δθ/2).
        weights: StageWeights,
        /// W_θ relative to W_p.
        heading: f64,
    },
    /// Go to goal, THESIS (4.6): bring body point `point` to the world point `goal`.
    GoToGoal {
        /// Goal in the world frame (m).
        goal: [f64; 2],
        /// Body point that must reach it (m); \[0, 0\] for the body centre.
        point: [f64; 2],
        /// W_m, W_f.
        weights: StageWeights,
    },
    /// Velocity fitting, THESIS (4.7): track a commanded (v*, ω*) on every input step.
    FitVelocity {
        /// Target velocity.
        target: Command,
        /// Weight of (v − v*)².
        w_v: f64,
        /// Weight of (ω − ω*)².
        w_omega: f64,
    },
    /// Trajectory following, THESIS (5.26): poses x_ref(k) for k = 0 … H_m (a shorter
    /// list holds its last pose).
    FollowTrajectory {
        /// Reference poses, world frame, one per MPC step starting at the current time.
        reference: Vec<Pose>,
        /// W_m (5.26 w_c), W_f (5.26 w_f).
        weights: StageWeights,
        /// Heading weight relative to position.
        heading: f64,
    },
    /// Following a segment leader, THESIS (5.25): keep this robot at `offset` in the
    /// leader's body frame along the leader's predicted trajectory.
    FollowLeader {
        /// The segment leader.
        leader: RobotId,
        /// This robot's pose in the leader's body frame when the segment is in shape.
        offset: Pose,
        /// W_m, W_f (much smaller than the leader's, THESIS 5.5.9).
        weights: StageWeights,
        /// Heading weight relative to position.
        heading: f64,
    },
}

/// An established anchor coupling: the anchor of `anchor_robot` sits in the opening of
/// `opening_robot`. Both robots' problems get the point-in-polygon constraint of the
/// projected anchor head (THESIS 4.11 / 5.23), the two cutting planes (5.17–5.18, 5.24)
/// over the constraint horizon, and the soft maintenance cost W_c J_c (4.8).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct CoupledPair {
    /// Robot whose anchor head is inserted.
    pub anchor_robot: RobotId,
    /// Robot whose opening holds it.
    pub opening_robot: RobotId,
}

/// What one robot contributes to a tick.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotInput {
    /// Robot id; unique within a tick.
    pub id: RobotId,
    /// Current pose (motion capture or simulator).
    pub pose: Pose,
    /// Velocity limits of this robot (from its drive calibration).
    pub limits: Limits,
    /// Behaviour cost terms, summed. Empty: hold still (smoothness and effort only).
    pub costs: Vec<CostTerm>,
}

/// How neighbours enter a robot's problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum NeighbourModel {
    /// Neighbours follow their plan from the previous tick, re-rolled from their current
    /// pose (default; an improvement over THESIS 5.4.4).
    #[default]
    Predicted,
    /// Neighbours stay at their current pose over the horizon (THESIS 5.4.4).
    Frozen,
}

/// Clarabel settings exposed for tuning.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SolverTuning {
    /// Iteration limit per QP.
    pub max_iter: u32,
    /// Absolute and relative duality-gap tolerance.
    pub tol_gap: f64,
    /// Feasibility tolerance.
    pub tol_feas: f64,
    /// Reuse the solver (symbolic factorisation) across ticks via in-place data updates.
    pub reuse_factorisation: bool,
    /// Largest number of iterative-refinement steps per KKT solve (Clarabel default 10).
    pub refinement_max_iter: u32,
    /// Relative tolerance of iterative refinement (Clarabel default 1e-13).
    pub refinement_reltol: f64,
}

impl Default for SolverTuning {
    fn default() -> Self {
        SolverTuning {
            max_iter: 50,
            tol_gap: 1e-5,
            tol_feas: 1e-7,
            reuse_factorisation: true,
            refinement_max_iter: 3,
            refinement_reltol: 1e-9,
        }
    }
}

fn default_true() -> bool {
    true
}

/// Configuration of every robot's MPC.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MpcConfig {
    /// Prediction horizon H_m (steps). THESIS: 10.
    pub horizon: usize,
    /// Constraint horizon H_c ≤ H_m (steps). THESIS: 3.
    pub constraint_horizon: usize,
    /// Step Δt (s). THESIS 5.2.3: 0.1 (10 Hz).
    pub dt: f64,
    /// Smoothness weight W_s on ‖u_k − u_{k+1}‖², THESIS (5.19); also applied to u_0 against
    /// the last applied command.
    pub w_smooth: [f64; 2],
    /// Effort weight on ‖u‖² (THESIS 4.8 W_s uᵀu), per (v, ω).
    pub w_effort: [f64; 2],
    /// Levenberg damping on ‖u − ū‖² around the linearisation point (keeps RTI steps short).
    pub w_damping: [f64; 2],
    /// Extra damping on ‖u − ū‖² for robots with established pairs: ū is the plan their
    /// neighbours were told (the predicted trajectory), so this keeps plans consistent
    /// between ticks and the neighbours' coupling constraints trustworthy (DMPC
    /// compatibility). Measured: 100/1 keeps coupled pairs inside their constraints in
    /// fast turns; 1/0.01 does not.
    pub w_consistency: [f64; 2],
    /// Established pairs get the hard coupling constraints (THESIS 5.23–5.24, point in
    /// polygon and cutting planes) on stages 1 … H_c; false: only the soft maintenance cost
    /// W_c J_c (4.8), and no [`MpcConfig::w_consistency`] (that damping exists to keep the
    /// neighbours' hard constraints trustworthy). Default true.
    #[serde(default = "default_true")]
    pub hard_couplings: bool,
    /// Soft maintenance weight W_c of established pairs (THESIS 4.8) on stages 1 … H_c.
    pub w_maintain: f64,
    /// Heading weight of the maintenance cost relative to its position term.
    pub maintain_heading: f64,
    /// Tightening of the coupling constraints (m): absorbs neighbours' deviations from
    /// their predictions and the model error of Euler integration.
    pub constraint_margin: f64,
    /// Number of sequential QPs per tick (1 = real-time iteration).
    pub sqp_iterations: usize,
    /// Condensed QP (inputs only, dense P; default) or sparse multiple-shooting QP
    /// (states as variables, linearised dynamics as equalities). Same solution.
    pub condensed: bool,
    /// Ticks a failed robot keeps executing its last feasible plan before it stops; with
    /// established couplings at most H_c − 1 (only constrained steps are replayed).
    pub max_fallback_ticks: u32,
    /// Neighbour model.
    pub neighbours: NeighbourModel,
    /// Robot geometry (anchor head, opening polygon, body size).
    pub geometry: GeometryF64,
    /// Clarabel tuning.
    pub solver: SolverTuning,
}

impl Default for MpcConfig {
    fn default() -> Self {
        MpcConfig {
            horizon: 10,
            constraint_horizon: 3,
            dt: 0.1,
            w_smooth: [10.0, 0.05],
            w_effort: [1e-3, 1e-4],
            w_damping: [1e-2, 1e-4],
            w_consistency: [100.0, 1.0],
            hard_couplings: true,
            w_maintain: 1.0e3,
            maintain_heading: 1e-4,
            constraint_margin: 1.0e-3,
            sqp_iterations: 1,
            condensed: true,
            max_fallback_ticks: 3,
            neighbours: NeighbourModel::Predicted,
            geometry: GeometryF64::from(&Geometry::default()),
            solver: SolverTuning::default(),
        }
    }
}

impl MpcConfig {
    /// Checks the configuration; the error names the bad field.
    pub fn validate(&self) -> Result<(), crate::MpcError> {
        let bad = |field: &'static str, reason: &str| {
            Err(crate::MpcError::InvalidConfig {
                field,
                reason: reason.to_string(),
            })
        };
        if self.horizon == 0 || self.horizon > 100 {
            return bad("horizon", "must be in 1..=100");
        }
        if self.constraint_horizon > self.horizon {
            return bad("constraint_horizon", "must be ≤ horizon");
        }
        if !(self.dt > 0.0 && self.dt.is_finite()) {
            return bad("dt", "must be finite and > 0");
        }
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if !self.w_smooth.iter().all(|&v| nonneg(v)) {
            return bad("w_smooth", "must be finite and ≥ 0");
        }
        if !self.w_effort.iter().all(|&v| nonneg(v)) {
            return bad("w_effort", "must be finite and ≥ 0");
        }
        if !self.w_consistency.iter().all(|&v| nonneg(v)) {
            return bad("w_consistency", "must be finite and ≥ 0");
        }
        if !self.w_damping.iter().all(|&v| nonneg(v)) {
            return bad("w_damping", "must be finite and ≥ 0");
        }
        if !nonneg(self.w_maintain) || !nonneg(self.maintain_heading) {
            return bad("w_maintain", "must be finite and ≥ 0");
        }
        if !nonneg(self.constraint_margin) {
            return bad("constraint_margin", "must be finite and ≥ 0");
        }
        if self.sqp_iterations == 0 || self.sqp_iterations > 50 {
            return bad("sqp_iterations", "must be in 1..=50");
        }
        self.geometry.validate()
    }
}

/// The geometry the MPC needs, widened to f64 (from the shared [`Geometry`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GeometryF64 {
    /// Body length L (m).
    pub length: f64,
    /// Body width (m).
    pub width: f64,
    /// Anchor head point a in the anchor robot's body frame (m), THESIS 5.10.
    pub anchor_head: [f64; 2],
    /// Opening centre in the opening robot's body frame (m).
    pub anchor_opening: [f64; 2],
    /// Counter-clockwise convex polygon in the opening robot's frame (m), THESIS 4.11.
    pub anchor_polygon: Vec<[f64; 2]>,
}

impl From<&Geometry> for GeometryF64 {
    fn from(g: &Geometry) -> Self {
        let w = |p: [f32; 2]| [f64::from(p[0]), f64::from(p[1])];
        GeometryF64 {
            length: f64::from(g.length),
            width: f64::from(g.width),
            anchor_head: w(g.anchor_head),
            anchor_opening: w(g.anchor_opening),
            anchor_polygon: g.anchor_polygon.iter().map(|&p| w(p)).collect(),
        }
    }
}

impl GeometryF64 {
    /// Checks the polygon is convex and counter-clockwise and sizes are positive.
    pub fn validate(&self) -> Result<(), crate::MpcError> {
        let bad = |field: &'static str, reason: &str| {
            Err(crate::MpcError::InvalidConfig {
                field,
                reason: reason.to_string(),
            })
        };
        if !(self.length > 0.0 && self.width > 0.0) {
            return bad("geometry.length/width", "must be > 0");
        }
        if self.anchor_head[0] == 0.0 || self.anchor_opening[0] == 0.0 {
            return bad(
                "geometry.anchor_head/anchor_opening",
                "must lie off the body y axis (front or back face)",
            );
        }
        let p = &self.anchor_polygon;
        if p.len() < 3 {
            return bad("geometry.anchor_polygon", "needs at least 3 vertices");
        }
        for k in 0..p.len() {
            let a = p[k];
            let b = p[(k + 1) % p.len()];
            let c = p[(k + 2) % p.len()];
            let cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
            if cross.is_nan() || cross <= 0.0 {
                return bad(
                    "geometry.anchor_polygon",
                    "must be convex, counter-clockwise, without repeated vertices",
                );
            }
        }
        Ok(())
    }

    /// Centroid of the anchor polygon's vertices: the preferred head position (maintenance cost).
    pub fn polygon_centre(&self) -> [f64; 2] {
        let n = self.anchor_polygon.len() as f64;
        let (sx, sy) = self
            .anchor_polygon
            .iter()
            .fold((0.0, 0.0), |(x, y), p| (x + p[0], y + p[1]));
        [sx / n, sy / n]
    }
}

/// Outcome of one robot's solve in a tick.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum SolveStatus {
    /// The QP(s) solved; `iterations` interior-point iterations in total.
    Solved {
        /// Interior-point iterations over all QPs of the tick.
        iterations: u32,
    },
    /// The solve failed (reason); the robot executes its last feasible plan, shifted.
    Fallback {
        /// Why the solve was rejected.
        reason: String,
        /// Consecutive ticks on the held plan, including this one.
        ticks: u32,
    },
    /// The solve failed and no usable held plan remains: the command is a stop.
    Stopped {
        /// Why the solve was rejected.
        reason: String,
    },
}

impl SolveStatus {
    /// True when this tick's plan came from a successful solve.
    pub fn is_solved(&self) -> bool {
        matches!(self, SolveStatus::Solved { .. })
    }
}

/// One robot's result of a tick.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotOutput {
    /// Robot id.
    pub id: RobotId,
    /// The checked command to execute now (inside box and butterfly).
    pub command: Command,
    /// Solver outcome.
    pub status: SolveStatus,
    /// Planned inputs u_0 … u_{H−1} (`command` = first).
    pub plan: Vec<Command>,
    /// Predicted poses x_0 … x_H of the plan (nonlinear rollout).
    pub predicted: Vec<Pose>,
}

/// Result of one tick for every robot, in input order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TickOutput {
    /// One entry per input robot, same order.
    pub robots: Vec<RobotOutput>,
}
