//! Drive mapping: (v, ω) → wheel speed targets, the v–ω "butterfly" feasibility polygon,
//! pose-based velocity estimation and the 30 Hz velocity stabiliser.
//!
//! Wheel commands `M` are wheel (output-shaft) speed targets in RPM, the unit of
//! [`puzzlebot_protocol::HostMsg::WheelSpeed`]; the on-robot PI loop holds them.
//!
//! * THESIS (2.1)–(2.2): differential drive, `ω_r = (2v + ωL)/(2R)`, `ω_l = (2v − ωL)/(2R)`;
//!   in RPM units this gives the nominal gains [`DriveMap::geometric`].
//! * THESIS (3.10): `v = k_v (M_r + M_l)/2`, `ω = k_ω (M_r − M_l)`, calibrated per robot,
//!   and the QP under it (weights μ_v, μ_ω; `M_min ≤ |M_r|, |M_l| ≤ M_max`), solved
//!   exactly by [`DriveMap::wheels`]: the feasible set of each wheel is
//!   `{0} ∪ [−M_max, −M_min] ∪ [M_min, M_max]`, so the QP splits into nine convex
//!   two-variable box QPs whose exact minima are compared.
//! * THESIS 3.5.1, 4.3.4: the feasible v–ω set is a butterfly of two kites with the
//!   corner points A = (a_v, a_ω) and B = (b_v, 0) ([`Butterfly`]).
//! * THESIS 4.4.3, 5.2.1: a 30 Hz stabiliser estimates the instant (v, ω) from poses over
//!   a short window and corrects the command ([`Stabiliser`]); commands too small for the
//!   wheels' dead-band M_min are dithered so that their mean motion is still made (ours).

use puzzlebot_params::{drive::Drive, geometry::Geometry, RobotParams};
use serde::{Deserialize, Serialize};

/// RPM per rad/s.
pub const RPM_PER_RAD_S: f64 = 60.0 / (2.0 * std::f64::consts::PI);

/// Wheel speed targets (RPM), left and right.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct WheelTargets {
    /// Left wheel target (RPM).
    pub left_rpm: f64,
    /// Right wheel target (RPM).
    pub right_rpm: f64,
}

/// A body velocity command: forward speed (m/s) and turn rate (rad/s, CCW).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// Forward speed (m/s).
    pub v: f64,
    /// Turn rate (rad/s), counter-clockwise.
    pub omega: f64,
}

impl Twist {
    /// A twist from its parts.
    pub const fn new(v: f64, omega: f64) -> Self {
        Twist { v, omega }
    }

    /// Standing still.
    pub const ZERO: Twist = Twist { v: 0.0, omega: 0.0 };

    /// True when both components are finite.
    pub fn is_finite(&self) -> bool {
        self.v.is_finite() && self.omega.is_finite()
    }
}

/// The v–ω feasibility polygon ("butterfly", THESIS 3.5.1 Fig. 3.12–3.13, 4.3.4).
///
/// For v ≥ 0 the wing is the kite O = (0, 0), (a_v, −|a_ω|), B = (b_v, 0), (a_v, |a_ω|);
/// the wing for v ≤ 0 is its mirror image. The two wings touch at the origin: a robot turns
/// fast only while it also moves.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Butterfly {
    /// Corner A = (v, ω) as calibrated (ω may be given negative, as in THESIS).
    pub a: [f64; 2],
    /// Corner B = (v, 0): top speed straight ahead.
    pub b: [f64; 2],
}

impl Butterfly {
    /// From the shared parameter set.
    pub fn from_drive(d: &Drive) -> Self {
        Butterfly {
            a: [f64::from(d.butterfly_a[0]), f64::from(d.butterfly_a[1])],
            b: [f64::from(d.butterfly_b[0]), f64::from(d.butterfly_b[1])],
        }
    }

    /// True when A and B describe a non-degenerate kite (0 < a_v < b_v, a_ω ≠ 0).
    pub fn is_valid(&self) -> bool {
        let [av, aw] = self.a;
        let bv = self.b[0];
        [av, aw, bv].iter().all(|x| x.is_finite()) && av > 0.0 && bv > av && aw.abs() > 0.0
    }

    /// The v ≥ 0 wing, counter-clockwise.
    fn wing(&self) -> [[f64; 2]; 4] {
        let av = self.a[0];
        let aw = self.a[1].abs();
        let bv = self.b[0];
        [[0.0, 0.0], [av, -aw], [bv, 0.0], [av, aw]]
    }

