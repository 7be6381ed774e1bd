//! A first-order DC gear-motor model with a quadrature encoder, for tuning and testing the
//! speed loop on the host (the simulator has its own, fuller plant).
//!
//! ```text
//! τ·dω/dt = ω_ss(d) − ω,   ω_ss(d) = sign(d)·K·(|d| − d₀) for |d| > d₀, else 0
//! K = ω_max / (1000 − d₀)
//! ```
//!
//! Default numbers (documented here, used to tune `puzzlebot_params::firmware` gains):
//! no-load speed ω_max = 520 RPM at full duty and 3.7 V (THESIS 5.2.3 commands up to
//! 450 RPM, so the motor has ~15 % headroom), time constant τ = 30 ms (small N20-class
//! gear motors are 20–40 ms), start-up dead-band d₀ = 80 per-mille (static friction; the
//! M_min of THESIS 3.4). 48 encoder edges per wheel revolution (see the parameter set).
//! Stiction: a wheel at rest stays at rest while |d| ≤ d₀.

use crate::encoder::{levels_of, Encoder};
use crate::estimator::SpeedEstimator;
use crate::pi::{WheelController, FULL_DUTY};
use puzzlebot_params::firmware::Firmware;

/// First-order motor numbers (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorModel {
    /// Wheel speed at full duty without load (RPM).
    pub no_load_rpm: f32,
    /// Mechanical time constant (s).
    pub tau_s: f32,
    /// Duty (per-mille) below which a resting wheel does not start.
    pub deadband_duty: f32,
}

impl Default for MotorModel {
    fn default() -> Self {
        MotorModel {
            no_load_rpm: 520.0,
            tau_s: 0.030,
            deadband_duty: 80.0,
        }
    }
}

impl MotorModel {
    /// Steady-state speed (RPM) at duty `d` (per-mille).
    pub fn steady_rpm(&self, d: f32) -> f32 {
        let d = d.clamp(-FULL_DUTY, FULL_DUTY);
        if d.abs() <= self.deadband_duty {
            return 0.0;
        }
        let k = self.no_load_rpm / (FULL_DUTY - self.deadband_duty);
        (k * (d.abs() - self.deadband_duty)).copysign(d)
    }
}

/// Turns a continuous wheel angle into timestamped quadrature edges fed to an [`Encoder`].
#[derive(Debug, Clone, Default)]
pub struct EdgeGenerator {
    index: i64,
    frac: f64,
}

impl EdgeGenerator {
    /// Start at position zero (levels 00); call `encoder.init_levels(false, false)`.
    pub fn new() -> Self {
        Self::default()
    }

    /// Move by `delta_edges` (fraction of an edge allowed) linearly over `[t0_us, t1_us]`,
    /// feeding every crossed edge with its interpolated timestamp to `enc`.
    pub fn advance(&mut self, delta_edges: f64, t0_us: f64, t1_us: f64, enc: &mut Encoder) {
        if delta_edges == 0.0 || !delta_edges.is_finite() {
            return;
        }
        let rate = delta_edges / (t1_us - t0_us).max(1e-9);
        let start = self.frac;
        let end = start + delta_edges;
        if delta_edges > 0.0 {
            let mut next = 1.0;
            while next <= end {
                self.index += 1;
                let t = t0_us + (next - start) / rate;
                let (a, b) = levels_of(self.index as i32);
                enc.on_edge(a, b, t.max(0.0) as u64);
                next += 1.0;
            }
            self.frac = end - (next - 1.0);
        } else {
            let mut next = 0.0;
            while next > end {
                self.index -= 1;
                let t = t0_us + (next - start) / rate;
                let (a, b) = levels_of(self.index as i32);
                enc.on_edge(a, b, t.max(0.0) as u64);
                next -= 1.0;
            }
            self.frac = end - next;
        }
    }
}

/// Result of a simulated step response.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepResult {
    /// Time after the step from which the true speed stays within ±2 % of the target (s).
    pub settle_s: f32,
    /// Peak overshoot as a fraction of the target (0.05 = 5 %).
    pub overshoot: f32,
    /// True speed at the end (RPM).
    pub final_rpm: f32,
}

