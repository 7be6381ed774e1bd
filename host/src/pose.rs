//! Pose input behind one trait: every source is a UDP datagram stream decoded by a
//! [`PoseDecoder`] — the documented PBP1 stream (`puzzlebot_protocol::pose`, also what the
//! simulator's virtual motion capture sends) or OptiTrack NatNet frames of data (the
//! `natnet` crate). Samples land in a shared [`PoseTable`] stamped with the host clock;
//! stale, untracked or missing poses read as `None`, and the control loop stops those robots.

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};

use puzzlebot_protocol::{messages::RobotId, pose::decode_poses};
use tokio::net::UdpSocket;
use tokio::task::JoinHandle;
use tokio::time::Instant;

use crate::config::UpAxis;
use crate::drive::PoseSample;

/// One body in one capture frame, in the ground plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// Robot id.
    pub robot: RobotId,
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Heading (rad, CCW from +x).
    pub theta: f64,
    /// False when the capture system lost the body in this frame.
    pub tracked: bool,
}

/// A datagram format carrying poses.
pub trait PoseDecoder: Send + 'static {
    /// Short name for logs.
    fn name(&self) -> &'static str;
    /// Decode one datagram into observations; an error names what was wrong.
    fn decode(&mut self, bytes: &[u8], out: &mut Vec<Observation>) -> Result<(), String>;
}

/// The documented PBP1 pose stream.
#[derive(Debug, Default, Clone, Copy)]
pub struct Pbp1Decoder;

impl PoseDecoder for Pbp1Decoder {
    fn name(&self) -> &'static str {
        "pbp1"
    }

    fn decode(&mut self, bytes: &[u8], out: &mut Vec<Observation>) -> Result<(), String> {
        decode_poses(bytes, |b| {
            out.push(Observation {
                robot: b.robot_id,
                x: f64::from(b.x),
                y: f64::from(b.y),
                theta: f64::from(b.yaw),
                tracked: b.tracked,
            })
        })
        .map(|_| ())
        .map_err(|e| e.to_string())
    }
}

/// OptiTrack NatNet FrameOfData datagrams; rigid-body streaming id = robot id.
#[derive(Debug, Clone, Copy)]
pub struct NatNetDecoder {
    version: natnet::Version,
    up: UpAxis,
}

impl NatNetDecoder {
    /// A decoder for bitstream `version` ("4.1", "3.1", …) and the capture frame's up axis.
    pub fn new(version: &str, up: UpAxis) -> Result<Self, String> {
        let mut parts = version.trim().split('.');
        let mut num = || -> Result<u8, String> {
            parts
                .next()
                .unwrap_or("0")
                .parse::<u8>()
                .map_err(|_| format!("NatNet version {version:?} is not major.minor"))
        };
        let (major, minor) = (num()?, num()?);
        let v = natnet::Version {
            major,
            minor,
            build: 0,
            revision: 0,
        };
        natnet::Decoder::new(v).map_err(|e| format!("NatNet version {version}: {e}"))?;
        Ok(NatNetDecoder { version: v, up })
    }
}

/// Ground-plane position and heading of a pose given as position and quaternion [x, y, z, w].
fn planar(position: [f32; 3], q: [f32; 4], up: UpAxis) -> (f64, f64, f64) {
    let [qx, qy, qz, qw] = q.map(f64::from);
    let [px, py, pz] = position.map(f64::from);
    // Body forward axis (+x) rotated into the capture frame.
    let fx = 1.0 - 2.0 * (qy * qy + qz * qz);
    let fy = 2.0 * (qx * qy + qw * qz);
    let fz = 2.0 * (qx * qz - qw * qy);
    match up {
        UpAxis::Z => (px, py, fy.atan2(fx)),
        // y up, right-handed: ground x = x, ground y = −z.
        UpAxis::Y => (px, -pz, (-fz).atan2(fx)),
    }
}

