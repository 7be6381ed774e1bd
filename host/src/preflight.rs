//! Pre-flight check before any run on a fleet: motion-capture rate and pose age, every
//! listed robot tracked and not swapped, link round-trip time and loss, battery, and what
//! `puzzlebot fleet check` checks (online with a session, announced kind, firmware versions
//! equal; [`crate::fleet_setup::check_report`]). A table, then the reasons to refuse.

use std::collections::BTreeMap;
use std::time::Duration;

use puzzlebot_mpc::Limits;
use puzzlebot_params::FleetParams;
use puzzlebot_protocol::messages::RobotId;

use crate::config::RobotEntry;
use crate::drive::PoseSample;
use crate::link::{FleetLink, RobotStatus};
use crate::pose::PoseTable;

/// Limits of the pre-flight check.
#[derive(Debug, Clone, PartialEq)]
pub struct PreflightLimits {
    /// Motion-capture frames per second accepted (Hz, inclusive).
    pub mocap_hz: (f64, f64),
    /// Oldest pose accepted at the end of the check (s).
    pub max_pose_age_s: f64,
    /// Longest mean link round-trip time accepted (ms).
    pub max_rtt_ms: f64,
    /// Largest share of robot datagrams lost accepted (0–1).
    pub max_loss: f64,
    /// Lowest battery accepted (mV); default: the firmware's low-battery threshold.
    pub battery_floor_mv: u16,
    /// How long poses are watched (s).
    pub window_s: f64,
    /// A pose moving faster than this many times the robot's top speed (plus
    /// [`PreflightLimits::jump_slack_m`]) is a jump: another body or a swapped label.
    pub jump_speed_factor: f64,
    /// Distance always allowed between two poses (m): motion-capture noise.
    pub jump_slack_m: f64,
}

impl PreflightLimits {
    /// The default limits for a fleet of `params`: 80–120 Hz motion capture, poses at most
    /// 50 ms old, RTT at most 50 ms, at most 5 % loss, the firmware's low-battery floor.
    pub fn for_fleet(params: &FleetParams) -> Self {
        PreflightLimits {
            mocap_hz: (80.0, 120.0),
            max_pose_age_s: 0.05,
            max_rtt_ms: 50.0,
            max_loss: 0.05,
            battery_floor_mv: params.non_pilot.firmware.low_battery_mv,
            window_s: 1.0,
            jump_speed_factor: 3.0,
            jump_slack_m: 0.01,
        }
    }
}

/// What the pose stream did during the check's window.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PoseWindow {
    /// Frames received over the window.
    pub frames: u64,
    /// Length of the window (s).
    pub seconds: f64,
    /// Each robot's last tracked pose and its age at the end (s).
    pub last: BTreeMap<RobotId, (PoseSample, f64)>,
    /// Pose jumps seen per robot (each one dropped from the track).
    pub jumps: BTreeMap<RobotId, u64>,
}

impl PoseWindow {
    /// Frames per second.
    pub fn rate_hz(&self) -> f64 {
        if self.seconds > 0.0 {
            self.frames as f64 / self.seconds
        } else {
            0.0
        }
    }

    /// Follow one pose of robot `id` from the previous one kept: a pose farther than
    /// `max_speed` × elapsed + `slack` (m) is a jump, counted and not kept.
    pub fn follow(&mut self, id: RobotId, p: PoseSample, age: f64, max_speed: f64, slack: f64) {
        if let Some((q, _)) = self.last.get(&id) {
            if p.t <= q.t {
                self.last.insert(id, (*q, age));
                return;
            }
            let moved = (p.x - q.x).hypot(p.y - q.y);
            if moved > max_speed * (p.t - q.t) + slack {
                *self.jumps.entry(id).or_insert(0) += 1;
                return;
            }
        }
        self.last.insert(id, (p, age));
    }
}

