//! Which robot this board is: the provisioning record in the `robot` flash partition
//! (written by `puzzlebot fleet provision` + `espflash write-bin`; format and parser in
//! `puzzlebot_firmware_core::provision`), so every robot runs the same image.
//!
//! Build-time provisioning stays as an option for a bench board: when
//! `PUZZLEBOT_ROBOT_ID` is set at build time, these variables make the record instead
//! (and the image is then a secret):
//!
//! | variable | meaning |
//! |---|---|
//! | `PUZZLEBOT_WIFI_SSID` | Wi-Fi network name |
//! | `PUZZLEBOT_WIFI_PASSWORD` | WPA2 password (empty or unset: open network) |
//! | `PUZZLEBOT_ROBOT_ID` | robot id, 0–65535 |
//! | `PUZZLEBOT_ROBOT_KEY` | 64 hex digits: this robot's key, `FleetKey::robot_key(id)` |
//! | `PUZZLEBOT_HOST` | host address `a.b.c.d` or `a.b.c.d:port` (default port 47800) |
//! | `PUZZLEBOT_ROBOT_KIND` | `pilot` or `non-pilot` (default `non-pilot`) |
//!
//! Without either (CI builds, a fresh board) the robot is unprovisioned: no Wi-Fi, no key,
//! motors always coasting.

use core::net::{Ipv4Addr, SocketAddrV4};
use esp_bootloader_esp_idf::partitions::{self, FlashStorage, PARTITION_TABLE_MAX_LEN};
use puzzlebot_firmware_core::provision::{Credentials, Provision, RecordError, RECORD_LEN};
use puzzlebot_protocol::{RobotId, RobotKey, RobotKind, DEFAULT_HOST_PORT};

/// Label of the data partition holding the record (`partitions.csv`).
pub const PARTITION_LABEL: &str = "robot";

/// Robot id used in announces when unprovisioned (never accepted by any host).
pub const UNPROVISIONED_ID: RobotId = u16::MAX;

/// Why this board is not provisioned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProvisionError {
    /// Nothing was provisioned (erased partition, no build variables).
    Missing,
    /// The partition table has no `robot` partition or cannot be read.
    NoPartition,
    /// A record is there but unusable (truncated, corrupted, unknown format).
    Record(RecordError),
    /// A build variable is set but invalid.
    BuildVariable(&'static str),
}

impl ProvisionError {
    /// True when something was provisioned but is unusable (LED code 2, not 1).
    pub fn is_bad(self) -> bool {
        !matches!(self, ProvisionError::Missing)
    }
}

impl core::fmt::Display for ProvisionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ProvisionError::Missing => f.write_str("no provisioning record"),
            ProvisionError::NoPartition => {
                write!(f, "no readable `{PARTITION_LABEL}` partition")
            }
            ProvisionError::Record(e) => write!(f, "{e}"),
            ProvisionError::BuildVariable(why) => f.write_str(why),
        }
    }
}

/// This board's provisioning: the build variables if `PUZZLEBOT_ROBOT_ID` was set at build
/// time, else the flash record.
pub fn load(flash: &mut FlashStorage<'_>) -> Result<Provision, ProvisionError> {
    if option_env!("PUZZLEBOT_ROBOT_ID").is_some() {
        return from_build_env();
    }
    match read_record(flash) {
        Err(ProvisionError::Record(RecordError::Empty)) => Err(ProvisionError::Missing),
        other => other,
    }
}

/// Read and parse the record at the start of the `robot` partition.
fn read_record(flash: &mut FlashStorage<'_>) -> Result<Provision, ProvisionError> {
    let mut table = [0u8; PARTITION_TABLE_MAX_LEN];
    let pt = partitions::read_partition_table(flash, &mut table)
        .map_err(|_| ProvisionError::NoPartition)?;
    let entry = pt
        .iter()
        .find(|p| p.label_as_str() == PARTITION_LABEL)
        .ok_or(ProvisionError::NoPartition)?;
    let mut buf = [0u8; RECORD_LEN];
    entry
        .as_flash_region(flash)
        .read(0, &mut buf)
        .map_err(|_| ProvisionError::NoPartition)?;
    Provision::decode(&buf).map_err(ProvisionError::Record)
}

/// The record made from the build variables.
fn from_build_env() -> Result<Provision, ProvisionError> {
    use ProvisionError::BuildVariable as Bad;
    let ssid = option_env!("PUZZLEBOT_WIFI_SSID").unwrap_or("");
    let password = option_env!("PUZZLEBOT_WIFI_PASSWORD").unwrap_or("");
    let id = option_env!("PUZZLEBOT_ROBOT_ID")
        .unwrap_or("")
        .trim()
        .parse::<RobotId>()
        .map_err(|_| Bad("PUZZLEBOT_ROBOT_ID is not a number 0..=65535"))?;
    let key = RobotKey::from_hex(option_env!("PUZZLEBOT_ROBOT_KEY").unwrap_or(""))
        .ok_or(Bad("PUZZLEBOT_ROBOT_KEY is not 64 hex digits"))?;
    let host = parse_host(option_env!("PUZZLEBOT_HOST").unwrap_or(""))
        .ok_or(Bad("PUZZLEBOT_HOST is not a.b.c.d[:port]"))?;
    let kind = match option_env!("PUZZLEBOT_ROBOT_KIND") {
        Some("pilot") => RobotKind::Pilot,
        _ => RobotKind::NonPilot,
    };
    Provision::new(id, kind, key, host, Credentials { ssid, password }, None)
        .map_err(ProvisionError::Record)
}

fn parse_host(s: &str) -> Option<SocketAddrV4> {
    let s = s.trim();
    if let Ok(a) = s.parse::<SocketAddrV4>() {
        return Some(a);
    }
    s.parse::<Ipv4Addr>()
        .ok()
        .map(|ip| SocketAddrV4::new(ip, DEFAULT_HOST_PORT))
}
