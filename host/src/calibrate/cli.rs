//! The `puzzlebot calibrate` command: run folder, parameter file, plot and printed summary.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

use puzzlebot_params::{RobotKind, RobotParams};
use puzzlebot_protocol::messages::RobotId;

use super::{apply, calibrate, plot_fit, write_params, Calibration, Mode, Plan};

/// Human summary of a calibration.
pub fn describe(cal: &Calibration) -> String {
    let f = cal.fit;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "robot {} ({} pairs, {}):",
        cal.robot,
        cal.measurements.len(),
        cal.plan.mode.unit()
    );
    let _ = writeln!(
        s,
        "  k_v   = {:.5e} m/s per unit   (rms residual {:.4} m/s)",
        f.k_v, f.rms_v
    );
    let _ = writeln!(
        s,
        "  k_ω   = {:.5e} rad/s per unit (rms residual {:.4} rad/s)",
        f.k_omega, f.rms_omega
    );
    let _ = writeln!(s, "  M_min = {:.1}, M_max = {:.0}", f.m_min, f.m_max);
    let _ = writeln!(
        s,
        "  butterfly A = ({:.4}, {:.3}), B = ({:.4}, 0)",
        f.a[0], f.a[1], f.b[0]
    );
    if let Some((kv, kw)) = cal.truth_fit {
        let _ = writeln!(
            s,
            "  ground truth fit: k_v = {kv:.5e} ({:+.2} %), k_ω = {kw:.5e} ({:+.2} %)",
            100.0 * (f.k_v / kv - 1.0),
            100.0 * (f.k_omega / kw - 1.0)
        );
    }
    s
}

/// Run folder `calibrate-ROBOT` and the parameter file to write (`out`, or
/// `robot-ROBOT.toml` / `robot-ROBOT-duty.toml` in the run folder).
pub(crate) fn cli_folder(
    robot: RobotId,
    mode: Mode,
    out: Option<&Path>,
    runs_dir: &Path,
) -> anyhow::Result<(crate::report::RunFolder, PathBuf)> {
    let folder = crate::report::RunFolder::create(runs_dir, &format!("calibrate-{robot}"))?;
    let name = match mode {
        Mode::Speed => format!("robot-{robot}.toml"),
        Mode::Duty => format!("robot-{robot}-duty.toml"),
    };
    let out: PathBuf = out
        .map(Path::to_path_buf)
        .unwrap_or_else(|| folder.dir().join(name));
    Ok((folder, out))
}

/// `puzzlebot calibrate --fleet F`: robot `robot` of a fleet config (a simulated robot:
/// `crate::simulated::calibrate`).
pub async fn run_cli(
    robot: RobotId,
    fleet: &crate::config::Fleet,
    mode: Mode,
    out: Option<&Path>,
    runs_dir: &Path,
) -> anyhow::Result<String> {
    let (folder, out) = cli_folder(robot, mode, out, runs_dir)?;
    let (link, poses) = crate::app::start_host(fleet).await?;
    if !link.wait_for_robots(1, Duration::from_secs(10)).await || !link.online().contains(&robot) {
        link.shutdown().await;
        anyhow::bail!("robot {robot} did not come online within 10 s");
    }
    let kind = link
        .status(robot)
        .and_then(|s| s.kind)
        .unwrap_or(RobotKind::NonPilot);
    let plan = Plan::default_for(mode, kind);
    let pb = crate::app::progress_bar(plan.steps() as f64, "calibrating");
    let cal = calibrate(&link, &poses.table, robot, &plan, Some(&pb), None).await;
    pb.finish_and_clear();
    link.shutdown().await;
    finish_cli(folder, &out, &fleet.params_for(robot, kind), &cal?, None)
}

/// The end of `puzzlebot calibrate`: the parameter file `out` (the fit applied to `base`),
/// the plot and `calibration.json` in the run folder, and the text to print (with the
/// simulator's dead-band `m_min_truth` when known).
pub(crate) fn finish_cli(
    mut folder: crate::report::RunFolder,
    out: &Path,
    base: &RobotParams,
    cal: &Calibration,
    m_min_truth: Option<f64>,
) -> anyhow::Result<String> {
    let params = apply(base, &cal.fit);
    write_params(out, &params, cal)?;
    let plot = folder.dir().join("calibration.svg");
    plot_fit(&plot, cal).map_err(|e| anyhow::anyhow!("plot: {e}"))?;
    folder.write_json("calibration.json", cal)?;
    folder.finish()?;
    let mut s = describe(cal);
    if let Some(t) = m_min_truth {
        let _ = writeln!(
            s,
            "  simulator dead-band M_min = {t:.1} ({:+.2} %)",
            100.0 * (cal.fit.m_min / t - 1.0)
        );
    }
    let _ = writeln!(s, "parameter file: {}", out.display());
    let _ = writeln!(s, "plot: {}", plot.display());
    let _ = writeln!(s, "run folder: {}", folder.dir().display());
    Ok(s)
}
