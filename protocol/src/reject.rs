//! Typed reasons for refusing a datagram, and encode errors.

use serde::{Deserialize, Serialize};

/// Why a received datagram was refused. Every decoder path ends in a message or one of these.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[repr(u8)]
pub enum Rejection {
    /// Longer than [`crate::MAX_DATAGRAM`].
    Oversized = 0,
    /// Shorter than header + tag.
    Truncated = 1,
    /// Protocol version byte differs from [`crate::PROTOCOL_VERSION`].
    BadVersion = 2,
    /// Direction bit says the frame was meant for the other side (reflection).
    WrongDirection = 3,
    /// Reserved flag bits set, or a frame on a stream the receiver does not accept here.
    BadFlags = 4,
    /// The robot id is not the expected one / not in the fleet.
    UnknownRobot = 5,
    /// The authentication tag does not verify (forged, corrupted, or another session's key).
    BadTag = 6,
    /// The counter was already accepted in this session.
    Replay = 7,
    /// The counter is below the reorder window.
    TooOld = 8,
    /// The tag verified but the payload is not a valid message (or has trailing bytes,
    /// or carries a non-finite / out-of-range number).
    MalformedPayload = 9,
    /// No session is established for this frame (no welcome yet, or a stale session).
    NoSession = 10,
    /// A hello frame whose nonce does not match the current handshake.
    StaleHandshake = 11,
}

impl Rejection {
    /// Every reason, for per-reason counters.
    pub const ALL: [Rejection; 12] = [
        Rejection::Oversized,
        Rejection::Truncated,
        Rejection::BadVersion,
        Rejection::WrongDirection,
        Rejection::BadFlags,
        Rejection::UnknownRobot,
        Rejection::BadTag,
        Rejection::Replay,
        Rejection::TooOld,
        Rejection::MalformedPayload,
        Rejection::NoSession,
        Rejection::StaleHandshake,
    ];

    /// Short stable name (for logs and counters).
    pub const fn name(self) -> &'static str {
        match self {
            Rejection::Oversized => "oversized",
            Rejection::Truncated => "truncated",
            Rejection::BadVersion => "bad_version",
            Rejection::WrongDirection => "wrong_direction",
            Rejection::BadFlags => "bad_flags",
            Rejection::UnknownRobot => "unknown_robot",
            Rejection::BadTag => "bad_tag",
            Rejection::Replay => "replay",
            Rejection::TooOld => "too_old",
            Rejection::MalformedPayload => "malformed_payload",
            Rejection::NoSession => "no_session",
            Rejection::StaleHandshake => "stale_handshake",
        }
    }
}

impl core::fmt::Display for Rejection {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(feature = "std")]
impl std::error::Error for Rejection {}

/// Why a message could not be sealed into a datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodeError {
    /// The payload does not fit [`crate::MAX_PAYLOAD`] / the output buffer.
    TooLarge,
    /// The send counter is exhausted (48 bits); start a new session.
    CounterExhausted,
    /// No session is established to send under.
    NoSession,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            EncodeError::TooLarge => f.write_str("message too large for one datagram"),
            EncodeError::CounterExhausted => f.write_str("send counter exhausted"),
            EncodeError::NoSession => f.write_str("no session established"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for EncodeError {}
