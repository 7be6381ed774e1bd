//! The host's 30 Hz velocity stabiliser: pose feedback and dead-band dithering on top of
//! the calibrated wheel mapping.

use serde::{Deserialize, Serialize};

use super::{DriveMap, Twist, WheelTargets};

/// Gains of the velocity stabiliser.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StabiliserGains {
    /// Proportional gain on the v error.
    pub kp_v: f64,
    /// Integral gain on the v error (1/s).
    pub ki_v: f64,
    /// Proportional gain on the ω error.
    pub kp_omega: f64,
    /// Integral gain on the ω error (1/s).
    pub ki_omega: f64,
    /// Largest integral correction, as a fraction of the butterfly's B (v) and |A| (ω).
    pub max_correction: f64,
}

impl Default for StabiliserGains {
    fn default() -> Self {
        StabiliserGains {
            // Small proportional terms: the pose-derived velocity is ~0.1 s late (window,
            // link, wheel response); larger kp made the 30 Hz loop chatter in simulation.
            kp_v: 0.1,
            ki_v: 2.0,
            kp_omega: 0.1,
            ki_omega: 2.0,
            max_correction: 0.5,
        }
    }
}

/// The host's 30 Hz velocity stabiliser (THESIS 4.4.3, 5.2.1): PI on the difference between
/// the commanded twist and the twist measured from poses, feeding the THESIS 3.10 mapping.
#[derive(Debug, Clone)]
pub struct Stabiliser {
    /// The robot's mapping.
    pub map: DriveMap,
    /// Gains.
    pub gains: StabiliserGains,
    integral: Twist,
    /// Motion the wheels' dead-band has held back so far (m, rad): added to the next
    /// commands until a wheel command at M_min releases it (the dither of
    /// [`Stabiliser::step`]).
    withheld: Twist,
}

impl Stabiliser {
    /// A stabiliser for one robot.
    pub fn new(map: DriveMap, gains: StabiliserGains) -> Self {
        Stabiliser {
            map,
            gains,
            integral: Twist::ZERO,
            withheld: Twist::ZERO,
        }
    }

    /// Forget the integral and the withheld motion (robot stopped, pose lost, new session).
    pub fn reset(&mut self) {
        self.integral = Twist::ZERO;
        self.withheld = Twist::ZERO;
    }

    /// Forget the integral only (feedback switched off for this robot; the withheld motion
    /// of the dead-band stays).
    pub fn forget_feedback(&mut self) {
        self.integral = Twist::ZERO;
    }

    /// One tick of `dt` seconds: the wheel targets for the desired twist given the
    /// measured one (None while poses are too few: feed-forward only).
    pub fn step(&mut self, desired: Twist, measured: Option<Twist>, dt: f64) -> WheelTargets {
        let want = self.map.butterfly.project(desired);
        if want == Twist::ZERO {
            self.reset();
            return WheelTargets::default();
        }
        let g = self.gains;
        let mut corr = Twist::ZERO;
        if let Some(m) = measured.filter(|m| m.is_finite()) {
            let ev = want.v - m.v;
            let ew = want.omega - m.omega;
            let lim_v = g.max_correction * self.map.butterfly.b[0].abs();
            let lim_w = g.max_correction * self.map.butterfly.a[1].abs();
            self.integral.v = (self.integral.v + g.ki_v * ev * dt).clamp(-lim_v, lim_v);
            self.integral.omega = (self.integral.omega + g.ki_omega * ew * dt).clamp(-lim_w, lim_w);
            corr = Twist::new(g.kp_v * ev, g.kp_omega * ew);
        }
        let cmd = Twist::new(
            want.v + corr.v + self.integral.v,
            want.omega + corr.omega + self.integral.omega,
        );
        // The correction compensates calibration error: it may leave the polygon, the
        // wheel bounds of the QP still hold.
        self.dither(cmd, dt)
    }

