//! Setting up a fleet: `puzzlebot fleet init` writes a commented fleet config and a fresh
//! fleet key; `puzzlebot fleet add` lists a robot in it; `puzzlebot fleet robot-key` prints
//! the key one robot is provisioned with (`firmware/README.md`). Nothing is overwritten and
//! nothing is left half-written.

use std::io::Write;
use std::path::{Path, PathBuf};

use puzzlebot_protocol::messages::{RobotId, RobotKind};

use crate::config::{ConfigError, Fleet};

/// Name of the fleet config `init` writes.
pub const CONFIG_FILE: &str = "fleet.toml";
/// Name of the key file `init` writes.
pub const KEY_FILE: &str = "fleet.key";

/// A fleet could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The file is there already; `init` never overwrites.
    #[error("{0}: already exists; not overwritten (remove it, or choose another folder)")]
    Exists(PathBuf),
    /// Reading or writing a file failed.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why (in the message, so it is not repeated as an error source).
        cause: std::io::Error,
    },
    /// The fleet config or its key is not usable.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The robot is listed already.
    #[error("{path}: robots: robot {id} is listed already")]
    Duplicate {
        /// The fleet config.
        path: PathBuf,
        /// The robot id.
        id: RobotId,
    },
}

/// The fleet config `init` writes: loopback addresses (a lab sets its own), no robots yet.
fn config_text() -> String {
    format!(
        "# PuzzleBot fleet config (host/README.md). Paths are relative to this file.\n\
         name = \"lab\"\n\
         # The 256-bit fleet key (64 hex characters). It never leaves the host: each robot is\n\
         # provisioned with its own key, `puzzlebot fleet robot-key ID`.\n\
         key_file = \"{KEY_FILE}\"\n\
         \n\
         [link]\n\
         # Where the host listens for robots; a real fleet binds the lab network's address.\n\
         bind = \"127.0.0.1:47800\"\n\
         # Accept robots that announce but are not listed below.\n\
         discover_unlisted = false\n\
         \n\
         [pose]\n\
         # \"pbp1\" (the documented UDP pose stream, also the simulator's) or \"natnet\".\n\
         source = \"pbp1\"\n\
         bind = \"127.0.0.1:47810\"\n\
         \n\
         # One entry per robot:\n\
         # [[robots]]\n\
         # id = 1\n\
         # kind = \"NonPilot\"            # or \"Pilot\"\n\
         # params = \"robot-1.toml\"      # optional, written by `puzzlebot calibrate`\n"
    )
}

/// Write `fleet.toml`, a fresh `fleet.key` and a fresh update signing key `update.key`
/// (both readable by the owner only) into `dir`, creating it. Refuses when any of them
/// exists; removes the keys again when the config cannot be written. Returns the config
/// and fleet key paths.
pub fn init(dir: &Path) -> Result<(PathBuf, PathBuf), SetupError> {
    let (config, key) = (dir.join(CONFIG_FILE), dir.join(KEY_FILE));
    let sign = dir.join(crate::fleet_update::SIGN_FILE);
    for p in [&config, &key, &sign] {
        if p.exists() {
            return Err(SetupError::Exists(p.clone()));
        }
    }
    std::fs::create_dir_all(dir).map_err(|cause| SetupError::Io {
        path: dir.to_path_buf(),
        cause,
    })?;
    let mut bytes = [0u8; 32];
    rand::fill(&mut bytes);
    let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
    write_new(&key, &format!("{hex}\n"), 0o600)?;
    let written = write_new(&sign, &update_key_text(), 0o600)
        .and_then(|_| write_new(&config, &config_text(), 0o644));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&key);
        let _ = std::fs::remove_file(&sign);
        return Err(e);
    }
    Ok((config, key))
}

fn update_key_text() -> String {
    format!("{}\n", crate::fleet_update::fresh_key_hex())
}

/// Give the fleet config `fleet` an update signing key (`update.key` beside it, owner-only)
/// if it has none; a fleet set up before updates existed needs this once. Returns its path.
pub fn add_update_key(fleet: &Path) -> Result<PathBuf, SetupError> {
    Fleet::load(fleet)?;
    let path = crate::fleet_update::key_path(fleet);
    write_new(&path, &update_key_text(), 0o600)?;
    Ok(path)
}

/// Create `path` (never replacing a file) with `mode` where the platform has modes, and
/// write `text`; a file written in part is removed.
fn write_new(path: &Path, text: &str, mode: u32) -> Result<(), SetupError> {
    let mut open = std::fs::OpenOptions::new();
    open.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        open.mode(mode);
    }
    #[cfg(not(unix))]
    let _ = mode;
    let io = |cause| SetupError::Io {
        path: path.to_path_buf(),
        cause,
    };
    let mut f = open.open(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::AlreadyExists {
            SetupError::Exists(path.to_path_buf())
        } else {
            io(e)
        }
    })?;
    if let Err(e) = f.write_all(text.as_bytes()).and_then(|_| f.sync_all()) {
        let _ = std::fs::remove_file(path);
        return Err(io(e));
    }
    Ok(())
}

