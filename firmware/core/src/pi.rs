//! The per-wheel speed loop: gain-scheduled PI with feed-forward, dead-band compensation,
//! anti-windup and an output slew limit (THESIS 5.2.3, 3.4).
//!
//! ```text
//! duty = FF(ω*) + Kp(s)·e + I,   I ← I + Ki(s)·e·T   (only while not pushing into a limit)
//! FF(ω*) = sign(ω*)·(d₀ + k_ff·|ω*|)     d₀: start-up dead-band M_min as duty (THESIS 3.4)
//! e = ω_ref − ω̂,   ω_ref ← ω_ref + (ω* − ω_ref)·T/(τ_ref + T)
//! ```
//!
//! Two degrees of freedom: the feed-forward alone would move the wheel along the
//! first-order reference ω_ref; the PI acts on the deviation from that reference, so it
//! corrects model errors and load without winding up during the rise of a large step.
//!
//! `s` is the size of the latest target change; THESIS 5.2.3 tuned three PI sets at target
//! changes of 123, 265 and 495 RPM and interpolated in between. Here the interpolation is
//! piecewise linear in `s` and clamped outside the first and last point, so the gains are a
//! continuous function of `s`. The integral is kept as a duty contribution, so a change of
//! `Ki` never makes the output jump.

use puzzlebot_params::firmware::Firmware;
use puzzlebot_protocol::{PiGains, DUTY_FULL_SCALE};

/// Full-scale duty as `f32` (per-mille).
pub const FULL_DUTY: f32 = DUTY_FULL_SCALE as f32;

/// Three PI gain sets at three target-change sizes, interpolated in between (THESIS 5.2.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainSchedule {
    /// Scheduling points: sizes of target changes (RPM), ascending.
    pub points: [f32; 3],
    /// Gains at each point.
    pub gains: [PiGains; 3],
}

impl GainSchedule {
    /// The schedule of a parameter set.
    pub fn from_params(p: &Firmware) -> Self {
        GainSchedule {
            points: p.schedule_rpm,
            gains: p.pi,
        }
    }

    /// Gains for a target change of `step_rpm` (magnitude used), linearly interpolated
    /// between the points and held constant outside them.
    pub fn gains_at(&self, step_rpm: f32) -> PiGains {
        let s = step_rpm.abs();
        let [p0, p1, p2] = self.points;
        let [g0, g1, g2] = self.gains;
        if !s.is_finite() || s <= p0 {
            return g0;
        }
        if s >= p2 {
            return g2;
        }
        let (a, b, ga, gb) = if s <= p1 {
            (p0, p1, g0, g1)
        } else {
            (p1, p2, g1, g2)
        };
        let w = if b > a { (s - a) / (b - a) } else { 1.0 };
        PiGains {
            kp: ga.kp + (gb.kp - ga.kp) * w,
            ki: ga.ki + (gb.ki - ga.ki) * w,
        }
    }
}

/// One wheel's PI speed controller. Duties are signed per-mille of full PWM.
#[derive(Debug, Clone)]
pub struct WheelController {
    schedule: GainSchedule,
    ff_slope: f32,
    ff_deadband: f32,
    max_rpm: f32,
    slew_per_s: f32,
    reference_tau_s: f32,
    reference: f32,
    holdoff_s: f32,
    unmeasured_s: f32,
    fresh: bool,
    target: f32,
    step: f32,
    integral: f32,
    duty: f32,
    saturated: bool,
}

impl WheelController {
    /// A stopped controller configured from `p`.
    pub fn new(p: &Firmware) -> Self {
        WheelController {
            schedule: GainSchedule::from_params(p),
            ff_slope: p.ff_duty_per_rpm,
            ff_deadband: p.ff_deadband_duty,
            max_rpm: p.max_rpm,
            slew_per_s: p.duty_slew_per_s,
            reference_tau_s: (p.reference_tau_ms * 1e-3).max(0.0),
            reference: 0.0,
            holdoff_s: f32::from(p.standstill_after_ms) * 1e-3,
            unmeasured_s: 0.0,
            fresh: true,
            target: 0.0,
            step: 0.0,
            integral: 0.0,
            duty: 0.0,
            saturated: false,
        }
    }

    /// Replace the gain sets (after a checked `SetParams`).
    pub fn set_gains(&mut self, gains: [PiGains; 3]) {
        self.schedule.gains = gains;
    }

    /// The gain schedule in force.
    pub fn schedule(&self) -> &GainSchedule {
        &self.schedule
    }

    /// Set a new target (RPM), clamped to ±`max_rpm`; a change of at least 1 RPM becomes
    /// the scheduling variable.
    pub fn set_target(&mut self, rpm: f32) {
        let rpm = if rpm.is_finite() {
            rpm.clamp(-self.max_rpm, self.max_rpm)
        } else {
            0.0
        };
        let change = (rpm - self.target).abs();
        if change >= 1.0 {
            self.step = change;
        }
        if rpm == 0.0 || (rpm > 0.0) != (self.target > 0.0) {
            // New direction or stop: the old integral is meaningless.
            self.integral = 0.0;
        }
        self.target = rpm;
    }

