//! Per-robot link statistics, status snapshots and link events.

use std::collections::BTreeMap;
use std::net::SocketAddr;

use puzzlebot_protocol::messages::{RobotId, RobotKind, Telemetry};
use serde::Serialize;
use tokio::time::Instant;

use super::{Inner, RobotLink};

/// Link quality of one robot.
#[derive(Debug, Clone, Default, Serialize)]
pub struct LinkStats {
    /// Valid frames received.
    pub rx_frames: u64,
    /// Telemetry frames received.
    pub telemetry: u64,
    /// Robot frames missing (gaps in the robot's session counter).
    pub rx_lost: u64,
    /// Frames sent (welcomes, commands, pings).
    pub tx_frames: u64,
    /// Pings sent.
    pub pings: u64,
    /// Pongs received.
    pub pongs: u64,
    /// Last round-trip time (ms, ping/pong).
    pub rtt_ms: Option<f64>,
    /// Smoothed round-trip time (ms).
    pub rtt_avg_ms: Option<f64>,
    /// Age of the last command the robot reported applied, when its telemetry arrived (ms).
    pub command_echo_ms: Option<f64>,
    /// Sessions opened (announces answered with a fresh host nonce).
    pub sessions: u64,
    /// Times the robot was marked offline.
    pub offline_events: u64,
    /// Rejected frames by reason.
    pub rejections: BTreeMap<&'static str, u64>,
}

impl LinkStats {
    /// Fraction of robot → host frames lost (0…1).
    pub fn rx_loss(&self) -> f64 {
        let total = self.rx_frames + self.rx_lost;
        if total == 0 {
            0.0
        } else {
            self.rx_lost as f64 / total as f64
        }
    }

    /// Total rejections.
    pub fn rejected(&self) -> u64 {
        self.rejections.values().sum()
    }
}

/// What the host knows about one robot.
#[derive(Debug, Clone, Serialize)]
pub struct RobotStatus {
    /// Robot id.
    pub id: RobotId,
    /// Kind from its announce.
    pub kind: Option<RobotKind>,
    /// Firmware version from its announce.
    pub firmware: Option<(u8, u8, u8)>,
    /// Where its datagrams come from.
    pub addr: Option<SocketAddr>,
    /// Heard from within the offline threshold.
    pub online: bool,
    /// A session is proven.
    pub established: bool,
    /// Seconds since the last valid frame.
    pub silent_s: Option<f64>,
    /// Latest telemetry.
    pub telemetry: Option<Telemetry>,
    /// Host time of the latest telemetry (s).
    pub telemetry_t: Option<f64>,
    /// Link statistics.
    pub stats: LinkStats,
}

/// Something that happened on the link (for logs and the run folder).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinkEvent {
    /// Host time (s since the link started).
    pub t: f64,
    /// The robot, when known.
    pub robot: Option<RobotId>,
    /// What happened.
    pub what: LinkEventKind,
}

/// Kinds of [`LinkEvent`].
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum LinkEventKind {
    /// First announce of a robot.
    Discovered {
        /// Its kind.
        kind: RobotKind,
    },
    /// A new session was offered (fresh host nonce).
    SessionOffered,
    /// Back online after silence (or first valid session frame).
    Online,
    /// Silent for the offline threshold.
    Offline,
    /// A frame refused (first few per reason and robot are reported).
    Rejected {
        /// Reason name.
        reason: &'static str,
    },
}

pub(super) fn status_of(inner: &Inner, id: RobotId, r: &RobotLink, now: Instant) -> RobotStatus {
    RobotStatus {
        id,
        kind: r.kind,
        firmware: r.firmware.map(|f| (f.major, f.minor, f.patch)),
        addr: r.addr,
        online: r.online,
        established: r.session.is_established(),
        silent_s: r.last_rx.map(|t| now.duration_since(t).as_secs_f64()),
        telemetry: r.telemetry,
        telemetry_t: r.telemetry_at.map(|t| inner.t(t)),
        stats: r.stats.clone(),
    }
}
