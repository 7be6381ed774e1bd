//! The fleet config (TOML): robots, key file, addresses, pose source, parameter overrides.
//!
//! ```toml
//! name = "lab"
//! key_file = "fleet.key"          # 64 hex characters; relative to this file
//!
//! [link]
//! bind = "127.0.0.1:47800"
//! discover_unlisted = false
//!
//! [pose]
//! source = "pbp1"                 # or "natnet"
//! bind = "127.0.0.1:47810"
//!
//! [[robots]]
//! id = 1
//! kind = "NonPilot"
//! params = "robot-1.toml"         # optional calibrated parameter file
//!
//! [params.rates]                  # any field of puzzlebot_params::FleetParams
//! offline_after_ms = 300
//! ```
//!
//! Every error names the file, the line and the field
//! ([`puzzlebot_params::load::from_toml_file`]).

use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use puzzlebot_params::{load::LoadError, FleetParams, RobotKind, RobotParams};
use puzzlebot_protocol::{messages::RobotId, FleetKey, DEFAULT_HOST_PORT};
use serde::{Deserialize, Serialize};

/// A fleet config or one of the files it references could not be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// TOML syntax or a field (file, line, column, field).
    #[error(transparent)]
    Load(#[from] LoadError),
    /// The key file is unreadable or not 64 hexadecimal characters.
    #[error("{path}: {message}")]
    Key {
        /// The key file.
        path: PathBuf,
        /// What is wrong (never the key itself).
        message: String,
    },
    /// A value parsed but is not usable.
    #[error("{path}: {field}: {message}")]
    Invalid {
        /// The config file.
        path: PathBuf,
        /// Dotted field name.
        field: String,
        /// What is wrong.
        message: String,
    },
}

/// Link settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LinkSection {
    /// Address the host binds for robot traffic.
    pub bind: SocketAddr,
    /// Accept robots that announce but are not listed under `[[robots]]`.
    pub discover_unlisted: bool,
}

impl Default for LinkSection {
    fn default() -> Self {
        LinkSection {
            bind: SocketAddr::from(([127, 0, 0, 1], DEFAULT_HOST_PORT)),
            discover_unlisted: false,
        }
    }
}

/// Which pose stream the host reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseSourceKind {
    /// The documented PBP1 stream (`puzzlebot_protocol::pose`), also the simulator's.
    Pbp1,
    /// OptiTrack NatNet frames of data (unicast).
    Natnet,
}

/// Which axis is up in the motion-capture frame (NatNet: Motive defaults to y-up).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UpAxis {
    /// y up: ground plane is x–(−z).
    Y,
    /// z up: ground plane is x–y.
    Z,
}

/// Pose input settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseSection {
    /// Stream format.
    pub source: PoseSourceKind,
    /// Address the host binds for the pose stream.
    pub bind: SocketAddr,
    /// NatNet bitstream version "major.minor" (NatNet only).
    pub natnet_version: String,
    /// Up axis of the capture frame (NatNet only).
    pub up_axis: UpAxis,
}

impl Default for PoseSection {
    fn default() -> Self {
        PoseSection {
            source: PoseSourceKind::Pbp1,
            bind: SocketAddr::from(([127, 0, 0, 1], puzzlebot_protocol::pose::DEFAULT_POSE_PORT)),
            natnet_version: "4.1".into(),
            up_axis: UpAxis::Y,
        }
    }
}

/// One robot of the fleet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotEntry {
    /// Robot id (as provisioned).
    pub id: RobotId,
    /// Pilot or non-pilot.
    pub kind: RobotKind,
    /// Optional parameter file of this robot (e.g. written by `puzzlebot calibrate`),
    /// relative to the config file.
    #[serde(default)]
    pub params: Option<PathBuf>,
}

/// The fleet config file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FleetConfig {
    /// Fleet name (run folders, logs).
    #[serde(default = "default_name")]
    pub name: String,
    /// File holding the 256-bit fleet key as 64 hex characters, relative to this file.
    pub key_file: PathBuf,
    /// Link settings.
    #[serde(default)]
    pub link: LinkSection,
    /// Pose input settings.
    #[serde(default)]
    pub pose: PoseSection,
    /// The robots.
    #[serde(default)]
    pub robots: Vec<RobotEntry>,
    /// Overrides of the shared parameter set (THESIS defaults otherwise).
    #[serde(default)]
    pub params: FleetParams,
}

