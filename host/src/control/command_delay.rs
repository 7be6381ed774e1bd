//! A controller's latency in simulation: every tick's commands take effect a fixed delay and
//! a random jitter later, as on a real host whose solve takes time while the fleet moves on.
//! The jitter is drawn from a seed (the same run gives the same delays), and a later tick's
//! commands never overtake an earlier tick's.

use std::collections::VecDeque;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Commands of type `T` waiting to take effect.
#[derive(Debug, Clone)]
pub struct CommandDelay<T> {
    /// Fixed part (µs).
    delay_us: u64,
    /// Random part, uniform in [0, this) per tick (µs; 0: none).
    jitter_us: u64,
    rng: StdRng,
    /// (apply time, issue time, commands), in order (µs).
    pending: VecDeque<(u64, u64, T)>,
}

impl<T> CommandDelay<T> {
    /// No delay; the jitter drawn from `seed` once one is set.
    pub fn new(seed: u64) -> Self {
        CommandDelay {
            delay_us: 0,
            jitter_us: 0,
            rng: StdRng::seed_from_u64(seed),
            pending: VecDeque::new(),
        }
    }

    /// Commands take effect `ms` after their tick (negative: 0).
    pub fn set_delay_ms(&mut self, ms: f64) {
        self.delay_us = (ms.max(0.0) * 1000.0) as u64;
    }

    /// And a further random delay in [0, `ms`) (negative: 0).
    pub fn set_jitter_ms(&mut self, ms: f64) {
        self.jitter_us = (ms.max(0.0) * 1000.0) as u64;
    }

    /// Commands issued at `now` (µs).
    pub fn push(&mut self, now: u64, commands: T) {
        let jitter = if self.jitter_us > 0 {
            self.rng.random_range(0..self.jitter_us)
        } else {
            0
        };
        let after = self.pending.back().map_or(0, |&(at, _, _)| at);
        self.pending
            .push_back(((now + self.delay_us + jitter).max(after), now, commands));
    }

    /// When the oldest waiting commands take effect (µs), if any wait.
    pub fn next_due(&self) -> Option<u64> {
        self.pending.front().map(|&(at, _, _)| at)
    }

    /// The oldest commands due by `now` (µs), with the time they were issued.
    pub fn pop_due(&mut self, now: u64) -> Option<(u64, T)> {
        if self.next_due()? <= now {
            self.pending.pop_front().map(|(_, issued, c)| (issued, c))
        } else {
            None
        }
    }

    /// Forget every waiting command.
    pub fn clear(&mut self) {
        self.pending.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_act_after_the_delay_in_order_and_reproducibly() {
        let mut d = CommandDelay::new(7);
        d.set_delay_ms(20.0);
        d.push(0, 'a');
        assert_eq!(d.pop_due(19_999), None);
        assert_eq!(d.pop_due(20_000), Some((0, 'a')));
        d.set_jitter_ms(50.0);
        let draw = |seed| {
            let mut d = CommandDelay::new(seed);
            d.set_delay_ms(20.0);
            d.set_jitter_ms(50.0);
            for k in 0..20 {
                d.push(k * 10_000, k);
            }
            let mut due = Vec::new();
            while let Some(at) = d.next_due() {
                due.push(at);
                d.pop_due(at);
            }
            due
        };
        let a = draw(7);
        assert_eq!(a, draw(7), "the same seed, the same delays");
        assert!(a.windows(2).all(|w| w[0] <= w[1]), "no overtaking: {a:?}");
        assert!(a
            .iter()
            .enumerate()
            .all(|(k, &at)| at >= k as u64 * 10_000 + 20_000));
        assert!(
            a.iter()
                .enumerate()
                .any(|(k, &at)| at > k as u64 * 10_000 + 20_000),
            "the jitter acts: {a:?}"
        );
    }
}
