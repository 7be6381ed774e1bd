//! The stateless decoders: the authenticated envelope and the pose stream.

use puzzlebot_protocol::pose::{decode_poses, encode_poses, BodyPose, POSE_BODY_LEN};
use puzzlebot_protocol::pose::{MAX_POSE_DATAGRAM, POSE_HEADER_LEN};
use puzzlebot_protocol::{
    open, peek_header, Direction, HostMsg, RobotMsg, Stream, MAX_DATAGRAM, TAG_LEN,
};

use super::{check_host_bounds, check_reencodes, input_key};

/// Envelope decoder: `peek_header` and `open` of both message types on raw bytes, then the
/// same bytes with a valid tag appended so payload decoding is reached.
pub fn fuzz_envelope(data: &[u8]) {
    let key = input_key(data).session_key(&[3; 16], &[4; 16]);
    let peek = peek_header(data);
    let hm = open::<HostMsg>(&key, data);
    let rm = open::<RobotMsg>(&key, data);
    if data.len() > MAX_DATAGRAM {
        assert!(peek.is_err() && hm.is_err() && rm.is_err());
    }
    // A fuzzer cannot forge HMAC-SHA256: raw input never authenticates.
    assert!(hm.is_err() && rm.is_err(), "forged frame accepted");

    // Structure-aware: treat the input as header + payload and tag it with the real key.
    let body_len = data.len().min(MAX_DATAGRAM - TAG_LEN);
    let mut frame = data[..body_len].to_vec();
    frame.extend_from_slice(&key.tag(&frame));
    let header = peek_header(&frame);
    if let Ok((h, m)) = open::<HostMsg>(&key, &frame) {
        assert_eq!(Ok(h), header);
        assert_eq!(h.direction, Direction::HostToRobot);
        check_host_bounds(&m);
        assert_eq!(h.stream == Stream::Hello, m.is_hello());
        check_reencodes(&key, h, &m);
    }
    if let Ok((h, m)) = open::<RobotMsg>(&key, &frame) {
        assert_eq!(Ok(h), header);
        assert_eq!(h.direction, Direction::RobotToHost);
        assert_eq!(h.stream == Stream::Hello, m.is_hello());
        check_reencodes(&key, h, &m);
    }
}

/// Pose stream decoder: never panics, delivers exactly `count` bodies, and what it accepts
/// re-encodes to an equal datagram (up to unused flag bits).
pub fn fuzz_poses(data: &[u8]) {
    let mut got: Vec<BodyPose> = Vec::new();
    let r = decode_poses(data, |b| got.push(b));
    match r {
        Ok(h) => {
            assert_eq!(got.len(), h.count);
            assert_eq!(data.len(), POSE_HEADER_LEN + h.count * POSE_BODY_LEN);
            let mut out = vec![0u8; MAX_POSE_DATAGRAM];
            let n = encode_poses(h.time_us, h.frame, &got, &mut out);
            assert_eq!(n, data.len());
            let mut again = Vec::new();
            let h2 = decode_poses(&out[..n], |b| again.push(b)).expect("re-encoded poses decode");
            assert_eq!(h, h2);
            assert_eq!(got, again);
        }
        Err(_) => assert!(got.is_empty(), "bodies delivered from a rejected datagram"),
    }
}
