//! Coordinator settings: status machine tolerances, timing, and the staged approach of side
//! connections.

use super::*;

/// Staged approach of a side connection (see [`Role::Dock`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DockConfig {
    /// Length of the approach (m).
    pub run_in: f64,
    /// How far outside the final place the approach starts (m); the line follower then
    /// holds a smaller distance off the side until just before the place, past the wrong
    /// hole 25 mm before it ([`DockConfig::hold`]).
    pub offset: f64,
    /// Approach speed (m/s): above the wheels' start-up dead-band (20 RPM ≈ 0.036 m/s).
    pub speed: f64,
    /// Position tolerance of the approach's start (m).
    pub capture: f64,
    /// Heading per metre of lateral distance (rad/m): below 1 / (half a body length).
    pub k_lat: f64,
    /// Aim this far inside the partner's side (m), so the sides end up pressed together.
    pub press: f64,
    /// Largest heading towards the partner (rad).
    pub max_heading: f64,
    /// Heading gain: ω = −k_θ · heading error (1/s).
    pub k_theta: f64,
    /// An assembly bent more than this at an anchor (rad) straightens before a robot docks
    /// at its side.
    pub max_bend: f64,
    /// The docking robot reverses after passing its place by this much (m): less than the
    /// 25 mm to the next hole.
    pub overshoot: f64,
    /// Side docking: passes over the place without the knob clicking in after which the
    /// robot backs out along the side, clear of it, to the start of its approach and comes in
    /// afresh: a robot sweeping flush against a bent row keeps it from straightening
    /// ([`DockConfig::clearance`]) and pushes it further round. A pass over ±`overshoot`
    /// takes about 2 · overshoot / speed ≈ 0.5 s, so the default gives a knob some 4 s of
    /// sweeping; it is a policy bound, not fitted to episodes.
    pub max_passes: u32,
    /// A bent assembly straightens only while the docking robot is at least this far from
    /// its side (m); nearer, the moving holes could catch its knobs at the wrong place.
    pub clearance: f64,
    /// Stand-off of an anchor approach to a waiting pilot, on its axis (m).
    pub standoff: f64,
    /// Side docking: lateral distance kept from the partner's side (m) until the last
    /// [`DockConfig::converge`] before the place: above the knob's 1.5 mm seat gap where the
    /// knob passes the wrong hole, and small enough that the robot still reaches its place
    /// (held further off, a docking robot sweeps over its place without its knob finding the
    /// hole).
    pub hold: f64,
    /// Side docking: distance before the place where the robot closes [`DockConfig::hold`]
    /// (m): past the wrong hole 25 mm before the place.
    pub converge: f64,
    /// Side docking: a heading error (rad) above which the robot, still short of
    /// [`DockConfig::converge`], turns on the spot before it drives on: driving with a larger
    /// error closes the hold and clicks the knob in one hole early.
    pub turn_first: f64,
    /// Anchor approach: going in, at least this much nearer (m) every
    /// [`DockConfig::in_stall_s`], or the robot backs off to the stand-off and comes in again.
    pub in_progress: f64,
    /// See [`DockConfig::in_progress`] (s).
    pub in_stall_s: f64,
    /// Anchor approach: this far out from the final place (m) the robot must be on the axis
    /// within [`DockConfig::in_lateral`] and [`DockConfig::in_yaw`], or it backs off to the
    /// stand-off and comes in again.
    pub in_check: f64,
    /// Largest lateral offset from the axis at [`DockConfig::in_check`] (m): the anchor
    /// head's funnel.
    pub in_lateral: f64,
    /// Largest heading error at [`DockConfig::in_check`] (rad).
    pub in_yaw: f64,
    /// Slowest turn on the spot (rad/s): both wheels above the dead-band.
    pub min_turn: f64,
    /// Fastest turn on the spot (rad/s): below the butterfly's corner A (2.19 rad/s).
    pub max_turn: f64,
    /// Step of the search for a clear stand-off along an anchor approach's axis (m).
    pub standoff_step: f64,
    /// Extra run-in of an anchor approach whose axis runs between other robots (m): the
    /// line follower's lateral offset decays over 1 / [`DockConfig::k_lat`] of travel, and
    /// this is well over that.
    pub flush_run_in: f64,
    /// Lateral distance an anchor approach keeps from robots beside its axis (m): more than
    /// a knob's 1.5 mm seat gap.
    pub flush_offset: f64,
    /// Distance before the place where an anchor approach closes
    /// [`DockConfig::flush_offset`] (m): less than the 25 mm to the next wrong hole.
    pub flush_converge: f64,
    /// Speed of the robot hitched behind a lane train's leader relative to the leader's
    /// (ratio; [`Coordinator::lane_train_roles`]): slower, so the leader pulls it.
    pub lane_trail: f64,
    /// Fastest turn of a non-pilot leading a lane train (rad/s).
    pub lane_turn: f64,
    /// Growing: how far an assembly may drive ahead to straighten before a robot docks at
    /// its side (m, per pair).
    pub grow_straighten: f64,
    /// How far beyond the route clearance of an approach's stand-off a robot that makes
    /// way for it stands (m).
    pub standoff_margin: f64,
    /// How far around the robots a route may swing out (m).
    pub route_margin: f64,
    /// An anchor pair whose head stays inside the opening's guide, moving less than the
    /// anchor's travel, for this long (s) while one of its robots drives away from the other
    /// at the approach speed is coupled ([`tug`]): an uncoupled head would have left the
    /// guide within (travel + seat) / speed ≈ 0.12 s; this is ten times that plus the harsh
    /// profile's worst controller latency.
    pub tug_s: f64,
}

