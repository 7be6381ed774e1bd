//! The fleet link: one UDP socket, discovery from announces, one authenticated
//! [`HostSession`] per robot, commands streamed at the command rate, telemetry ingested,
//! per-robot link statistics, offline detection and recovery.
//!
//! Keys: each robot's key is derived from the fleet key ([`FleetKey::robot_key`]); neither
//! is ever logged. A robot that reboots announces with a fresh nonce and gets a new
//! session; a restarted host has no session at all, so the robots' failsafe stops them
//! until they announce again and are welcomed under fresh nonces.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::net::SocketAddr;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use puzzlebot_params::rates::Rates;
use puzzlebot_protocol::{
    messages::{Announce, FirmwareVersion, RobotId, RobotKind, Telemetry},
    peek_header,
    session::HostReceived,
    FleetKey, HostMsg, HostSession, Nonce, Rejection, RobotMsg, Stream, UpdateStatus, MAX_DATAGRAM,
};
use serde::Serialize;
use tokio::net::UdpSocket;
use tokio::task::JoinHandle;
use tokio::time::Instant;

/// Link settings.
#[derive(Debug, Clone)]
pub struct LinkConfig {
    /// Address to bind (robots send here).
    pub bind: SocketAddr,
    /// Rates and timeouts (command rate, offline threshold).
    pub rates: Rates,
    /// Robots allowed to open sessions; `None` accepts any id that authenticates.
    pub allowed: Option<BTreeSet<RobotId>>,
    /// Ping interval for round-trip time.
    pub ping_interval: Duration,
}

impl LinkConfig {
    /// Settings for `bind` with default rates, any robot, 2 Hz pings.
    pub fn new(bind: SocketAddr) -> Self {
        LinkConfig {
            bind,
            rates: Rates::default(),
            allowed: None,
            ping_interval: Duration::from_millis(500),
        }
    }
}

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

struct RobotLink {
    session: HostSession,
    kind: Option<RobotKind>,
    firmware: Option<FirmwareVersion>,
    addr: Option<SocketAddr>,
    online: bool,
    last_rx: Option<Instant>,
    telemetry: Option<Telemetry>,
    telemetry_at: Option<Instant>,
    last_counter: Option<u64>,
    command: HostMsg,
    last_cmd_tx: Option<Instant>,
    sent_cmds: VecDeque<(u64, Instant)>,
    next_ping: Option<Instant>,
    ping_seq: u32,
    stats: LinkStats,
    update: Option<UpdateStatus>,
}

impl RobotLink {
    fn new(id: RobotId, key: &FleetKey) -> Self {
        RobotLink {
            session: HostSession::new(id, key.robot_key(id)),
            kind: None,
            firmware: None,
            addr: None,
            online: false,
            last_rx: None,
            telemetry: None,
            telemetry_at: None,
            last_counter: None,
            command: HostMsg::Stop,
            last_cmd_tx: None,
            sent_cmds: VecDeque::new(),
            next_ping: None,
            ping_seq: 0,
            stats: LinkStats::default(),
            update: None,
        }
    }
}

struct State {
    robots: BTreeMap<RobotId, RobotLink>,
    /// Rejections that belong to no known robot.
    global_rejections: BTreeMap<&'static str, u64>,
    events: Vec<LinkEvent>,
}

struct Inner {
    socket: UdpSocket,
    key: FleetKey,
    config: LinkConfig,
    epoch: Instant,
    state: Mutex<State>,
}

impl Inner {
    fn lock(&self) -> MutexGuard<'_, State> {
        // A poisoned lock only means another task panicked mid-update; the state is
        // plain data and still usable.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn t(&self, at: Instant) -> f64 {
        at.duration_since(self.epoch).as_secs_f64()
    }
}

/// The running fleet link. Cloning shares it; dropping the last clone does not stop the
/// tasks: call [`FleetLink::shutdown`] (or [`FleetLink::abort`] to simulate a crash).
#[derive(Clone)]
pub struct FleetLink {
    inner: Arc<Inner>,
    tasks: Arc<Mutex<Vec<JoinHandle<()>>>>,
}

/// Most reject events per robot and reason written to the event log (all are counted).
const MAX_REJECT_EVENTS: u64 = 5;

