//! The one PuzzleBot parameter set: every robot number the firmware, the simulator and
//! the host use, with THESIS defaults (DESIGN.md §8), loadable from TOML (`std` feature).
//!
//! Units are SI (m, kg, s, rad) unless a field name says otherwise (`_rpm`, `_ms`, `_mm`).
//! Values are `f32` so the `no_std` firmware shares them; the host widens to `f64`.
//!
//! Ownership of sections: [`geometry`] and [`mass`] (bodies), [`drive`] (host drive
//! mapping / calibration), [`firmware`] (on-robot loop), [`plant`] (simulator motor and
//! battery), [`coupling`] (anchor and knobs), [`rates`] (loop rates and link timing).
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod angle;
pub mod coupling;
pub mod drive;
pub mod firmware;
#[cfg(feature = "std")]
pub mod formation;
pub mod geometry;
#[cfg(feature = "std")]
pub mod kind_defaults;
#[cfg(feature = "std")]
pub mod load;
pub mod mass;
pub mod plant;
#[cfg(feature = "std")]
pub mod pose;
pub mod rates;
#[cfg(feature = "std")]
pub mod terrain;

pub use puzzlebot_protocol::RobotKind;

use serde::{Deserialize, Serialize};

/// Everything about one robot kind (or one calibrated robot).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotParams {
    /// Body and wheel geometry, connection points.
    pub geometry: geometry::Geometry,
    /// Mass and centre of mass.
    pub mass: mass::Mass,
    /// Host-side drive mapping (k_v, k_ω, M_min/M_max, butterfly).
    pub drive: drive::Drive,
    /// On-robot speed loop.
    pub firmware: firmware::Firmware,
    /// Simulated motor, gearbox, encoder and battery.
    pub plant: plant::Plant,
    /// Anchor and knob mechanics.
    pub coupling: coupling::Coupling,
}

impl Default for RobotParams {
    fn default() -> Self {
        RobotParams::for_kind(RobotKind::NonPilot)
    }
}

impl RobotParams {
    /// THESIS defaults of the chapter-5 robot (ESP32-C3, encoders) of the given kind.
    pub fn for_kind(kind: RobotKind) -> Self {
        RobotParams {
            geometry: geometry::Geometry::default(),
            mass: mass::Mass::for_kind(kind),
            drive: drive::Drive::for_kind(kind),
            firmware: firmware::Firmware::default(),
            plant: plant::Plant::for_kind(kind),
            coupling: coupling::Coupling::default(),
        }
    }
}

/// Parameters of both kinds of a fleet. Read from a file, each kind's table lies over that
/// kind's defaults ([`kind_defaults`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[cfg_attr(not(feature = "std"), derive(Deserialize))]
#[cfg_attr(not(feature = "std"), serde(default, deny_unknown_fields))]
pub struct FleetParams {
    /// Pilot robots.
    pub pilot: RobotParams,
    /// Non-pilot robots.
    pub non_pilot: RobotParams,
    /// Loop rates and link timing.
    pub rates: rates::Rates,
}

impl Default for FleetParams {
    fn default() -> Self {
        FleetParams {
            pilot: RobotParams::for_kind(RobotKind::Pilot),
            non_pilot: RobotParams::for_kind(RobotKind::NonPilot),
            rates: rates::Rates::default(),
        }
    }
}

impl FleetParams {
    /// Check ranges of both kinds (the couplings, [`coupling::Coupling::check`]); the error
    /// names the field (`pilot.coupling.<field>`).
    #[cfg(feature = "std")]
    pub fn check(&self) -> Result<(), std::string::String> {
        for (kind, r) in [("pilot", &self.pilot), ("non_pilot", &self.non_pilot)] {
            r.coupling.check().map_err(|e| std::format!("{kind}.{e}"))?;
        }
        Ok(())
    }

    /// Parameters of a robot of `kind`.
    pub fn robot(&self, kind: RobotKind) -> &RobotParams {
        match kind {
            RobotKind::Pilot => &self.pilot,
            RobotKind::NonPilot => &self.non_pilot,
        }
    }
}
