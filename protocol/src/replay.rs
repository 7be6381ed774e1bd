//! Strictly increasing counters with a small reorder window (IPsec-style bitmap).

use crate::reject::Rejection;

/// Width of the reorder window: a frame up to this many counters behind the newest
/// accepted one is still accepted once.
pub const REPLAY_WINDOW: u64 = 64;

/// Per-stream replay state of a receiver.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReplayWindow {
    /// Highest counter accepted so far; `None` before the first frame.
    highest: Option<u64>,
    /// Bit `i` set: counter `highest - i` was accepted.
    seen: u64,
}

impl ReplayWindow {
    /// A fresh window (new session).
    pub const fn new() -> Self {
        ReplayWindow {
            highest: None,
            seen: 0,
        }
    }

    /// Highest accepted counter.
    pub fn highest(&self) -> Option<u64> {
        self.highest
    }

    /// Would `counter` be accepted? (No state change.)
    pub fn check(&self, counter: u64) -> Result<(), Rejection> {
        let Some(h) = self.highest else {
            return Ok(());
        };
        if counter > h {
            return Ok(());
        }
        let back = h - counter;
        if back >= REPLAY_WINDOW {
            return Err(Rejection::TooOld);
        }
        if self.seen & (1u64 << back) != 0 {
            return Err(Rejection::Replay);
        }
        Ok(())
    }

    /// Check and record `counter`. Call only for authenticated frames.
    pub fn accept(&mut self, counter: u64) -> Result<(), Rejection> {
        self.check(counter)?;
        match self.highest {
            None => {
                self.highest = Some(counter);
                self.seen = 1;
            }
            Some(h) if counter > h => {
                let shift = counter - h;
                self.seen = if shift >= REPLAY_WINDOW {
                    0
                } else {
                    self.seen << shift
                };
                self.seen |= 1;
                self.highest = Some(counter);
            }
            Some(h) => {
                self.seen |= 1u64 << (h - counter);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_order_reordered_replayed_and_old() {
        let mut w = ReplayWindow::new();
        assert_eq!(w.accept(5), Ok(()));
        assert_eq!(w.accept(7), Ok(()));
        assert_eq!(
            w.accept(6),
            Ok(()),
            "reordered within window is accepted once"
        );
        assert_eq!(w.accept(6), Err(Rejection::Replay));
        assert_eq!(w.accept(7), Err(Rejection::Replay));
        assert_eq!(w.accept(200), Ok(()));
        assert_eq!(w.accept(200 - REPLAY_WINDOW), Err(Rejection::TooOld));
        assert_eq!(w.accept(200 - REPLAY_WINDOW + 1), Ok(()));
        assert_eq!(w.highest(), Some(200));
    }
}
