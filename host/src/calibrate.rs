//! Automatic calibration of one robot (THESIS 3.5.1): drive command pairs, measure v and ω
//! from poses averaged over seconds, fit k_v and k_ω of THESIS (3.10) by least squares,
//! find the start-up dead-band M_min by bisection, read the butterfly points A and B off
//! the measured envelope, write the robot's parameter file and plot the fit.
//!
//! Two command spaces: [`Mode::Speed`] (wheel-speed targets in RPM, held by the on-robot PI:
//! the units the host drives with) and [`Mode::Duty`] (raw per-mille duties, open loop, as
//! THESIS calibrated its PWM-driven v2 robots).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Duration;

use plotters::prelude::*;
use puzzlebot_params::{RobotKind, RobotParams};
use puzzlebot_protocol::{messages::RobotId, HostMsg};
use serde::Serialize;

use crate::drive::{wrap_angle, PoseSample};
use crate::link::FleetLink;
use crate::pose::PoseTable;

/// Command space of the calibration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Mode {
    /// Wheel-speed targets (RPM).
    Speed,
    /// Raw duties (per-mille).
    Duty,
}

impl Mode {
    /// Largest command magnitude: the firmware's speed range (RPM) or full duty (per-mille).
    pub fn full_scale(self) -> f64 {
        match self {
            Mode::Speed => f64::from(puzzlebot_params::firmware::Firmware::default().max_rpm),
            Mode::Duty => f64::from(puzzlebot_protocol::messages::DUTY_FULL_SCALE),
        }
    }

    /// Unit name.
    pub fn unit(self) -> &'static str {
        match self {
            Mode::Speed => "RPM",
            Mode::Duty => "per-mille duty",
        }
    }

    fn message(self, right: f64, left: f64) -> HostMsg {
        match self {
            Mode::Speed => HostMsg::WheelSpeed {
                left_rpm: left as f32,
                right_rpm: right as f32,
            },
            Mode::Duty => {
                let fs = Mode::Duty.full_scale();
                HostMsg::RawDuty {
                    left: left.round().clamp(-fs, fs) as i16,
                    right: right.round().clamp(-fs, fs) as i16,
                }
            }
        }
    }
}

/// What to drive.
#[derive(Debug, Clone, Serialize)]
pub struct Plan {
    /// Command space.
    pub mode: Mode,
    /// Command pairs (M_r, M_l).
    pub pairs: Vec<(f64, f64)>,
    /// Time to reach steady state before measuring (s).
    pub settle: f64,
    /// Measuring time per pair (s).
    pub hold: f64,
    /// Bisection interval for M_min.
    pub dead_band_range: (f64, f64),
    /// Bisection steps.
    pub dead_band_steps: u32,
    /// Displacement (m) that counts as "moved" in a dead-band trial.
    pub moved_threshold: f64,
}

impl Plan {
    /// The default plan for `kind` in `mode`: straight pairs, turning pairs, full speed,
    /// each driven forward then backward so the robot stays near its start.
    pub fn default_for(mode: Mode, kind: RobotKind) -> Plan {
        let fs = mode.full_scale();
        // Means and differences as fractions of full scale.
        let mut base: Vec<(f64, f64)> = vec![(0.3, 0.0), (0.6, 0.0), (1.0, 0.0)];
        match kind {
            // Non-pilots turn in place; pilots need forward speed to turn (THESIS 3.5.1).
            RobotKind::NonPilot => base.extend([(0.0, 0.4), (0.0, 0.8), (0.5, 0.5)]),
            RobotKind::Pilot => base.extend([(0.5, 0.2), (0.6, 0.4), (0.7, 0.6)]),
        }
        let mut pairs = Vec::new();
        for (m, d) in base {
            let (r, l) = ((m + d / 2.0) * fs, (m - d / 2.0) * fs);
            let (r, l) = (r.min(fs), l.max(-fs));
            pairs.push((r, l));
            pairs.push((-r, -l));
        }
        Plan {
            mode,
            pairs,
            settle: 0.4,
            hold: 0.8,
            dead_band_range: (0.0, 0.3 * fs),
            dead_band_steps: 7,
            moved_threshold: 0.002,
        }
    }