impl PoseDecoder for NatNetDecoder {
    fn name(&self) -> &'static str {
        "natnet"
    }

    fn decode(&mut self, bytes: &[u8], out: &mut Vec<Observation>) -> Result<(), String> {
        let decoder = natnet::Decoder::new(self.version).map_err(|e| e.to_string())?;
        let msg = decoder
            .parse(bytes)
            .map_err(|e| e.to_string())?
            .into_message();
        let natnet::Message::FrameOfData(frame) = msg else {
            // Model definitions and other messages carry no poses.
            return Ok(());
        };
        for b in &frame.rigid_bodies {
            let Ok(robot) = RobotId::try_from(b.id) else {
                continue;
            };
            let (x, y, theta) = planar(b.position, b.orientation, self.up);
            let finite = x.is_finite() && y.is_finite() && theta.is_finite();
            out.push(Observation {
                robot,
                x,
                y,
                theta,
                tracked: b.tracking_valid() && finite,
            });
        }
        Ok(())
    }
}

#[derive(Debug, Clone, Copy)]
struct Entry {
    sample: PoseSample,
    at: Instant,
}

/// Latest pose of every body, stamped with the host clock.
#[derive(Debug, Clone)]
pub struct PoseTable {
    epoch: Instant,
    inner: Arc<Mutex<PoseTableInner>>,
}

#[derive(Debug, Default)]
struct PoseTableInner {
    /// The latest observation of each body, tracked or not.
    latest: BTreeMap<RobotId, Entry>,
    /// The latest tracked observation of each body: a frame that lost the body does not
    /// erase it, so one dropped frame is not a lost pose (a pose is lost when this one is
    /// older than the stale limit).
    tracked: BTreeMap<RobotId, Entry>,
    datagrams: u64,
    errors: u64,
    last_error: Option<String>,
}

/// Counters of a pose input.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct PoseStats {
    /// Datagrams decoded.
    pub datagrams: u64,
    /// Datagrams refused.
    pub errors: u64,
    /// The last refusal.
    pub last_error: Option<String>,
}

