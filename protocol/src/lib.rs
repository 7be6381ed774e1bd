//! PuzzleBot wire protocol: every message, the authenticated datagram envelope,
//! key derivation, sessions and replay protection.
//!
//! `no_std` by default-features-off (the firmware), `std` for the host and simulator.
//! Nothing here allocates or panics on any input: every rejection is a [`Rejection`].
//!
//! Datagram layout (see `README.md` for the table):
//!
//! ```text
//! | ver u8 | flags u8 | robot id u16 LE | counter u48 LE | postcard payload | tag 16 B |
//! ```
//!
//! `flags` bit 0 is the direction (0 robot→host, 1 host→robot), bit 1 the stream
//! (0 hello: announce/welcome under the robot's hello key, 1 session: everything else
//! under the per-session key). The tag is HMAC-SHA256 over header and payload, truncated
//! to 128 bits (DESIGN.md §4: beyond MAVLink 2's 48-bit tag).
#![cfg_attr(not(feature = "std"), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod crypto;
pub mod envelope;
pub mod messages;
pub mod pose;
pub mod reject;
pub mod replay;
pub mod session;
pub mod update;

pub use crypto::{Authenticator, FleetKey, MacKey, Nonce, RobotKey, SessionKey};
pub use envelope::{open, peek_header, seal, Direction, Header, Stream};
pub use messages::*;
pub use reject::{EncodeError, Rejection};
pub use replay::ReplayWindow;
pub use session::{HostReceived, HostSession, RobotSession, PENDING_OFFERS};
pub use update::{UpdateRefusal, UpdateState, UpdateStatus, UPDATE_CHUNK};

/// Protocol version carried in every datagram's first byte. Version 2 added the
/// announce's `reset_reason`, version 3 the over-the-air update messages ([`update`]),
/// version 4 [`HostMsg::WheelSpeedHold`]; a frame of any other version is refused as
/// `bad_version`.
pub const PROTOCOL_VERSION: u8 = 4;
/// Size of the fixed header (version, flags, robot id, 48-bit counter).
pub const HEADER_LEN: usize = 10;
/// Size of the truncated HMAC-SHA256 tag.
pub const TAG_LEN: usize = 16;
/// Hard upper bound of any datagram, in bytes; larger input is rejected unread.
pub const MAX_DATAGRAM: usize = 128;
/// Largest payload that fits the datagram bound.
pub const MAX_PAYLOAD: usize = MAX_DATAGRAM - HEADER_LEN - TAG_LEN;
/// Largest counter value (48 bits); a sender that reaches it must start a new session.
pub const MAX_COUNTER: u64 = (1 << 48) - 1;
/// Default UDP port the host listens on.
pub const DEFAULT_HOST_PORT: u16 = 47800;
/// Default UDP port a robot listens on.
pub const DEFAULT_ROBOT_PORT: u16 = 47801;
