//! The provisioning record: what makes one firmware image a particular robot.
//!
//! Robot id, kind, Wi-Fi credentials, robot key, host address and the fleet's update key
//! live in a small record in a flash data partition (`robot`, see
//! `firmware/esp32c3/partitions.csv`), written once per robot by `puzzlebot fleet
//! provision` and `espflash write-bin`. Every image is the same; the record is the secret.
//!
//! Layout (little-endian, [`RECORD_LEN`] bytes):
//!
//! ```text
//! offset size field
//! 0      4    magic "PBPR"
//! 4      1    format (RECORD_FORMAT = 1)
//! 5      1    kind: 0 non-pilot, 1 pilot
//! 6      2    robot id u16
//! 8      32   robot key (FleetKey::robot_key(id))
//! 40     4    host IPv4 address (a.b.c.d as 4 bytes)
//! 44     2    host UDP port u16
//! 46     1    SSID length (1..=32)
//! 47     32   SSID (UTF-8, zero padded)
//! 79     1    password length (0 open network, else 8..=64)
//! 80     64   password (UTF-8, zero padded)
//! 144    32   update key: Ed25519 public key that signs firmware updates (all zero: none)
//! 176    4    CRC-32 (IEEE) of bytes 0..176
//! ```
//!
//! [`Provision::decode`] refuses anything else — erased flash, a truncated or corrupted
//! record, an unknown format — and a robot without a valid record stays unprovisioned
//! (never drives, never transmits).

use core::net::{Ipv4Addr, SocketAddrV4};

use puzzlebot_protocol::{RobotId, RobotKey, RobotKind};

/// First four bytes of every record.
pub const RECORD_MAGIC: [u8; 4] = *b"PBPR";
/// Format version this parser reads and [`Provision::encode`] writes.
pub const RECORD_FORMAT: u8 = 1;
/// Size of an encoded record (bytes).
pub const RECORD_LEN: usize = 180;
/// Longest SSID (bytes, IEEE 802.11).
pub const MAX_SSID: usize = 32;
/// Longest WPA2 passphrase (bytes; 64 = a raw hex PSK).
pub const MAX_PASSWORD: usize = 64;
/// Shortest WPA2 passphrase (bytes); an empty password means an open network.
pub const MIN_PASSWORD: usize = 8;

const KIND_AT: usize = 5;
const ID_AT: usize = 6;
const KEY_AT: usize = 8;
const IP_AT: usize = 40;
const PORT_AT: usize = 44;
const SSID_AT: usize = 46;
const PASSWORD_AT: usize = 79;
const UPDATE_KEY_AT: usize = 144;
const CRC_AT: usize = 176;

/// Why a record cannot be used (the robot then stays unprovisioned).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecordError {
    /// Erased flash (all 0xFF) or all zero: nothing was ever written.
    Empty,
    /// Fewer bytes than a record.
    Truncated {
        /// Bytes available.
        len: usize,
    },
    /// The first four bytes are not "PBPR".
    BadMagic,
    /// A format this firmware does not read.
    UnsupportedFormat(u8),
    /// The CRC does not match the contents (corrupted record).
    Checksum,
    /// The kind byte is neither 0 nor 1.
    BadKind(u8),
    /// SSID empty or longer than [`MAX_SSID`], or not UTF-8.
    Ssid,
    /// Password of 1..=7 or more than [`MAX_PASSWORD`] bytes, or not UTF-8.
    Password,
    /// Host address 0.0.0.0, a broadcast or multicast address, or port 0.
    Host,
}

impl core::fmt::Display for RecordError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            RecordError::Empty => f.write_str("no provisioning record (erased partition)"),
            RecordError::Truncated { len } => {
                write!(f, "provisioning record truncated: {len} of {RECORD_LEN} bytes")
            }
            RecordError::BadMagic => f.write_str("provisioning record: bad magic (not PBPR)"),
            RecordError::UnsupportedFormat(v) => write!(
                f,
                "provisioning record: format {v} unsupported (this firmware reads {RECORD_FORMAT})"
            ),
            RecordError::Checksum => f.write_str("provisioning record: checksum mismatch"),
            RecordError::BadKind(k) => write!(f, "provisioning record: kind {k} is not 0 or 1"),
            RecordError::Ssid => {
                write!(f, "provisioning record: SSID must be 1..={MAX_SSID} bytes of UTF-8")
            }
            RecordError::Password => write!(
                f,
                "provisioning record: password must be empty or {MIN_PASSWORD}..={MAX_PASSWORD} bytes of UTF-8"
            ),
            RecordError::Host => f.write_str(
                "provisioning record: host must be a unicast IPv4 address with a non-zero port",
            ),
        }
    }
}