impl FleetLink {
    /// Bind the socket and start the receive and streaming tasks.
    pub async fn start(key: FleetKey, config: LinkConfig) -> std::io::Result<FleetLink> {
        let socket = UdpSocket::bind(config.bind).await?;
        let inner = Arc::new(Inner {
            socket,
            key,
            config,
            epoch: Instant::now(),
            state: Mutex::new(State {
                robots: BTreeMap::new(),
                global_rejections: BTreeMap::new(),
                events: Vec::new(),
            }),
        });
        let rx = tokio::spawn(recv_loop(inner.clone()));
        let tx = tokio::spawn(stream_loop(inner.clone()));
        tracing::info!(addr = %inner.socket.local_addr()?, "fleet link listening");
        Ok(FleetLink {
            inner,
            tasks: Arc::new(Mutex::new(vec![rx, tx])),
        })
    }

    /// The bound address.
    pub fn local_addr(&self) -> std::io::Result<SocketAddr> {
        self.inner.socket.local_addr()
    }

    /// Seconds since the link started (the host clock of every record).
    pub fn now(&self) -> f64 {
        self.inner.t(Instant::now())
    }

    /// When the link started: the zero of [`FleetLink::now`]. A pose input stamps its
    /// poses from the same instant, so a pose's age is `now() - pose.t`.
    pub fn epoch(&self) -> Instant {
        self.inner.epoch
    }

    /// Rates in force.
    pub fn rates(&self) -> Rates {
        self.inner.config.rates
    }

    /// Set a robot's command and send it at once; it is repeated at the command rate
    /// while the robot is online. Unknown robots are ignored.
    pub async fn command(&self, id: RobotId, msg: HostMsg) {
        let frame = {
            let mut st = self.inner.lock();
            let Some(r) = st.robots.get_mut(&id) else {
                return;
            };
            r.command = msg;
            if !r.online {
                return;
            }
            seal_command(&self.inner, r, Instant::now())
        };
        if let Some((buf, n, addr)) = frame {
            let _ = self.inner.socket.send_to(&buf[..n], addr).await;
        }
    }

    /// Send a one-off message (e.g. parameters, emergency stop) without changing the
    /// streamed command. Returns false when the robot has no session or address.
    pub async fn send_once(&self, id: RobotId, msg: &HostMsg) -> bool {
        let frame = {
            let mut st = self.inner.lock();
            let Some(r) = st.robots.get_mut(&id) else {
                return false;
            };
            let Some(addr) = r.addr else { return false };
            let mut buf = [0u8; MAX_DATAGRAM];
            match r.session.send(msg, &mut buf) {
                Ok(n) => {
                    r.stats.tx_frames += 1;
                    Some((buf, n, addr))
                }
                Err(_) => None,
            }
        };
        match frame {
            Some((buf, n, addr)) => self.inner.socket.send_to(&buf[..n], addr).await.is_ok(),
            None => false,
        }
    }

    /// The latest over-the-air update report of robot `id`, taken (each report is seen once).
    pub fn take_update_status(&self, id: RobotId) -> Option<UpdateStatus> {
        self.inner
            .lock()
            .robots
            .get_mut(&id)
            .and_then(|r| r.update.take())
    }

    /// Command every known robot to stop (streamed), and send the stop at once.
    pub async fn stop_all(&self) {
        for id in self.robot_ids() {
            self.command(id, HostMsg::Stop).await;
        }
    }

    /// Ids of every robot that ever announced.
    pub fn robot_ids(&self) -> Vec<RobotId> {
        self.inner.lock().robots.keys().copied().collect()
    }

    /// Ids of robots online with a proven session.
    pub fn online(&self) -> Vec<RobotId> {
        self.inner
            .lock()
            .robots
            .iter()
            .filter(|(_, r)| r.online && r.session.is_established())
            .map(|(id, _)| *id)
            .collect()
    }

    /// Status of one robot.
    pub fn status(&self, id: RobotId) -> Option<RobotStatus> {
        let now = Instant::now();
        let st = self.inner.lock();
        st.robots
            .get(&id)
            .map(|r| status_of(&self.inner, id, r, now))
    }

    /// Status of every known robot.
    pub fn statuses(&self) -> Vec<RobotStatus> {
        let now = Instant::now();
        let st = self.inner.lock();
        st.robots
            .iter()
            .map(|(id, r)| status_of(&self.inner, *id, r, now))
            .collect()
    }

    /// Rejections that could not be attributed to a known robot, by reason.
    pub fn global_rejections(&self) -> BTreeMap<&'static str, u64> {
        self.inner.lock().global_rejections.clone()
    }

    /// Take the events since the last call.
    pub fn drain_events(&self) -> Vec<LinkEvent> {
        std::mem::take(&mut self.inner.lock().events)
    }

    /// Wait until `n` robots are online with proven sessions, or `timeout` passes.
    pub async fn wait_for_robots(&self, n: usize, timeout: Duration) -> bool {
        let end = Instant::now() + timeout;
        loop {
            if self.online().len() >= n {
                return true;
            }
            if Instant::now() >= end {
                return false;
            }
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    }

    /// Stop every robot, give the datagrams a moment, then end the tasks.
    pub async fn shutdown(&self) {
        self.stop_all().await;
        tokio::time::sleep(Duration::from_millis(20)).await;
        self.abort();
    }

    /// End the tasks at once without telling the robots (a host crash, for tests).
    pub fn abort(&self) {
        let tasks = std::mem::take(&mut *self.tasks.lock().unwrap_or_else(|e| e.into_inner()));
        for t in tasks {
            t.abort();
        }
    }
}

