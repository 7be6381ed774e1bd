//! Scenario files (TOML): robots with kinds and initial poses, terrain, link impairments,
//! motion-capture noise, initial couplings, parameter overrides and the seed.
//!
//! ```toml
//! seed = 7
//! [impairments]            # default for every robot
//! latency_ms = 2.0
//! jitter_ms = 1.0
//! loss = 0.01
//! [mocap]
//! position_noise_m = 0.0005
//! [[robots]]
//! id = 1
//! kind = "NonPilot"        # or "Pilot"
//! pose = [0.0, 0.0, 0.0]   # x (m), y (m), yaw (rad)
//! [[robots]]
//! id = 2
//! kind = "Pilot"
//! pose = [0.2, 0.0, 0.0]
//! impairments = { loss = 0.1 }   # this robot only
//! [[terrain.platforms]]
//! name = "start"
//! polygon = [[-1.0, -1.0], [0.5, -1.0], [0.5, 1.0], [-1.0, 1.0]]
//! height = 0.045
//! ```

use crate::math::Pose;
use crate::mechanics::LinkKind;
use crate::mocap::MocapConfig;
use crate::radio::Impairments;
use puzzlebot_params::load::{from_toml_file, from_toml_str, LoadError};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind, RobotParams};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One robot of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    /// Robot id (unique).
    pub id: u16,
    /// Pilot or non-pilot.
    #[serde(default = "default_kind")]
    pub kind: RobotKind,
    /// Initial pose [x, y, yaw] (m, m, rad).
    #[serde(default)]
    pub pose: [f64; 3],
    /// This robot's link impairments (default: the scenario's).
    #[serde(default)]
    pub impairments: Option<Impairments>,
    /// Start switched off (no firmware running until `set_online`).
    #[serde(default)]
    pub offline: bool,
    /// How this robot's plant differs from the parameters everyone (the host too) believes.
    #[serde(default)]
    pub mismatch: PlantMismatch,
}

/// Host-model mismatch of one robot (DESIGN §6): factors on the believed parameters that the
/// simulated plant runs with instead (1 = as believed), as real robots differ from their
/// nominal parameter set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlantMismatch {
    /// Factor on the motor's torque / back-EMF constant `plant.motor_k` (motor gain).
    pub motor_gain: f64,
    /// Factor on the static friction `plant.friction_static` (the start-up dead-band).
    pub dead_band: f64,
    /// Factor on the wheel radius `geometry.wheel_radius`.
    pub wheel_radius: f64,
}

impl PlantMismatch {
    /// The plant is exactly as believed.
    pub const NONE: PlantMismatch = PlantMismatch {
        motor_gain: 1.0,
        dead_band: 1.0,
        wheel_radius: 1.0,
    };

    /// Check ranges (each factor within 0.5…2); the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        for (n, v) in [
            ("motor_gain", self.motor_gain),
            ("dead_band", self.dead_band),
            ("wheel_radius", self.wheel_radius),
        ] {
            if !(v.is_finite() && (0.5..=2.0).contains(&v)) {
                return Err(format!("{n}: must be within 0.5..=2, got {v}"));
            }
        }
        Ok(())
    }

    /// `believed` as this robot's plant really is.
    pub fn apply(&self, believed: &RobotParams) -> RobotParams {
        let mut p = believed.clone();
        p.plant.motor_k = (f64::from(p.plant.motor_k) * self.motor_gain) as f32;
        p.plant.friction_static = (f64::from(p.plant.friction_static) * self.dead_band) as f32;
        p.geometry.wheel_radius = (f64::from(p.geometry.wheel_radius) * self.wheel_radius) as f32;
        p
    }
}

impl Default for PlantMismatch {
    fn default() -> Self {
        PlantMismatch::NONE
    }
}

fn default_kind() -> RobotKind {
    RobotKind::NonPilot
}

/// A coupling that holds at the start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CouplingSpec {
    /// Anchor or knob.
    pub kind: LinkKind,
    /// Robot id with the anchor / knob.
    pub a: u16,
    /// Robot id with the opening / hole.
    pub b: u16,
}

/// A whole scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Scenario {
    /// Seed of every random stream (link, mocap, boot nonces).
    pub seed: u64,
    /// Robots.
    pub robots: Vec<RobotSpec>,
    /// Terrain (default: endless flat floor).
    pub terrain: Terrain,
    /// Default link impairments.
    pub impairments: Impairments,
    /// Motion capture.
    pub mocap: MocapConfig,
    /// Couplings that hold at the start.
    pub couplings: Vec<CouplingSpec>,
    /// Robot parameters (THESIS defaults; override any field).
    pub params: FleetParams,
}

impl Default for Scenario {
    fn default() -> Self {
        Scenario {
            seed: 1,
            robots: Vec::new(),
            terrain: Terrain::flat(),
            impairments: Impairments::NONE,
            mocap: MocapConfig::default(),
            couplings: Vec::new(),
            params: FleetParams::default(),
        }
    }
}

/// Why a scenario cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// Unreadable or unparsable file (names file, line, column and field).
    #[error(transparent)]
    Load(#[from] LoadError),
    /// A value is out of range (names the field).
    #[error("{0}")]
    Invalid(String),
}

impl Scenario {
    /// `n` non-pilot robots with ids 1…n in rows of ten, 0.15 m apart, facing +x.
    pub fn grid(n: usize, seed: u64) -> Scenario {
        let robots = (0..n)
            .map(|i| RobotSpec {
                id: (i + 1) as u16,
                kind: RobotKind::NonPilot,
                pose: [(i % 10) as f64 * 0.15, (i / 10) as f64 * 0.15, 0.0],
                impairments: None,
                offline: false,
                mismatch: PlantMismatch::NONE,
            })
            .collect();
        Scenario {
            seed,
            robots,
            ..Scenario::default()
        }
    }

