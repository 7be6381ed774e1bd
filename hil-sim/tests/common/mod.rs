//! A minimal in-process host for lockstep tests: answers announces, keeps one session per
//! robot and seals commands, with deterministic host nonces.
#![allow(dead_code)]

use puzzlebot_protocol::session::HostReceived;
use puzzlebot_protocol::{FleetKey, HostMsg, HostSession, RobotId, RobotMsg, MAX_DATAGRAM};
use puzzlebot_sim::World;
use std::collections::BTreeMap;

/// Fleet key used by the tests.
pub fn key() -> FleetKey {
    FleetKey([0x42; 32])
}

/// Host side of every robot.
pub struct MiniHost {
    key: FleetKey,
    sessions: BTreeMap<RobotId, HostSession>,
    nonce: u64,
    /// Telemetry received, per robot (latest).
    pub telemetry: BTreeMap<RobotId, puzzlebot_protocol::Telemetry>,
    /// Last datagram sealed for each robot (for replay tests).
    pub last_sent: BTreeMap<RobotId, Vec<u8>>,
}

impl MiniHost {
    /// A host for fleet `key`.
    pub fn new(key: FleetKey) -> MiniHost {
        MiniHost {
            key,
            sessions: BTreeMap::new(),
            nonce: 0,
            telemetry: BTreeMap::new(),
            last_sent: BTreeMap::new(),
        }
    }

    /// Handle a datagram from robot `id`; returns a reply to send back (a welcome).
    pub fn receive(&mut self, id: RobotId, frame: &[u8]) -> Option<Vec<u8>> {
        // The robot key is derived (an HMAC) only for a robot seen for the first time.
        let fleet = &self.key;
        let s = self
            .sessions
            .entry(id)
            .or_insert_with(|| HostSession::new(id, fleet.robot_key(id)));
        self.nonce += 1;
        let n = self.nonce;
        let mut out = [0u8; MAX_DATAGRAM];
        match s.receive(
            frame,
            || {
                let mut b = [0u8; 16];
                b[..8].copy_from_slice(&n.to_le_bytes());
                b
            },
            &mut out,
        ) {
            Ok(HostReceived::Announce { welcome_len, .. }) => Some(out[..welcome_len].to_vec()),
            Ok(HostReceived::Message(_, RobotMsg::Telemetry(t))) => {
                self.telemetry.insert(id, t);
                None
            }
            _ => None,
        }
    }

    /// True once robot `id` proved its session.
    pub fn established(&self, id: RobotId) -> bool {
        self.sessions
            .get(&id)
            .is_some_and(HostSession::is_established)
    }

    /// Seal `msg` for robot `id` (None before the first announce).
    pub fn seal(&mut self, id: RobotId, msg: &HostMsg) -> Option<Vec<u8>> {
        let s = self.sessions.get_mut(&id)?;
        let mut out = [0u8; MAX_DATAGRAM];
        let n = s.send(msg, &mut out).ok()?;
        let v = out[..n].to_vec();
        let last = self.last_sent.entry(id).or_default();
        last.clear();
        last.extend_from_slice(&v);
        Some(v)
    }

    /// Exchange pending datagrams with the world.
    pub fn pump(&mut self, w: &mut World) {
        for (id, frame) in w.take_from_robots() {
            if let Some(reply) = self.receive(id, &frame) {
                w.send_to_robot(id, &reply);
            }
        }
    }
}

/// Run the world for `secs`, pumping the host every step and sending `cmd(t_s, id)` to every
/// robot at 30 Hz (THESIS 4.4.3) once its session is established.
pub fn drive(
    w: &mut World,
    host: &mut MiniHost,
    secs: f64,
    mut cmd: impl FnMut(f64, RobotId) -> Option<HostMsg>,
) {
    let end = w.time_us() + (secs * 1e6) as u64;
    let ids = w.robot_ids();
    let mut next_cmd = w.time_us();
    while w.time_us() < end {
        w.step();
        host.pump(w);
        if w.time_us() >= next_cmd {
            next_cmd = w.time_us() + 33_333;
            let t = w.time_us() as f64 * 1e-6;
            for &id in &ids {
                if !host.established(id) {
                    continue;
                }
                if let Some(m) = cmd(t, id) {
                    if let Some(f) = host.seal(id, &m) {
                        w.send_to_robot(id, &f);
                    }
                }
            }
        }
    }
}

/// Wheel-speed command.
pub fn speed(left_rpm: f32, right_rpm: f32) -> HostMsg {
    HostMsg::WheelSpeed {
        left_rpm,
        right_rpm,
    }
}

/// Run until every robot has a session (at most `secs`); panics otherwise.
pub fn connect(w: &mut World, host: &mut MiniHost, secs: f64) {
    let ids = w.robot_ids();
    let end = w.time_us() + (secs * 1e6) as u64;
    while w.time_us() < end {
        w.step();
        host.pump(w);
        if ids.iter().all(|&id| host.established(id)) {
            return;
        }
    }
    panic!("robots did not connect within {secs} s");
}