/// List robot `id` of `kind` in the fleet config `fleet` (appended as a `[[robots]]` entry,
/// the rest of the file and its comments kept). The config must load before and after;
/// the new text replaces the file only once it has loaded (written beside it, then
/// renamed), so a failure leaves the file as it was.
pub fn add_robot(fleet: &Path, id: RobotId, kind: RobotKind) -> Result<(), SetupError> {
    let loaded = Fleet::load(fleet)?;
    if loaded.config.robots.iter().any(|r| r.id == id) {
        return Err(SetupError::Duplicate {
            path: fleet.to_path_buf(),
            id,
        });
    }
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |cause| SetupError::Io { path, cause }
    };
    let mut text = std::fs::read_to_string(fleet).map_err(io(fleet))?;
    if !text.is_empty() && !text.ends_with('\n') {
        text.push('\n');
    }
    text.push_str(&format!("\n[[robots]]\nid = {id}\nkind = \"{kind:?}\"\n"));
    let name = fleet
        .file_name()
        .map_or_else(|| "fleet.toml".into(), |n| n.to_string_lossy().into_owned());
    let next = fleet.with_file_name(format!(".{name}.new"));
    let _ = std::fs::remove_file(&next);
    write_new(&next, &text, 0o644)?;
    if let Err(e) = Fleet::load(&next) {
        let _ = std::fs::remove_file(&next);
        return Err(e.into());
    }
    std::fs::rename(&next, fleet).map_err(|e| {
        let _ = std::fs::remove_file(&next);
        io(fleet)(e)
    })
}

/// The key robot `id` of the fleet config `fleet` is provisioned with, as 64 hex characters.
pub fn robot_key_hex(fleet: &Path, id: RobotId) -> Result<String, SetupError> {
    let fleet = Fleet::load(fleet)?;
    Ok(fleet
        .key
        .robot_key(id)
        .0
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect())
}

