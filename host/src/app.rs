//! The jobs behind the `puzzlebot` subcommands that drive a fleet config's robots, as library
//! functions (the CLI parses arguments and prints; tests call these directly). The tracking
//! demo on a simulated fleet is [`crate::simulated::tracking`].

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::Duration;

use puzzlebot_params::RobotKind;

use crate::config::{Fleet, PoseSourceKind};
use crate::control::{ControlLoop, Path as RefPath, RunSummary, Trajectory, TrajectoryFollower};
use crate::link::{FleetLink, LinkConfig, RobotStatus};
use crate::pose::{NatNetDecoder, Pbp1Decoder, PoseInput};
use crate::report::RunFolder;

/// What a finished run left behind.
#[derive(Debug, Clone)]
pub struct RunReport {
    /// The run folder.
    pub folder: PathBuf,
    /// Files written (plots, summary).
    pub files: Vec<PathBuf>,
    /// The loop's summary.
    pub summary: RunSummary,
}

/// Finish a run folder: its files and `summary.json`.
pub(crate) fn finish_folder(
    mut folder: RunFolder,
    summary: RunSummary,
) -> anyhow::Result<RunReport> {
    let mut files = folder.finish()?;
    files.push(folder.write_json("summary.json", &summary)?);
    Ok(RunReport {
        folder: folder.dir().to_path_buf(),
        files,
        summary,
    })
}