    /// Number of progress steps.
    pub fn steps(&self) -> u64 {
        self.pairs.len() as u64 + u64::from(self.dead_band_steps)
    }
}

/// One measured pair.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Measurement {
    /// Right command.
    pub m_r: f64,
    /// Left command.
    pub m_l: f64,
    /// Measured forward speed (m/s).
    pub v: f64,
    /// Measured turn rate (rad/s).
    pub omega: f64,
    /// Pose samples used.
    pub samples: usize,
    /// The same from ground truth, when a probe was given (simulation).
    pub truth: Option<(f64, f64)>,
}

/// The fitted numbers.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Fit {
    /// k_v (m/s per unit of mean command).
    pub k_v: f64,
    /// k_ω (rad/s per unit of command difference).
    pub k_omega: f64,
    /// M_min: smallest symmetric command that moves the robot.
    pub m_min: f64,
    /// M_max: the full-scale command.
    pub m_max: f64,
    /// Butterfly A (v, ω).
    pub a: [f64; 2],
    /// Butterfly B (v, 0).
    pub b: [f64; 2],
    /// RMS residual of the v fit (m/s).
    pub rms_v: f64,
    /// RMS residual of the ω fit (rad/s).
    pub rms_omega: f64,
}

/// Everything a calibration produced.
#[derive(Debug, Clone, Serialize)]
pub struct Calibration {
    /// Robot.
    pub robot: RobotId,
    /// Plan.
    pub plan: Plan,
    /// Measured pairs.
    pub measurements: Vec<Measurement>,
    /// Dead-band trials (command, moved distance m).
    pub dead_band_trials: Vec<(f64, f64)>,
    /// Fit from poses.
    pub fit: Fit,
    /// Fit of k_v, k_ω from ground truth (simulation), for comparison.
    pub truth_fit: Option<(f64, f64)>,
}

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

/// Optional ground truth (v, ω) of the robot (simulation), sampled while measuring.
pub type VelocityProbe = Box<dyn Fn() -> Option<(f64, f64)> + Send>;

struct Collector {
    samples: Vec<PoseSample>,
    truth: Vec<(f64, f64)>,
}