impl Default for DockConfig {
    fn default() -> Self {
        DockConfig {
            run_in: 0.10,
            offset: 0.006,
            speed: 0.05,
            capture: 0.012,
            k_lat: 20.0,
            press: 0.0003,
            max_heading: 0.2,
            k_theta: 4.0,
            max_bend: 0.04,
            overshoot: 0.012,
            clearance: 0.003,
            max_passes: 8,
            hold: 0.003,
            converge: 0.022,
            turn_first: 0.08,
            in_progress: 0.003,
            in_stall_s: 3.0,
            in_check: 0.01,
            in_lateral: 0.005,
            in_yaw: 0.2,
            standoff: 0.06,
            min_turn: 0.9,
            max_turn: 1.5,
            standoff_step: 0.02,
            flush_run_in: 0.08,
            flush_offset: 0.004,
            flush_converge: 0.02,
            lane_trail: 0.6,
            lane_turn: 0.5,
            grow_straighten: 0.1,
            standoff_margin: 0.01,
            route_margin: 0.3,
            tug_s: 1.5,
        }
    }
}

/// Coordinator settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CoordinatorConfig {
    /// Status machine tolerances.
    pub tolerances: PairTolerances,
    /// A planned robot unseen for this long is lost and the plan is recomputed (s).
    pub lost_after_s: f64,
    /// A pair starts only when every pair of a shorter centre distance is connected
    /// (strict convex-first, THESIS 5.2.2: rows before the side joins).
    pub strict_convex_first: bool,
    /// MPC horizon samples for trajectory references.
    pub horizon_steps: usize,
    /// MPC step (s).
    pub dt: f64,
    /// Heading gain of the THESIS (3.2) point controller used by rendezvous.
    pub heading_gain: f64,
    /// Staged approach of side connections.
    pub dock: DockConfig,
    /// A formation counts as complete once every planned pair has stayed connected this long
    /// (s): the last join can knock an earlier pair loose a moment after it connects.
    pub form_settle_s: f64,
    /// A grown formation whose planned pairs are all connected keeps its members at their
    /// planned places this long at most (s) for the layout's closing knobs to seat
    /// ([`super::Closure`]), then counts as complete with them open.
    pub closure_wait_s: f64,
    /// Smallest turning radius of a pilot (m,
    /// [`puzzlebot_params::drive::Drive::min_turn_radius`]).
    pub pilot_turn_radius: f64,
    /// Smallest turning radius of a non-pilot (m,
    /// [`puzzlebot_params::drive::Drive::min_turn_radius`]): its butterfly has no turn
    /// without motion, so a "turn on the spot" runs on a circle this wide
    /// ([`Coordinator::turn_in_place`]).
    pub turn_radius: f64,
    /// Room to spare between two robot bodies that pass or stand beside each other (m),
    /// added to their sizes ([`Coordinator::room`]).
    pub spare: f64,
    /// Gain pulling a hitched train member's connection point onto its neighbour's (1/s).
    pub hitch_gain: f64,
    /// Largest turn rate commanded to a hitched non-pilot train member (rad/s).
    pub hitch_max_turn: f64,
    /// Taking assemblies apart.
    pub decouple: DecoupleConfig,
}

/// Taking assemblies apart: released pairs driving clear, unplanned knobs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DecoupleConfig {
    /// Speed of a released pair's robot driving clear (m/s).
    pub clear_speed: f64,
    /// A released anchor pair drives apart until the head is this far out of the opening
    /// (m): held where it popped, a wiggling neighbour can push it back in while the rest
    /// of the train wiggles.
    pub clear: f64,
    /// A released anchor pair whose head is still not [`DecoupleConfig::clear`] out after
    /// this many times the time its robot needs to drive that far (plus the anchor's
    /// travel) at [`DecoupleConfig::clear_speed`] is still held: its legs did not pop
    /// although the measured yaw left the anchor's range for a moment, and driving straight
    /// on drags the partner along.
    pub clear_time_factor: f64,
    /// How far two knob-coupled robots may stand from their planned relative place (m) for
    /// the knob to count as planned: under half the 25 mm between a side's holes.
    pub knob_place_tolerance: f64,
    /// A person is asked again to lift an unplanned knob pair after this long (s).
    pub knob_lift_repeat_s: f64,
}

impl Default for DecoupleConfig {
    fn default() -> Self {
        DecoupleConfig {
            clear_speed: 0.02,
            clear: 0.015,
            clear_time_factor: 3.0,
            knob_place_tolerance: 0.008,
            knob_lift_repeat_s: 10.0,
        }
    }
}

impl Default for CoordinatorConfig {
    fn default() -> Self {
        CoordinatorConfig {
            tolerances: PairTolerances::default(),
            lost_after_s: 1.0,
            strict_convex_first: true,
            horizon_steps: 10,
            form_settle_s: 1.0,
            closure_wait_s: 10.0,
            dt: 0.1,
            heading_gain: 1.0,
            dock: DockConfig::default(),
            pilot_turn_radius: puzzlebot_params::drive::Drive::for_kind(RobotKind::Pilot)
                .min_turn_radius(),
            turn_radius: puzzlebot_params::drive::Drive::for_kind(RobotKind::NonPilot)
                .min_turn_radius(),
            spare: 0.005,
            hitch_gain: 1.0,
            hitch_max_turn: 1.5,
            decouple: DecoupleConfig::default(),
        }
    }
}
