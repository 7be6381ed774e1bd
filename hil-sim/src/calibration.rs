//! Open-loop drive calibration of THESIS 3.5.1, run on the simulated plant.
//!
//! The chapter-3 robots were commanded with pairs of motor PWM values (M_r, M_l), their
//! average linear and angular velocities were measured over several seconds, and
//! `v = k_v (M_r + M_l)/2`, `ω = k_ω (M_r − M_l)` (THESIS 3.10) were fitted; the feasible
//! v–ω region ("butterfly", Figures 3.12–3.13) is the polygon through the origin, the
//! corner A = (a_x, a_y) and the top speed B = (b_x, 0), mirrored. Here the same
//! procedure runs on [`crate::drive`]: a grid of PWM pairs (0…255, the ATmega328P's 8-bit
//! PWM on IN1 with IN2 low, i.e. fast decay), the steady (v, ω) of each, least-squares
//! slopes through the origin, and the convex hull of the measured (v, |ω|) points for the
//! butterfly.

use crate::drive::{step, Bridge, DriveModel, DriveState};
use crate::math::{cross, sub, V2};
use puzzlebot_params::{RobotKind, RobotParams};

/// Full scale of the chapter-3 PWM commands.
pub const PWM_MAX: i32 = 255;
/// Largest PWM of the calibration grid (see the module documentation).
pub const PWM_CAP: i32 = 230;

/// One measured command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Right and left PWM.
    pub m: [i32; 2],
    /// Mean forward speed (m/s).
    pub v: f64,
    /// Mean yaw rate (rad/s).
    pub omega: f64,
}

/// Result of a calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// Fitted k_v (m/s per PWM unit of the mean).
    pub k_v: f64,
    /// Fitted k_ω (rad/s per PWM unit of the difference).
    pub k_omega: f64,
    /// Top speed with |ω| small (m/s).
    pub b_x: f64,
    /// Upper hull of (v, |ω|) over v ≥ 0, left to right (starts at the origin).
    pub hull: Vec<V2>,
    /// Every measured point.
    pub points: Vec<Point>,
}

impl Calibration {
    /// Largest |ω| of the feasible region at forward speed `v` (0 outside it).
    pub fn omega_max_at(&self, v: f64) -> f64 {
        for w in self.hull.windows(2) {
            let (p, q) = (w[0], w[1]);
            if v >= p[0] && v <= q[0] {
                if q[0] - p[0] < 1e-12 {
                    return p[1].max(q[1]);
                }
                return p[1] + (q[1] - p[1]) * (v - p[0]) / (q[0] - p[0]);
            }
        }
        0.0
    }

    /// The corner A of the butterfly: the hull vertex of largest |ω| (returned as (v, −|ω|),
    /// THESIS's sign convention).
    pub fn corner_a(&self) -> V2 {
        let a = self
            .hull
            .iter()
            .copied()
            .max_by(|a, b| a[1].total_cmp(&b[1]))
            .unwrap_or([0.0, 0.0]);
        [a[0], -a[1]]
    }
}

/// Steady (v, ω) of a robot driven open-loop with PWM `m` = (right, left): settle for
/// `settle_s`, then average over `measure_s`.
pub fn measure(model: &DriveModel, m: [i32; 2], settle_s: f64, measure_s: f64) -> (f64, f64) {
    let bridge = |p: i32| {
        let d = (p.clamp(-PWM_MAX, PWM_MAX) * 1000 / PWM_MAX) as i16;
        // PWM on one input, the other low (fast decay), as an ATmega `analogWrite` does.
        if d >= 0 {
            Bridge {
                in1: d as u16,
                in2: 0,
            }
        } else {
            Bridge {
                in1: 0,
                in2: (-d) as u16,
            }
        }
    };
    let mut s = DriveState::at_rest(model, 0.5);
    let cmd = [bridge(m[1]), bridge(m[0])]; // [left, right]
    let dt = 1e-3;
    for _ in 0..(settle_s / dt) as usize {
        step(model, &mut s, cmd, dt);
    }
    let n = (measure_s / dt) as usize;
    let (mut v, mut w) = (0.0, 0.0);
    for _ in 0..n {
        step(model, &mut s, cmd, dt);
        v += s.v;
        w += s.omega;
    }
    (v / n as f64, w / n as f64)
}

/// Run the calibration for a robot of `kind` with `params` on a PWM grid of `step_pwm`.
pub fn calibrate(kind: RobotKind, params: &RobotParams, step_pwm: i32) -> Calibration {
    let model = DriveModel::new(kind, &params.plant, &params.mass, &params.geometry);
    let step_pwm = step_pwm.max(1);
    let mut points = Vec::new();
    let mut mr = -PWM_CAP;
    while mr <= PWM_CAP {
        let mut ml = -PWM_CAP;
        while ml <= PWM_CAP {
            if mr + ml >= 0 {
                let (v, omega) = measure(&model, [mr, ml], 1.0, 1.0);
                points.push(Point {
                    m: [mr, ml],
                    v,
                    omega,
                });
            }
            ml += step_pwm;
        }
        mr += step_pwm;
    }
    // Least squares through the origin (THESIS 3.10).
    let (mut sv, mut smm, mut sw, mut sdd) = (0.0, 0.0, 0.0, 0.0);
    for p in &points {
        let mean = f64::from(p.m[0] + p.m[1]) / 2.0;
        let diff = f64::from(p.m[0] - p.m[1]);
        sv += p.v * mean;
        smm += mean * mean;
        if p.m[0] >= 0 && p.m[1] >= 0 {
            sw += p.omega * diff;
            sdd += diff * diff;
        }
    }
    let k_v = if smm > 0.0 { sv / smm } else { 0.0 };
    let k_omega = if sdd > 0.0 { sw / sdd } else { 0.0 };
    let w_all = points.iter().map(|p| p.omega.abs()).fold(0.0, f64::max);
    let b_x = points
        .iter()
        .filter(|p| p.omega.abs() <= 0.05 * w_all.max(1e-9))
        .map(|p| p.v)
        .fold(0.0, f64::max);
    // Upper convex hull of (v, |ω|) with v ≥ 0, anchored at the origin and (b_x, 0).
    let mut pts: Vec<V2> = points
        .iter()
        .filter(|p| p.v >= 0.0)
        .map(|p| [p.v, p.omega.abs()])
        .collect();
    pts.push([0.0, 0.0]);
    pts.push([b_x, 0.0]);
    pts.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let mut hull: Vec<V2> = Vec::new();
    for p in pts {
        while hull.len() >= 2
            && cross(
                sub(hull[hull.len() - 1], hull[hull.len() - 2]),
                sub(p, hull[hull.len() - 2]),
            ) >= 0.0
        {
            hull.pop();
        }
        hull.push(p);
    }
    Calibration {
        k_v,
        k_omega,
        b_x,
        hull,
        points,
    }
}
