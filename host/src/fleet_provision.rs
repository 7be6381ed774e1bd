//! `puzzlebot fleet provision`: the provisioning record of one robot, as a blob for
//! `espflash write-bin` (`firmware/README.md`). Every robot runs the same image; this
//! record (format and parser: `puzzlebot_firmware_core::provision`) makes it robot `id`.

use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::path::{Path, PathBuf};

use puzzlebot_firmware_core::provision::{Credentials, Provision, RECORD_LEN};
use puzzlebot_protocol::{RobotId, DEFAULT_HOST_PORT};

use crate::config::{ConfigError, Fleet};

/// Flash offset of the `robot` data partition in `firmware/esp32c3/partitions.csv`
/// (checked against the file by a test).
pub const PARTITION_OFFSET: u32 = 0x3D_0000;
/// Environment variable the Wi-Fi password is read from (never a command-line argument).
pub const PASSWORD_ENV: &str = "PUZZLEBOT_WIFI_PASSWORD";

/// A record could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ProvisionError {
    /// The fleet config or its key is not usable.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The robot is not in the fleet config.
    #[error("{path}: robots: robot {id} is not listed (add it: puzzlebot fleet add --id {id} --kind pilot|non-pilot)")]
    NotListed {
        /// The fleet config.
        path: PathBuf,
        /// The robot id.
        id: RobotId,
    },
    /// The host address in the config is not one a robot can reach.
    #[error(
        "{path}: link.bind: {addr} is not an address robots can reach; give --host a.b.c.d[:port]"
    )]
    Unreachable {
        /// The fleet config.
        path: PathBuf,
        /// The bound address.
        addr: SocketAddr,
    },
    /// A command-line value is not usable.
    #[error("{arg}: {message}")]
    Arg {
        /// The option.
        arg: &'static str,
        /// What is wrong.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why (in the message, so it is not repeated as an error source).
        cause: std::io::Error,
    },
}

/// What `provision` needs besides the fleet config.
#[derive(Debug, Clone)]
pub struct Request {
    /// The robot.
    pub id: RobotId,
    /// Wi-Fi network name.
    pub ssid: String,
    /// WPA2 passphrase (empty: open network).
    pub password: String,
    /// Host address override (`a.b.c.d[:port]`); default: the config's `link.bind`.
    pub host: Option<String>,
}

/// The record of robot `req.id` of the fleet config at `fleet`: its kind from the config,
/// its key derived from the fleet key, the host address, the Wi-Fi credentials and the
/// fleet's update key (`None`: the robot refuses updates).
pub fn record(
    fleet: &Path,
    req: &Request,
    update_key: Option<[u8; 32]>,
) -> Result<[u8; RECORD_LEN], ProvisionError> {
    let loaded = Fleet::load(fleet)?;
    let entry = loaded
        .config
        .robots
        .iter()
        .find(|r| r.id == req.id)
        .ok_or_else(|| ProvisionError::NotListed {
            path: fleet.to_path_buf(),
            id: req.id,
        })?;
    let host = match &req.host {
        Some(h) => parse_host(h)?,
        None => match loaded.config.link.bind {
            SocketAddr::V4(a) if reachable(*a.ip()) => a,
            addr => {
                return Err(ProvisionError::Unreachable {
                    path: fleet.to_path_buf(),
                    addr,
                })
            }
        },
    };
    let wifi = Credentials {
        ssid: &req.ssid,
        password: &req.password,
    };
    let p = Provision::new(
        req.id,
        entry.kind,
        loaded.key.robot_key(req.id),
        host,
        wifi,
        update_key,
    )
    .map_err(|e| {
        let arg = match e {
            puzzlebot_firmware_core::RecordError::Ssid => "--ssid",
            puzzlebot_firmware_core::RecordError::Password => PASSWORD_ENV,
            _ => "--host",
        };
        let text = e.to_string();
        let message = text
            .strip_prefix("provisioning record: ")
            .unwrap_or(&text)
            .to_string();
        ProvisionError::Arg { arg, message }
    })?;
    Ok(p.encode())
}

fn reachable(ip: Ipv4Addr) -> bool {
    !(ip.is_unspecified() || ip.is_loopback() || ip.is_broadcast() || ip.is_multicast())
}

/// `a.b.c.d` (default port) or `a.b.c.d:port`, an address a robot can send to.
fn parse_host(s: &str) -> Result<SocketAddrV4, ProvisionError> {
    let bad = |message: String| ProvisionError::Arg {
        arg: "--host",
        message,
    };
    let s = s.trim();
    let addr = s
        .parse::<SocketAddrV4>()
        .or_else(|_| {
            s.parse::<Ipv4Addr>()
                .map(|ip| SocketAddrV4::new(ip, DEFAULT_HOST_PORT))
        })
        .map_err(|_| bad(format!("'{s}' is not a.b.c.d or a.b.c.d:port")))?;
    if !reachable(*addr.ip()) || addr.port() == 0 {
        return Err(bad(format!("{addr} is not an address robots can reach")));
    }
    Ok(addr)
}

/// Write `blob` to `path`, readable by the owner only (it holds the robot key and the
/// Wi-Fi password); written beside it and renamed, so a failure leaves no partial file.
pub fn write_blob(path: &Path, blob: &[u8]) -> Result<(), ProvisionError> {
    use std::io::Write;
    let io = |cause| ProvisionError::Io {
        path: path.to_path_buf(),
        cause,
    };
    let name = path
        .file_name()
        .map_or_else(|| "robot.bin".into(), |n| n.to_string_lossy().into_owned());
    let next = path.with_file_name(format!(".{name}.new"));
    let _ = std::fs::remove_file(&next);
    let mut open = std::fs::OpenOptions::new();
    open.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        open.mode(0o600);
    }
    let written = open
        .open(&next)
        .and_then(|mut f| f.write_all(blob).and_then(|_| f.sync_all()))
        .and_then(|_| std::fs::rename(&next, path));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&next);
        return Err(io(e));
    }
    Ok(())
}

