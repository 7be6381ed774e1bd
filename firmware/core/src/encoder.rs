//! Quadrature decoding of the magnetic wheel encoders and a short history of timestamped
//! edges for the speed estimator.
//!
//! The ESP32-C3 has no pulse counter, so every edge of A or B raises a GPIO interrupt that
//! reads both levels and a hardware timer (DESIGN.md §5) and calls [`Encoder::on_edge`].
//! The simulator calls the same function from its encoder model.

/// How many of the most recent counted edges are kept for the speed estimator.
pub const EDGE_HISTORY: usize = 16;

/// One counted edge: when it happened and the position it led to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Edge {
    /// Timestamp of the edge (µs, injected clock).
    pub t_us: u64,
    /// Position after the edge (edges, signed).
    pub position: i32,
}

/// What one input change meant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Levels unchanged (bounce or spurious interrupt), or the first reading.
    None,
    /// One step forward (A leads B).
    Forward,
    /// One step backward (B leads A).
    Backward,
    /// Both channels changed at once: an edge was missed; direction unknown, not counted.
    Illegal,
}

/// Quadrature state of levels (A, B) as an index 0..=3: `(a << 1) | b`.
#[inline]
pub const fn state_of(a: bool, b: bool) -> u8 {
    ((a as u8) << 1) | (b as u8)
}

/// Levels (A, B) of a position: the forward Gray sequence is 00 → 10 → 11 → 01 → 00.
pub const fn levels_of(position: i32) -> (bool, bool) {
    match position.rem_euclid(4) {
        0 => (false, false),
        1 => (true, false),
        2 => (true, true),
        _ => (false, true),
    }
}

/// All 16 transitions `[previous state][new state]` of the forward sequence 0 → 2 → 3 → 1 → 0.
const TRANSITIONS: [[Step; 4]; 4] = {
    use Step::{Backward as B, Forward as F, Illegal as X, None as N};
    [
        // to:  00 01 10 11
        /* 00 */ [N, B, F, X],
        /* 01 */ [F, N, X, B],
        /* 10 */ [B, X, N, F],
        /* 11 */ [X, F, B, N],
    ]
};

/// Decode one transition between two quadrature states (each 0..=3; higher bits ignored).
#[inline]
pub const fn decode(previous: u8, current: u8) -> Step {
    TRANSITIONS[(previous & 3) as usize][(current & 3) as usize]
}

/// One wheel's quadrature decoder with a ring of recent edge timestamps.
#[derive(Debug, Clone)]
pub struct Encoder {
    state: Option<u8>,
    position: i32,
    errors: u32,
    ring: [Edge; EDGE_HISTORY],
    head: usize,
    len: usize,
}

impl Default for Encoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Encoder {
    /// A decoder that has not yet seen the input levels.
    pub const fn new() -> Self {
        Encoder {
            state: None,
            position: 0,
            errors: 0,
            ring: [Edge {
                t_us: 0,
                position: 0,
            }; EDGE_HISTORY],
            head: 0,
            len: 0,
        }
    }

    /// Record the levels read at start-up (no step is counted).
    pub fn init_levels(&mut self, a: bool, b: bool) {
        self.state = Some(state_of(a, b));
    }

    /// Feed one interrupt: the levels of A and B right after an edge, and its timestamp.
    pub fn on_edge(&mut self, a: bool, b: bool, t_us: u64) -> Step {
        let cur = state_of(a, b);
        let Some(prev) = self.state.replace(cur) else {
            return Step::None;
        };
        let step = decode(prev, cur);
        match step {
            Step::Forward => self.position = self.position.wrapping_add(1),
            Step::Backward => self.position = self.position.wrapping_sub(1),
            Step::Illegal => {
                self.errors = self.errors.wrapping_add(1);
                return step;
            }
            Step::None => return step,
        }
        self.ring[self.head] = Edge {
            t_us,
            position: self.position,
        };
        self.head = (self.head + 1) % EDGE_HISTORY;
        self.len = (self.len + 1).min(EDGE_HISTORY);
        step
    }

    /// Net position (edges) since start.
    pub fn position(&self) -> i32 {
        self.position
    }