/// `puzzlebot fleet check`: one line per listed robot (online, announced kind, firmware
/// version) and the problems found: a listed robot offline or without a session, a kind
/// other than the config's, firmware versions that differ, robots online but not listed.
/// No problems: ready to run.
pub fn check_report(
    listed: &[crate::config::RobotEntry],
    statuses: &[crate::link::RobotStatus],
) -> (String, Vec<String>) {
    let mut table = format!(
        "{:>5}  {:<9} {:<9} {:<8} {}\n",
        "robot", "listed", "announced", "link", "firmware"
    );
    let mut problems = Vec::new();
    let kind = |k: Option<RobotKind>| match k {
        Some(RobotKind::Pilot) => "pilot",
        Some(RobotKind::NonPilot) => "non-pilot",
        None => "-",
    };
    let mut versions = std::collections::BTreeSet::new();
    for r in listed {
        let s = statuses.iter().find(|s| s.id == r.id);
        let online = s.is_some_and(|s| s.online && s.established);
        let announced = s.and_then(|s| s.kind);
        let firmware = s.and_then(|s| s.firmware);
        table.push_str(&format!(
            "{:>5}  {:<9} {:<9} {:<8} {}\n",
            r.id,
            kind(Some(r.kind)),
            kind(announced),
            if online { "online" } else { "offline" },
            firmware.map_or_else(|| "-".into(), |(a, b, c)| format!("{a}.{b}.{c}"))
        ));
        if !online {
            problems.push(format!("robot {}: not online with a session", r.id));
        }
        if announced.is_some_and(|k| k != r.kind) {
            problems.push(format!(
                "robot {}: announces itself as {} but is listed as {}",
                r.id,
                kind(announced),
                kind(Some(r.kind))
            ));
        }
        versions.extend(firmware);
    }
    if versions.len() > 1 {
        let v: Vec<String> = versions
            .iter()
            .map(|(a, b, c)| format!("{a}.{b}.{c}"))
            .collect();
        problems.push(format!("firmware versions differ: {}", v.join(", ")));
    }
    for s in statuses {
        if s.online && !listed.iter().any(|r| r.id == s.id) {
            problems.push(format!("robot {}: online but not listed", s.id));
        }
    }
    (table, problems)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!(
            "puzzlebot-fleet-setup-{name}-{}",
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn init_writes_a_fleet_that_loads_and_never_overwrites_it() {
        let d = scratch("init");
        let (config, key) = init(&d).expect("init");
        let fleet = Fleet::load(&config).expect("the written config loads");
        assert!(fleet.config.robots.is_empty());
        assert!(fleet.config.link.bind.ip().is_loopback());
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&key).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o600, "the key is readable by its owner only");
        }
        assert!(crate::fleet_update::verifying_key(&config)
            .unwrap()
            .is_some());
        let before = std::fs::read_to_string(&key).unwrap();
        let err = init(&d).unwrap_err().to_string();
        assert!(
            err.contains("fleet.toml: already exists"),
            "one line naming the file: {err}"
        );
        assert_eq!(std::fs::read_to_string(&key).unwrap(), before, "key kept");
        // Each init makes its own key.
        let d2 = scratch("init2");
        let (_, key2) = init(&d2).unwrap();
        assert_ne!(std::fs::read_to_string(key2).unwrap(), before);
        let _ = std::fs::remove_dir_all(&d);
        let _ = std::fs::remove_dir_all(&d2);
    }

    #[test]
    fn a_key_file_alone_is_not_replaced_and_no_config_is_left_behind() {
        let d = scratch("key-only");
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join(KEY_FILE), "old").unwrap();
        let err = init(&d).unwrap_err().to_string();
        assert!(err.contains("fleet.key: already exists"), "{err}");
        assert!(!d.join(CONFIG_FILE).exists(), "nothing half-written");
        assert!(!d.join(crate::fleet_update::SIGN_FILE).exists());
        assert_eq!(std::fs::read_to_string(d.join(KEY_FILE)).unwrap(), "old");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn a_fleet_without_an_update_key_gets_one_once() {
        let d = scratch("update-key");
        let (config, _) = init(&d).unwrap();
        let sign = crate::fleet_update::key_path(&config);
        std::fs::remove_file(&sign).unwrap();
        assert_eq!(add_update_key(&config).unwrap(), sign);
        assert!(crate::fleet_update::read_signing_key(&config).is_ok());
        let err = add_update_key(&config).unwrap_err().to_string();
        assert!(err.contains("update.key: already exists"), "{err}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn robots_are_added_once_and_the_config_keeps_its_comments() {
        let d = scratch("add");
        let (config, _) = init(&d).unwrap();
        add_robot(&config, 3, RobotKind::Pilot).expect("add 3");
        add_robot(&config, 4, RobotKind::NonPilot).expect("add 4");
        let fleet = Fleet::load(&config).unwrap();
        let listed: Vec<(RobotId, RobotKind)> =
            fleet.config.robots.iter().map(|r| (r.id, r.kind)).collect();
        assert_eq!(
            listed,
            vec![(3, RobotKind::Pilot), (4, RobotKind::NonPilot)]
        );
        let text = std::fs::read_to_string(&config).unwrap();
        assert!(text.contains("# PuzzleBot fleet config"), "comments kept");
        let err = add_robot(&config, 3, RobotKind::NonPilot)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("fleet.toml: robots: robot 3 is listed already"),
            "{err}"
        );
        assert_eq!(std::fs::read_to_string(&config).unwrap(), text, "unchanged");
        // A config that does not load is left as it is.
        std::fs::write(&config, "name = 5\n").unwrap();
        assert!(add_robot(&config, 5, RobotKind::Pilot).is_err());
        assert_eq!(std::fs::read_to_string(&config).unwrap(), "name = 5\n");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn the_check_names_offline_robots_wrong_kinds_and_mixed_firmware() {
        use crate::config::RobotEntry;
        use crate::link::{LinkStats, RobotStatus};
        let entry = |id, kind| RobotEntry {
            id,
            kind,
            params: None,
        };
        let status = |id, kind, firmware| RobotStatus {
            id,
            kind: Some(kind),
            firmware: Some(firmware),
            addr: None,
            online: true,
            established: true,
            silent_s: Some(0.0),
            telemetry: None,
            telemetry_t: None,
            stats: LinkStats::default(),
        };
        let listed = [entry(1, RobotKind::Pilot), entry(2, RobotKind::NonPilot)];
        let ready = [
            status(1, RobotKind::Pilot, (0, 3, 0)),
            status(2, RobotKind::NonPilot, (0, 3, 0)),
        ];
        let (table, problems) = check_report(&listed, &ready);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(table.lines().count(), 3, "{table}");
        let wrong = [
            status(1, RobotKind::NonPilot, (0, 3, 0)),
            status(5, RobotKind::NonPilot, (0, 4, 0)),
        ];
        let (_, problems) = check_report(&listed, &wrong);
        assert_eq!(
            problems,
            vec![
                "robot 1: announces itself as non-pilot but is listed as pilot".to_string(),
                "robot 2: not online with a session".to_string(),
                "robot 5: online but not listed".to_string(),
            ]
        );
        let mixed = [
            status(1, RobotKind::Pilot, (0, 3, 0)),
            status(2, RobotKind::NonPilot, (0, 4, 0)),
        ];
        let (_, problems) = check_report(&listed, &mixed);
        assert_eq!(problems, vec!["firmware versions differ: 0.3.0, 0.4.0"]);
    }

    #[test]
    fn robot_keys_are_the_fleet_keys_derivation_and_a_bad_key_is_named() {
        let d = scratch("robot-key");
        let (config, _) = init(&d).unwrap();
        let fleet = Fleet::load(&config).unwrap();
        let want: String = fleet
            .key
            .robot_key(3)
            .0
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        assert_eq!(robot_key_hex(&config, 3).unwrap(), want);
        assert_ne!(robot_key_hex(&config, 4).unwrap(), want);
        std::fs::write(d.join(KEY_FILE), "not hex\n").unwrap();
        let err = robot_key_hex(&config, 3).unwrap_err().to_string();
        assert!(
            err.contains("fleet.key") && err.contains("64 hexadecimal"),
            "{err}"
        );
        let _ = std::fs::remove_dir_all(&d);
    }
}