    /// The reference-model speed the PI tracks now (RPM).
    pub fn reference(&self) -> f32 {
        self.reference
    }

    /// Target in force (RPM).
    pub fn target(&self) -> f32 {
        self.target
    }

    /// Duty of the last update (per-mille).
    pub fn duty(&self) -> f32 {
        self.duty
    }

    /// True when the last output hit the duty or slew limit.
    pub fn saturated(&self) -> bool {
        self.saturated
    }

    /// Stop: zero target, integral and duty.
    pub fn reset(&mut self) {
        self.target = 0.0;
        self.reference = 0.0;
        self.unmeasured_s = 0.0;
        self.fresh = true;
        self.step = 0.0;
        self.integral = 0.0;
        self.duty = 0.0;
        self.saturated = false;
    }

    /// Feed-forward duty for a target (dead-band compensated, THESIS 3.4).
    pub fn feed_forward(&self, rpm: f32) -> f32 {
        if rpm == 0.0 {
            return 0.0;
        }
        (self.ff_deadband + self.ff_slope * rpm.abs()).copysign(rpm)
    }

    /// One loop period of `dt_s` seconds with the measured speed; returns the duty.
    ///
    /// `None` means no usable measurement yet (a wheel starting from rest has produced
    /// fewer than two encoder edges): the output is then feed-forward plus the frozen
    /// integral, for at most the hold-off time (`standstill_after_ms`); after that the
    /// wheel is taken as stalled (0 RPM) so the PI can push it free.
    pub fn update(&mut self, measured_rpm: Option<f32>, dt_s: f32) -> f32 {
        if self.target == 0.0 {
            // Zero target: drive nothing (the DRV8833 brakes at zero duty).
            self.integral = 0.0;
            self.reference = 0.0;
            self.fresh = true;
            self.duty = 0.0;
            self.saturated = false;
            return 0.0;
        }
        let dt_s = dt_s.max(0.0);
        let measured = match measured_rpm {
            Some(m) if m.is_finite() => {
                self.unmeasured_s = 0.0;
                if self.fresh {
                    // Bumpless start on a wheel that is already turning.
                    self.reference = m;
                }
                Some(m)
            }
            _ => {
                self.unmeasured_s += dt_s;
                (self.unmeasured_s > self.holdoff_s).then_some(0.0)
            }
        };
        self.fresh = false;
        let g = self.schedule.gains_at(self.step);
        let denom = self.reference_tau_s + dt_s;
        self.reference = if denom > 0.0 {
            self.reference + (self.target - self.reference) * (dt_s / denom)
        } else {
            self.target
        };
        let Some(measured) = measured else {
            // Feed-forward only while the speed is not yet measurable.
            let max_change = self.slew_per_s * dt_s;
            let wanted = self.feed_forward(self.target) + self.integral;
            let out = wanted
                .clamp(-FULL_DUTY, FULL_DUTY)
                .clamp(self.duty - max_change, self.duty + max_change);
            self.saturated = out != wanted;
            self.duty = out;
            return out;
        };
        let e = self.reference - measured;
        let candidate = self.integral + g.ki * e * dt_s;
        let wanted = self.feed_forward(self.target) + g.kp * e + candidate;
        let max_change = self.slew_per_s * dt_s;
        let out = wanted
            .clamp(-FULL_DUTY, FULL_DUTY)
            .clamp(self.duty - max_change, self.duty + max_change);
        self.saturated = out != wanted;
        // Anti-windup by conditional integration: do not integrate an error that pushes
        // further into the active limit.
        let pushing_into_limit = self.saturated && (wanted - out) * e > 0.0;
        if !pushing_into_limit {
            self.integral = candidate.clamp(-FULL_DUTY, FULL_DUTY);
        }
        self.duty = out;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ClosedLoop, MotorModel};

    fn sched() -> GainSchedule {
        GainSchedule::from_params(&Firmware::default())
    }

    #[test]
    fn interpolation_is_continuous_and_hits_the_points() {
        let s = sched();
        for (i, &p) in s.points.iter().enumerate() {
            assert_eq!(s.gains_at(p), s.gains[i]);
        }
        // Small increments make small changes everywhere, including outside the points.
        let mut prev = s.gains_at(0.0);
        let mut x = 0.0f32;
        let bound_kp = s.gains.iter().map(|g| g.kp).fold(0.0f32, f32::max);
        let bound_ki = s.gains.iter().map(|g| g.ki).fold(0.0f32, f32::max);
        while x < 700.0 {
            x += 0.25;
            let g = s.gains_at(x);
            assert!((g.kp - prev.kp).abs() <= bound_kp * 0.01, "kp jump at {x}");
            assert!((g.ki - prev.ki).abs() <= bound_ki * 0.01, "ki jump at {x}");
            prev = g;
        }
        assert_eq!(s.gains_at(-300.0), s.gains_at(300.0));
        assert_eq!(s.gains_at(f32::NAN), s.gains[0]);
    }

