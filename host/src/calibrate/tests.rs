//! Tests of the calibration fits and the parameter file.

use super::*;
use crate::drive::wrap_angle;
use puzzlebot_params::RobotParams;

#[test]
fn fits_recover_synthetic_gains_and_butterfly() {
    let (kv, kw) = (0.0018, 0.045);
    let plan = Plan::default_for(Mode::Speed, RobotKind::NonPilot);
    let data: Vec<_> = plan
        .pairs
        .iter()
        .map(|&(r, l)| (r, l, kv * (r + l) / 2.0 * 1.001, kw * (r - l) * 0.999))
        .collect();
    let (fv, fw, rv, rw) = fit_gains(&data, 20.0);
    assert!(
        (fv / kv - 1.0).abs() < 0.002 && (fw / kw - 1.0).abs() < 0.002,
        "{fv} {fw}"
    );
    assert!(rv < 1e-3 && rw < 1e-2);
    let (a, b) = fit_butterfly(&data);
    assert!((b[0] - kv * 450.0 * 1.001).abs() < 1e-9);
    assert!(a[1] < 0.0 && a[0] > 0.0 && a[0] < b[0]);
}

#[test]
fn velocity_from_noisy_circle_samples() {
    let (v, w) = (0.06, 1.2);
    let mut rng_state = 12345u64;
    let mut noise = || {
        rng_state = rng_state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((rng_state >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.001
    };
    let samples: Vec<_> = (0..80)
        .map(|i| {
            let t = f64::from(i) * 0.01;
            let th = w * t;
            PoseSample {
                t,
                x: v / w * th.sin() + noise(),
                y: v / w * (1.0 - th.cos()) + noise(),
                theta: wrap_angle(th),
            }
        })
        .collect();
    let (ev, ew) = velocity_of(&samples).expect("enough");
    assert!((ev - v).abs() < 0.003 && (ew - w).abs() < 0.01, "{ev} {ew}");
}

#[test]
fn parameter_file_round_trips() {
    let plan = Plan::default_for(Mode::Speed, RobotKind::NonPilot);
    let fit = Fit {
        k_v: 0.0018,
        k_omega: 0.045,
        m_min: 12.5,
        m_max: 450.0,
        a: [0.02, -2.0],
        b: [0.8, 0.0],
        rms_v: 0.0,
        rms_omega: 0.0,
    };
    let cal = Calibration {
        robot: 3,
        plan,
        measurements: vec![],
        dead_band_trials: vec![],
        fit,
        truth_fit: None,
    };
    let p = apply(&RobotParams::default(), &fit);
    let path = std::env::temp_dir().join(format!("pb-cal-{}.toml", std::process::id()));
    write_params(&path, &p, &cal).expect("write");
    let back = RobotParams::from_file(&path).expect("loadable");
    assert_eq!(back.drive.k_v, 0.0018f32);
    assert_eq!(back.drive.min_rpm, 12.5f32);
    assert_eq!(back, p);
}
