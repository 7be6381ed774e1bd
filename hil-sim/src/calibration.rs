//! Open-loop drive calibration of THESIS 3.5.1, run on the simulated plant.
//!
//! The chapter-3 robots were commanded with pairs of motor PWM values (M_r, M_l), their
//! average linear and angular velocities were measured over several seconds, and
//! `v = k_v (M_r + M_l)/2`, `ω = k_ω (M_r − M_l)` (THESIS 3.10) were fitted; the feasible
//! v–ω region ("butterfly", Figures 3.12–3.13) is the polygon through the origin, the
//! corner A = (a_x, a_y) and the top speed B = (b_x, 0), mirrored. Here the same
//! procedure runs on [`crate::drive`]: a grid of PWM pairs ([`Procedure`]), the steady
//! (v, ω) of each, least-squares slopes through the origin over every point, B the fastest
//! point that does not turn, and the upper convex hull of the measured (v, |ω|) points
//! whose highest vertex is A.
//!
//! [`Procedure::thesis_3_5_1`] is the run THESIS describes (both motors forward, speed
//! proportional to PWM); [`Procedure::full_grid`] also drives wheels backwards and shows
//! whether a robot can turn in place.
//!
//! What a forward-only run cannot show: with neither wheel reversing, the fastest turn is a
//! pivot about the stopped inner wheel, so at the corner A `a_x ≥ |a_y|·L/2` (L the track).
//! THESIS's non-pilot A = (0.037, −2.19) has `a_x = |a_y|·16.9 mm`, below L/2 = 20 mm
//! (its inner wheel was going backwards), while its k_ω/k_v = 23.7 /m says L ≈ 42 mm. The
//! two cannot both hold for one two-wheeled robot, so the chapter-3 non-pilot preset
//! reproduces k_v, k_ω and B and puts A on the pivot line.

use crate::drive::{step, Bridge, DriveModel, DriveState};
use crate::math::{cross, sub, V2};
use puzzlebot_params::{RobotKind, RobotParams};

/// Full scale of the chapter-3 PWM commands.
pub const PWM_MAX: i32 = 255;
/// Largest PWM of the full-grid calibration ([`Procedure::full_grid`]).
pub const PWM_CAP: i32 = 230;
/// Largest PWM of the THESIS 3.5.1 calibration runs ([`Procedure::thesis_3_5_1`]).
///
/// THESIS does not state it. For a speed proportional to PWM (THESIS 3.4: "linearly
/// proportional to the PWM signal") the fitted slope k_v times the largest PWM is the top
/// speed B, so B / k_v is that PWM: 0.11 / 0.0006 = 183 (non-pilot) and 0.47 / 0.0024 =
/// 196 (pilot). Both robots ran the same procedure; 190 is between the two.
pub const THESIS_PWM_MAX: i32 = 190;

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

/// How the DRV8833 is driven by an 8-bit PWM value (datasheet table "PWM control of
/// motor speed").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decay {
    /// PWM on one input, the other low (xIN1 = PWM, xIN2 = 0): the armature coasts during
    /// the off time, as a bare Arduino `analogWrite` on one pin does. With a light load the
    /// speed barely depends on the duty once the motor turns.
    Fast,
    /// One input high, PWM on the other (xIN1 = 1, xIN2 = PWM): the armature is shorted
    /// during the off time, so the average voltage and the speed are proportional to the
    /// duty ("the motor rotational speed is linearly proportional to the PWM signal with a
    /// fixed load", THESIS 3.4). PWM 0 brakes.
    Slow,
}

/// DRV8833 inputs (per-mille) for the signed 8-bit PWM `p` driven with `decay`.
pub fn bridge_for(p: i32, decay: Decay) -> Bridge {
    let d = (p.clamp(-PWM_MAX, PWM_MAX) * 1000 / PWM_MAX) as i16;
    let on = d.unsigned_abs();
    match (decay, d >= 0) {
        (Decay::Fast, true) => Bridge { in1: on, in2: 0 },
        (Decay::Fast, false) => Bridge { in1: 0, in2: on },
        (Decay::Slow, true) => Bridge {
            in1: 1000,
            in2: 1000 - on,
        },
        (Decay::Slow, false) => Bridge {
            in1: 1000 - on,
            in2: 1000,
        },
    }
}

/// Steady (v, ω) of a robot driven open-loop with PWM `m` = (right, left) in fast decay:
/// settle for `settle_s`, then average over `measure_s`.
pub fn measure(model: &DriveModel, m: [i32; 2], settle_s: f64, measure_s: f64) -> (f64, f64) {
    measure_with(model, m, Decay::Fast, settle_s, measure_s)
}