    /// Scale of the ω axis relative to v (for distances in the v–ω plane).
    fn omega_scale(&self) -> f64 {
        let aw = self.a[1].abs();
        if aw > 0.0 {
            self.b[0] / aw
        } else {
            1.0
        }
    }

    /// True when `t` lies in the butterfly (edges included, tolerance 1e-9).
    pub fn contains(&self, t: Twist) -> bool {
        let p = [t.v.abs(), t.omega];
        let w = self.wing();
        let s = self.omega_scale();
        (0..4).all(|i| {
            let a = w[i];
            let b = w[(i + 1) % 4];
            let cross = (b[0] - a[0]) * (p[1] - a[1]) * s - (b[1] - a[1]) * s * (p[0] - a[0]);
            cross >= -1e-9
        })
    }

    /// The nearest feasible twist (distance in v and scaled ω), keeping the sign of v.
    /// A twist with v = 0 and ω ≠ 0 is moved onto the forward wing.
    pub fn project(&self, t: Twist) -> Twist {
        if !self.is_valid() || !t.is_finite() {
            return Twist::ZERO;
        }
        if self.contains(t) {
            return t;
        }
        let sign = if t.v < 0.0 { -1.0 } else { 1.0 };
        let s = self.omega_scale();
        let p = [t.v.abs(), t.omega * s];
        let w = self.wing().map(|q| [q[0], q[1] * s]);
        let mut best = [0.0, 0.0];
        let mut best_d = f64::INFINITY;
        for i in 0..4 {
            let q = closest_on_segment(w[i], w[(i + 1) % 4], p);
            let d = (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2);
            if d < best_d {
                best_d = d;
                best = q;
            }
        }
        Twist::new(sign * best[0], best[1] / s)
    }
}

fn closest_on_segment(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> [f64; 2] {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    if len2 <= 0.0 {
        return a;
    }
    let u = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0);
    [a[0] + u * d[0], a[1] + u * d[1]]
}

/// The calibrated (v, ω) → wheel mapping of one robot (THESIS 3.10 and its QP).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DriveMap {
    /// k_v: m/s per RPM of mean wheel command.
    pub k_v: f64,
    /// k_ω: rad/s per RPM of wheel command difference (right − left).
    pub k_omega: f64,
    /// M_min: smallest non-zero wheel command magnitude (RPM).
    pub m_min: f64,
    /// M_max: largest wheel command magnitude (RPM).
    pub m_max: f64,
    /// μ_v: weight of the linear-speed error in the QP.
    pub mu_v: f64,
    /// μ_ω: weight of the turn-rate error in the QP.
    pub mu_omega: f64,
    /// Feasible v–ω set.
    pub butterfly: Butterfly,
}

impl DriveMap {
    /// The calibrated mapping of a robot's parameter set (k_v, k_ω, M_min, M_max, A, B).
    pub fn from_params(p: &RobotParams) -> Self {
        let d = &p.drive;
        let half_base = f64::from(p.geometry.wheel_base) * 0.5;
        DriveMap {
            k_v: f64::from(d.k_v),
            k_omega: f64::from(d.k_omega),
            m_min: f64::from(d.min_rpm),
            m_max: f64::from(d.max_rpm),
            mu_v: 1.0,
            // Weigh ω errors as the wheel-rim speed they cause: (L/2)·Δω.
            mu_omega: half_base * half_base,
            butterfly: Butterfly::from_drive(d),
        }
    }

    /// The ideal differential drive of THESIS (2.1)–(2.2) in RPM units:
    /// `k_v = 2πR/60`, `k_ω = 2πR/(60 L)`; M_min, M_max and the butterfly from `p`.
    pub fn geometric(p: &RobotParams) -> Self {
        let (k_v, k_omega) = geometric_gains(&p.geometry);
        DriveMap {
            k_v,
            k_omega,
            ..DriveMap::from_params(p)
        }
    }