/// Everything a robot needs to join its fleet (a decoded record).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Provision {
    /// This robot's id.
    pub id: RobotId,
    /// Pilot or non-pilot.
    pub kind: RobotKind,
    /// This robot's key.
    pub key: RobotKey,
    /// The host's UDP address.
    pub host: SocketAddrV4,
    /// Ed25519 public key that signs firmware updates; `None`: updates are refused.
    pub update_key: Option<[u8; 32]>,
    ssid: [u8; MAX_SSID],
    ssid_len: u8,
    password: [u8; MAX_PASSWORD],
    password_len: u8,
}

/// Wi-Fi credentials and identity for [`Provision::new`].
#[derive(Debug, Clone, Copy)]
pub struct Credentials<'a> {
    /// Wi-Fi network name.
    pub ssid: &'a str,
    /// WPA2 passphrase; empty for an open network.
    pub password: &'a str,
}

impl Provision {
    /// A record for robot `id`, checked as [`Provision::decode`] checks it.
    pub fn new(
        id: RobotId,
        kind: RobotKind,
        key: RobotKey,
        host: SocketAddrV4,
        wifi: Credentials<'_>,
        update_key: Option<[u8; 32]>,
    ) -> Result<Provision, RecordError> {
        check_ssid(wifi.ssid.as_bytes())?;
        check_password(wifi.password.as_bytes())?;
        check_host(host)?;
        let mut ssid = [0u8; MAX_SSID];
        ssid[..wifi.ssid.len()].copy_from_slice(wifi.ssid.as_bytes());
        let mut password = [0u8; MAX_PASSWORD];
        password[..wifi.password.len()].copy_from_slice(wifi.password.as_bytes());
        Ok(Provision {
            id,
            kind,
            key,
            host,
            update_key,
            ssid,
            ssid_len: wifi.ssid.len() as u8,
            password,
            password_len: wifi.password.len() as u8,
        })
    }

    /// Wi-Fi network name.
    pub fn ssid(&self) -> &str {
        // Checked UTF-8 in `new` and `decode`.
        core::str::from_utf8(&self.ssid[..usize::from(self.ssid_len)]).unwrap_or("")
    }

    /// WPA2 passphrase (empty: open network).
    pub fn password(&self) -> &str {
        core::str::from_utf8(&self.password[..usize::from(self.password_len)]).unwrap_or("")
    }

    /// The record as written to flash.
    pub fn encode(&self) -> [u8; RECORD_LEN] {
        let mut b = [0u8; RECORD_LEN];
        b[..4].copy_from_slice(&RECORD_MAGIC);
        b[4] = RECORD_FORMAT;
        b[KIND_AT] = match self.kind {
            RobotKind::NonPilot => 0,
            RobotKind::Pilot => 1,
        };
        b[ID_AT..ID_AT + 2].copy_from_slice(&self.id.to_le_bytes());
        b[KEY_AT..KEY_AT + 32].copy_from_slice(&self.key.0);
        b[IP_AT..IP_AT + 4].copy_from_slice(&self.host.ip().octets());
        b[PORT_AT..PORT_AT + 2].copy_from_slice(&self.host.port().to_le_bytes());
        b[SSID_AT] = self.ssid_len;
        b[SSID_AT + 1..SSID_AT + 1 + MAX_SSID].copy_from_slice(&self.ssid);
        b[PASSWORD_AT] = self.password_len;
        b[PASSWORD_AT + 1..PASSWORD_AT + 1 + MAX_PASSWORD].copy_from_slice(&self.password);
        b[UPDATE_KEY_AT..UPDATE_KEY_AT + 32].copy_from_slice(&self.update_key.unwrap_or([0; 32]));
        let crc = crc32(&b[..CRC_AT]);
        b[CRC_AT..].copy_from_slice(&crc.to_le_bytes());
        b
    }