impl PoseTable {
    /// An empty table; times are seconds since `epoch`.
    pub fn new(epoch: Instant) -> Self {
        PoseTable {
            epoch,
            inner: Arc::new(Mutex::new(PoseTableInner::default())),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, PoseTableInner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Record observations received at `at`.
    pub fn record(&self, obs: &[Observation], at: Instant) {
        let t = at.duration_since(self.epoch).as_secs_f64();
        let mut g = self.lock();
        g.datagrams += 1;
        for o in obs {
            let e = Entry {
                sample: PoseSample {
                    t,
                    x: o.x,
                    y: o.y,
                    theta: o.theta,
                },
                at,
            };
            g.latest.insert(o.robot, e);
            if o.tracked {
                g.tracked.insert(o.robot, e);
            }
        }
    }

    fn record_error(&self, e: String) {
        let mut g = self.lock();
        g.errors += 1;
        g.last_error = Some(e);
    }

    /// The latest tracked pose of `robot` if it is at most `max_age` old (frames that lost
    /// the body in between do not count: the capture drops single frames).
    pub fn fresh(&self, robot: RobotId, max_age: std::time::Duration) -> Option<PoseSample> {
        let now = Instant::now();
        let g = self.lock();
        g.tracked
            .get(&robot)
            .filter(|e| now.duration_since(e.at) <= max_age)
            .map(|e| e.sample)
    }

    /// The latest pose of `robot`, however old or untracked.
    pub fn latest(&self, robot: RobotId) -> Option<PoseSample> {
        self.lock().latest.get(&robot).map(|e| e.sample)
    }

    /// The latest pose of `robot` if it is tracked, however old.
    pub fn latest_tracked(&self, robot: RobotId) -> Option<PoseSample> {
        self.lock().tracked.get(&robot).map(|e| e.sample)
    }

    /// How long ago the latest pose of `robot` arrived.
    pub fn age(&self, robot: RobotId) -> Option<std::time::Duration> {
        let now = Instant::now();
        self.lock()
            .latest
            .get(&robot)
            .map(|e| now.duration_since(e.at))
    }

    /// Counters.
    pub fn stats(&self) -> PoseStats {
        let g = self.lock();
        PoseStats {
            datagrams: g.datagrams,
            errors: g.errors,
            last_error: g.last_error.clone(),
        }
    }
}

/// A running pose input: a bound socket and its receive task.
pub struct PoseInput {
    /// The table it fills.
    pub table: PoseTable,
    addr: SocketAddr,
    task: JoinHandle<()>,
}

impl PoseInput {
    /// Bind `bind` and decode every datagram with `decoder` into a new table.
    pub async fn start(
        bind: SocketAddr,
        mut decoder: impl PoseDecoder,
        epoch: Instant,
    ) -> std::io::Result<PoseInput> {
        let socket = UdpSocket::bind(bind).await?;
        let addr = socket.local_addr()?;
        let table = PoseTable::new(epoch);
        let t2 = table.clone();
        tracing::info!(%addr, source = decoder.name(), "pose input listening");
        let task = tokio::spawn(async move {
            let mut buf = vec![0u8; 65_536];
            let mut obs = Vec::new();
            loop {
                let Ok((n, _)) = socket.recv_from(&mut buf).await else {
                    tokio::time::sleep(std::time::Duration::from_millis(1)).await;
                    continue;
                };
                let at = Instant::now();
                obs.clear();
                match decoder.decode(&buf[..n], &mut obs) {
                    Ok(()) => t2.record(&obs, at),
                    Err(e) => {
                        tracing::debug!(error = %e, "pose datagram refused");
                        t2.record_error(e);
                    }
                }
            }
        });
        Ok(PoseInput { table, addr, task })
    }

    /// The bound address (send poses here).
    pub fn local_addr(&self) -> SocketAddr {
        self.addr
    }
}

impl Drop for PoseInput {
    fn drop(&mut self) {
        self.task.abort();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_protocol::pose::{encode_poses, BodyPose, MAX_POSE_DATAGRAM};

    #[tokio::test]
    async fn pbp1_stream_fills_the_table_and_goes_stale() {
        let input = PoseInput::start(
            "127.0.0.1:0".parse().expect("addr"),
            Pbp1Decoder,
            Instant::now(),
        )
        .await
        .expect("bind");
        let tx = UdpSocket::bind("127.0.0.1:0").await.expect("bind");
        let mut buf = [0u8; MAX_POSE_DATAGRAM];
        let bodies = [
            BodyPose {
                robot_id: 4,
                x: 0.5,
                y: -0.25,
                z: 0.0,
                yaw: 1.0,
                tracked: true,
            },
            BodyPose {
                robot_id: 5,
                x: 0.0,
                y: 0.0,
                z: 0.0,
                yaw: 0.0,
                tracked: false,
            },
        ];
        let n = encode_poses(1, 1, &bodies, &mut buf);
        tx.send_to(&buf[..n], input.local_addr())
            .await
            .expect("send");
        tx.send_to(b"garbage", input.local_addr())
            .await
            .expect("send");
        let ms = std::time::Duration::from_millis;
        for _ in 0..200 {
            if input.table.stats().errors > 0 && input.table.latest(4).is_some() {
                break;
            }
            tokio::time::sleep(ms(2)).await;
        }
        let p = input.table.fresh(4, ms(500)).expect("fresh");
        assert!((p.x - 0.5).abs() < 1e-6 && (p.theta - 1.0).abs() < 1e-6);
        assert!(
            input.table.fresh(5, ms(500)).is_none(),
            "never tracked reads as missing"
        );
        // A frame that lost robot 4 leaves its last tracked pose: one dropped frame is not
        // a lost pose.
        let lost = [BodyPose {
            x: 0.9,
            tracked: false,
            ..bodies[0]
        }];
        let n = encode_poses(2, 2, &lost, &mut buf);
        tx.send_to(&buf[..n], input.local_addr())
            .await
            .expect("send");
        for _ in 0..200 {
            if input
                .table
                .latest(4)
                .is_some_and(|p| (p.x - 0.9).abs() < 1e-6)
            {
                break;
            }
            tokio::time::sleep(ms(2)).await;
        }
        let p = input.table.fresh(4, ms(500)).expect("still fresh");
        assert!(
            (p.x - 0.5).abs() < 1e-6,
            "the tracked pose, not the lost frame's"
        );
        assert!(input.table.fresh(6, ms(500)).is_none(), "never seen");
        assert_eq!(input.table.stats().errors, 1);
        tokio::time::sleep(ms(30)).await;
        assert!(input.table.fresh(4, ms(10)).is_none(), "stale");
    }

    #[tokio::test]
    async fn natnet_stream_over_loopback_fills_the_table() {
        let input = PoseInput::start(
            "127.0.0.1:0".parse().expect("addr"),
            NatNetDecoder::new("4.1", UpAxis::Z).expect("version"),
            Instant::now(),
        )
        .await
        .expect("bind");
        let server = natnet::SyntheticServer::new(natnet::Version::V4_1, 1_000_000);
        let tx = UdpSocket::bind("127.0.0.1:0").await.expect("bind");
        let wire = server
            .datagram(
                1,
                0.01,
                &[natnet::PlannedBody::tracked(
                    7,
                    [0.1, 0.2, 0.0],
                    [0.0, 0.0, 0.0, 1.0],
                )],
            )
            .expect("encode");
        tx.send_to(&wire, input.local_addr()).await.expect("send");
        let ms = std::time::Duration::from_millis;
        for _ in 0..200 {
            if input.table.latest(7).is_some() {
                break;
            }
            tokio::time::sleep(ms(2)).await;
        }
        let p = input.table.fresh(7, ms(500)).expect("pose from NatNet");
        assert!((p.x - 0.1).abs() < 1e-6 && (p.y - 0.2).abs() < 1e-6 && p.theta.abs() < 1e-6);
    }

    #[test]
    fn natnet_synthetic_frames_decode_to_planar_poses() {
        let server = natnet::SyntheticServer::new(natnet::Version::V4_1, 1_000_000);
        let yaw: f32 = 0.7;
        // y-up capture frame: heading yaw about +y maps to ground heading yaw.
        let (s, c) = ((yaw / 2.0).sin(), (yaw / 2.0).cos());
        let bodies = [
            natnet::PlannedBody::tracked(3, [0.2, 0.05, -0.4], [0.0, s, 0.0, c]),
            natnet::PlannedBody::dropout(8),
        ];
        let wire = server.datagram(10, 0.1, &bodies).expect("encode");
        let mut d = NatNetDecoder::new("4.1", UpAxis::Y).expect("version");
        let mut out = Vec::new();
        d.decode(&wire, &mut out).expect("decode");
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].robot, 3);
        assert!(
            (out[0].x - 0.2).abs() < 1e-6 && (out[0].y - 0.4).abs() < 1e-6,
            "{:?}",
            out[0]
        );
        assert!((out[0].theta - f64::from(yaw)).abs() < 1e-5, "{:?}", out[0]);
        assert!(!out[1].tracked);
        // z-up: rotation about +z.
        let (s, c) = ((yaw / 2.0).sin(), (yaw / 2.0).cos());
        let wire = server
            .datagram(
                11,
                0.2,
                &[natnet::PlannedBody::tracked(
                    3,
                    [0.2, 0.3, 0.0],
                    [0.0, 0.0, s, c],
                )],
            )
            .expect("encode");
        let mut d = NatNetDecoder::new("4.1", UpAxis::Z).expect("version");
        out.clear();
        d.decode(&wire, &mut out).expect("decode");
        assert!((out[0].y - 0.3).abs() < 1e-6 && (out[0].theta - f64::from(yaw)).abs() < 1e-5);
        assert!(d.decode(b"\x07\x00\xff\xff", &mut out).is_err());
        assert!(NatNetDecoder::new("four", UpAxis::Y).is_err());
    }
}