    /// Check the numbers; the error names the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, x: f64| {
            if x.is_finite() && x > 0.0 {
                Ok(())
            } else {
                Err(format!("drive.{name} must be a positive number (got {x})"))
            }
        };
        pos("k_v", self.k_v)?;
        pos("k_omega", self.k_omega)?;
        pos("max_rpm", self.m_max)?;
        if !(self.m_min.is_finite() && self.m_min >= 0.0 && self.m_min < self.m_max) {
            return Err(format!(
                "drive.min_rpm must lie in [0, max_rpm) (got {})",
                self.m_min
            ));
        }
        if !self.butterfly.is_valid() {
            return Err(format!(
                "drive.butterfly_a/butterfly_b must satisfy 0 < a_v < b_v and a_ω ≠ 0 (got A = {:?}, B = {:?})",
                self.butterfly.a, self.butterfly.b
            ));
        }
        Ok(())
    }

    /// The twist the robot makes for wheel commands (THESIS 3.10, dead-band ignored).
    pub fn twist_of(&self, w: WheelTargets) -> Twist {
        Twist::new(
            self.k_v * (w.right_rpm + w.left_rpm) * 0.5,
            self.k_omega * (w.right_rpm - w.left_rpm),
        )
    }

    /// Wheel commands for `t`: the exact minimiser of the THESIS 3.10 QP
    /// `μ_v (k_v (M_r+M_l)/2 − v)² + μ_ω (k_ω (M_r−M_l) − ω)²` subject to each wheel being
    /// 0 or `M_min ≤ |M| ≤ M_max`. Non-finite input gives a stop.
    pub fn wheels(&self, t: Twist) -> WheelTargets {
        if !t.is_finite() || self.validate().is_err() {
            return WheelTargets::default();
        }
        // Objective f(r, l) = ½ xᵀ H x − gᵀ x + const, x = (r, l).
        let cv = self.k_v * 0.5;
        let cw = self.k_omega;
        // f = μv (cv r + cv l − v)² + μω (cw r − cw l − ω)²
        let f = |r: f64, l: f64| {
            self.mu_v * (cv * (r + l) - t.v).powi(2)
                + self.mu_omega * (cw * (r - l) - t.omega).powi(2)
        };
        let intervals = [
            (-self.m_max, -self.m_min),
            (0.0, 0.0),
            (self.m_min, self.m_max),
        ];
        // Unconstrained minimiser (exact inverse of 3.10).
        let free_r = t.v / self.k_v + t.omega / (2.0 * self.k_omega);
        let free_l = t.v / self.k_v - t.omega / (2.0 * self.k_omega);
        let mut best = (0.0, 0.0);
        let mut best_f = f(0.0, 0.0);
        for &(r0, r1) in &intervals {
            for &(l0, l1) in &intervals {
                let (r, l) = box_qp(&f, self, t, (r0, r1), (l0, l1), (free_r, free_l));
                let val = f(r, l);
                if val < best_f - 1e-15 {
                    best_f = val;
                    best = (r, l);
                }
            }
        }
        WheelTargets {
            right_rpm: best.0,
            left_rpm: best.1,
        }
    }

    /// Project onto the butterfly, then map to wheels: what the host sends for `t`.
    pub fn command(&self, t: Twist) -> WheelTargets {
        self.wheels(self.butterfly.project(t))
    }
}

/// Nominal gains of THESIS (2.1)–(2.2) in RPM units: `(k_v, k_ω)`.
pub fn geometric_gains(g: &Geometry) -> (f64, f64) {
    let r = f64::from(g.wheel_radius);
    let l = f64::from(g.wheel_base);
    let k_v = r / RPM_PER_RAD_S;
    (k_v, k_v / l)
}