    /// Parse a record from the start of `bytes` (the partition's contents; bytes after the
    /// record are ignored). Every check of the module documentation applies.
    pub fn decode(bytes: &[u8]) -> Result<Provision, RecordError> {
        let head = &bytes[..bytes.len().min(4)];
        if !head.is_empty() && (head.iter().all(|&x| x == 0xff) || head.iter().all(|&x| x == 0)) {
            return Err(RecordError::Empty);
        }
        if bytes.len() < RECORD_LEN {
            return Err(if bytes.is_empty() {
                RecordError::Empty
            } else {
                RecordError::Truncated { len: bytes.len() }
            });
        }
        let b = &bytes[..RECORD_LEN];
        if b[..4] != RECORD_MAGIC {
            return Err(RecordError::BadMagic);
        }
        if b[4] != RECORD_FORMAT {
            return Err(RecordError::UnsupportedFormat(b[4]));
        }
        let crc = u32::from_le_bytes([b[CRC_AT], b[CRC_AT + 1], b[CRC_AT + 2], b[CRC_AT + 3]]);
        if crc != crc32(&b[..CRC_AT]) {
            return Err(RecordError::Checksum);
        }
        let kind = match b[KIND_AT] {
            0 => RobotKind::NonPilot,
            1 => RobotKind::Pilot,
            k => return Err(RecordError::BadKind(k)),
        };
        let id = u16::from_le_bytes([b[ID_AT], b[ID_AT + 1]]);
        let mut key = [0u8; 32];
        key.copy_from_slice(&b[KEY_AT..KEY_AT + 32]);
        let ip = Ipv4Addr::new(b[IP_AT], b[IP_AT + 1], b[IP_AT + 2], b[IP_AT + 3]);
        let host = SocketAddrV4::new(ip, u16::from_le_bytes([b[PORT_AT], b[PORT_AT + 1]]));
        let ssid_len = usize::from(b[SSID_AT]);
        let ssid = b
            .get(SSID_AT + 1..SSID_AT + 1 + ssid_len)
            .ok_or(RecordError::Ssid)?;
        let pw_len = usize::from(b[PASSWORD_AT]);
        let password = b
            .get(PASSWORD_AT + 1..PASSWORD_AT + 1 + pw_len)
            .filter(|_| pw_len <= MAX_PASSWORD)
            .ok_or(RecordError::Password)?;
        if ssid_len > MAX_SSID {
            return Err(RecordError::Ssid);
        }
        let ssid = core::str::from_utf8(ssid).map_err(|_| RecordError::Ssid)?;
        let password = core::str::from_utf8(password).map_err(|_| RecordError::Password)?;
        let mut update_key = [0u8; 32];
        update_key.copy_from_slice(&b[UPDATE_KEY_AT..UPDATE_KEY_AT + 32]);
        let update_key = (update_key != [0; 32]).then_some(update_key);
        Provision::new(
            id,
            kind,
            RobotKey(key),
            host,
            Credentials { ssid, password },
            update_key,
        )
    }
}

fn check_ssid(s: &[u8]) -> Result<(), RecordError> {
    if s.is_empty() || s.len() > MAX_SSID {
        return Err(RecordError::Ssid);
    }
    Ok(())
}

fn check_password(p: &[u8]) -> Result<(), RecordError> {
    if !(p.is_empty() || (MIN_PASSWORD..=MAX_PASSWORD).contains(&p.len())) {
        return Err(RecordError::Password);
    }
    Ok(())
}

fn check_host(h: SocketAddrV4) -> Result<(), RecordError> {
    let ip = h.ip();
    if ip.is_unspecified() || ip.is_broadcast() || ip.is_multicast() || h.port() == 0 {
        return Err(RecordError::Host);
    }
    Ok(())
}

