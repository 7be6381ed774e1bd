//! The fleet link: one UDP socket, discovery from announces, one authenticated
//! [`HostSession`] per robot, commands streamed at the command rate, telemetry ingested,
//! per-robot link statistics, offline detection and recovery.
//!
//! Keys: each robot's key is derived from the fleet key ([`FleetKey::robot_key`]); neither
//! is ever logged. A robot that reboots announces with a fresh nonce and gets a new
//! session; a restarted host has no session at all, so the robots' failsafe stops them
//! until they announce again and are welcomed under fresh nonces.

mod receive;
mod status;
mod stream;

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::net::SocketAddr;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use puzzlebot_params::rates::Rates;
use puzzlebot_protocol::{
    messages::{FirmwareVersion, RobotId, RobotKind, Telemetry},
    FleetKey, HostMsg, HostSession, UpdateStatus, MAX_DATAGRAM,
};
use tokio::net::UdpSocket;
use tokio::task::JoinHandle;
use tokio::time::Instant;

pub use status::{LinkEvent, LinkEventKind, LinkStats, RobotStatus};

use receive::recv_loop;
use status::status_of;
use stream::{seal_command, stream_loop};

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

#[cfg(test)]
mod tests;