/// Watch the pose table for `limits.window_s`: frame rate, each listed robot's track and
/// its jumps (a robot's top speed from `params`).
pub async fn watch_poses(
    table: &PoseTable,
    listed: &[RobotEntry],
    params: &FleetParams,
    limits: &PreflightLimits,
) -> PoseWindow {
    let mut w = PoseWindow::default();
    let start = tokio::time::Instant::now();
    let frames0 = table.stats().datagrams;
    let window = Duration::from_secs_f64(limits.window_s.max(0.05));
    let mut iv = tokio::time::interval(Duration::from_millis(5));
    while start.elapsed() < window {
        iv.tick().await;
        for r in listed {
            let v_max = Limits::from_drive(&params.robot(r.kind).drive).v_max;
            if let (Some(p), Some(age)) = (table.latest_tracked(r.id), table.age(r.id)) {
                w.follow(
                    r.id,
                    p,
                    age.as_secs_f64(),
                    v_max * limits.jump_speed_factor,
                    limits.jump_slack_m,
                );
            }
        }
    }
    w.frames = table.stats().datagrams.saturating_sub(frames0);
    w.seconds = start.elapsed().as_secs_f64();
    w
}

/// The pre-flight table and the reasons to refuse a run (none: ready).
pub fn evaluate(
    listed: &[RobotEntry],
    statuses: &[RobotStatus],
    poses: &PoseWindow,
    limits: &PreflightLimits,
) -> (String, Vec<String>) {
    let (mut table, mut problems) = crate::fleet_setup::check_report(listed, statuses);
    let rate = poses.rate_hz();
    let (lo, hi) = limits.mocap_hz;
    table.push_str(&format!(
        "\nmotion capture: {rate:.1} Hz (accepted {lo:.0}-{hi:.0} Hz)\n"
    ));
    if !(lo..=hi).contains(&rate) {
        problems.push(format!(
            "motion capture at {rate:.1} Hz, outside {lo:.0}-{hi:.0} Hz"
        ));
    }
    table.push_str(&format!(
        "{:>5}  {:<8} {:>9} {:>6} {:>9} {:>7} {:>9}\n",
        "robot", "tracked", "pose age", "jumps", "RTT", "loss", "battery"
    ));
    for r in listed {
        let s = statuses.iter().find(|s| s.id == r.id);
        let last = poses.last.get(&r.id);
        let jumps = poses.jumps.get(&r.id).copied().unwrap_or(0);
        let rtt = s.and_then(|s| s.stats.rtt_avg_ms);
        let loss = s.map(|s| s.stats.rx_loss());
        let battery = s.and_then(|s| s.telemetry).map(|t| t.battery_mv);
        table.push_str(&format!(
            "{:>5}  {:<8} {:>9} {:>6} {:>9} {:>7} {:>9}\n",
            r.id,
            if last.is_some() { "yes" } else { "no" },
            last.map_or("-".into(), |(_, a)| format!("{:.0} ms", a * 1e3)),
            jumps,
            rtt.map_or("-".into(), |x| format!("{x:.1} ms")),
            loss.map_or("-".into(), |x| format!("{:.1} %", 100.0 * x)),
            battery.map_or("-".into(), |b| format!("{:.2} V", f64::from(b) / 1e3)),
        ));
        match last {
            None => problems.push(format!("robot {}: not tracked by motion capture", r.id)),
            Some((_, age)) if *age > limits.max_pose_age_s => problems.push(format!(
                "robot {}: pose {:.0} ms old (at most {:.0} ms)",
                r.id,
                age * 1e3,
                limits.max_pose_age_s * 1e3
            )),
            Some(_) => {}
        }
        if jumps > 0 {
            problems.push(format!(
                "robot {}: {jumps} pose jumps faster than it can drive (swapped or mislabelled body?)",
                r.id
            ));
        }
        if let Some(x) = rtt.filter(|x| *x > limits.max_rtt_ms) {
            problems.push(format!(
                "robot {}: link RTT {x:.1} ms (at most {:.0} ms)",
                r.id, limits.max_rtt_ms
            ));
        }
        if let Some(x) = loss.filter(|x| *x > limits.max_loss) {
            problems.push(format!(
                "robot {}: link loss {:.1} % (at most {:.1} %)",
                r.id,
                100.0 * x,
                100.0 * limits.max_loss
            ));
        }
        if s.is_some_and(|s| s.online) {
            match battery {
                None => problems.push(format!("robot {}: no battery reading", r.id)),
                Some(b) if b < limits.battery_floor_mv => problems.push(format!(
                    "robot {}: battery {:.2} V below {:.2} V",
                    r.id,
                    f64::from(b) / 1e3,
                    f64::from(limits.battery_floor_mv) / 1e3
                )),
                Some(_) => {}
            }
        }
    }
    (table, problems)
}

