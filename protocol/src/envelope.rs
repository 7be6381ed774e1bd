//! The datagram envelope: fixed header, postcard payload, truncated HMAC tag.

use crate::crypto::Authenticator;
use crate::messages::{Message, RobotId};
use crate::reject::{EncodeError, Rejection};
use crate::{HEADER_LEN, MAX_COUNTER, MAX_DATAGRAM, PROTOCOL_VERSION, TAG_LEN};

/// Which way a frame travels; bound into the tag so frames cannot be reflected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Robot → host (announce, telemetry, pong, replies).
    RobotToHost,
    /// Host → robot (welcome, commands, parameters, ping).
    HostToRobot,
}

/// Which key authenticates a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stream {
    /// Announce / welcome, under the robot's hello key.
    Hello,
    /// Everything else, under the session key.
    Session,
}

const FLAG_HOST_TO_ROBOT: u8 = 1 << 0;
const FLAG_SESSION: u8 = 1 << 1;
const FLAGS_KNOWN: u8 = FLAG_HOST_TO_ROBOT | FLAG_SESSION;

/// The fixed 10-byte header of every datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Header {
    /// Direction of travel.
    pub direction: Direction,
    /// Hello or session stream.
    pub stream: Stream,
    /// Robot the frame is from or for.
    pub robot_id: RobotId,
    /// Strictly increasing per sender, stream and session (48 bits).
    pub counter: u64,
}

impl Header {
    fn write(&self, out: &mut [u8]) {
        out[0] = PROTOCOL_VERSION;
        let mut f = 0;
        if self.direction == Direction::HostToRobot {
            f |= FLAG_HOST_TO_ROBOT;
        }
        if self.stream == Stream::Session {
            f |= FLAG_SESSION;
        }
        out[1] = f;
        out[2..4].copy_from_slice(&self.robot_id.to_le_bytes());
        out[4..10].copy_from_slice(&self.counter.to_le_bytes()[..6]);
    }
}

/// Read and check the header without authenticating (to find the right key).
///
/// Checks size bounds, version and flags; the tag is not checked.
pub fn peek_header(frame: &[u8]) -> Result<Header, Rejection> {
    if frame.len() > MAX_DATAGRAM {
        return Err(Rejection::Oversized);
    }
    if frame.len() < HEADER_LEN + TAG_LEN + 1 {
        return Err(Rejection::Truncated);
    }
    if frame[0] != PROTOCOL_VERSION {
        return Err(Rejection::BadVersion);
    }
    let f = frame[1];
    if f & !FLAGS_KNOWN != 0 {
        return Err(Rejection::BadFlags);
    }
    let mut c = [0u8; 8];
    c[..6].copy_from_slice(&frame[4..10]);
    Ok(Header {
        direction: if f & FLAG_HOST_TO_ROBOT != 0 {
            Direction::HostToRobot
        } else {
            Direction::RobotToHost
        },
        stream: if f & FLAG_SESSION != 0 {
            Stream::Session
        } else {
            Stream::Hello
        },
        robot_id: u16::from_le_bytes([frame[2], frame[3]]),
        counter: u64::from_le_bytes(c),
    })
}

/// Encode `msg` with `header` into `out`, authenticated with `key`; returns the length.
///
/// The header's direction and stream must match the message (they are derived from it
/// by [`crate::session`]; a mismatch is a caller bug that the receiver will reject).
pub fn seal<M: Message>(
    key: &impl Authenticator,
    header: Header,
    msg: &M,
    out: &mut [u8],
) -> Result<usize, EncodeError> {
    if header.counter > MAX_COUNTER {
        return Err(EncodeError::CounterExhausted);
    }
    let cap = out.len().min(MAX_DATAGRAM);
    if cap < HEADER_LEN + TAG_LEN + 1 {
        return Err(EncodeError::TooLarge);
    }
    header.write(out);
    let payload_len = postcard::to_slice(msg, &mut out[HEADER_LEN..cap - TAG_LEN])
        .map_err(|_| EncodeError::TooLarge)?
        .len();
    let body = HEADER_LEN + payload_len;
    let tag = key.tag(&out[..body]);
    out[body..body + TAG_LEN].copy_from_slice(&tag);
    Ok(body + TAG_LEN)
}

/// Authenticate and decode a frame under `key`; checks direction, stream and payload.
///
/// Replay checking is the session's job ([`crate::ReplayWindow`]): call it only after
/// this returns `Ok`, so forged counters never move the window.
pub fn open<M: Message>(key: &impl Authenticator, frame: &[u8]) -> Result<(Header, M), Rejection> {
    let header = peek_header(frame)?;
    if header.direction != M::DIRECTION {
        return Err(Rejection::WrongDirection);
    }
    let body = frame.len() - TAG_LEN;
    if !key.verify(&frame[..body], &frame[body..]) {
        return Err(Rejection::BadTag);
    }
    let msg: M = match postcard::take_from_bytes::<M>(&frame[HEADER_LEN..body]) {
        Ok((m, [])) => m,
        _ => return Err(Rejection::MalformedPayload),
    };
    if !msg.valid() {
        return Err(Rejection::MalformedPayload);
    }
    let expect = if msg.hello() {
        Stream::Hello
    } else {
        Stream::Session
    };
    if header.stream != expect {
        return Err(Rejection::BadFlags);
    }
    Ok((header, msg))
}