/// The Wi-Fi password: the first line of `file`, else [`PASSWORD_ENV`], else empty (an
/// open network).
pub fn read_password(file: Option<&Path>) -> Result<String, ProvisionError> {
    match file {
        Some(f) => {
            let text = std::fs::read_to_string(f).map_err(|cause| ProvisionError::Io {
                path: f.to_path_buf(),
                cause,
            })?;
            Ok(text.lines().next().unwrap_or("").to_string())
        }
        None => Ok(std::env::var(PASSWORD_ENV).unwrap_or_default()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_firmware_core::{Provision, RecordError};
    use puzzlebot_protocol::RobotKind;

    fn fleet(name: &str) -> (PathBuf, PathBuf) {
        let d =
            std::env::temp_dir().join(format!("puzzlebot-provision-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        let (config, _) = crate::fleet_setup::init(&d).expect("init");
        crate::fleet_setup::add_robot(&config, 3, RobotKind::Pilot).expect("add");
        (d, config)
    }

    fn request(host: Option<&str>) -> Request {
        Request {
            id: 3,
            ssid: "lab".into(),
            password: "correct horse".into(),
            host: host.map(str::to_string),
        }
    }

    #[test]
    fn the_blob_is_read_back_by_the_firmware_parser() {
        let (d, config) = fleet("roundtrip");
        let blob = record(&config, &request(Some("192.168.1.10")), Some([5; 32])).unwrap();
        let out = d.join("robot-3.bin");
        write_blob(&out, &blob).unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&out).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, 0o600, "the blob holds the robot key");
        }
        let p = Provision::decode(&std::fs::read(&out).unwrap()).expect("firmware parses it");
        let fleet = Fleet::load(&config).unwrap();
        assert_eq!(p.id, 3);
        assert_eq!(p.kind, RobotKind::Pilot);
        assert_eq!(p.key, fleet.key.robot_key(3));
        assert_eq!(p.host.to_string(), "192.168.1.10:47800");
        assert_eq!((p.ssid(), p.password()), ("lab", "correct horse"));
        assert_eq!(p.update_key, Some([5; 32]));
        // A blob cut short or with a flipped byte is refused by the firmware.
        assert_eq!(
            Provision::decode(&blob[..100]),
            Err(RecordError::Truncated { len: 100 })
        );
        let mut bad = blob;
        bad[60] ^= 0x20;
        assert_eq!(Provision::decode(&bad), Err(RecordError::Checksum));
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn every_bad_input_has_a_one_line_error() {
        let (d, config) = fleet("errors");
        let msg = |r: Result<[u8; RECORD_LEN], ProvisionError>| {
            let m = r.unwrap_err().to_string();
            assert!(!m.contains('\n'), "one line: {m}");
            m
        };
        let mut wrong_id = request(Some("10.0.0.2"));
        wrong_id.id = 9;
        assert!(msg(record(&config, &wrong_id, None))
            .contains("fleet.toml: robots: robot 9 is not listed"));
        // The init config binds loopback, which no robot can reach.
        assert!(msg(record(&config, &request(None), None))
            .contains("link.bind: 127.0.0.1:47800 is not an address robots can reach"));
        assert_eq!(
            msg(record(&config, &request(Some("lab-pc")), None)),
            "--host: 'lab-pc' is not a.b.c.d or a.b.c.d:port"
        );
        assert!(msg(record(&config, &request(Some("10.0.0.2:0")), None))
            .starts_with("--host: 10.0.0.2:0 is not"));
        let mut long_ssid = request(Some("10.0.0.2"));
        long_ssid.ssid = "x".repeat(33);
        assert!(msg(record(&config, &long_ssid, None)).starts_with("--ssid: SSID must be"));
        let mut short_pw = request(Some("10.0.0.2"));
        short_pw.password = "abc".into();
        assert!(msg(record(&config, &short_pw, None))
            .starts_with("PUZZLEBOT_WIFI_PASSWORD: password must be empty or 8..=64"));
        let missing = d.join("nope.toml");
        assert!(msg(record(&missing, &request(Some("10.0.0.2")), None)).contains("nope.toml"));
        std::fs::write(d.join(crate::fleet_setup::KEY_FILE), "abc\n").unwrap();
        let m = msg(record(&config, &request(Some("10.0.0.2")), None));
        assert!(
            m.contains("fleet.key") && m.contains("64 hexadecimal"),
            "{m}"
        );
        assert!(read_password(Some(&d.join("no-such-file"))).is_err());
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn the_offset_is_the_one_of_the_shipped_partition_table() {
        let csv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/esp32c3/partitions.csv");
        let text = std::fs::read_to_string(&csv).expect("partition table");
        let robot = text
            .lines()
            .find(|l| l.trim_start().starts_with("robot,"))
            .expect("a `robot` partition");
        let offset = robot.split(',').nth(3).expect("offset column").trim();
        let offset = u32::from_str_radix(offset.trim_start_matches("0x"), 16).unwrap();
        assert_eq!(offset, PARTITION_OFFSET);
        let size = robot.split(',').nth(4).expect("size column").trim();
        let size = usize::from_str_radix(size.trim_start_matches("0x"), 16).unwrap();
        assert!(RECORD_LEN <= size, "the record fits the partition");
    }
}