    /// Illegal double steps seen since start.
    pub fn errors(&self) -> u32 {
        self.errors
    }

    /// A copy of the counters and the edge history (oldest first) for the control loop.
    pub fn snapshot(&self) -> EncoderSnapshot {
        let mut edges = [Edge::default(); EDGE_HISTORY];
        let start = (self.head + EDGE_HISTORY - self.len) % EDGE_HISTORY;
        for (i, e) in edges.iter_mut().take(self.len).enumerate() {
            *e = self.ring[(start + i) % EDGE_HISTORY];
        }
        EncoderSnapshot {
            position: self.position,
            errors: self.errors,
            edges,
            len: self.len,
        }
    }
}

/// The state of one encoder at a control tick, as handed to [`crate::Robot::tick`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EncoderSnapshot {
    /// Net position (edges).
    pub position: i32,
    /// Illegal transitions since start.
    pub errors: u32,
    /// The most recent counted edges, oldest first; only `len` are valid.
    pub edges: [Edge; EDGE_HISTORY],
    /// Number of valid entries in `edges`.
    pub len: usize,
}

impl Default for EncoderSnapshot {
    fn default() -> Self {
        Encoder::new().snapshot()
    }
}

impl EncoderSnapshot {
    /// The valid edges, oldest first.
    pub fn edges(&self) -> &[Edge] {
        &self.edges[..self.len.min(EDGE_HISTORY)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_sixteen_transitions() {
        for prev in 0..4u8 {
            for cur in 0..4u8 {
                let step = decode(prev, cur);
                let diff = prev ^ cur;
                if diff == 0 {
                    assert_eq!(step, Step::None);
                } else if diff == 3 {
                    assert_eq!(step, Step::Illegal, "{prev}->{cur}");
                } else {
                    // One bit changed: forward iff it follows the Gray sequence.
                    let fwd = [2u8, 0, 3, 1][prev as usize] == cur;
                    assert_eq!(step, if fwd { Step::Forward } else { Step::Backward });
                }
            }
        }
    }

    #[test]
    fn counts_forward_backward_and_errors() {
        let mut e = Encoder::new();
        e.init_levels(false, false);
        for p in 1..=10 {
            let (a, b) = levels_of(p);
            assert_eq!(e.on_edge(a, b, p as u64 * 100), Step::Forward);
        }
        assert_eq!(e.position(), 10);
        for p in (5..10).rev() {
            let (a, b) = levels_of(p);
            assert_eq!(e.on_edge(a, b, 2000), Step::Backward);
        }
        assert_eq!(e.position(), 5);
        // Jump two states: illegal, counted as an error, position unchanged.
        let (a, b) = levels_of(7);
        assert_eq!(e.on_edge(a, b, 3000), Step::Illegal);
        assert_eq!(e.errors(), 1);
        assert_eq!(e.position(), 5);
        // Repeating the same levels is no step.
        assert_eq!(e.on_edge(a, b, 3001), Step::None);
        // Decoding continues from the new state.
        let (a, b) = levels_of(8);
        assert_eq!(e.on_edge(a, b, 3100), Step::Forward);
        assert_eq!(e.position(), 6);
    }

    #[test]
    fn history_keeps_newest_edges_in_order() {
        let mut e = Encoder::new();
        e.init_levels(false, false);
        for p in 1..=40 {
            let (a, b) = levels_of(p);
            e.on_edge(a, b, p as u64 * 10);
        }
        let s = e.snapshot();
        assert_eq!(s.len, EDGE_HISTORY);
        let edges = s.edges();
        assert_eq!(edges.last().map(|x| x.position), Some(40));
        assert_eq!(edges[0].position, 40 - EDGE_HISTORY as i32 + 1);
        assert!(edges.windows(2).all(|w| w[0].t_us < w[1].t_us));
    }

    #[test]
    fn first_reading_without_init_is_not_a_step() {
        let mut e = Encoder::new();
        assert_eq!(e.on_edge(true, true, 5), Step::None);
        assert_eq!(e.position(), 0);
        assert_eq!(e.snapshot().len, 0);
    }
}
