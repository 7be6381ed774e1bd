//! The calibrated parameter set and its parameter file.

use std::path::Path;

use puzzlebot_params::RobotParams;

use super::{Calibration, Fit, Mode};

/// `base` with the calibrated drive numbers.
pub fn apply(base: &RobotParams, fit: &Fit) -> RobotParams {
    let mut p = base.clone();
    p.drive.k_v = fit.k_v as f32;
    p.drive.k_omega = fit.k_omega as f32;
    p.drive.min_rpm = fit.m_min as f32;
    p.drive.max_rpm = fit.m_max as f32;
    p.drive.butterfly_a = [fit.a[0] as f32, fit.a[1] as f32];
    p.drive.butterfly_b = [fit.b[0] as f32, fit.b[1] as f32];
    p
}

/// Write the robot's parameter file (loadable by `RobotParams::from_file`).
pub fn write_params(path: &Path, params: &RobotParams, cal: &Calibration) -> anyhow::Result<()> {
    // The set is f32; print each number as its shortest f32 decimal (0.05, not 0.0500000007).
    let mut value = toml::Value::try_from(params)?;
    shorten_floats(&mut value);
    let body = toml::to_string_pretty(&value)?;
    let header = format!(
        "# Robot {} calibrated by `puzzlebot calibrate` (THESIS 3.5.1), command space: {} ({}).\n\
         # drive.k_v, drive.k_omega, drive.min_rpm and drive.max_rpm are in these units.\n",
        cal.robot,
        match cal.plan.mode {
            Mode::Speed => "wheel speed",
            Mode::Duty => "raw duty",
        },
        cal.plan.mode.unit()
    );
    std::fs::write(path, header + &body)?;
    Ok(())
}

fn shorten_floats(v: &mut toml::Value) {
    match v {
        toml::Value::Float(x) => {
            if let Ok(short) = format!("{}", *x as f32).parse::<f64>() {
                *x = short;
            }
        }
        toml::Value::Array(a) => a.iter_mut().for_each(shorten_floats),
        toml::Value::Table(t) => t.iter_mut().for_each(|(_, v)| shorten_floats(v)),
        _ => {}
    }
}
