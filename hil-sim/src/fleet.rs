//! A simulated fleet on loopback: the [`World`] in its own thread, one UDP socket per robot
//! on 127.0.0.1 (ephemeral port) speaking the real protocol through the robot's firmware,
//! and the virtual motion capture sent as the documented pose stream.
//!
//! Robots send to `host_addr` from their own socket and receive on it, exactly like the
//! hardware (the host learns each robot's address from its announce). Datagrams received
//! from the sockets enter the virtual radio at the current simulation time, so impairments
//! apply in both directions. Sockets are polled every [`POLL_US`] of simulated time.
//!
//! With [`Pace::RealTime`] simulated time follows the wall clock (the firmware's failsafe
//! and the host's 30 Hz stream then mean what they say); with
//! [`Pace::AsFastAsPossible`] the world runs flat out (useful when nothing external has to
//! keep up, e.g. robots replaying a scripted drive).

use crate::radio::Impairments;
use crate::scenario::Scenario;
use crate::world::{GroundTruth, World, WorldError};
use crate::Pose;
use puzzlebot_protocol::{FleetKey, RobotId, MAX_DATAGRAM};
use std::io::ErrorKind;
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Simulated time between socket polls (µs).
pub const POLL_US: u64 = 2_000;
/// Simulated time between ground-truth snapshots (µs).
pub const TRUTH_US: u64 = 10_000;

/// How simulated time relates to the wall clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pace {
    /// One simulated second per wall-clock second.
    RealTime,
    /// As fast as the machine allows.
    AsFastAsPossible,
}

/// How to run a fleet.
#[derive(Debug, Clone)]
pub struct SimOptions {
    /// The fleet key; each robot holds `fleet_key.robot_key(id)`.
    pub fleet_key: FleetKey,
    /// Where robots send (the host's UDP address; must be loopback).
    pub host_addr: SocketAddr,
    /// Where motion-capture frames go (loopback), if anywhere.
    pub pose_addr: Option<SocketAddr>,
    /// Pacing.
    pub pace: Pace,
}