fn default_name() -> String {
    "fleet".into()
}

/// A loaded fleet: the config, its key and each robot's parameters.
#[derive(Debug, Clone)]
pub struct Fleet {
    /// Where the config was read from.
    pub path: PathBuf,
    /// The config.
    pub config: FleetConfig,
    /// The fleet key (never logged; `Debug` is redacted).
    pub key: FleetKey,
    /// Parameters per listed robot (kind defaults, overrides, then the robot's own file).
    pub robot_params: Vec<(RobotId, RobotParams)>,
}

impl Fleet {
    /// Load a fleet config and everything it references.
    pub fn load(path: &Path) -> Result<Fleet, ConfigError> {
        let config: FleetConfig = puzzlebot_params::load::from_toml_file(path)?;
        let base = path.parent().unwrap_or_else(|| Path::new("."));
        let mut seen = std::collections::BTreeSet::new();
        for (i, r) in config.robots.iter().enumerate() {
            if !seen.insert(r.id) {
                return Err(ConfigError::Invalid {
                    path: path.to_path_buf(),
                    field: format!("robots[{i}].id"),
                    message: format!("robot id {} is listed twice", r.id),
                });
            }
        }
        let key_path = base.join(&config.key_file);
        let key = read_key(&key_path)?;
        let mut robot_params = Vec::new();
        for r in &config.robots {
            let p = match &r.params {
                Some(file) => RobotParams::from_file_for(r.kind, &base.join(file))?,
                None => config.params.robot(r.kind).clone(),
            };
            robot_params.push((r.id, p));
        }
        Ok(Fleet {
            path: path.to_path_buf(),
            config,
            key,
            robot_params,
        })
    }

    /// Parameters of robot `id` (listed robots), or the kind defaults with overrides.
    pub fn params_for(&self, id: RobotId, kind: RobotKind) -> RobotParams {
        self.robot_params
            .iter()
            .find(|(i, _)| *i == id)
            .map(|(_, p)| p.clone())
            .unwrap_or_else(|| self.config.params.robot(kind).clone())
    }
}

/// Read a fleet key file (64 hex characters, surrounding whitespace ignored).
pub fn read_key(path: &Path) -> Result<FleetKey, ConfigError> {
    let text = std::fs::read_to_string(path).map_err(|e| ConfigError::Key {
        path: path.to_path_buf(),
        message: format!("cannot read fleet key: {e}"),
    })?;
    FleetKey::from_hex(&text).ok_or_else(|| ConfigError::Key {
        path: path.to_path_buf(),
        message: "fleet key must be exactly 64 hexadecimal characters".into(),
    })
}

