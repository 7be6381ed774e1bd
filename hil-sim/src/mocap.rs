//! Virtual motion capture: ground-truth poses at a fixed rate with Gaussian noise and
//! dropouts, as frames of the documented UDP pose stream (`puzzlebot_protocol::pose`).

use crate::rng::Rng;
use puzzlebot_protocol::pose::{
    encode_poses, BodyPose, MAX_BODIES_PER_DATAGRAM, MAX_POSE_DATAGRAM,
};
use serde::{Deserialize, Serialize};

/// Motion-capture settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MocapConfig {
    /// Frame rate (Hz); DESIGN.md §3: 100.
    pub rate_hz: f64,
    /// Standard deviation of position noise (m).
    pub position_noise_m: f64,
    /// Standard deviation of yaw noise (rad).
    pub yaw_noise_rad: f64,
    /// Probability that a body is lost in a frame (reported untracked, last pose repeated).
    pub dropout: f64,
}

impl Default for MocapConfig {
    fn default() -> Self {
        // Vicon-class numbers: sub-millimetre, a few milliradians.
        MocapConfig {
            rate_hz: 100.0,
            position_noise_m: 0.0003,
            yaw_noise_rad: 0.003,
            dropout: 0.0,
        }
    }
}

impl MocapConfig {
    /// Check ranges; the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.rate_hz.is_finite() && (1.0..=1000.0).contains(&self.rate_hz)) {
            return Err(format!(
                "rate_hz: must be within 1..=1000, got {}",
                self.rate_hz
            ));
        }
        for (n, v) in [
            ("position_noise_m", self.position_noise_m),
            ("yaw_noise_rad", self.yaw_noise_rad),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{n}: must be finite and >= 0, got {v}"));
            }
        }
        if !(self.dropout.is_finite() && (0.0..=1.0).contains(&self.dropout)) {
            return Err(format!(
                "dropout: must be within 0..=1, got {}",
                self.dropout
            ));
        }
        Ok(())
    }
}

/// One capture frame.
#[derive(Debug, Clone, PartialEq)]
pub struct MocapFrame {
    /// Capture time (µs, simulation clock).
    pub time_us: u64,
    /// Frame number.
    pub frame: u32,
    /// Bodies.
    pub bodies: Vec<BodyPose>,
}

impl MocapFrame {
    /// Encode as one or more pose datagrams (≤ 72 bodies each).
    pub fn datagrams(&self) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        let mut buf = [0u8; MAX_POSE_DATAGRAM];
        if self.bodies.is_empty() {
            let n = encode_poses(self.time_us, self.frame, &[], &mut buf);
            out.push(buf[..n].to_vec());
        }
        for chunk in self.bodies.chunks(MAX_BODIES_PER_DATAGRAM) {
            let n = encode_poses(self.time_us, self.frame, chunk, &mut buf);
            out.push(buf[..n].to_vec());
        }
        out
    }
}

/// The capture system's state: noise stream and last reported poses.
#[derive(Debug, Clone)]
pub struct Mocap {
    /// Settings.
    pub config: MocapConfig,
    rng: Rng,
    frame: u32,
    last: Vec<BodyPose>,
}

impl Mocap {
    /// A capture system with its own random stream.
    pub fn new(config: MocapConfig, rng: Rng) -> Mocap {
        Mocap {
            config,
            rng,
            frame: 0,
            last: Vec::new(),
        }
    }

    /// Period between frames (µs).
    pub fn period_us(&self) -> u64 {
        (1.0e6 / self.config.rate_hz).round().max(1.0) as u64
    }

    /// Capture `truth` = (id, x, y, z, yaw) at `time_us`.
    pub fn capture(&mut self, time_us: u64, truth: &[(u16, f64, f64, f64, f64)]) -> MocapFrame {
        let c = self.config;
        let mut bodies = Vec::with_capacity(truth.len());
        for (i, &(id, x, y, z, yaw)) in truth.iter().enumerate() {
            let nx = self.rng.normal() * c.position_noise_m;
            let ny = self.rng.normal() * c.position_noise_m;
            let nz = self.rng.normal() * c.position_noise_m;
            let nyaw = self.rng.normal() * c.yaw_noise_rad;
            let lost = self.rng.chance(c.dropout);
            let prev = match self.last.get(i) {
                Some(b) if b.robot_id == id => Some(*b),
                _ => self.last.iter().find(|b| b.robot_id == id).copied(),
            };
            let b = match (lost, prev) {
                (true, Some(p)) => BodyPose {
                    tracked: false,
                    ..p
                },
                (true, None) => BodyPose {
                    robot_id: id,
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                    yaw: 0.0,
                    tracked: false,
                },
                (false, _) => BodyPose {
                    robot_id: id,
                    x: (x + nx) as f32,
                    y: (y + ny) as f32,
                    z: (z + nz) as f32,
                    yaw: crate::math::wrap(yaw + nyaw) as f32,
                    tracked: true,
                },
            };
            bodies.push(b);
        }
        self.last.clone_from(&bodies);
        let f = MocapFrame {
            time_us,
            frame: self.frame,
            bodies,
        };
        self.frame = self.frame.wrapping_add(1);
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_protocol::pose::decode_poses;

    #[test]
    fn frames_round_trip_through_the_pose_stream_with_noise_and_dropouts() {
        let cfg = MocapConfig {
            dropout: 0.3,
            position_noise_m: 0.001,
            ..MocapConfig::default()
        };
        let mut m = Mocap::new(cfg, Rng::new(1, 2));
        let truth: Vec<_> = (0..100u16)
            .map(|i| (i, f64::from(i), 1.0, 0.0, 0.5))
            .collect();
        let f = m.capture(10_000, &truth);
        let dg = f.datagrams();
        assert_eq!(dg.len(), 2);
        let mut got = Vec::new();
        for d in &dg {
            decode_poses(d, |b| got.push(b)).expect("valid datagram");
        }
        assert_eq!(got.len(), 100);
        let lost = got.iter().filter(|b| !b.tracked).count();
        assert!((10..60).contains(&lost), "{lost}");
        let err = got
            .iter()
            .filter(|b| b.tracked)
            .map(|b| (f64::from(b.x) - f64::from(b.robot_id)).abs())
            .fold(0.0, f64::max);
        assert!(err > 0.0 && err < 0.006, "{err}");
    }
}
