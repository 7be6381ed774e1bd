//! Per-robot provisioning from the build environment (never from the repository).
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
//! A build without them (CI) compiles and yields an unprovisioned robot: no Wi-Fi, no key,
//! motors always coasting.

use core::net::{Ipv4Addr, SocketAddrV4};
use puzzlebot_protocol::{RobotId, RobotKey, RobotKind, DEFAULT_HOST_PORT};

/// Everything a robot needs to join the fleet.
pub struct Provision {
    /// Wi-Fi network name.
    pub ssid: &'static str,
    /// Wi-Fi password (empty: open network).
    pub password: &'static str,
    /// This robot's id.
    pub id: RobotId,
    /// This robot's key.
    pub key: RobotKey,
    /// The host's UDP address.
    pub host: SocketAddrV4,
}

/// Robot id used in announces when unprovisioned (never accepted by any host).
pub const UNPROVISIONED_ID: RobotId = u16::MAX;

/// Pilot or non-pilot, from `PUZZLEBOT_ROBOT_KIND`.
pub fn kind() -> RobotKind {
    match option_env!("PUZZLEBOT_ROBOT_KIND") {
        Some("pilot") => RobotKind::Pilot,
        _ => RobotKind::NonPilot,
    }
}

/// Why a build is not provisioned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProvisionError {
    /// A required variable is unset (a CI or bare build).
    Missing(&'static str),
    /// A variable is set but invalid (a bad provisioning record).
    Invalid(&'static str),
}

impl core::fmt::Display for ProvisionError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ProvisionError::Missing(v) => write!(f, "{v} unset"),
            ProvisionError::Invalid(why) => f.write_str(why),
        }
    }
}

/// The provisioning of this build, or the first missing/invalid variable.
pub fn from_build_env() -> Result<Provision, ProvisionError> {
    use ProvisionError::{Invalid, Missing};
    let ssid = option_env!("PUZZLEBOT_WIFI_SSID")
        .filter(|s| !s.is_empty())
        .ok_or(Missing("PUZZLEBOT_WIFI_SSID"))?;
    let password = option_env!("PUZZLEBOT_WIFI_PASSWORD").unwrap_or("");
    let id = option_env!("PUZZLEBOT_ROBOT_ID")
        .ok_or(Missing("PUZZLEBOT_ROBOT_ID"))?
        .trim()
        .parse::<RobotId>()
        .map_err(|_| Invalid("PUZZLEBOT_ROBOT_ID is not a number 0..=65535"))?;
    let key = RobotKey::from_hex(
        option_env!("PUZZLEBOT_ROBOT_KEY").ok_or(Missing("PUZZLEBOT_ROBOT_KEY"))?,
    )
    .ok_or(Invalid("PUZZLEBOT_ROBOT_KEY is not 64 hex digits"))?;
    let host = parse_host(option_env!("PUZZLEBOT_HOST").ok_or(Missing("PUZZLEBOT_HOST"))?)
        .ok_or(Invalid("PUZZLEBOT_HOST is not a.b.c.d[:port]"))?;
    Ok(Provision {
        ssid,
        password,
        id,
        key,
        host,
    })
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