/// Exact minimum of the convex quadratic `f` over the box `[r0, r1] × [l0, l1]`.
fn box_qp(
    f: &impl Fn(f64, f64) -> f64,
    m: &DriveMap,
    t: Twist,
    (r0, r1): (f64, f64),
    (l0, l1): (f64, f64),
    (fr, fl): (f64, f64),
) -> (f64, f64) {
    if (r0..=r1).contains(&fr) && (l0..=l1).contains(&fl) {
        return (fr, fl);
    }
    // Otherwise the minimum lies on an edge: minimise the 1-D quadratic along each edge.
    let cv = m.k_v * 0.5;
    let cw = m.k_omega;
    // ∂f/∂r = 2μv cv (cv(r+l) − v) + 2μω cw (cw(r−l) − ω); minimiser in r for fixed l:
    let a = m.mu_v * cv * cv + m.mu_omega * cw * cw;
    let r_for = |l: f64| {
        let b = m.mu_v * cv * (cv * l - t.v) + m.mu_omega * cw * (-cw * l - t.omega);
        (-b / a).clamp(r0, r1)
    };
    let l_for = |r: f64| {
        let b = m.mu_v * cv * (cv * r - t.v) - m.mu_omega * cw * (cw * r - t.omega);
        (-b / a).clamp(l0, l1)
    };
    let candidates = [
        (r_for(l0), l0),
        (r_for(l1), l1),
        (r0, l_for(r0)),
        (r1, l_for(r1)),
    ];
    let mut best = candidates[0];
    let mut best_f = f(best.0, best.1);
    for &c in &candidates[1..] {
        let v = f(c.0, c.1);
        if v < best_f {
            best_f = v;
            best = c;
        }
    }
    best
}

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
    use puzzlebot_params::RobotKind;

    fn map() -> DriveMap {
        DriveMap::geometric(&RobotParams::for_kind(RobotKind::NonPilot))
    }

    #[test]
    fn unconstrained_mapping_inverts_thesis_3_10_and_matches_2_1() {
        let m = map();
        let t = Twist::new(0.08, 0.8);
        let w = m.wheels(t);
        let back = m.twist_of(w);
        assert!((back.v - t.v).abs() < 1e-12 && (back.omega - t.omega).abs() < 1e-12);
        // THESIS (2.1): right wheel rad/s = (2v + ωL)/(2R).
        let g = Geometry::default();
        let (r, l) = (f64::from(g.wheel_radius), f64::from(g.wheel_base));
        let wr = (2.0 * t.v + t.omega * l) / (2.0 * r) * RPM_PER_RAD_S;
        assert!((w.right_rpm - wr).abs() < 1e-9, "{w:?} vs {wr}");
    }

    #[test]
    fn dead_band_and_saturation_are_respected() {
        let m = map();
        // A crawl that would need |M| < M_min on both wheels: stop or jump to M_min, whichever is closer.
        let tiny = m.wheels(Twist::new(m.k_v * m.m_min * 0.3, 0.0));
        assert_eq!(tiny, WheelTargets::default());
        let small = m.wheels(Twist::new(m.k_v * m.m_min * 0.8, 0.0));
        assert!(
            (small.left_rpm - m.m_min).abs() < 1e-9 && (small.right_rpm - m.m_min).abs() < 1e-9
        );
        let huge = m.wheels(Twist::new(10.0, 0.0));
        assert!((huge.left_rpm - m.m_max).abs() < 1e-9);
        // Turning in place where one wheel would need less than M_min.
        let w = m.wheels(Twist::new(m.k_v * m.m_min * 1.5, 2.0 * m.k_omega * m.m_min));
        for x in [w.left_rpm, w.right_rpm] {
            assert!(
                x == 0.0 || (m.m_min - 1e-9..=m.m_max + 1e-9).contains(&x.abs()),
                "{w:?}"
            );
        }
        assert_eq!(m.wheels(Twist::new(f64::NAN, 0.0)), WheelTargets::default());
    }

    #[test]
    fn brute_force_agrees_with_exact_qp() {
        let m = map();
        let f = |t: Twist, w: WheelTargets| {
            let c = m.twist_of(w);
            m.mu_v * (c.v - t.v).powi(2) + m.mu_omega * (c.omega - t.omega).powi(2)
        };
        let feasible = |x: f64| x == 0.0 || (m.m_min..=m.m_max).contains(&x.abs());
        let grid: Vec<f64> = (-900..=900)
            .map(|i| f64::from(i) * 0.5)
            .filter(|x| feasible(*x))
            .collect();
        for t in [
            Twist::new(0.03, 3.0),
            Twist::new(-0.5, 1.0),
            Twist::new(0.01, -0.3),
            Twist::new(0.2, 20.0),
        ] {
            let w = m.wheels(t);
            assert!(feasible(w.left_rpm) && feasible(w.right_rpm), "{w:?}");
            let mut best = f64::INFINITY;
            for &r in &grid {
                for &l in grid.iter().step_by(3) {
                    best = best.min(f(
                        t,
                        WheelTargets {
                            left_rpm: l,
                            right_rpm: r,
                        },
                    ));
                }
            }
            assert!(f(t, w) <= best + 1e-9, "{t:?}: {} > {best}", f(t, w));
        }
    }

    #[test]
    fn butterfly_contains_and_projects() {
        let b = Butterfly::from_drive(&Drive::for_kind(RobotKind::NonPilot));
        assert!(b.contains(Twist::new(0.05, 0.5)));
        assert!(b.contains(Twist::new(-0.05, -0.5)));
        assert!(!b.contains(Twist::new(0.0, 1.0)));
        assert!(!b.contains(Twist::new(0.2, 0.0)));
        let p = b.project(Twist::new(0.2, 0.0));
        assert!((p.v - 0.11).abs() < 1e-9 && p.omega.abs() < 1e-9);
        let p = b.project(Twist::new(-0.2, 0.0));
        assert!((p.v + 0.11).abs() < 1e-9);
        let p = b.project(Twist::new(0.0, 1.0));
        assert!(b.contains(p) && p.v > 0.0 && p.omega > 0.0);
        assert_eq!(b.project(Twist::new(f64::INFINITY, 0.0)), Twist::ZERO);
    }

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
