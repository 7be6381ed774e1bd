//! Least-squares fits of a calibration: drive gains of THESIS (3.10), butterfly points and
//! velocities from pose samples.

use crate::drive::{wrap_angle, PoseSample};

/// Least squares through the origin: slope of y over x.
fn slope(xs: &[f64], ys: &[f64]) -> f64 {
    let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| x * y).sum();
    let sxx: f64 = xs.iter().map(|x| x * x).sum();
    if sxx > 0.0 {
        sxy / sxx
    } else {
        0.0
    }
}

/// Fit THESIS (3.10) `v = k_v (M_r + M_l)/2`, `ω = k_ω (M_r − M_l)` to `(M_r, M_l, v, ω)`,
/// returning `(k_v, k_ω, rms_v, rms_ω)`. Pairs with a wheel inside the dead-band `m_min`
/// are left out (the robot does not follow 3.10 there).
pub fn fit_gains(data: &[(f64, f64, f64, f64)], m_min: f64) -> (f64, f64, f64, f64) {
    let used: Vec<_> = data
        .iter()
        .filter(|(r, l, _, _)| r.abs() > m_min && l.abs() > m_min)
        .collect();
    let mean: Vec<f64> = used.iter().map(|d| (d.0 + d.1) / 2.0).collect();
    let diff: Vec<f64> = used.iter().map(|d| d.0 - d.1).collect();
    let v: Vec<f64> = used.iter().map(|d| d.2).collect();
    let w: Vec<f64> = used.iter().map(|d| d.3).collect();
    let k_v = slope(&mean, &v);
    let k_w = slope(&diff, &w);
    let n = used.len().max(1) as f64;
    let rms_v = (mean
        .iter()
        .zip(&v)
        .map(|(m, v)| (k_v * m - v).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let rms_w = (diff
        .iter()
        .zip(&w)
        .map(|(d, w)| (k_w * d - w).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    (k_v, k_w, rms_v, rms_w)
}

/// Butterfly points from measured (v, ω): B = fastest straight run; A = the fastest turn,
/// mirrored to ω < 0 (THESIS 3.5.1 projects the points by symmetry), with a_v kept inside
/// (0, b_v).
pub fn fit_butterfly(meas: &[(f64, f64, f64, f64)]) -> ([f64; 2], [f64; 2]) {
    let straight = |d: &&(f64, f64, f64, f64)| (d.0 - d.1).abs() <= 1e-9;
    let b_v = meas
        .iter()
        .filter(straight)
        .map(|d| d.2.abs())
        .fold(0.0, f64::max);
    let turn = meas
        .iter()
        .max_by(|x, y| x.3.abs().total_cmp(&y.3.abs()))
        .map(|d| (d.2.abs(), d.3.abs()))
        .unwrap_or((0.0, 0.0));
    let a_v = turn.0.clamp(0.05 * b_v, 0.95 * b_v);
    ([a_v, -turn.1], [b_v, 0.0])
}

/// (v, ω) by least-squares slopes of travelled distance (projected on the heading) and of
/// the unwrapped heading over time.
pub(super) fn velocity_of(samples: &[PoseSample]) -> Option<(f64, f64)> {
    if samples.len() < 5 {
        return None;
    }
    let mut s = 0.0;
    let mut th = samples[0].theta;
    let mut ts = Vec::with_capacity(samples.len());
    let mut dist = Vec::with_capacity(samples.len());
    let mut head = Vec::with_capacity(samples.len());
    for (i, p) in samples.iter().enumerate() {
        if i > 0 {
            let q = samples[i - 1];
            let mid = q.theta + wrap_angle(p.theta - q.theta) / 2.0;
            s += (p.x - q.x) * mid.cos() + (p.y - q.y) * mid.sin();
            th += wrap_angle(p.theta - q.theta);
        }
        ts.push(p.t - samples[0].t);
        dist.push(s);
        head.push(th);
    }
    let lsq = |ys: &[f64]| {
        let n = ys.len() as f64;
        let mt = ts.iter().sum::<f64>() / n;
        let my = ys.iter().sum::<f64>() / n;
        let num: f64 = ts.iter().zip(ys).map(|(t, y)| (t - mt) * (y - my)).sum();
        let den: f64 = ts.iter().map(|t| (t - mt).powi(2)).sum();
        if den > 0.0 {
            num / den
        } else {
            0.0
        }
    };
    Some((lsq(&dist), lsq(&head)))
}