/// Steady (v, ω) of a robot driven open-loop with PWM `m` = (right, left) and `decay`:
/// settle for `settle_s`, then average over `measure_s` (THESIS 3.5.1 averages over
/// "several seconds" because velocities from consecutive poses are too noisy).
pub fn measure_with(
    model: &DriveModel,
    m: [i32; 2],
    decay: Decay,
    settle_s: f64,
    measure_s: f64,
) -> (f64, f64) {
    let mut s = DriveState::at_rest(model, 0.5);
    let cmd = [bridge_for(m[1], decay), bridge_for(m[0], decay)]; // [left, right]
    let dt = 1e-3;
    for _ in 0..(settle_s / dt) as usize {
        step(model, &mut s, cmd, dt);
    }
    let n = ((measure_s / dt) as usize).max(1);
    let (mut v, mut w) = (0.0, 0.0);
    for _ in 0..n {
        step(model, &mut s, cmd, dt);
        v += s.v;
        w += s.omega;
    }
    (v / n as f64, w / n as f64)
}

/// A calibration run: which PWM pairs are commanded, how, and for how long.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Procedure {
    /// Largest |PWM| of the grid.
    pub pwm_max: i32,
    /// Grid spacing (PWM units); the grid always includes 0 and ±`pwm_max`.
    pub step: i32,
    /// Include reverse PWMs (pairs with a non-negative mean), e.g. turning in place.
    pub reverse: bool,
    /// Bridge drive.
    pub decay: Decay,
    /// Settling time before averaging (s).
    pub settle_s: f64,
    /// Averaging time (s).
    pub measure_s: f64,
}

impl Procedure {
    /// The whole v ≥ 0 half of the command space (±[`PWM_CAP`], reverse included, fast
    /// decay): shows whether a robot can turn in place (the butterfly's waist).
    pub fn full_grid(step: i32) -> Procedure {
        Procedure {
            pwm_max: PWM_CAP,
            step,
            reverse: true,
            decay: Decay::Fast,
            settle_s: 1.0,
            measure_s: 1.0,
        }
    }

    /// THESIS 3.5.1 as the thesis ran it on the chapter-3 robots: "a combination of
    /// different motor PWM signals" on a grid, both motors forward (0…[`THESIS_PWM_MAX`];
    /// the thesis shows the region with v > 0 and mirrors it), speed proportional to PWM
    /// (slow decay, see [`Decay::Slow`]), ten steps of 19; velocities averaged over
    /// seconds. The chapter-3 preset (`Plant::chapter3`) was fitted with this grid.
    pub fn thesis_3_5_1() -> Procedure {
        Procedure {
            pwm_max: THESIS_PWM_MAX,
            step: THESIS_PWM_MAX / 10,
            reverse: false,
            decay: Decay::Slow,
            settle_s: 1.0,
            measure_s: 2.0,
        }
    }

    /// The commanded (right, left) pairs.
    pub fn pairs(&self) -> Vec<[i32; 2]> {
        let levels = self.levels();
        let mut out = Vec::new();
        for &mr in &levels {
            for &ml in &levels {
                if mr + ml >= 0 {
                    out.push([mr, ml]);
                }
            }
        }
        out
    }

    /// The PWM values of one motor, ascending.
    fn levels(&self) -> Vec<i32> {
        let step = self.step.max(1);
        let max = self.pwm_max.clamp(1, PWM_MAX);
        let lo = if self.reverse { -max } else { 0 };
        let mut out: Vec<i32> = (0..)
            .map(|k| lo + k * step)
            .take_while(|&p| p < max)
            .collect();
        if self.reverse && !out.contains(&0) {
            out.push(0);
            out.sort_unstable();
        }
        out.push(max);
        out
    }
}

/// Run the full-grid calibration ([`Procedure::full_grid`]) for a robot of `kind` with
/// `params` on a PWM grid of `step_pwm`.
pub fn calibrate(kind: RobotKind, params: &RobotParams, step_pwm: i32) -> Calibration {
    calibrate_with(kind, params, &Procedure::full_grid(step_pwm))
}

/// Run the calibration `proc` for a robot of `kind` with `params`.
pub fn calibrate_with(kind: RobotKind, params: &RobotParams, proc: &Procedure) -> Calibration {
    let model = DriveModel::new(kind, &params.plant, &params.mass, &params.geometry);
    let points: Vec<Point> = proc
        .pairs()
        .into_iter()
        .map(|m| {
            let (v, omega) = measure_with(&model, m, proc.decay, proc.settle_s, proc.measure_s);
            Point { m, v, omega }
        })
        .collect();
    // Least squares through the origin (THESIS 3.10).
    let (mut sv, mut smm, mut sw, mut sdd) = (0.0, 0.0, 0.0, 0.0);
    for p in &points {
        let mean = f64::from(p.m[0] + p.m[1]) / 2.0;
        let diff = f64::from(p.m[0] - p.m[1]);
        sv += p.v * mean;
        smm += mean * mean;
        sw += p.omega * diff;
        sdd += diff * diff;
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
