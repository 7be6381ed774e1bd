//! The documented UDP pose stream: what the host reads from motion capture bridges and
//! what the simulator's virtual motion capture serves.
//!
//! One datagram carries part or all of one capture frame, little-endian, no padding:
//!
//! ```text
//! offset size field
//! 0      4    magic "PBP1"
//! 4      8    u64 capture time (µs, sender clock)
//! 12     4    u32 frame number (all datagrams of one frame share it)
//! 16     2    u16 body count n (≤ MAX_BODIES_PER_DATAGRAM)
//! 18     19·n bodies: u16 robot id, f32 x (m), f32 y (m), f32 z (m), f32 yaw (rad, CCW from +x), u8 flags
//! ```
//!
//! Flags bit 0: tracked (0 means the body was lost in this frame; its numbers are stale).
//! The stream is not authenticated: run it on the lab's wired network or loopback only.

/// Magic bytes at the start of every pose datagram.
pub const POSE_MAGIC: [u8; 4] = *b"PBP1";
/// Bytes of the pose datagram header.
pub const POSE_HEADER_LEN: usize = 18;
/// Bytes of one body record.
pub const POSE_BODY_LEN: usize = 19;
/// Most bodies in one datagram (keeps datagrams under 1,400 bytes).
pub const MAX_BODIES_PER_DATAGRAM: usize = 72;
/// Largest pose datagram.
pub const MAX_POSE_DATAGRAM: usize = POSE_HEADER_LEN + POSE_BODY_LEN * MAX_BODIES_PER_DATAGRAM;
/// Default UDP port of the pose stream.
pub const DEFAULT_POSE_PORT: u16 = 47810;

/// One rigid body's pose in a capture frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyPose {
    /// Robot id the body is assigned to.
    pub robot_id: u16,
    /// Position (m).
    pub x: f32,
    /// Position (m).
    pub y: f32,
    /// Height (m).
    pub z: f32,
    /// Heading (rad), counter-clockwise from +x.
    pub yaw: f32,
    /// False when the capture system lost the body in this frame.
    pub tracked: bool,
}

/// Why a pose datagram was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PoseError {
    /// Wrong magic (not a pose datagram, or another version).
    BadMagic,
    /// Shorter than its header says.
    Truncated,
    /// More bodies than allowed, or bytes after the last body.
    BadLength,
    /// A coordinate is not finite.
    NonFinite,
}

impl core::fmt::Display for PoseError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            PoseError::BadMagic => "not a PBP1 pose datagram",
            PoseError::Truncated => "pose datagram truncated",
            PoseError::BadLength => "pose datagram length does not match its body count",
            PoseError::NonFinite => "pose datagram carries a non-finite number",
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for PoseError {}

/// Encode a frame's bodies into `out`; returns bytes written. Bodies beyond
/// [`MAX_BODIES_PER_DATAGRAM`] or what `out` holds are not written (send another datagram).
pub fn encode_poses(time_us: u64, frame: u32, bodies: &[BodyPose], out: &mut [u8]) -> usize {
    if out.len() < POSE_HEADER_LEN {
        return 0;
    }
    let n = bodies
        .len()
        .min(MAX_BODIES_PER_DATAGRAM)
        .min((out.len() - POSE_HEADER_LEN) / POSE_BODY_LEN);
    out[0..4].copy_from_slice(&POSE_MAGIC);
    out[4..12].copy_from_slice(&time_us.to_le_bytes());
    out[12..16].copy_from_slice(&frame.to_le_bytes());
    out[16..18].copy_from_slice(&(n as u16).to_le_bytes());
    for (i, b) in bodies[..n].iter().enumerate() {
        let o = POSE_HEADER_LEN + i * POSE_BODY_LEN;
        out[o..o + 2].copy_from_slice(&b.robot_id.to_le_bytes());
        out[o + 2..o + 6].copy_from_slice(&b.x.to_le_bytes());
        out[o + 6..o + 10].copy_from_slice(&b.y.to_le_bytes());
        out[o + 10..o + 14].copy_from_slice(&b.z.to_le_bytes());
        out[o + 14..o + 18].copy_from_slice(&b.yaw.to_le_bytes());
        out[o + 18] = u8::from(b.tracked);
    }
    POSE_HEADER_LEN + n * POSE_BODY_LEN
}

