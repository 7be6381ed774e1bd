//! Receiving datagrams: discovery, session handshakes, telemetry ingestion, loss and
//! round-trip accounting, and rejection bookkeeping.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use puzzlebot_protocol::{
    messages::{Announce, RobotId},
    peek_header,
    session::HostReceived,
    Nonce, Rejection, RobotMsg, Stream, MAX_DATAGRAM,
};
use tokio::time::Instant;

use super::{Inner, LinkEvent, LinkEventKind, RobotLink, State};

/// Most reject events per robot and reason written to the event log (all are counted).
const MAX_REJECT_EVENTS: u64 = 5;

fn fresh_nonce() -> Nonce {
    let mut n = [0u8; 16];
    rand::fill(&mut n);
    n
}

fn note_rejection(
    inner: &Inner,
    st: &mut State,
    id: Option<RobotId>,
    why: Rejection,
    now: Instant,
) {
    let name = why.name();
    let count = match id.and_then(|i| st.robots.get_mut(&i)) {
        Some(r) => {
            let c = r.stats.rejections.entry(name).or_insert(0);
            *c += 1;
            *c
        }
        None => {
            let c = st.global_rejections.entry(name).or_insert(0);
            *c += 1;
            *c
        }
    };
    if count <= MAX_REJECT_EVENTS {
        tracing::debug!(robot = ?id, reason = name, "datagram rejected");
        st.events.push(LinkEvent {
            t: inner.t(now),
            robot: id,
            what: LinkEventKind::Rejected { reason: name },
        });
    }
}

/// Handle one datagram; returns a reply to send.
fn handle(
    inner: &Inner,
    frame: &[u8],
    src: SocketAddr,
    now: Instant,
) -> Option<(Vec<u8>, SocketAddr)> {
    let mut st = inner.lock();
    let header = match peek_header(frame) {
        Ok(h) => h,
        Err(why) => {
            note_rejection(inner, &mut st, None, why, now);
            return None;
        }
    };
    let id = header.robot_id;
    if let Some(allowed) = &inner.config.allowed {
        if !allowed.contains(&id) {
            note_rejection(inner, &mut st, None, Rejection::UnknownRobot, now);
            return None;
        }
    }
    let known = st.robots.contains_key(&id);
    if !known {
        if header.stream != Stream::Hello {
            // A robot we have no session with (e.g. after a host restart): it will stop
            // on its failsafe and announce again.
            note_rejection(inner, &mut st, None, Rejection::NoSession, now);
            return None;
        }
        st.robots.insert(id, RobotLink::new(id, &inner.key));
    }
    let t = inner.t(now);
    let mut out = [0u8; MAX_DATAGRAM];
    let (events, reply) = {
        let r = st.robots.get_mut(&id)?;
        let res = r.session.receive(frame, fresh_nonce, &mut out);
        let mut events = Vec::new();
        let reply = match res {
            Err(why) => {
                if known {
                    note_rejection(inner, &mut st, Some(id), why, now);
                } else {
                    // A forged or foreign announce never creates a robot entry.
                    st.robots.remove(&id);
                    note_rejection(inner, &mut st, None, why, now);
                }
                return None;
            }
            Ok(HostReceived::Announce {
                announce,
                welcome_len,
                new_session,
            }) => {
                let Announce {
                    kind,
                    firmware,
                    reset_reason,
                    ..
                } = announce;
                if r.kind.is_none() {
                    tracing::info!(robot = id, ?kind, %src, "robot discovered");
                    events.push(LinkEventKind::Discovered { kind });
                }
                r.kind = Some(kind);
                r.firmware = Some(firmware);
                r.addr = Some(src);
                r.last_rx = Some(now);
                r.stats.tx_frames += 1;
                if new_session {
                    r.stats.sessions += 1;
                    r.last_counter = None;
                    if reset_reason.is_fault() {
                        tracing::warn!(
                            robot = id,
                            reset = reset_reason.name(),
                            "robot announces after a fault reset"
                        );
                    }
                    tracing::info!(robot = id, reset = reset_reason.name(), "session offered");
                    events.push(LinkEventKind::SessionOffered);
                }
                Some((out[..welcome_len].to_vec(), src))
            }
            Ok(HostReceived::Message(h, msg)) => {
                r.addr = Some(src);
                r.last_rx = Some(now);
                r.stats.rx_frames += 1;
                if !r.online {
                    r.online = true;
                    tracing::info!(robot = id, "robot online");
                    events.push(LinkEventKind::Online);
                }
                // Loss from gaps in the robot's session counter (every session frame
                // uses it: telemetry, pongs, replies).
                match r.last_counter {
                    // Far below the last counter: a new session restarted at 0.
                    Some(last) if h.counter + 64 < last => {}
                    Some(last) if h.counter > last + 1 => r.stats.rx_lost += h.counter - last - 1,
                    // A late frame arrived after its gap was counted as lost.
                    Some(last) if h.counter < last => {
                        r.stats.rx_lost = r.stats.rx_lost.saturating_sub(1)
                    }
                    _ => {}
                }
                if r.last_counter
                    .is_none_or(|l| h.counter > l || h.counter + 64 < l)
                {
                    r.last_counter = Some(h.counter);
                }
                match msg {
                    RobotMsg::Telemetry(tm) => {
                        r.stats.telemetry += 1;
                        if let Some(&(_, sent)) = r
                            .sent_cmds
                            .iter()
                            .find(|(c, _)| *c == tm.last_command_counter)
                        {
                            r.stats.command_echo_ms =
                                Some(now.duration_since(sent).as_secs_f64() * 1e3);
                        }
                        r.telemetry = Some(tm);
                        r.telemetry_at = Some(now);
                    }
                    RobotMsg::Pong { host_time_us, .. } => {
                        r.stats.pongs += 1;
                        let sent = inner.epoch + Duration::from_micros(host_time_us);
                        if sent <= now {
                            let ms = now.duration_since(sent).as_secs_f64() * 1e3;
                            r.stats.rtt_ms = Some(ms);
                            r.stats.rtt_avg_ms = Some(match r.stats.rtt_avg_ms {
                                Some(a) => 0.8 * a + 0.2 * ms,
                                None => ms,
                            });
                        }
                    }
                    RobotMsg::ParamsReply { rejected } => {
                        if let Some(why) = rejected {
                            tracing::warn!(robot = id, ?why, "robot refused parameters");
                        }
                    }
                    RobotMsg::UpdateStatus(u) => r.update = Some(u),
                    RobotMsg::Announce(_) => {}
                }
                None
            }
        };
        (events, reply)
    };
    for what in events {
        st.events.push(LinkEvent {
            t,
            robot: Some(id),
            what,
        });
    }
    reply
}

pub(super) async fn recv_loop(inner: Arc<Inner>) {
    // One byte more than the largest datagram, so oversized input is seen as such.
    let mut buf = [0u8; MAX_DATAGRAM + 1];
    loop {
        let (n, src) = match inner.socket.recv_from(&mut buf).await {
            Ok(x) => x,
            Err(e) => {
                // ICMP port-unreachable from a robot that went away surfaces here on some
                // platforms; it is not fatal.
                tracing::trace!(error = %e, "recv error");
                tokio::time::sleep(Duration::from_millis(1)).await;
                continue;
            }
        };
        let now = Instant::now();
        if let Some((reply, to)) = handle(&inner, &buf[..n], src, now) {
            let _ = inner.socket.send_to(&reply, to).await;
        }
    }
}