    /// Parse TOML text; `path` names the source in errors.
    pub fn from_toml(path: &Path, text: &str) -> Result<Scenario, ScenarioError> {
        let s: Scenario = from_toml_str(path, text)?;
        s.validate()
            .map_err(|e| ScenarioError::Invalid(format!("{}: {e}", path.display())))?;
        Ok(s)
    }

    /// Read and parse a TOML file.
    pub fn from_file(path: &Path) -> Result<Scenario, ScenarioError> {
        let s: Scenario = from_toml_file(path)?;
        s.validate()
            .map_err(|e| ScenarioError::Invalid(format!("{}: {e}", path.display())))?;
        Ok(s)
    }

    /// Check ids, numbers and ranges; the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        let mut ids: Vec<u16> = self.robots.iter().map(|r| r.id).collect();
        ids.sort_unstable();
        if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
            return Err(format!("robots: id {} appears twice", w[0]));
        }
        for (i, r) in self.robots.iter().enumerate() {
            if r.pose.iter().any(|v| !v.is_finite()) {
                return Err(format!("robots[{i}].pose: non-finite number"));
            }
            if let Some(imp) = &r.impairments {
                imp.validate()
                    .map_err(|e| format!("robots[{i}].impairments.{e}"))?;
            }
            r.mismatch
                .validate()
                .map_err(|e| format!("robots[{i}].mismatch.{e}"))?;
        }
        self.impairments
            .validate()
            .map_err(|e| format!("impairments.{e}"))?;
        self.mocap.validate().map_err(|e| format!("mocap.{e}"))?;
        self.terrain
            .validate()
            .map_err(|e| format!("terrain.{e}"))?;
        for (i, c) in self.couplings.iter().enumerate() {
            for (f, id) in [("a", c.a), ("b", c.b)] {
                if !ids.contains(&id) {
                    return Err(format!("couplings[{i}].{f}: no robot with id {id}"));
                }
            }
            if c.a == c.b {
                return Err(format!("couplings[{i}]: a robot cannot couple to itself"));
            }
        }
        for (name, p) in [
            ("pilot", &self.params.pilot),
            ("non_pilot", &self.params.non_pilot),
        ] {
            puzzlebot_firmware_core::check_config(&p.firmware)
                .map_err(|e| format!("params.{name}.{e}"))?;
            let g = &p.geometry;
            if !(g.wheel_radius > 0.0 && g.wheel_base > 0.0 && g.length > 0.0 && g.width > 0.0) {
                return Err(format!("params.{name}.geometry: sizes must be > 0"));
            }
            let pl = &p.plant;
            let positive = [
                ("motor_resistance", pl.motor_resistance),
                ("motor_k", pl.motor_k),
                ("rotor_inertia", pl.rotor_inertia),
                ("gear_ratio", pl.gear_ratio),
                ("gear_efficiency", pl.gear_efficiency),
                ("yaw_inertia", pl.yaw_inertia),
                ("traction_slip_speed", pl.traction_slip_speed),
                ("battery_capacity_mah", pl.battery_capacity_mah),
            ];
            for (f, v) in positive {
                if !(v.is_finite() && v > 0.0) {
                    return Err(format!("params.{name}.plant.{f}: must be > 0, got {v}"));
                }
            }
            if !(p.mass.mass.is_finite() && p.mass.mass > 0.0) {
                return Err(format!("params.{name}.mass.mass: must be > 0"));
            }
        }
        Ok(())
    }

    /// Initial pose of robot spec `r`.
    pub fn pose_of(r: &RobotSpec) -> Pose {
        Pose::new(r.pose[0], r.pose[1], r.pose[2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_documented_example_and_names_bad_fields() {
        let text = r#"
seed = 7
[impairments]
latency_ms = 2.0
[[robots]]
id = 1
kind = "NonPilot"
pose = [0.0, 0.0, 0.0]
[[robots]]
id = 2
kind = "Pilot"
pose = [0.2, 0.0, 0.0]
impairments = { loss = 0.1 }
[[terrain.platforms]]
polygon = [[-1.0, -1.0], [0.5, -1.0], [0.5, 1.0], [-1.0, 1.0]]
height = 0.045
[[couplings]]
kind = "Anchor"
a = 2
b = 1
"#;
        let s = Scenario::from_toml(Path::new("s.toml"), text).expect("valid");
        assert_eq!(s.seed, 7);
        assert_eq!(s.robots[1].kind, RobotKind::Pilot);
        assert_eq!(s.robots[1].impairments.map(|i| i.loss), Some(0.1));
        assert_eq!(s.terrain.platforms.len(), 1);
        let bad = text.replace("latency_ms = 2.0", "latency_ms = \"slow\"");
        let e = Scenario::from_toml(Path::new("s.toml"), &bad)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("s.toml:4:"), "{e}");
        let dup = text.replace("id = 2", "id = 1");
        let e = Scenario::from_toml(Path::new("s.toml"), &dup)
            .unwrap_err()
            .to_string();
        assert!(e.contains("id 1 appears twice"), "{e}");
        let neg = text.replace("loss = 0.1", "loss = 2.0");
        let e = Scenario::from_toml(Path::new("s.toml"), &neg)
            .unwrap_err()
            .to_string();
        assert!(e.contains("robots[1].impairments.loss"), "{e}");
    }
}