    /// Wheel commands for `cmd` over the dead-band: the QP maps a twist too small for
    /// M_min to a stop, so a persistent small command would never move the robot (a
    /// coupled robot aligning its last millimetres stalled for 30 s). The motion held back
    /// accumulates and is added to the next commands until the QP sends the wheels at M_min
    /// for a tick: first-order sigma-delta modulation, the mean twist equals `cmd`. At most
    /// one such tick of motion is held back.
    fn dither(&mut self, cmd: Twist, dt: f64) -> WheelTargets {
        if !(dt > 0.0 && dt.is_finite()) {
            return self.map.wheels(cmd);
        }
        let w = self.map.wheels(Twist::new(
            cmd.v + self.withheld.v / dt,
            cmd.omega + self.withheld.omega / dt,
        ));
        let made = self.map.twist_of(w);
        let lim_v = self.map.k_v * self.map.m_min * dt;
        let lim_w = 2.0 * self.map.k_omega * self.map.m_min * dt;
        self.withheld = Twist::new(
            (self.withheld.v + (cmd.v - made.v) * dt).clamp(-lim_v, lim_v),
            (self.withheld.omega + (cmd.omega - made.omega) * dt).clamp(-lim_w, lim_w),
        );
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive::tests::map;

    #[test]
    fn stabiliser_integral_removes_gain_error() {
        // The robot really moves at 60 % of what the map believes.
        let m = map();
        let mut s = Stabiliser::new(m, StabiliserGains::default());
        let want = Twist::new(0.05, 0.3);
        let mut measured = None;
        for _ in 0..300 {
            let w = s.step(want, measured, 1.0 / 30.0);
            let real = m.twist_of(w);
            measured = Some(Twist::new(real.v * 0.6, real.omega * 0.6));
        }
        let got = measured.expect("ran");
        assert!(
            (got.v - want.v).abs() < 1e-3 && (got.omega - want.omega).abs() < 1e-2,
            "{got:?}"
        );
    }

    #[test]
    fn commands_inside_the_dead_band_move_the_robot_on_average() {
        // Without feedback (a coupled robot), a twist too small for M_min: every wheel
        // command is a stop or at least M_min, and the mean motion is the commanded one.
        let m = map();
        let mut s = Stabiliser::new(m, StabiliserGains::default());
        let dt = 1.0 / 30.0;
        for want in [
            Twist::new(0.006, 0.0),
            Twist::new(-0.004, 0.0),
            Twist::new(0.0, 0.1),
        ] {
            assert_eq!(
                m.wheels(want),
                WheelTargets::default(),
                "inside the dead-band"
            );
            s.reset();
            let mut sum = Twist::ZERO;
            let n = 300;
            for _ in 0..n {
                let w = s.step(want, None, dt);
                for rpm in [w.left_rpm, w.right_rpm] {
                    assert!(rpm == 0.0 || rpm.abs() >= m.m_min - 1e-9, "{w:?}");
                }
                let t = m.twist_of(w);
                sum = Twist::new(sum.v + t.v, sum.omega + t.omega);
            }
            let mean = Twist::new(sum.v / n as f64, sum.omega / n as f64);
            assert!(
                (mean.v - want.v).abs() < 0.05 * m.k_v * m.m_min
                    && (mean.omega - want.omega).abs() < 0.05 * m.k_omega * m.m_min,
                "{want:?}: mean {mean:?}"
            );
        }
        // Commands the wheels can follow are not modulated, and a stop is a stop.
        s.reset();
        let big = Twist::new(0.05, 0.3);
        for _ in 0..3 {
            let (a, b) = (s.step(big, None, dt), m.wheels(big));
            assert!(
                (a.left_rpm - b.left_rpm).abs() < 1e-9 && (a.right_rpm - b.right_rpm).abs() < 1e-9,
                "{a:?} vs {b:?}"
            );
        }
        assert_eq!(s.step(Twist::ZERO, None, dt), WheelTargets::default());
    }
}