fn status_of(inner: &Inner, id: RobotId, r: &RobotLink, now: Instant) -> RobotStatus {
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

type Frame = ([u8; MAX_DATAGRAM], usize, SocketAddr);

fn seal_command(_inner: &Inner, r: &mut RobotLink, now: Instant) -> Option<Frame> {
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

async fn recv_loop(inner: Arc<Inner>) {
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

async fn stream_loop(inner: Arc<Inner>) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use puzzlebot_protocol::{messages::Telemetry, RobotSession};

    fn telemetry() -> RobotMsg {
        RobotMsg::Telemetry(Telemetry {
            uptime_ms: 1,
            measured_rpm: [0.0; 2],
            target_rpm: [0.0; 2],
            duty: [0; 2],
            encoder_counts: [0; 2],
            battery_mv: 3700,
            rssi_dbm: -40,
            flags: 0,
            last_command_counter: 0,
        })
    }

    #[tokio::test]
    async fn sessions_open_and_forged_garbage_and_replays_are_counted() {
        let key = FleetKey([1; 32]);
        let link = FleetLink::start(
            key.clone(),
            LinkConfig::new("127.0.0.1:0".parse().expect("addr")),
        )
        .await
        .expect("link");
        let to = link.local_addr().expect("addr");
        let sock = UdpSocket::bind("127.0.0.1:0").await.expect("bind");
        let fw = FirmwareVersion {
            major: 0,
            minor: 1,
            patch: 0,
        };
        let mut buf = [0u8; MAX_DATAGRAM];
        // A robot provisioned with another fleet's key.
        let mut forged = RobotSession::new(3, FleetKey([2; 32]).robot_key(3), [9; 16]);
        let n = forged
            .announce(RobotKind::NonPilot, fw, &mut buf)
            .expect("seal");
        sock.send_to(&buf[..n], to).await.expect("send");
        sock.send_to(b"xx", to).await.expect("send");
        // A genuine robot: announce, welcome, telemetry, then a replay of that telemetry.
        let mut good = RobotSession::new(4, key.robot_key(4), [7; 16]);
        let n = good.announce(RobotKind::Pilot, fw, &mut buf).expect("seal");
        sock.send_to(&buf[..n], to).await.expect("send");
        let mut rx = [0u8; 256];
        let (n, _) = tokio::time::timeout(Duration::from_secs(2), sock.recv_from(&mut rx))
            .await
            .expect("welcome in time")
            .expect("recv");
        good.receive(&rx[..n]).expect("welcome verifies");
        let n = good.send(&telemetry(), &mut buf).expect("seal");
        sock.send_to(&buf[..n], to).await.expect("send");
        sock.send_to(&buf[..n], to).await.expect("send");
        let mut ok = false;
        for _ in 0..200 {
            tokio::time::sleep(Duration::from_millis(5)).await;
            let st = link.status(4);
            if st
                .as_ref()
                .is_some_and(|s| s.online && s.stats.rejections.get("replay") == Some(&1))
            {
                ok = true;
                break;
            }
        }
        assert!(ok, "{:?}", link.status(4));
        let st = link.status(4).expect("known");
        assert_eq!(st.kind, Some(RobotKind::Pilot));
        assert!(st.established && st.telemetry.is_some());
        assert_eq!(st.stats.sessions, 1);
        let global = link.global_rejections();
        assert_eq!(global.get("bad_tag"), Some(&1), "{global:?}");
        assert_eq!(global.get("truncated"), Some(&1), "{global:?}");
        assert!(
            link.status(3).is_none(),
            "a forged announce creates no robot"
        );
        // The link streams the current command (Stop) to the online robot.
        let (n, _) = tokio::time::timeout(Duration::from_secs(2), sock.recv_from(&mut rx))
            .await
            .expect("command in time")
            .expect("recv");
        let (_, msg) = good.receive(&rx[..n]).expect("command verifies");
        assert!(
            matches!(msg, HostMsg::Stop | HostMsg::Ping { .. }),
            "{msg:?}"
        );
        link.abort();
    }
}
