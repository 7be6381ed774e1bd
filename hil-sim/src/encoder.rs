//! Magnetic quadrature encoder on a wheel: turns the wheel angle into A/B level changes
//! with exact (interpolated) edge times, the way GPIO any-edge interrupts see them.
//!
//! Resolution: `Firmware::encoder_edges_per_rev` edges (all four quadrature edges) per
//! wheel revolution, the one number firmware and simulator share.

use core::f64::consts::TAU;

/// One level change seen by the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EdgeEvent {
    /// Channel A level after the edge.
    pub a: bool,
    /// Channel B level after the edge.
    pub b: bool,
    /// Time of the edge (µs since boot of the simulation).
    pub t_us: u64,
}

/// Quadrature encoder state of one wheel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuadEncoder {
    edges_per_rev: f64,
    /// Edges per radian (`edges_per_rev / 2π`) and its inverse, precomputed.
    per_rad: f64,
    rad_per_edge: f64,
    /// Edge index of the current state (floor of angle·edges/2π).
    count: i64,
}

/// A/B levels of quadrature state `count mod 4` (Gray sequence 00, 10, 11, 01 forward).
pub fn levels(count: i64) -> (bool, bool) {
    match count.rem_euclid(4) {
        0 => (false, false),
        1 => (true, false),
        2 => (true, true),
        _ => (false, true),
    }
}

/// `x.floor() as i64` without a libm call (the default x86-64 target has no SSE4.1
/// `roundsd`, so `f64::floor` is a function call in the simulator's hottest loop).
fn floor_i64(x: f64) -> i64 {
    let t = x as i64; // truncates toward zero (saturating)
    if (t as f64) > x {
        t - 1
    } else {
        t
    }
}

impl QuadEncoder {
    /// An encoder with `edges_per_rev` edges per wheel revolution at wheel angle `angle`.
    pub fn new(edges_per_rev: u16, angle: f64) -> QuadEncoder {
        let e = f64::from(edges_per_rev.max(1));
        QuadEncoder {
            edges_per_rev: e,
            per_rad: e / TAU,
            rad_per_edge: TAU / e,
            count: floor_i64(angle * e / TAU),
        }
    }

    /// Current A/B levels.
    pub fn levels(&self) -> (bool, bool) {
        levels(self.count)
    }

    /// Edges since power-up (signed).
    pub fn count(&self) -> i64 {
        self.count
    }

    /// The wheel moved from `a0` (at `t0_us`) to `a1` (at `t1_us`), linearly in between:
    /// call `emit` for every edge crossed, in time order.
    pub fn advance(
        &mut self,
        a0: f64,
        a1: f64,
        t0_us: u64,
        t1_us: u64,
        mut emit: impl FnMut(EdgeEvent),
    ) {
        let target = floor_i64(a1 * self.per_rad);
        if target == self.count {
            return;
        }
        let span = (t1_us - t0_us) as f64;
        let da = a1 - a0;
        // Guard against a runaway (never more than a full turn per step in practice).
        let max_edges = 4 * self.edges_per_rev as i64 + 8;
        let mut n = 0;
        while self.count != target && n < max_edges {
            n += 1;
            // The boundary crossed next: going up it is count+1, going down it is count.
            let (next, boundary) = if target > self.count {
                (self.count + 1, self.count + 1)
            } else {
                (self.count - 1, self.count)
            };
            let ang = boundary as f64 * self.rad_per_edge;
            let frac = if da.abs() > 0.0 {
                ((ang - a0) / da).clamp(0.0, 1.0)
            } else {
                1.0
            };
            let t = t0_us + (frac * span).round() as u64;
            self.count = next;
            let (a, b) = levels(next);
            emit(EdgeEvent {
                a,
                b,
                t_us: t.min(t1_us),
            });
        }
        self.count = target;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_matches_f64_floor() {
        for x in [
            -2.5, -2.0, -1e-12, -0.0, 0.0, 1e-12, 0.999_999, 1.0, 7.5, -7.5, 1e15, -1e15,
        ] {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn one_revolution_gives_edges_per_rev_edges_in_time_order() {
        let mut got = Vec::new();
        // 1 rev over 48 steps of 1 ms, slightly offset so no edge sits on a step boundary.
        let mut a = 0.01;
        let mut e = QuadEncoder::new(48, a);
        for k in 0..48u64 {
            let a1 = a + TAU / 48.0;
            e.advance(a, a1, k * 1000, (k + 1) * 1000, |ev| got.push(ev));
            a = a1;
        }
        assert_eq!(got.len(), 48);
        assert!(got.windows(2).all(|w| w[0].t_us <= w[1].t_us));
        // Each edge flips exactly one channel.
        for w in got.windows(2) {
            assert_eq!(u8::from(w[0].a != w[1].a) + u8::from(w[0].b != w[1].b), 1);
        }
        // Backwards gives the reverse sequence.
        let mut back = Vec::new();
        e.advance(a, a - TAU / 12.0, 48_000, 49_000, |ev| back.push(ev));
        assert_eq!(back.len(), 4);
        assert_eq!(e.count(), got.len() as i64 - 4);
    }
}