/// Write a fresh random fleet key file (hex), readable only by the owner where supported.
pub fn write_new_key(path: &Path) -> std::io::Result<FleetKey> {
    let mut k = [0u8; 32];
    rand::fill(&mut k);
    let hex: String = k.iter().map(|b| format!("{b:02x}")).collect();
    std::fs::write(path, format!("{hex}\n"))?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600))?;
    }
    Ok(FleetKey(k))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir() -> PathBuf {
        let d = std::env::temp_dir().join(format!(
            "pb-config-{}-{}",
            std::process::id(),
            rand::random::<u32>()
        ));
        std::fs::create_dir_all(&d).expect("temp dir");
        d
    }

    #[test]
    fn loads_a_full_config() {
        let d = dir();
        write_new_key(&d.join("fleet.key")).expect("key");
        std::fs::write(d.join("r2.toml"), "[drive]\nk_v = 0.002\n").expect("write");
        std::fs::write(
            d.join("fleet.toml"),
            "name = \"lab\"\nkey_file = \"fleet.key\"\n[[robots]]\nid = 1\nkind = \"NonPilot\"\n[[robots]]\nid = 2\nkind = \"Pilot\"\nparams = \"r2.toml\"\n[params.rates]\noffline_after_ms = 250\n",
        )
        .expect("write");
        let f = Fleet::load(&d.join("fleet.toml")).expect("valid");
        assert_eq!(f.config.robots.len(), 2);
        assert_eq!(f.config.params.rates.offline_after_ms, 250);
        assert_eq!(f.params_for(2, RobotKind::Pilot).drive.k_v, 0.002);
        assert_eq!(format!("{:?}", f.key), "FleetKey(<redacted>)");
    }

    #[test]
    fn errors_name_file_line_and_field() {
        let d = dir();
        write_new_key(&d.join("fleet.key")).expect("key");
        let p = d.join("fleet.toml");
        std::fs::write(
            &p,
            "key_file = \"fleet.key\"\n[[robots]]\nid = 1\nkind = \"Tank\"\n",
        )
        .expect("write");
        let msg = Fleet::load(&p).expect_err("bad kind").to_string();
        assert!(
            msg.contains("fleet.toml:4:") && msg.contains("Tank"),
            "{msg}"
        );
        std::fs::write(&p, "key_file = \"fleet.key\"\n[link]\nbind = 5\n").expect("write");
        let msg = Fleet::load(&p).expect_err("bad bind").to_string();
        assert!(msg.contains("fleet.toml:3:"), "{msg}");
        std::fs::write(&p, "key_file = \"missing.key\"\n").expect("write");
        let msg = Fleet::load(&p).expect_err("no key").to_string();
        assert!(msg.contains("missing.key"), "{msg}");
        std::fs::write(d.join("bad.key"), "xyz").expect("write");
        std::fs::write(&p, "key_file = \"bad.key\"\n").expect("write");
        let msg = Fleet::load(&p).expect_err("bad key").to_string();
        assert!(
            msg.contains("bad.key") && msg.contains("64 hexadecimal"),
            "{msg}"
        );
    }

    #[test]
    fn every_bad_input_is_one_line_naming_its_file() {
        let d = dir().join("bad-inputs");
        std::fs::create_dir_all(&d).expect("dir");
        write_new_key(&d.join("fleet.key")).expect("key");
        let p = d.join("fleet.toml");
        let load = |text: &str| {
            std::fs::write(&p, text).expect("write");
            let msg = Fleet::load(&p).expect_err("refused").to_string();
            assert_eq!(msg.lines().count(), 1, "one line: {msg}");
            msg
        };
        // An id out of range for a robot id (u16), or negative.
        for id in ["70000", "-1"] {
            let msg = load(&format!(
                "key_file = \"fleet.key\"\n[[robots]]\nid = {id}\nkind = \"Pilot\"\n"
            ));
            assert!(
                msg.contains("fleet.toml:3:") && msg.contains("u16"),
                "{msg}"
            );
        }
        // A key of the right length that is not hex, and one too long.
        for key in ["g".repeat(64), "ab".repeat(33)] {
            std::fs::write(d.join("odd.key"), &key).expect("write");
            let msg = load("key_file = \"odd.key\"\n");
            assert!(
                msg.contains("odd.key: fleet key must be exactly 64 hexadecimal"),
                "{msg}"
            );
            assert!(!msg.contains(&key[..8]), "the key is not echoed: {msg}");
        }
        // A missing config, a missing key file, a key that cannot be read.
        let msg = Fleet::load(&d.join("absent.toml"))
            .expect_err("missing")
            .to_string();
        assert!(
            msg.ends_with("absent.toml: cannot read: No such file or directory (os error 2)"),
            "{msg}"
        );
        let msg = load("key_file = \"absent.key\"\n");
        assert!(
            msg.contains("absent.key") && msg.contains("cannot read fleet key"),
            "{msg}"
        );
        std::fs::create_dir_all(d.join("dir.key")).expect("dir");
        let msg = load("key_file = \"dir.key\"\n");
        assert!(
            msg.contains("dir.key") && msg.contains("cannot read fleet key"),
            "{msg}"
        );
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let locked = d.join("locked.key");
            write_new_key(&locked).expect("key");
            std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o000))
                .expect("chmod");
            // Root reads any file: the refusal is only observable for other users.
            if std::fs::read(&locked).is_err() {
                let msg = load("key_file = \"locked.key\"\n");
                assert!(
                    msg.contains("locked.key: cannot read fleet key") && msg.contains("ermission"),
                    "{msg}"
                );
            }
        }
    }
}