/// CRC-32 (IEEE 802.3, reflected, as zlib's `crc32`).
pub fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &byte in data {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = (crc >> 1) ^ (0xEDB8_8320 & (crc & 1).wrapping_neg());
        }
    }
    !crc
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_protocol::FleetKey;

    fn sample() -> Provision {
        Provision::new(
            3,
            RobotKind::Pilot,
            FleetKey([7; 32]).robot_key(3),
            SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10), 47800),
            Credentials {
                ssid: "lab",
                password: "correct horse",
            },
            Some([9; 32]),
        )
        .expect("valid")
    }

    #[test]
    fn crc32_matches_the_zlib_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn a_record_round_trips_and_ignores_what_follows_it() {
        let p = sample();
        let mut sector = [0xffu8; 4096];
        sector[..RECORD_LEN].copy_from_slice(&p.encode());
        let back = Provision::decode(&sector).expect("decodes");
        assert_eq!(back, p);
        assert_eq!(back.ssid(), "lab");
        assert_eq!(back.password(), "correct horse");
        assert_eq!(back.update_key, Some([9; 32]));
    }

    #[test]
    fn erased_truncated_and_corrupted_records_are_refused() {
        assert_eq!(Provision::decode(&[0xff; 4096]), Err(RecordError::Empty));
        assert_eq!(Provision::decode(&[]), Err(RecordError::Empty));
        let good = sample().encode();
        assert_eq!(
            Provision::decode(&good[..RECORD_LEN - 1]),
            Err(RecordError::Truncated {
                len: RECORD_LEN - 1
            })
        );
        // Every single-bit flip anywhere in the record is caught.
        for i in 0..RECORD_LEN {
            for bit in 0..8 {
                let mut bad = good;
                bad[i] ^= 1 << bit;
                assert!(
                    Provision::decode(&bad).is_err(),
                    "flip of byte {i} bit {bit}"
                );
            }
        }
        let mut newer = good;
        newer[4] = RECORD_FORMAT + 1;
        assert_eq!(
            Provision::decode(&newer),
            Err(RecordError::UnsupportedFormat(RECORD_FORMAT + 1))
        );
    }

    #[test]
    fn a_robot_with_a_corrupted_record_never_drives_nor_transmits() {
        use crate::{Robot, Sensors};
        use puzzlebot_params::firmware::Firmware;
        use puzzlebot_protocol::FirmwareVersion;
        let mut bad = sample().encode();
        bad[100] ^= 1;
        let key = Provision::decode(&bad).ok().map(|p| p.key);
        let v = FirmwareVersion {
            major: 0,
            minor: 1,
            patch: 0,
        };
        let nonces = || [1u8; 16];
        let mut robot = Robot::new(
            u16::MAX,
            RobotKind::NonPilot,
            key,
            Firmware::default(),
            v,
            nonces,
        )
        .expect("valid parameters");
        let mut buf = [0u8; puzzlebot_protocol::MAX_DATAGRAM];
        for t in 1..100u64 {
            let out = robot.tick(t * 20_000, &Sensors::default());
            assert!(out.is_stopped(), "coasting at {t}");
            assert_eq!(robot.poll_transmit(t * 20_000, &mut buf), None, "silent");
        }
    }

    #[test]
    fn invalid_fields_are_refused_even_with_a_good_checksum() {
        let reseal = |f: &dyn Fn(&mut [u8; RECORD_LEN])| {
            let mut b = sample().encode();
            f(&mut b);
            let crc = crc32(&b[..CRC_AT]);
            b[CRC_AT..].copy_from_slice(&crc.to_le_bytes());
            Provision::decode(&b)
        };
        assert_eq!(reseal(&|b| b[KIND_AT] = 7), Err(RecordError::BadKind(7)));
        assert_eq!(reseal(&|b| b[SSID_AT] = 0), Err(RecordError::Ssid));
        assert_eq!(reseal(&|b| b[SSID_AT] = 33), Err(RecordError::Ssid));
        assert_eq!(reseal(&|b| b[SSID_AT + 1] = 0xff), Err(RecordError::Ssid));
        assert_eq!(reseal(&|b| b[PASSWORD_AT] = 3), Err(RecordError::Password));
        assert_eq!(reseal(&|b| b[PASSWORD_AT] = 65), Err(RecordError::Password));
        assert_eq!(
            reseal(&|b| b[IP_AT..IP_AT + 4].fill(0)),
            Err(RecordError::Host)
        );
        assert_eq!(
            reseal(&|b| b[PORT_AT..PORT_AT + 2].fill(0)),
            Err(RecordError::Host)
        );
    }

    #[test]
    fn bad_inputs_to_new_are_refused() {
        let key = FleetKey([1; 32]).robot_key(1);
        let host = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 1), 47800);
        let make = |ssid: &str, password: &str, host| {
            Provision::new(
                1,
                RobotKind::NonPilot,
                key.clone(),
                host,
                Credentials { ssid, password },
                None,
            )
        };
        assert_eq!(make("", "", host).unwrap_err(), RecordError::Ssid);
        let long = "s".repeat(33);
        assert_eq!(make(&long, "", host).unwrap_err(), RecordError::Ssid);
        assert_eq!(
            make("lab", "short", host).unwrap_err(),
            RecordError::Password
        );
        let bcast = SocketAddrV4::new(Ipv4Addr::BROADCAST, 47800);
        assert_eq!(make("lab", "", bcast).unwrap_err(), RecordError::Host);
        let open = make("lab", "", host).expect("an open network is fine");
        assert_eq!(Provision::decode(&open.encode()), Ok(open));
    }
}
