//! Key hierarchy: fleet key → per-robot key → hello key and per-session keys.
//!
//! The 256-bit fleet key stays on the host. Each robot is provisioned with its own
//! robot key `HMAC(fleet, "puzzlebot/robot" ‖ id)`, so a robot taken apart reveals
//! nothing about its siblings. Session keys mix a fresh robot nonce and a fresh host
//! nonce, so no frame from an earlier boot, announce cycle or host run verifies again.

use hmac::{Hmac, Mac};
use sha2::Sha256;
use subtle::ConstantTimeEq;

type HmacSha256 = Hmac<Sha256>;

/// Length of the nonces exchanged in the handshake.
pub const NONCE_LEN: usize = 16;
/// A handshake nonce (robot: fresh per boot and per announce cycle; host: fresh per session).
pub type Nonce = [u8; NONCE_LEN];

macro_rules! key_type {
    ($(#[$m:meta])* $name:ident) => {
        $(#[$m])*
        #[derive(Clone)]
        pub struct $name(pub [u8; 32]);
        impl PartialEq for $name {
            /// Constant-time comparison (no early exit that leaks where keys differ).
            fn eq(&self, other: &Self) -> bool {
                bool::from(self.0.ct_eq(&other.0))
            }
        }
        impl Eq for $name {}
        impl core::fmt::Debug for $name {
            fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                // Keys are never logged.
                f.write_str(concat!(stringify!($name), "(<redacted>)"))
            }
        }
    };
}

key_type!(
    /// The per-fleet 256-bit secret (host only; never sent over the air).
    FleetKey
);
key_type!(
    /// A robot's own key, derived from the fleet key; provisioned into that robot only.
    RobotKey
);
key_type!(
    /// The key of one session (one robot nonce × one host nonce).
    SessionKey
);

fn prf(key: &[u8; 32], parts: &[&[u8]]) -> [u8; 32] {
    // HMAC accepts keys of any length: `new_from_slice` cannot fail here.
    let mut mac = match HmacSha256::new_from_slice(key) {
        Ok(m) => m,
        Err(_) => unreachable_hmac(),
    };
    for p in parts {
        mac.update(p);
    }
    mac.finalize().into_bytes().into()
}

#[cold]
fn unreachable_hmac() -> ! {
    unreachable!("HMAC-SHA256 accepts keys of every length")
}

impl FleetKey {
    /// Derive the key provisioned into robot `id`.
    pub fn robot_key(&self, id: u16) -> RobotKey {
        RobotKey(prf(&self.0, &[b"puzzlebot/robot", &id.to_le_bytes()]))
    }

    /// Parse 64 hexadecimal characters (surrounding whitespace ignored).
    pub fn from_hex(s: &str) -> Option<FleetKey> {
        parse_hex32(s).map(FleetKey)
    }
}

impl RobotKey {
    /// Key that authenticates the hello stream (announce / welcome).
    pub fn hello_key(&self) -> SessionKey {
        SessionKey(prf(&self.0, &[b"puzzlebot/hello"]))
    }

    /// Key of the session opened by `robot_nonce` (announce) and `host_nonce` (welcome).
    pub fn session_key(&self, robot_nonce: &Nonce, host_nonce: &Nonce) -> SessionKey {
        SessionKey(prf(
            &self.0,
            &[b"puzzlebot/session", robot_nonce, host_nonce],
        ))
    }

    /// Parse 64 hexadecimal characters (surrounding whitespace ignored).
    pub fn from_hex(s: &str) -> Option<RobotKey> {
        parse_hex32(s).map(RobotKey)
    }
}

impl SessionKey {
    /// Full 32-byte HMAC-SHA256 over `parts`.
    fn mac(&self, parts: &[&[u8]]) -> HmacSha256 {
        let mut mac = match HmacSha256::new_from_slice(&self.0) {
            Ok(m) => m,
            Err(_) => unreachable_hmac(),
        };
        for p in parts {
            mac.update(p);
        }
        mac
    }

    /// The truncated tag over `data`.
    pub fn tag(&self, data: &[u8]) -> [u8; crate::TAG_LEN] {
        let full: [u8; 32] = self.mac(&[data]).finalize().into_bytes().into();
        let mut t = [0u8; crate::TAG_LEN];
        t.copy_from_slice(&full[..crate::TAG_LEN]);
        t
    }

    /// Constant-time check of a truncated tag over `data`.
    pub fn verify(&self, data: &[u8], tag: &[u8]) -> bool {
        tag.len() == crate::TAG_LEN && self.mac(&[data]).verify_truncated_left(tag).is_ok()
    }
}

/// Something that computes and checks the truncated frame tag ([`crate::envelope`]).
pub trait Authenticator {
    /// The truncated HMAC-SHA256 tag over `data`.
    fn tag(&self, data: &[u8]) -> [u8; crate::TAG_LEN];
    /// Constant-time check of a truncated tag over `data`.
    fn verify(&self, data: &[u8], tag: &[u8]) -> bool;
}

impl Authenticator for SessionKey {
    fn tag(&self, data: &[u8]) -> [u8; crate::TAG_LEN] {
        SessionKey::tag(self, data)
    }
    fn verify(&self, data: &[u8], tag: &[u8]) -> bool {
        SessionKey::verify(self, data, tag)
    }
}

/// A [`SessionKey`] with the HMAC-SHA256 inner and outer pads already hashed: every tag
/// and check then costs only the message's blocks (two SHA-256 compressions fewer per
/// frame than keying from the raw key each time). Same tags as the key it came from.
///
/// The hashed pads are as secret as the key (they suffice to forge tags): never printed,
/// no equality (nothing to compare them against in variable time).
#[derive(Clone)]
pub struct MacKey(HmacSha256);

impl MacKey {
    /// Pre-key `key`.
    pub fn new(key: &SessionKey) -> MacKey {
        MacKey(key.mac(&[]))
    }
}

impl core::fmt::Debug for MacKey {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        // Keys are never logged.
        f.write_str("MacKey(<redacted>)")
    }
}

