//! Virtual radio: per-robot, per-direction link impairments (latency, jitter, loss,
//! duplication, reordering), deterministic from the scenario seed.
//!
//! Each direction of each robot has its own random stream, so changing one robot's
//! impairments or traffic never changes what another robot experiences.

use crate::rng::Rng;
use serde::{Deserialize, Serialize};

/// Impairments of one robot's link (applied to both directions).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Impairments {
    /// Fixed one-way latency (ms).
    pub latency_ms: f64,
    /// Extra one-way delay, uniform in 0…jitter (ms).
    pub jitter_ms: f64,
    /// Probability that a datagram is lost (0…1).
    pub loss: f64,
    /// Probability that a datagram arrives twice (0…1).
    pub duplicate: f64,
    /// Probability that a datagram is held back behind later ones (0…1).
    pub reorder: f64,
}

impl Impairments {
    /// A perfect link.
    pub const NONE: Impairments = Impairments {
        latency_ms: 0.0,
        jitter_ms: 0.0,
        loss: 0.0,
        duplicate: 0.0,
        reorder: 0.0,
    };

    /// Check ranges; the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("latency_ms", self.latency_ms),
            ("jitter_ms", self.jitter_ms),
        ] {
            if !(v.is_finite() && (0.0..=10_000.0).contains(&v)) {
                return Err(format!("{name}: must be within 0..=10000 ms, got {v}"));
            }
        }
        for (name, v) in [
            ("loss", self.loss),
            ("duplicate", self.duplicate),
            ("reorder", self.reorder),
        ] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return Err(format!(
                    "{name}: must be a probability within 0..=1, got {v}"
                ));
            }
        }
        Ok(())
    }
}

/// A datagram in flight.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InFlight {
    /// Simulation time of arrival (µs).
    pub at_us: u64,
    /// Tie-breaker: order of entry.
    pub seq: u64,
    /// The bytes.
    pub bytes: Vec<u8>,
}

/// One direction of one robot's link.
#[derive(Debug, Clone)]
pub struct Channel {
    rng: Rng,
    seq: u64,
    queue: Vec<InFlight>,
    /// Datagrams dropped by the loss model.
    pub lost: u64,
    /// Datagrams duplicated.
    pub duplicated: u64,
}

/// Bound on datagrams in flight per direction; beyond it the oldest are dropped
/// (a real radio queue is bounded too).
pub const MAX_IN_FLIGHT: usize = 512;

impl Channel {
    /// A channel drawing from `rng`.
    pub fn new(rng: Rng) -> Channel {
        Channel {
            rng,
            seq: 0,
            queue: Vec::new(),
            lost: 0,
            duplicated: 0,
        }
    }

    fn delay_us(&mut self, imp: &Impairments) -> u64 {
        let mut d = imp.latency_ms + imp.jitter_ms * self.rng.uniform();
        if self.rng.chance(imp.reorder) {
            // Held back long enough to arrive behind the next datagrams.
            d += 2.0 * imp.jitter_ms + 2.0 + 5.0 * self.rng.uniform();
        }
        (d * 1000.0).round() as u64
    }

    /// Send `bytes` at `now_us` through impairments `imp`.
    pub fn send(&mut self, now_us: u64, bytes: &[u8], imp: &Impairments) {
        // Draw the same number of random values whatever happens, so one datagram's fate
        // does not shift the stream of the next.
        let lost = self.rng.chance(imp.loss);
        let dup = self.rng.chance(imp.duplicate);
        let d1 = self.delay_us(imp);
        let d2 = self.delay_us(imp) + 100;
        if lost {
            self.lost += 1;
            return;
        }
        let push = |at_us: u64, q: &mut Vec<InFlight>, seq: &mut u64| {
            if q.len() >= MAX_IN_FLIGHT {
                q.remove(0);
            }
            q.push(InFlight {
                at_us,
                seq: *seq,
                bytes: bytes.to_vec(),
            });
            *seq += 1;
        };
        push(now_us + d1, &mut self.queue, &mut self.seq);
        if dup {
            self.duplicated += 1;
            push(now_us + d1.max(d2), &mut self.queue, &mut self.seq);
        }
    }

    /// Take every datagram due at or before `now_us`, in arrival order.
    pub fn due(&mut self, now_us: u64, mut each: impl FnMut(&[u8])) {
        if self.queue.iter().all(|f| f.at_us > now_us) {
            return;
        }
        self.queue.sort_by_key(|f| (f.at_us, f.seq));
        let n = self.queue.partition_point(|f| f.at_us <= now_us);
        for f in self.queue.drain(..n) {
            each(&f.bytes);
        }
    }

    /// Drop everything in flight (robot switched off).
    pub fn clear(&mut self) {
        self.queue.clear();
    }

    /// Datagrams in flight.
    pub fn in_flight(&self) -> usize {
        self.queue.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(imp: Impairments, seed: u64) -> Vec<(u64, u8)> {
        let mut c = Channel::new(Rng::new(seed, 9));
        let mut got = Vec::new();
        for t in 0..200u64 {
            c.send(t * 1000, &[t as u8], &imp);
            c.due(t * 1000, |b| got.push((t, b[0])));
        }
        c.due(u64::MAX, |b| got.push((u64::MAX, b[0])));
        got
    }

    #[test]
    fn impairments_are_deterministic_and_have_effect() {
        let imp = Impairments {
            latency_ms: 3.0,
            jitter_ms: 4.0,
            loss: 0.2,
            duplicate: 0.1,
            reorder: 0.1,
        };
        let a = run(imp, 1);
        assert_eq!(a, run(imp, 1));
        assert_ne!(a, run(imp, 2));
        let n = a.len();
        assert!((150..200).contains(&n), "{n} delivered");
        let mut payloads: Vec<u8> = a.iter().map(|x| x.1).collect();
        assert!(payloads.windows(2).any(|w| w[1] < w[0]), "some reordering");
        payloads.sort_unstable();
        assert!(payloads.windows(2).any(|w| w[1] == w[0]), "some duplicates");
        assert!(a.iter().all(|(t, p)| *t >= u64::from(*p) + 3));
        let clean = run(Impairments::NONE, 1);
        assert_eq!(clean.len(), 200);
        assert!(clean.iter().all(|(t, p)| *t == u64::from(*p)));
        assert!(imp.validate().is_ok());
        assert!(Impairments { loss: 1.5, ..imp }
            .validate()
            .unwrap_err()
            .contains("loss"));
    }
}