/// A decoded pose datagram header; iterate bodies with [`decode_poses`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PoseHeader {
    /// Capture time (µs, sender clock).
    pub time_us: u64,
    /// Frame number.
    pub frame: u32,
    /// Bodies in this datagram.
    pub count: usize,
}

fn f32_at(b: &[u8], o: usize) -> f32 {
    f32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

/// Decode a pose datagram, calling `each` for every body. Nothing is delivered unless the
/// whole datagram is valid.
pub fn decode_poses(bytes: &[u8], mut each: impl FnMut(BodyPose)) -> Result<PoseHeader, PoseError> {
    if bytes.len() < POSE_HEADER_LEN {
        return Err(if bytes.len() >= 4 && bytes[0..4] != POSE_MAGIC {
            PoseError::BadMagic
        } else {
            PoseError::Truncated
        });
    }
    if bytes[0..4] != POSE_MAGIC {
        return Err(PoseError::BadMagic);
    }
    let mut t = [0u8; 8];
    t.copy_from_slice(&bytes[4..12]);
    let time_us = u64::from_le_bytes(t);
    let frame = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]);
    let count = u16::from_le_bytes([bytes[16], bytes[17]]) as usize;
    if count > MAX_BODIES_PER_DATAGRAM {
        return Err(PoseError::BadLength);
    }
    let need = POSE_HEADER_LEN + count * POSE_BODY_LEN;
    if bytes.len() < need {
        return Err(PoseError::Truncated);
    }
    if bytes.len() > need {
        return Err(PoseError::BadLength);
    }
    let body = |i: usize| {
        let o = POSE_HEADER_LEN + i * POSE_BODY_LEN;
        BodyPose {
            robot_id: u16::from_le_bytes([bytes[o], bytes[o + 1]]),
            x: f32_at(bytes, o + 2),
            y: f32_at(bytes, o + 6),
            z: f32_at(bytes, o + 10),
            yaw: f32_at(bytes, o + 14),
            tracked: bytes[o + 18] & 1 != 0,
        }
    };
    for i in 0..count {
        let b = body(i);
        if ![b.x, b.y, b.z, b.yaw].iter().all(|v| v.is_finite()) {
            return Err(PoseError::NonFinite);
        }
    }
    for i in 0..count {
        each(body(i));
    }
    Ok(PoseHeader {
        time_us,
        frame,
        count,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_rejections() {
        let bodies = [
            BodyPose {
                robot_id: 3,
                x: 0.1,
                y: -0.2,
                z: 0.0,
                yaw: 1.5,
                tracked: true,
            },
            BodyPose {
                robot_id: 9,
                x: 1.0,
                y: 2.0,
                z: 0.1,
                yaw: -3.0,
                tracked: false,
            },
        ];
        let mut buf = [0u8; MAX_POSE_DATAGRAM];
        let n = encode_poses(123_456, 7, &bodies, &mut buf);
        assert_eq!(n, POSE_HEADER_LEN + 2 * POSE_BODY_LEN);
        let mut got = Vec::new();
        let h = decode_poses(&buf[..n], |b| got.push(b)).expect("valid");
        assert_eq!((h.time_us, h.frame, h.count), (123_456, 7, 2));
        assert_eq!(got, bodies);
        assert_eq!(
            decode_poses(&buf[..n - 1], |_| ()),
            Err(PoseError::Truncated)
        );
        let mut bad = buf;
        bad[0] = b'X';
        assert_eq!(decode_poses(&bad[..n], |_| ()), Err(PoseError::BadMagic));
        let mut nan = buf;
        nan[POSE_HEADER_LEN + 2..POSE_HEADER_LEN + 6].copy_from_slice(&f32::NAN.to_le_bytes());
        let mut delivered = 0;
        assert_eq!(
            decode_poses(&nan[..n], |_| delivered += 1),
            Err(PoseError::NonFinite)
        );
        assert_eq!(delivered, 0);
    }
}
