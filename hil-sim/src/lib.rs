//! Software-in-the-loop simulator: motor/body/coupling plant running `firmware/core`
//! over loopback UDP (DESIGN.md §6).
//!
//! * [`drive`]: DC motor (R, L, k_t, k_e, rotor inertia), gearbox with stiction
//!   (start-up dead-band), traction-limited wheels, pilot / non-pilot bodies, LiPo sag.
//! * [`encoder`]: magnetic quadrature encoder with exact edge timestamps.
//! * [`mechanics`]: contacts and anchor / knob couplings (position-based model; the module
//!   says why no physics engine).
//! * [`radio`], [`mocap`]: impaired virtual radio, noisy 100 Hz motion capture.
//! * [`physics3d`]: the 3-D crossing world (rapier3d): formed assemblies over gaps and steps.
//! * [`world`]: the lockstep [`World`] (no sockets, deterministic from the seed).
//! * [`fleet`]: [`SimFleet`], the world in its own thread with one UDP socket per robot on
//!   127.0.0.1 and the pose stream, for the host and end-to-end tests.
//! * [`scenario`]: TOML scenario files.
//! * [`watchdog`]: the firmware's watchdog and fault path on a simulated robot.
//!
//! ```no_run
//! use puzzlebot_sim::{Pace, Scenario, SimFleet, SimOptions};
//! use puzzlebot_protocol::FleetKey;
//! let fleet = SimFleet::start(
//!     Scenario::grid(4, 1),
//!     SimOptions {
//!         fleet_key: FleetKey([7; 32]),
//!         host_addr: "127.0.0.1:47800".parse().unwrap(),
//!         pose_addr: None,
//!         pace: Pace::RealTime,
//!     },
//! )
//! .expect("fleet starts");
//! println!("robot 1 listens on {}", fleet.robot_addr(1).unwrap());
//! let truth = fleet.ground_truth();
//! fleet.stop();
//! # let _ = truth;
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod calibration;
pub mod drive;
pub mod encoder;
pub mod fleet;
pub mod math;
pub mod mechanics;
pub mod mocap;
pub mod ota;
pub mod physics3d;
pub mod radio;
pub mod rng;
pub mod scenario;
pub mod watchdog;
pub mod world;

pub use fleet::{FleetError, Pace, SimFleet, SimOptions};
pub use math::Pose;
pub use mechanics::LinkKind;
pub use mocap::MocapConfig;
pub use radio::Impairments;
pub use scenario::{CouplingSpec, PlantMismatch, RobotSpec, Scenario, ScenarioError};
pub use world::{EventKind, GroundTruth, RobotTruth, SimEvent, World, WorldError, LIFT_APART};