async fn drive_and_collect(
    link: &FleetLink,
    poses: &PoseTable,
    robot: RobotId,
    msg: HostMsg,
    settle: f64,
    hold: f64,
    probe: Option<&VelocityProbe>,
) -> Collector {
    let period = Duration::from_secs_f64(1.0 / f64::from(link.rates().command_hz).max(1.0));
    let start = tokio::time::Instant::now();
    let settle_end = start + Duration::from_secs_f64(settle);
    let end = settle_end + Duration::from_secs_f64(hold);
    let mut c = Collector {
        samples: Vec::new(),
        truth: Vec::new(),
    };
    let mut next_cmd = start;
    let stale = Duration::from_millis(100);
    loop {
        let now = tokio::time::Instant::now();
        if now >= end {
            break;
        }
        if now >= next_cmd {
            link.command(robot, msg.clone()).await;
            next_cmd = now + period;
        }
        if now >= settle_end {
            if let Some(p) = poses.fresh(robot, stale) {
                if c.samples.last().is_none_or(|l| p.t > l.t) {
                    c.samples.push(p);
                }
            }
            if let Some(t) = probe.and_then(|f| f()) {
                c.truth.push(t);
            }
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    c
}

/// (v, ω) by least-squares slopes of travelled distance (projected on the heading) and of
/// the unwrapped heading over time.
fn velocity_of(samples: &[PoseSample]) -> Option<(f64, f64)> {
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

/// Run the calibration `plan` on `robot` over a running link and pose input.
pub async fn calibrate(
    link: &FleetLink,
    poses: &PoseTable,
    robot: RobotId,
    plan: &Plan,
    progress: Option<&indicatif::ProgressBar>,
    truth: Option<VelocityProbe>,
) -> anyhow::Result<Calibration> {
    if !link.online().contains(&robot) {
        anyhow::bail!("robot {robot} is not online");
    }
    let stop = HostMsg::Stop;
    let mut dead_band_trials = Vec::new();
    // M_min by bisection: the smallest symmetric command that moves the robot.
    let (mut lo, mut hi) = plan.dead_band_range;
    for _ in 0..plan.dead_band_steps {
        let mid = 0.5 * (lo + hi);
        drive_and_collect(link, poses, robot, stop.clone(), 0.25, 0.0, None).await;
        let c = drive_and_collect(
            link,
            poses,
            robot,
            plan.mode.message(mid, mid),
            0.05,
            0.7,
            None,
        )
        .await;
        let moved = match (c.samples.first(), c.samples.last()) {
            (Some(a), Some(b)) => ((b.x - a.x).powi(2) + (b.y - a.y).powi(2)).sqrt(),
            _ => anyhow::bail!(
                "robot {robot}: no poses while calibrating (is motion capture running?)"
            ),
        };
        dead_band_trials.push((mid, moved));
        if moved > plan.moved_threshold {
            hi = mid;
        } else {
            lo = mid;
        }
        if let Some(pb) = progress {
            pb.inc(1);
        }
    }
    let m_min = hi;
    let mut measurements = Vec::new();
    for &(r, l) in &plan.pairs {
        let c = drive_and_collect(
            link,
            poses,
            robot,
            plan.mode.message(r, l),
            plan.settle,
            plan.hold,
            truth.as_ref(),
        )
        .await;
        let Some((v, omega)) = velocity_of(&c.samples) else {
            anyhow::bail!("robot {robot}: too few poses for pair ({r}, {l})");
        };
        let tr = (!c.truth.is_empty()).then(|| {
            let n = c.truth.len() as f64;
            (
                c.truth.iter().map(|t| t.0).sum::<f64>() / n,
                c.truth.iter().map(|t| t.1).sum::<f64>() / n,
            )
        });
        measurements.push(Measurement {
            m_r: r,
            m_l: l,
            v,
            omega,
            samples: c.samples.len(),
            truth: tr,
        });
        if let Some(pb) = progress {
            pb.inc(1);
        }
    }
    link.command(robot, HostMsg::Stop).await;
    let data: Vec<_> = measurements
        .iter()
        .map(|m| (m.m_r, m.m_l, m.v, m.omega))
        .collect();
    let (k_v, k_omega, rms_v, rms_omega) = fit_gains(&data, m_min);
    let (a, b) = fit_butterfly(&data);
    let truth_data: Vec<_> = measurements
        .iter()
        .filter_map(|m| m.truth.map(|t| (m.m_r, m.m_l, t.0, t.1)))
        .collect();
    let truth_fit = (truth_data.len() == measurements.len() && !truth_data.is_empty()).then(|| {
        let (kv, kw, _, _) = fit_gains(&truth_data, m_min);
        (kv, kw)
    });
    Ok(Calibration {
        robot,
        plan: plan.clone(),
        measurements,
        dead_band_trials,
        fit: Fit {
            k_v,
            k_omega,
            m_min,
            m_max: plan.mode.full_scale(),
            a,
            b,
            rms_v,
            rms_omega,
        },
        truth_fit,
    })
}

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

/// A chart of the calibration plot (f64 × f64 axes).
type Panel<'a, 'b> = ChartContext<
    'a,
    SVGBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// One panel of the calibration plot: its chart over ±`x_max` × ±`y_max` with axis labels and
/// the measured points.
fn panel<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    caption: String,
    (x_desc, y_desc): (String, &str),
    (x_max, y_max): (f64, f64),
    points: impl Iterator<Item = (f64, f64)>,
) -> Result<Panel<'a, 'b>, String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let mut c = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(-x_max..x_max, -y_max..y_max)
        .map_err(|x| e(&x))?;
    c.configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .draw()
        .map_err(|x| e(&x))?;
    c.draw_series(points.map(|p| Circle::new(p, 4, BLUE.filled())))
        .map_err(|x| e(&x))?;
    Ok(c)
}

/// A fitted gain y = k·x drawn across a panel, its ends kept inside the chart (plotters does
/// not clip line ends).
fn gain_line(c: &mut Panel<'_, '_>, k: f64, (x_max, y_max): (f64, f64)) -> Result<(), String> {
    let x = if k.abs() > 0.0 {
        x_max.min(y_max / k.abs())
    } else {
        x_max
    };
    c.draw_series(LineSeries::new(
        [(-x, -k * x), (x, k * x)],
        RED.stroke_width(2),
    ))
    .map_err(|x| x.to_string())?;
    Ok(())
}

/// Plot measured v and ω against the fitted lines of THESIS (3.10) and the butterfly.
pub fn plot_fit(path: &Path, cal: &Calibration) -> Result<(), String> {
    let root = SVGBackend::new(path, (1200, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let panels = root.split_evenly((1, 3));
    let f = cal.fit;
    let unit = cal.plan.mode.unit();
    let ms = &cal.measurements;
    let peak = |x: fn(&Measurement) -> f64, at_least: f64| {
        ms.iter().map(|m| x(m).abs()).fold(at_least, f64::max) * 1.1 + 1e-6
    };
    let vmax = peak(|m| m.v, f.b[0]);
    let wmax = peak(|m| m.omega, f.a[1].abs());
    // v against mean command.
    let range = (f.m_max, vmax);
    let mut c = panel(
        &panels[0],
        format!("v = k_v (M_r+M_l)/2, k_v = {:.3e}", f.k_v),
        (format!("mean command ({unit})"), "v (m/s)"),
        range,
        ms.iter().map(|m| ((m.m_r + m.m_l) / 2.0, m.v)),
    )?;
    gain_line(&mut c, f.k_v, range)?;
    // ω against difference.
    let range = (2.0 * f.m_max, wmax);
    let mut c = panel(
        &panels[1],
        format!("ω = k_ω (M_r−M_l), k_ω = {:.3e}", f.k_omega),
        (format!("command difference ({unit})"), "ω (rad/s)"),
        range,
        ms.iter().map(|m| (m.m_r - m.m_l, m.omega)),
    )?;
    gain_line(&mut c, f.k_omega, range)?;
    // Butterfly.
    let mut c = panel(
        &panels[2],
        format!(
            "butterfly A = ({:.3}, {:.2}), B = ({:.3}, 0)",
            f.a[0], f.a[1], f.b[0]
        ),
        ("v (m/s)".to_string(), "ω (rad/s)"),
        (vmax, wmax),
        ms.iter().map(|m| (m.v, m.omega)),
    )?;
    let (av, aw, bv) = (f.a[0], f.a[1].abs(), f.b[0]);
    for s in [1.0, -1.0] {
        let wing = vec![
            (0.0, 0.0),
            (s * av, -aw),
            (s * bv, 0.0),
            (s * av, aw),
            (0.0, 0.0),
        ];
        c.draw_series(LineSeries::new(wing, RED.stroke_width(2)))
            .map_err(|x| x.to_string())?;
    }
    root.present().map_err(|x| x.to_string())
}

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

/// Measured pairs grouped for reporting: (M_r, M_l) → (v, ω).
pub fn table(cal: &Calibration) -> BTreeMap<String, (f64, f64)> {
    cal.measurements
        .iter()
        .map(|m| (format!("({:.0}, {:.0})", m.m_r, m.m_l), (m.v, m.omega)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