/// A progress bar of `len` steps (tenths of a second).
pub fn progress_bar(len: f64, what: &str) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(len.max(1.0) as u64);
    pb.set_style(
        indicatif::ProgressStyle::with_template("{msg:>10} [{bar:40}] {percent:>3}% {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

/// Progress of a long job of `len` steps on stderr: a bar on a terminal, one line per tenth
/// of the job when piped or logged (where a bar does not show), nothing when `show` is off.
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    what: String,
    len: u64,
    done: std::sync::atomic::AtomicU64,
    start: std::time::Instant,
    show: bool,
}

impl Progress {
    /// A job of `len` steps of `what` (`"series"`, `"cases"`).
    pub fn new(len: usize, what: &str, show: bool) -> Progress {
        use std::io::IsTerminal;
        let bar = (show && std::io::stderr().is_terminal()).then(|| progress_bar(len as f64, what));
        Progress {
            bar,
            what: what.to_string(),
            len: len as u64,
            done: std::sync::atomic::AtomicU64::new(0),
            start: std::time::Instant::now(),
            show,
        }
    }

    /// One step done.
    pub fn inc(&self) {
        let n = self.done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if let Some(b) = &self.bar {
            b.inc(1);
        } else if self.show && (n.is_multiple_of((self.len / 10).max(1)) || n == self.len) {
            eprintln!(
                "{} {n}/{} after {:.0} s",
                self.what,
                self.len,
                self.start.elapsed().as_secs_f64()
            );
        }
    }

    /// The job is over: clear the bar.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// Start the link and pose input a fleet config describes.
pub async fn start_host(fleet: &Fleet) -> anyhow::Result<(FleetLink, PoseInput)> {
    let c = &fleet.config;
    let mut cfg = LinkConfig::new(c.link.bind);
    cfg.rates = c.params.rates;
    if !c.link.discover_unlisted {
        cfg.allowed = Some(c.robots.iter().map(|r| r.id).collect::<BTreeSet<_>>());
    }
    let link = FleetLink::start(fleet.key.clone(), cfg).await?;
    // One clock: pose times count from the link's epoch, as the control loop's do.
    let epoch = link.epoch();
    let poses = match c.pose.source {
        PoseSourceKind::Pbp1 => PoseInput::start(c.pose.bind, Pbp1Decoder, epoch).await?,
        PoseSourceKind::Natnet => {
            let d = NatNetDecoder::new(&c.pose.natnet_version, c.pose.up_axis).map_err(|e| {
                anyhow::anyhow!("{}: pose.natnet_version: {e}", fleet.path.display())
            })?;
            PoseInput::start(c.pose.bind, d, epoch).await?
        }
    };
    Ok((link, poses))
}

/// Behaviour of `puzzlebot run`: each robot follows a path from the pose it has at the start.
#[derive(Debug, Clone, Copy)]
pub enum Behaviour {
    /// Straight ahead for `length` m.
    Line {
        /// Length (m).
        length: f64,
    },
    /// A full circle of `radius` m to the left.
    Circle {
        /// Radius (m).
        radius: f64,
    },
}

/// Run a behaviour against the robots of a fleet config (real or simulated elsewhere), after
/// the pre-flight check ([`crate::preflight`]; `force` starts despite it, logged).
pub async fn run_fleet(
    fleet: &Fleet,
    behaviour: Behaviour,
    speed: f64,
    wait: Duration,
    runs_dir: &Path,
    force: bool,
) -> anyhow::Result<RunReport> {
    let (link, poses) = start_host(fleet).await?;
    let params = &fleet.config.params;
    let limits = crate::preflight::PreflightLimits::for_fleet(params);
    let listed = &fleet.config.robots;
    let (table, problems) =
        crate::preflight::check(&link, &poses.table, listed, params, &limits, wait).await;
    eprint!("{table}");
    if let Err(e) = crate::preflight::decide(&problems, force) {
        link.shutdown().await;
        return Err(e);
    }
    let stale = Duration::from_millis(u64::from(fleet.config.params.rates.pose_stale_after_ms));
    let mut plans = BTreeMap::new();
    for id in link.online() {
        let Some(p) = poses.table.fresh(id, stale.max(Duration::from_millis(500))) else {
            tracing::warn!(robot = id, "no pose: robot stays still");
            continue;
        };
        let pi = std::f64::consts::PI;
        let path = match behaviour {
            Behaviour::Line { length } => RefPath::Line {
                start: [p.x, p.y],
                heading: p.theta,
                length,
            },
            Behaviour::Circle { radius } => RefPath::Circle {
                center: [p.x - radius * p.theta.sin(), p.y + radius * p.theta.cos()],
                radius,
                phase: p.theta - pi / 2.0,
                ccw: true,
            },
        };
        plans.insert(
            id,
            Trajectory {
                path,
                speed,
                accel: 0.1,
            },
        );
    }
    if plans.is_empty() {
        link.shutdown().await;
        anyhow::bail!("no robot online with a pose: nothing to drive");
    }
    let mut ctl = TrajectoryFollower::new(plans);
    let f2 = fleet.clone();
    let mut lp = ControlLoop::new(link.clone(), poses.table.clone(), move |id, kind| {
        f2.params_for(id, kind)
    });
    let mut folder = RunFolder::create(runs_dir, &fleet.config.name)?;
    let pb = progress_bar((ctl.duration() + ctl.settle) * 10.0, "driving");
    let summary = lp.run(&mut ctl, Some(&mut folder), Some(&pb)).await;
    pb.finish_and_clear();
    link.shutdown().await;
    finish_folder(folder, summary)
}

/// One line per robot for `puzzlebot status` and the end of a run.
pub fn status_table(statuses: &[RobotStatus]) -> String {
    let mut s = format!(
        "{:>5}  {:<9} {:<8} {:>8} {:>8} {:>7} {:>6}  {}\n",
        "robot", "kind", "link", "battery", "RTT", "loss", "rej", "state"
    );
    for r in statuses {
        let kind = match r.kind {
            Some(RobotKind::Pilot) => "pilot",
            Some(RobotKind::NonPilot) => "non-pilot",
            None => "?",
        };
        let link = if r.online && r.established {
            "online"
        } else if r.online {
            "pending"
        } else {
            "offline"
        };
        let battery = r
            .telemetry
            .map(|t| format!("{:.2} V", f64::from(t.battery_mv) / 1000.0))
            .unwrap_or_else(|| "-".into());
        let rtt = r
            .stats
            .rtt_avg_ms
            .map(|x| format!("{x:.1} ms"))
            .unwrap_or_else(|| "-".into());
        let state = match r.telemetry {
            None => "-".to_string(),
            Some(t) => {
                use puzzlebot_protocol::messages::flags;
                let mut parts = Vec::new();
                for (bit, name) in [
                    (flags::ESTOP, "e-stop"),
                    (flags::FAILSAFE, "failsafe"),
                    (flags::RAW_DUTY, "raw-duty"),
                    (flags::LOW_BATTERY, "low-battery"),
                    (flags::ENCODER_ERROR, "encoder-error"),
                    (flags::SATURATED, "saturated"),
                    (flags::UNPROVISIONED, "unprovisioned"),
                ] {
                    if t.flags & bit != 0 {
                        parts.push(name);
                    }
                }
                if parts.is_empty() {
                    if t.target_rpm.iter().any(|x| *x != 0.0) {
                        "driving".into()
                    } else {
                        "idle".into()
                    }
                } else {
                    parts.join(",")
                }
            }
        };
        s.push_str(&format!(
            "{:>5}  {:<9} {:<8} {:>8} {:>8} {:>6.1}% {:>6}  {}\n",
            r.id,
            kind,
            link,
            battery,
            rtt,
            100.0 * r.stats.rx_loss(),
            r.stats.rejected(),
            state
        ));
    }
    s
}

/// Summary lines of a run report.
pub fn describe(report: &RunReport) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "{} ticks in {:.1} s ({}).\n",
        report.summary.ticks, report.summary.duration, report.summary.controller
    ));
    s.push_str("robot  mean error  max error  rx loss  RTT\n");
    for (id, t) in &report.summary.tracking {
        let l = report.summary.link.get(id);
        s.push_str(&format!(
            "{:>5}  {:>7.2} mm  {:>6.2} mm  {:>6.1}%  {}\n",
            id,
            t.mean_error * 1e3,
            t.max_error * 1e3,
            l.map(|l| 100.0 * l.rx_loss()).unwrap_or(0.0),
            l.and_then(|l| l.rtt_avg_ms)
                .map(|x| format!("{x:.2} ms"))
                .unwrap_or_else(|| "-".into()),
        ));
    }
    s.push_str(&format!(
        "mean tracking error {:.2} mm\nrun folder: {}\n",
        report.summary.mean_tracking_error() * 1e3,
        report.folder.display()
    ));
    for f in &report.files {
        s.push_str(&format!("  {}\n", f.display()));
    }
    s
}
