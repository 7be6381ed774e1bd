//! Instant (v, ω) of a robot from its recent poses.

use serde::{Deserialize, Serialize};

use super::Twist;

/// A planar pose sample: time (s), position (m), heading (rad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseSample {
    /// Time (s, host clock).
    pub t: f64,
    /// Position x (m).
    pub x: f64,
    /// Position y (m).
    pub y: f64,
    /// Heading (rad).
    pub theta: f64,
}

pub use puzzlebot_params::angle::wrap_angle;

/// Instant (v, ω) from poses by least-squares slopes over a short window (THESIS 4.4.3:
/// "calculates the instant linear and angular velocity within a small time window").
#[derive(Debug, Clone)]
pub struct VelocityEstimator {
    window: f64,
    samples: std::collections::VecDeque<PoseSample>,
}

impl VelocityEstimator {
    /// Estimator over the last `window` seconds of samples.
    pub fn new(window: f64) -> Self {
        VelocityEstimator {
            window,
            samples: std::collections::VecDeque::new(),
        }
    }

    /// Forget every sample (pose lost).
    pub fn clear(&mut self) {
        self.samples.clear();
    }

    /// Add a sample; headings are unwrapped against the previous sample. Out-of-order and
    /// duplicate times are ignored.
    pub fn push(&mut self, mut s: PoseSample) {
        if let Some(last) = self.samples.back() {
            if s.t <= last.t {
                return;
            }
            s.theta = last.theta + wrap_angle(s.theta - last.theta);
        }
        self.samples.push_back(s);
        while let Some(first) = self.samples.front() {
            if s.t - first.t > self.window {
                self.samples.pop_front();
            } else {
                break;
            }
        }
    }

    /// The estimate, once at least three samples span a third of the window.
    pub fn estimate(&self) -> Option<Twist> {
        let n = self.samples.len();
        if n < 3 {
            return None;
        }
        let t0 = self.samples[0].t;
        let span = self.samples[n - 1].t - t0;
        if span < self.window / 3.0 {
            return None;
        }
        let nf = n as f64;
        let mt = self.samples.iter().map(|s| s.t - t0).sum::<f64>() / nf;
        let slope = |get: &dyn Fn(&PoseSample) -> f64| {
            let m = self.samples.iter().map(get).sum::<f64>() / nf;
            let mut num = 0.0;
            let mut den = 0.0;
            for s in &self.samples {
                let dt = s.t - t0 - mt;
                num += dt * (get(s) - m);
                den += dt * dt;
            }
            if den > 0.0 {
                num / den
            } else {
                0.0
            }
        };
        let vx = slope(&|s| s.x);
        let vy = slope(&|s| s.y);
        let omega = slope(&|s| s.theta);
        let th = self.samples.iter().map(|s| s.theta).sum::<f64>() / nf;
        Some(Twist::new(vx * th.cos() + vy * th.sin(), omega))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_estimate_of_a_circle() {
        let mut e = VelocityEstimator::new(0.15);
        let (v, w) = (0.05, 0.5);
        for i in 0..30 {
            let t = f64::from(i) * 0.01;
            let th = 3.0 + w * t; // crosses ±π: unwrapping matters
            let (x, y) = ((v / w) * th.sin(), -(v / w) * th.cos());
            e.push(PoseSample {
                t,
                x,
                y,
                theta: wrap_angle(th),
            });
        }
        let est = e.estimate().expect("enough samples");
        assert!(
            (est.v - v).abs() < 1e-3 && (est.omega - w).abs() < 1e-6,
            "{est:?}"
        );
    }
}
