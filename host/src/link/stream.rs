//! Streaming to robots: the latest command at the command rate, pings for round-trip
//! time, and offline detection.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use puzzlebot_protocol::{peek_header, HostMsg, MAX_DATAGRAM};
use tokio::time::Instant;

use super::{Inner, LinkEvent, LinkEventKind, RobotLink};

pub(super) type Frame = ([u8; MAX_DATAGRAM], usize, SocketAddr);

pub(super) fn seal_command(_inner: &Inner, r: &mut RobotLink, now: Instant) -> Option<Frame> {
    let addr = r.addr?;
    let mut buf = [0u8; MAX_DATAGRAM];
    let n = r.session.send(&r.command, &mut buf).ok()?;
    if let Ok(h) = peek_header(&buf[..n]) {
        r.sent_cmds.push_back((h.counter, now));
        while r.sent_cmds.len() > 64 {
            r.sent_cmds.pop_front();
        }
    }
    r.last_cmd_tx = Some(now);
    r.stats.tx_frames += 1;
    Some((buf, n, addr))
}

pub(super) async fn stream_loop(inner: Arc<Inner>) {
    let hz = f64::from(inner.config.rates.command_hz).clamp(1.0, 1000.0);
    let period = Duration::from_secs_f64(1.0 / hz);
    let offline_after = Duration::from_millis(u64::from(inner.config.rates.offline_after_ms));
    // Check offline status four times per command period, so detection is well inside the limit.
    let check = period / 4;
    let mut tick = tokio::time::interval(check);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    // Declared one check early, so a robot is always marked offline by the threshold.
    let offline_after = offline_after.saturating_sub(check);
    loop {
        tick.tick().await;
        let now = Instant::now();
        let mut frames: Vec<Frame> = Vec::new();
        {
            let mut st = inner.lock();
            let mut events = Vec::new();
            for (id, r) in st.robots.iter_mut() {
                let silent = r
                    .last_rx
                    .is_none_or(|t| now.duration_since(t) >= offline_after);
                if r.online && silent {
                    r.online = false;
                    r.command = HostMsg::Stop;
                    r.stats.offline_events += 1;
                    tracing::warn!(robot = id, "robot offline");
                    events.push(LinkEvent {
                        t: inner.t(now),
                        robot: Some(*id),
                        what: LinkEventKind::Offline,
                    });
                }
                if !r.online || !r.session.is_established() {
                    continue;
                }
                // Stream the latest command unless the controller just sent it.
                let due = r
                    .last_cmd_tx
                    .is_none_or(|t| now.duration_since(t) >= period.mul_f64(0.9));
                if due {
                    if let Some(f) = seal_command(&inner, r, now) {
                        frames.push(f);
                    }
                }
                if r.next_ping.is_none_or(|t| now >= t) {
                    r.next_ping = Some(now + inner.config.ping_interval);
                    r.ping_seq = r.ping_seq.wrapping_add(1);
                    let ping = HostMsg::Ping {
                        seq: r.ping_seq,
                        host_time_us: now.duration_since(inner.epoch).as_micros() as u64,
                    };
                    let mut buf = [0u8; MAX_DATAGRAM];
                    if let (Ok(n), Some(addr)) = (r.session.send(&ping, &mut buf), r.addr) {
                        r.stats.pings += 1;
                        r.stats.tx_frames += 1;
                        frames.push((buf, n, addr));
                    }
                }
            }
            st.events.extend(events);
        }
        for (buf, n, addr) in frames {
            let _ = inner.socket.send_to(&buf[..n], addr).await;
        }
    }
}
