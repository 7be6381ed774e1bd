//! Automatic calibration of one robot (THESIS 3.5.1): drive command pairs, measure v and ω
//! from poses averaged over seconds, fit k_v and k_ω of THESIS (3.10) by least squares,
//! find the start-up dead-band M_min by bisection, read the butterfly points A and B off
//! the measured envelope, write the robot's parameter file and plot the fit.
//!
//! Two command spaces: [`Mode::Speed`] (wheel-speed targets in RPM, held by the on-robot PI:
//! the units the host drives with) and [`Mode::Duty`] (raw per-mille duties, open loop, as
//! THESIS calibrated its PWM-driven v2 robots).

mod cli;
mod fit;
mod params_file;
mod plot;

use std::collections::BTreeMap;
use std::time::Duration;

use puzzlebot_params::RobotKind;
use puzzlebot_protocol::{messages::RobotId, HostMsg};
use serde::Serialize;

use crate::drive::PoseSample;
use crate::link::FleetLink;
use crate::pose::PoseTable;

#[cfg(feature = "sim")]
pub(crate) use cli::{cli_folder, finish_cli};
pub use cli::{describe, run_cli};
pub use fit::{fit_butterfly, fit_gains};
pub use params_file::{apply, write_params};
pub use plot::plot_fit;

use fit::velocity_of;

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

/// Measured pairs grouped for reporting: (M_r, M_l) → (v, ω).
pub fn table(cal: &Calibration) -> BTreeMap<String, (f64, f64)> {
    cal.measurements
        .iter()
        .map(|m| (format!("({:.0}, {:.0})", m.m_r, m.m_l), (m.v, m.omega)))
        .collect()
}

#[cfg(test)]
mod tests;