/// Run the whole check on a started host: wait up to `wait` for the listed robots, watch
/// the poses, evaluate. Returns the table and the reasons to refuse.
pub async fn check(
    link: &FleetLink,
    poses: &PoseTable,
    listed: &[RobotEntry],
    params: &FleetParams,
    limits: &PreflightLimits,
    wait: Duration,
) -> (String, Vec<String>) {
    let _ = link.wait_for_robots(listed.len().max(1), wait).await;
    let window = watch_poses(poses, listed, params, limits).await;
    evaluate(listed, &link.statuses(), &window, limits)
}

/// Refuse a run unless the check passed or `force` is set; a forced start is logged with
/// its reasons.
pub fn decide(problems: &[String], force: bool) -> anyhow::Result<()> {
    if problems.is_empty() {
        return Ok(());
    }
    if force {
        tracing::warn!(
            reasons = %problems.join("; "),
            "pre-flight check failed; starting anyway (--force)"
        );
        return Ok(());
    }
    anyhow::bail!(
        "pre-flight check failed (--force starts anyway): {}",
        problems.join("; ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_params::RobotKind;

    fn sample(t: f64, x: f64) -> PoseSample {
        PoseSample {
            t,
            x,
            y: 0.0,
            theta: 0.0,
        }
    }

    fn listed() -> Vec<RobotEntry> {
        vec![RobotEntry {
            id: 1,
            kind: RobotKind::NonPilot,
            params: None,
        }]
    }

    #[test]
    fn a_pose_jumping_faster_than_the_robot_drives_is_dropped_and_counted() {
        let mut w = PoseWindow::default();
        w.follow(1, sample(0.00, 0.0), 0.0, 0.5, 0.01);
        w.follow(1, sample(0.01, 0.004), 0.0, 0.5, 0.01);
        // Another body's pose 0.3 m away 10 ms later: dropped, the track stays.
        w.follow(1, sample(0.02, 0.3), 0.0, 0.5, 0.01);
        w.follow(1, sample(0.03, 0.008), 0.0, 0.5, 0.01);
        assert_eq!(w.jumps[&1], 1);
        assert_eq!(w.last[&1].0.x, 0.008);
    }

    #[test]
    fn an_untracked_robot_and_a_slow_mocap_refuse_the_run_with_reasons() {
        let p = FleetParams::default();
        let limits = PreflightLimits::for_fleet(&p);
        let w = PoseWindow {
            frames: 40,
            seconds: 1.0,
            ..PoseWindow::default()
        };
        let (table, problems) = evaluate(&listed(), &[], &w, &limits);
        assert!(table.contains("motion capture: 40.0 Hz"), "{table}");
        assert!(
            problems
                .iter()
                .any(|p| p.contains("40.0 Hz, outside 80-120 Hz")),
            "{problems:?}"
        );
        assert!(
            problems
                .iter()
                .any(|p| p == "robot 1: not tracked by motion capture"),
            "{problems:?}"
        );
        let err = decide(&problems, false).unwrap_err().to_string();
        assert!(err.starts_with("pre-flight check failed"), "{err}");
        assert!(decide(&problems, true).is_ok(), "--force overrides");
    }

    #[test]
    fn slow_or_lossy_links_low_batteries_swaps_and_mixed_firmware_are_reasons() {
        use crate::link::{LinkStats, RobotStatus};
        use puzzlebot_protocol::messages::Telemetry;
        let limits = PreflightLimits::for_fleet(&FleetParams::default());
        let listed = vec![
            RobotEntry {
                id: 1,
                kind: RobotKind::Pilot,
                params: None,
            },
            RobotEntry {
                id: 2,
                kind: RobotKind::NonPilot,
                params: None,
            },
        ];
        let telemetry = |battery_mv| Telemetry {
            uptime_ms: 1000,
            measured_rpm: [0.0; 2],
            target_rpm: [0.0; 2],
            duty: [0; 2],
            encoder_counts: [0; 2],
            battery_mv,
            rssi_dbm: -50,
            flags: 0,
            last_command_counter: 0,
        };
        let status = |id, kind, firmware, rtt, lost, battery: Option<u16>| RobotStatus {
            id,
            kind: Some(kind),
            firmware: Some(firmware),
            addr: None,
            online: true,
            established: true,
            silent_s: Some(0.0),
            telemetry: battery.map(telemetry),
            telemetry_t: None,
            stats: LinkStats {
                rx_frames: 90,
                rx_lost: lost,
                rtt_avg_ms: Some(rtt),
                ..LinkStats::default()
            },
        };
        let mut w = PoseWindow {
            frames: 100,
            seconds: 1.0,
            ..PoseWindow::default()
        };
        w.last.insert(1, (sample(1.0, 0.0), 0.01));
        w.last.insert(2, (sample(1.0, 0.2), 0.01));
        let good = [
            status(1, RobotKind::Pilot, (0, 3, 0), 4.0, 0, Some(3900)),
            status(2, RobotKind::NonPilot, (0, 3, 0), 5.0, 0, Some(3900)),
        ];
        let (table, problems) = evaluate(&listed, &good, &w, &limits);
        assert!(problems.is_empty(), "{problems:?}\n{table}");
        assert!(table.contains("3.90 V"), "{table}");
        w.jumps.insert(2, 3);
        let bad = [
            status(1, RobotKind::Pilot, (0, 3, 0), 80.0, 10, Some(3300)),
            status(2, RobotKind::NonPilot, (0, 4, 0), 5.0, 0, None),
        ];
        let (_, problems) = evaluate(&listed, &bad, &w, &limits);
        for want in [
            "firmware versions differ: 0.3.0, 0.4.0",
            "robot 1: link RTT 80.0 ms (at most 50 ms)",
            "robot 1: link loss 10.0 % (at most 5.0 %)",
            "robot 1: battery 3.30 V below 3.40 V",
            "robot 2: 3 pose jumps faster than it can drive (swapped or mislabelled body?)",
            "robot 2: no battery reading",
        ] {
            assert!(problems.iter().any(|p| p == want), "{want}: {problems:?}");
        }
    }

    #[test]
    fn an_old_pose_is_a_reason_and_a_fresh_one_at_the_mocap_rate_is_not() {
        let limits = PreflightLimits::for_fleet(&FleetParams::default());
        let mut w = PoseWindow {
            frames: 100,
            seconds: 1.0,
            ..PoseWindow::default()
        };
        w.last.insert(1, (sample(1.0, 0.0), 0.2));
        let (_, problems) = evaluate(&listed(), &[], &w, &limits);
        assert!(
            problems
                .iter()
                .any(|p| p == "robot 1: pose 200 ms old (at most 50 ms)"),
            "{problems:?}"
        );
        w.last.insert(1, (sample(1.0, 0.0), 0.01));
        let (_, problems) = evaluate(&listed(), &[], &w, &limits);
        assert!(
            !problems
                .iter()
                .any(|p| p.contains("pose") || p.contains("Hz")),
            "{problems:?}"
        );
    }
}