impl Authenticator for MacKey {
    fn tag(&self, data: &[u8]) -> [u8; crate::TAG_LEN] {
        let mut mac = self.0.clone();
        mac.update(data);
        let full: [u8; 32] = mac.finalize().into_bytes().into();
        let mut t = [0u8; crate::TAG_LEN];
        t.copy_from_slice(&full[..crate::TAG_LEN]);
        t
    }
    fn verify(&self, data: &[u8], tag: &[u8]) -> bool {
        if tag.len() != crate::TAG_LEN {
            return false;
        }
        let mut mac = self.0.clone();
        mac.update(data);
        mac.verify_truncated_left(tag).is_ok()
    }
}

fn parse_hex32(s: &str) -> Option<[u8; 32]> {
    let s = s.trim().as_bytes();
    if s.len() != 64 {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, pair) in s.chunks_exact(2).enumerate() {
        let hi = hex_val(pair[0])?;
        let lo = hex_val(pair[1])?;
        out[i] = (hi << 4) | lo;
    }
    Some(out)
}

fn hex_val(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'a'..=b'f' => Some(c - b'a' + 10),
        b'A'..=b'F' => Some(c - b'A' + 10),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robot_keys_differ_per_robot_and_sessions_per_nonce() {
        let f = FleetKey([7; 32]);
        assert_ne!(f.robot_key(1), f.robot_key(2));
        let k = f.robot_key(1);
        assert_ne!(
            k.session_key(&[1; 16], &[2; 16]),
            k.session_key(&[1; 16], &[3; 16])
        );
        assert_ne!(
            k.session_key(&[1; 16], &[2; 16]),
            k.session_key(&[4; 16], &[2; 16])
        );
        assert_ne!(k.hello_key(), k.session_key(&[0; 16], &[0; 16]));
    }

    #[test]
    fn pre_keyed_mac_gives_the_same_tags() {
        let k = FleetKey([9; 32])
            .robot_key(3)
            .session_key(&[1; 16], &[2; 16]);
        let m = MacKey::new(&k);
        for len in [0usize, 1, 10, 55, 56, 63, 64, 65, 118, 200] {
            let data: [u8; 200] = core::array::from_fn(|i| (i * 7 + len) as u8);
            let t = k.tag(&data[..len]);
            assert_eq!(Authenticator::tag(&m, &data[..len]), t, "len {len}");
            assert!(Authenticator::verify(&m, &data[..len], &t));
            let mut bad = t;
            bad[len % crate::TAG_LEN] ^= 1;
            assert!(!Authenticator::verify(&m, &data[..len], &bad));
            assert!(!Authenticator::verify(
                &m,
                &data[..len],
                &t[..crate::TAG_LEN - 1]
            ));
        }
        assert_eq!(format!("{m:?}"), "MacKey(<redacted>)");
    }

    #[test]
    fn tags_match_an_independent_hmac_sha256() {
        // Expected values: Python's `hmac.new(b"\x5a" * 32, data, hashlib.sha256)`, first
        // 16 bytes. Pins the wire format for both key forms.
        fn hex(s: &str) -> [u8; crate::TAG_LEN] {
            core::array::from_fn(|i| {
                hex_val(s.as_bytes()[2 * i]).unwrap_or(0) << 4
                    | hex_val(s.as_bytes()[2 * i + 1]).unwrap_or(0)
            })
        }
        let k = SessionKey([0x5a; 32]);
        let m = MacKey::new(&k);
        let long: [u8; 100] = core::array::from_fn(|i| i as u8);
        for (data, want) in [
            (&b""[..], "87a26610b4e32f22d6d403b2397f534f"),
            (&b"puzzlebot"[..], "79405ae137dcc18135a03618cab5dd49"),
            (&long[..], "b912879eadf14a2be6f8dab67679828d"),
        ] {
            assert_eq!(k.tag(data), hex(want), "{} bytes", data.len());
            assert_eq!(Authenticator::tag(&k, data), hex(want));
            assert_eq!(Authenticator::tag(&m, data), hex(want));
            assert!(Authenticator::verify(&k, data, &hex(want)));
        }
    }

    #[test]
    fn hex_keys_parse_and_reject() {
        let hex = "00112233445566778899aabbccddeeff00112233445566778899AABBCCDDEEFF";
        let k = FleetKey::from_hex(hex).expect("valid hex");
        assert_eq!(k.0[1], 0x11);
        assert_eq!(k.0[31], 0xff);
        assert!(FleetKey::from_hex(&hex[..62]).is_none());
        assert!(FleetKey::from_hex(&hex.replace('0', "g")).is_none());
        assert_eq!(format!("{k:?}"), "FleetKey(<redacted>)");
    }
}