/// Why a fleet could not start.
#[derive(Debug, thiserror::Error)]
pub enum FleetError {
    /// The world could not be built.
    #[error(transparent)]
    World(#[from] WorldError),
    /// An address is not on loopback (the simulator only talks to 127.0.0.0/8 / ::1).
    #[error("{what} {addr} is not a loopback address")]
    NotLoopback {
        /// Which option.
        what: &'static str,
        /// The address.
        addr: SocketAddr,
    },
    /// A socket could not be opened.
    #[error("cannot open UDP socket on 127.0.0.1: {0}")]
    Socket(#[from] std::io::Error),
    /// The simulation thread could not be started.
    #[error("cannot start the simulation thread: {0}")]
    Thread(std::io::Error),
}

enum Command {
    Online(RobotId, bool),
    Impair(RobotId, Impairments),
    Place(RobotId, Pose),
    LiftKnobs(Vec<RobotId>),
    UpdateKey(Option<[u8; 32]>),
}

struct Shared {
    truth: Mutex<GroundTruth>,
    commands: Mutex<Vec<Command>>,
    stop: AtomicBool,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// A running simulated fleet (see the module documentation). Stops when dropped.
pub struct SimFleet {
    addrs: Vec<(RobotId, SocketAddr)>,
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for SimFleet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimFleet")
            .field("robots", &self.addrs)
            .finish()
    }
}

impl SimFleet {
    /// Build the world of `scenario`, bind one socket per robot and start the thread.
    pub fn start(scenario: Scenario, opts: SimOptions) -> Result<SimFleet, FleetError> {
        if !opts.host_addr.ip().is_loopback() {
            return Err(FleetError::NotLoopback {
                what: "host address",
                addr: opts.host_addr,
            });
        }
        if let Some(p) = opts.pose_addr {
            if !p.ip().is_loopback() {
                return Err(FleetError::NotLoopback {
                    what: "pose address",
                    addr: p,
                });
            }
        }
        let world = World::new(&scenario, &opts.fleet_key)?;
        let mut sockets = Vec::new();
        let mut addrs = Vec::new();
        for id in world.robot_ids() {
            let s = UdpSocket::bind("127.0.0.1:0")?;
            s.set_nonblocking(true)?;
            addrs.push((id, s.local_addr()?));
            sockets.push((id, s));
        }
        let pose_sock = match opts.pose_addr {
            Some(_) => Some(UdpSocket::bind("127.0.0.1:0")?),
            None => None,
        };
        let shared = Arc::new(Shared {
            truth: Mutex::new(world.ground_truth()),
            commands: Mutex::new(Vec::new()),
            stop: AtomicBool::new(false),
        });
        let sh = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("puzzlebot-sim".into())
            .spawn(move || run(world, sockets, pose_sock, opts, sh))
            .map_err(FleetError::Thread)?;
        Ok(SimFleet {
            addrs,
            shared,
            thread: Some(thread),
        })
    }

    /// The UDP address robot `id` listens on.
    pub fn robot_addr(&self, id: RobotId) -> Option<SocketAddr> {
        self.addrs.iter().find(|(i, _)| *i == id).map(|(_, a)| *a)
    }

    /// Every robot's id and address.
    pub fn robot_addrs(&self) -> &[(RobotId, SocketAddr)] {
        &self.addrs
    }

    /// The latest ground truth (refreshed every [`TRUTH_US`] of simulated time).
    pub fn ground_truth(&self) -> GroundTruth {
        lock(&self.shared.truth).clone()
    }

    /// Switch robot `id` off or on (a reboot with a fresh boot nonce).
    pub fn set_online(&self, id: RobotId, online: bool) {
        lock(&self.shared.commands).push(Command::Online(id, online));
    }

    /// Change robot `id`'s link impairments.
    pub fn set_impairments(&self, id: RobotId, imp: Impairments) {
        lock(&self.shared.commands).push(Command::Impair(id, imp));
    }

    /// Put robot `id` at `pose` by hand.
    pub fn place(&self, id: RobotId, pose: Pose) {
        lock(&self.shared.commands).push(Command::Place(id, pose));
    }

    /// Lift the knob pairs among robots `ids` apart by hand ([`World::lift_knobs`]).
    pub fn lift_knobs(&self, ids: &[RobotId]) {
        lock(&self.shared.commands).push(Command::LiftKnobs(ids.to_vec()));
    }

    /// Make every robot trust firmware updates signed with `key` ([`World::set_update_key`]).
    pub fn set_update_key(&self, key: Option<[u8; 32]>) {
        lock(&self.shared.commands).push(Command::UpdateKey(key));
    }

    /// Stop the simulation thread and close the sockets.
    pub fn stop(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for SimFleet {
    fn drop(&mut self) {
        self.halt();
    }
}

fn run(
    mut world: World,
    sockets: Vec<(RobotId, UdpSocket)>,
    pose_sock: Option<UdpSocket>,
    opts: SimOptions,
    shared: Arc<Shared>,
) {
    let start = Instant::now();
    let t_start = world.time_us();
    let mut buf = [0u8; 2048];
    let mut next_truth = 0;
    let steps = (POLL_US / world.step_us()).max(1);
    while !shared.stop.load(Ordering::Relaxed) {
        for c in std::mem::take(&mut *lock(&shared.commands)) {
            match c {
                Command::Online(id, on) => {
                    world.set_online(id, on);
                }
                Command::Impair(id, imp) => {
                    world.set_impairments(id, imp);
                }
                Command::Place(id, p) => {
                    world.place(id, p);
                }
                Command::LiftKnobs(ids) => {
                    world.lift_knobs(&ids);
                }
                Command::UpdateKey(key) => {
                    world.set_update_key(key);
                }
            }
        }
        for (id, s) in &sockets {
            loop {
                match s.recv_from(&mut buf) {
                    Ok((n, _from)) => {
                        if n <= MAX_DATAGRAM {
                            world.send_to_robot(*id, &buf[..n]);
                        } else {
                            // Oversized: the firmware rejects it unread; keep it bounded.
                            world.send_to_robot(*id, &buf[..MAX_DATAGRAM + 1]);
                        }
                    }
                    Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                    Err(e) if e.kind() == ErrorKind::ConnectionRefused => continue,
                    Err(_) => break,
                }
            }
        }
        for _ in 0..steps {
            world.step();
        }
        for (id, frame) in world.take_from_robots() {
            if let Some((_, s)) = sockets.iter().find(|(i, _)| *i == id) {
                let _ = s.send_to(&frame, opts.host_addr);
            }
        }
        let frames = world.take_mocap();
        if let (Some(ps), Some(addr)) = (&pose_sock, opts.pose_addr) {
            for f in frames {
                for d in f.datagrams() {
                    let _ = ps.send_to(&d, addr);
                }
            }
        }
        if world.time_us() >= next_truth {
            *lock(&shared.truth) = world.ground_truth();
            next_truth = world.time_us() + TRUTH_US;
        }
        if opts.pace == Pace::RealTime {
            let sim = Duration::from_micros(world.time_us() - t_start);
            let wall = start.elapsed();
            if sim > wall {
                std::thread::sleep(sim - wall);
            }
        }
    }
    *lock(&shared.truth) = world.ground_truth();
}