/// One wheel in closed loop: motor model, encoder, estimator and PI controller at the
/// firmware's loop rate, integrated in 100 µs sub-steps.
#[derive(Debug, Clone)]
pub struct ClosedLoop {
    /// Controller parameters.
    pub params: Firmware,
    /// Plant.
    pub motor: MotorModel,
}

impl ClosedLoop {
    /// A loop with these parameters and this motor.
    pub fn new(params: Firmware, motor: MotorModel) -> Self {
        ClosedLoop { params, motor }
    }

    /// Step from rest to `target_rpm`, simulated for `duration_s`.
    pub fn step_response(&self, target_rpm: f32, duration_s: f32) -> StepResult {
        self.step_response_traced(target_rpm, duration_s, &mut |_, _, _, _, _| {})
    }

    /// As [`ClosedLoop::step_response`], calling `trace(t_s, true_rpm, estimate, reference,
    /// duty)` at every control tick.
    pub fn step_response_traced(
        &self,
        target_rpm: f32,
        duration_s: f32,
        trace: &mut dyn FnMut(f32, f32, f32, f32, f32),
    ) -> StepResult {
        let period_us = (1.0e6 / self.params.loop_hz.max(1.0)) as u64;
        let sub_us = 100u64;
        let epr = f64::from(self.params.encoder_edges_per_rev);
        let mut ctl = WheelController::new(&self.params);
        let mut est = SpeedEstimator::new(
            self.params.encoder_edges_per_rev,
            period_us,
            u64::from(self.params.standstill_after_ms) * 1000,
        );
        let mut enc = Encoder::new();
        enc.init_levels(false, false);
        let mut gen = EdgeGenerator::new();
        let mut rpm = 0.0f32;
        let mut duty = 0.0f32;
        let mut peak = 0.0f32;
        let mut last_out = 0.0f32;
        let end_us = (duration_s * 1.0e6) as u64;
        let tol = 0.02 * target_rpm.abs();
        let mut t = 0u64;
        ctl.set_target(target_rpm);
        while t < end_us {
            if t.is_multiple_of(period_us) {
                let measured = est.update(t, &enc.snapshot());
                duty = ctl.update(est.reliable().then_some(measured), period_us as f32 * 1e-6);
                trace(t as f32 * 1e-6, rpm, measured, ctl.reference(), duty);
            }
            let ss = self.motor.steady_rpm(duty);
            let moving = rpm != 0.0 || duty.abs() > self.motor.deadband_duty;
            let dt = sub_us as f32 * 1e-6;
            let next = if moving {
                rpm + (ss - rpm) * (dt / self.motor.tau_s).min(1.0)
            } else {
                0.0
            };
            let mean = 0.5 * (rpm + next);
            gen.advance(
                f64::from(mean) / 60.0 * epr * f64::from(dt),
                t as f64,
                (t + sub_us) as f64,
                &mut enc,
            );
            rpm = next;
            t += sub_us;
            peak = peak.max(rpm * target_rpm.signum());
            if (rpm - target_rpm).abs() > tol {
                last_out = t as f32 * 1e-6;
            }
        }
        StepResult {
            settle_s: last_out,
            overshoot: if target_rpm == 0.0 {
                0.0
            } else {
                (peak / target_rpm.abs() - 1.0).max(0.0)
            },
            final_rpm: rpm,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_numbers() {
        let m = MotorModel::default();
        assert_eq!(m.steady_rpm(1000.0), 520.0);
        assert_eq!(m.steady_rpm(80.0), 0.0);
        assert!(m.steady_rpm(-1000.0) < -519.0);
    }

    #[test]
    fn edge_generator_counts_exactly_both_ways() {
        let mut enc = Encoder::new();
        enc.init_levels(false, false);
        let mut g = EdgeGenerator::new();
        let mut t = 0.0;
        for _ in 0..1000 {
            g.advance(0.375, t, t + 100.0, &mut enc);
            t += 100.0;
        }
        assert_eq!(enc.position(), 375);
        for _ in 0..1000 {
            g.advance(-0.5, t, t + 100.0, &mut enc);
            t += 100.0;
        }
        assert_eq!(enc.position(), 375 - 500);
        assert_eq!(enc.errors(), 0);
    }
}
