//! HAL-agnostic PuzzleBot robot logic (`no_std`): quadrature decoding, edge-timestamp speed
//! estimation, the gain-scheduled PI speed loop, the DRV8833 mapping and the authenticated
//! command session with failsafe. The ESP32-C3 image (`firmware/esp32c3`) and every robot
//! of the simulator (`hil-sim`) run exactly this code (DESIGN.md §2, §5).
//!
//! Nothing here reads a clock or touches hardware: time is passed in as microseconds since
//! boot, nonces come from a [`NonceSource`], encoder edges are fed to an [`Encoder`] (from a
//! GPIO interrupt or a simulated encoder), and [`Robot::tick`] returns the four PWM duties
//! of the DRV8833 ([`MotorOutputs`], per-mille of the PWM period, see [`drv8833`]).
//!
//! # Usage
//!
//! ```
//! use puzzlebot_firmware_core::{levels_of, Encoder, Robot, Sensors};
//! use puzzlebot_params::firmware::Firmware;
//! use puzzlebot_protocol::{FirmwareVersion, FleetKey, RobotKind, MAX_DATAGRAM};
//!
//! let key = FleetKey([7; 32]).robot_key(3);
//! let mut n = 0u8;
//! let nonces = move || { n = n.wrapping_add(1); [n; 16] }; // use a real RNG on hardware
//! let version = FirmwareVersion { major: 0, minor: 1, patch: 0 };
//! let mut robot = Robot::new(3, RobotKind::NonPilot, Some(key), Firmware::default(), version, nonces)
//!     .expect("default parameters are valid");
//!
//! // Encoders: one per wheel, fed from the any-edge interrupt with (A, B, timestamp µs).
//! let mut left = Encoder::new();
//! let right = Encoder::new();
//! left.init_levels(false, false);
//! let (a, b) = levels_of(1);
//! left.on_edge(a, b, 1_000);
//!
//! // The 50 Hz loop: tick, apply the outputs to the PWM channels, send what is pending.
//! let mut buf = [0u8; MAX_DATAGRAM];
//! let now_us = 20_000;
//! let sensors = Sensors {
//!     battery_mv: 3_900,
//!     rssi_dbm: -50,
//!     encoders: [left.snapshot(), right.snapshot()],
//! };
//! let out = robot.tick(now_us, &sensors);
//! assert!(out.is_stopped()); // nothing commanded yet: the motors coast
//! while let Some(len) = robot.poll_transmit(now_us, &mut buf) {
//!     let _datagram = &buf[..len]; // send over UDP to the host (an announce here)
//! }
//! // Every received UDP payload: robot.on_datagram(payload, now_us).
//! ```
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod drv8833;
pub mod encoder;
pub mod estimator;
pub mod model;
pub mod pi;
pub mod provision;
pub mod robot;
pub mod safety;
pub mod update;

pub use drv8833::{Decay, HBridge, MotorCommand, MotorOutputs, PWM_FULL_SCALE};
pub use encoder::{levels_of, Edge, Encoder, EncoderSnapshot, Step, EDGE_HISTORY};
pub use estimator::SpeedEstimator;
pub use pi::{GainSchedule, WheelController};
pub use provision::{Credentials, Provision, RecordError, RECORD_LEN};
pub use robot::{
    check_config, ConfigError, DriveMode, LinkStats, NonceSource, Robot, Sensors, Status,
};
pub use safety::{
    on_fault, reset_reason, Fault, FaultMark, HwReset, SafeOutputs, TickSupervisor, Watchdog,
    FAULT_OUTPUTS, WATCHDOG_TIMEOUT_MS,
};
pub use update::{Manifest, SlotError, Trial, TrialAction, UpdateRequest, UpdateSlot, Updater};