    #[test]
    fn interpolation_midpoint_is_the_mean() {
        let mut s = sched();
        s.gains = [
            PiGains { kp: 1.0, ki: 10.0 },
            PiGains { kp: 3.0, ki: 30.0 },
            PiGains { kp: 5.0, ki: 70.0 },
        ];
        let mid = s.gains_at((s.points[0] + s.points[1]) / 2.0);
        assert!((mid.kp - 2.0).abs() < 1e-5 && (mid.ki - 20.0).abs() < 1e-4);
        let mid = s.gains_at((s.points[1] + s.points[2]) / 2.0);
        assert!((mid.kp - 4.0).abs() < 1e-5 && (mid.ki - 50.0).abs() < 1e-4);
    }

    /// Step response from rest: settling time to ±2 % and overshoot, on the nominal model,
    /// on motors 10 % weaker / stronger than the feed-forward assumes, and on motors with
    /// time constants of 20 and 45 ms instead of 30 ms.
    #[test]
    fn pi_step_responses_settle_within_300ms() {
        for &target in &[100.0f32, 250.0, 450.0, -250.0] {
            for &(gain_factor, tau_s) in &[
                (1.0f32, 0.030f32),
                (0.9, 0.030),
                (1.1, 0.030),
                (1.0, 0.020),
                (1.0, 0.045),
            ] {
                let motor = MotorModel {
                    no_load_rpm: MotorModel::default().no_load_rpm * gain_factor,
                    tau_s,
                    ..MotorModel::default()
                };
                let r = ClosedLoop::new(Firmware::default(), motor).step_response(target, 1.0);
                assert!(
                    r.settle_s <= 0.300,
                    "target {target} x{gain_factor} tau {tau_s}: settled after {} s",
                    r.settle_s
                );
                assert!(
                    r.overshoot < 0.10,
                    "target {target} x{gain_factor} tau {tau_s}: overshoot {}",
                    r.overshoot
                );
            }
        }
    }

    #[test]
    fn anti_windup_limits_overshoot_after_saturation() {
        // A motor too weak to reach the target saturates the output for a while; once the
        // target becomes reachable the integral must not have wound up.
        let p = Firmware::default();
        let mut c = WheelController::new(&p);
        c.set_target(450.0);
        for _ in 0..50 {
            c.update(Some(200.0), 0.02);
        }
        assert!(c.saturated());
        assert!(c.duty() <= FULL_DUTY);
        // Integral bounded by the duty range and not grown while saturated.
        assert!(
            c.integral <= FULL_DUTY - c.feed_forward(450.0) + 1e-3,
            "{}",
            c.integral
        );
    }

    #[test]
    fn slew_limit_bounds_duty_change() {
        let p = Firmware::default();
        let mut c = WheelController::new(&p);
        c.set_target(450.0);
        let d1 = c.update(Some(0.0), 0.02);
        assert!((d1 - p.duty_slew_per_s * 0.02).abs() < 1e-3, "{d1}");
        c.set_target(-450.0);
        let d2 = c.update(Some(450.0), 0.02);
        assert!((d1 - d2).abs() <= p.duty_slew_per_s * 0.02 + 1e-3);
    }

    #[test]
    fn feed_forward_only_until_measured_then_stall_push() {
        let p = Firmware::default();
        let mut c = WheelController::new(&p);
        c.set_target(100.0);
        let ff = c.feed_forward(100.0);
        let mut last = 0.0;
        // Ticks of 20 ms that stay within the hold-off.
        for _ in 0..p.standstill_after_ms / 20 {
            last = c.update(None, 0.02);
            assert!(last <= ff + 1e-3, "{last}");
        }
        assert!((last - ff).abs() < 1e-3);
        // Still nothing after the hold-off: a stalled wheel, the PI pushes harder.
        for _ in 0..10 {
            last = c.update(None, 0.02);
        }
        assert!(last > ff + 10.0, "{last}");
    }

    #[test]
    fn target_is_clamped_and_zero_stops() {
        let p = Firmware::default();
        let mut c = WheelController::new(&p);
        c.set_target(900.0);
        assert_eq!(c.target(), p.max_rpm);
        c.set_target(f32::INFINITY);
        assert_eq!(c.target(), 0.0);
        c.set_target(-900.0);
        assert_eq!(c.target(), -p.max_rpm);
        c.update(Some(0.0), 0.02);
        c.set_target(0.0);
        assert_eq!(c.update(Some(100.0), 0.02), 0.0);
    }
}
