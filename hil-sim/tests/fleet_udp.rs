//! The fleet over real UDP sockets on 127.0.0.1: handshake, commands, forged and replayed
//! datagrams, a robot rebooting, the pose stream.

use puzzlebot_protocol::pose::decode_poses;
use puzzlebot_protocol::session::HostReceived;
use puzzlebot_protocol::{FleetKey, HostMsg, HostSession, Rejection, MAX_DATAGRAM};
use puzzlebot_sim::{Pace, Scenario, SimFleet, SimOptions};
use std::collections::BTreeMap;
use std::net::{SocketAddr, UdpSocket};
use std::time::{Duration, Instant};

struct Host {
    sock: UdpSocket,
    key: FleetKey,
    sessions: BTreeMap<u16, (HostSession, SocketAddr)>,
    nonces: u8,
    announces: Vec<[u8; 16]>,
}

impl Host {
    fn pump(&mut self, for_ms: u64) {
        let end = Instant::now() + Duration::from_millis(for_ms);
        let mut buf = [0u8; 256];
        while Instant::now() < end {
            let Ok((n, from)) = self.sock.recv_from(&mut buf) else {
                continue;
            };
            let Ok(h) = puzzlebot_protocol::peek_header(&buf[..n]) else {
                continue;
            };
            let id = h.robot_id;
            let key = self.key.robot_key(id);
            let entry = self
                .sessions
                .entry(id)
                .or_insert_with(|| (HostSession::new(id, key), from));
            entry.1 = from;
            self.nonces = self.nonces.wrapping_add(1);
            let nn = self.nonces;
            let mut out = [0u8; MAX_DATAGRAM];
            if let Ok(HostReceived::Announce {
                welcome_len,
                announce,
                ..
            }) = entry.0.receive(&buf[..n], || [nn; 16], &mut out)
            {
                if !self.announces.contains(&announce.robot_nonce) {
                    self.announces.push(announce.robot_nonce);
                }
                let _ = self.sock.send_to(&out[..welcome_len], from);
            }
        }
    }

    fn command(&mut self, id: u16, msg: &HostMsg) -> Option<Vec<u8>> {
        let (s, addr) = self.sessions.get_mut(&id)?;
        let mut out = [0u8; MAX_DATAGRAM];
        let n = s.send(msg, &mut out).ok()?;
        self.sock.send_to(&out[..n], *addr).ok()?;
        Some(out[..n].to_vec())
    }
}

#[test]
fn fleet_speaks_the_real_protocol_over_loopback() {
    let sock = UdpSocket::bind("127.0.0.1:0").expect("bind");
    sock.set_read_timeout(Some(Duration::from_millis(5)))
        .expect("timeout");
    let pose_sock = UdpSocket::bind("127.0.0.1:0").expect("bind");
    pose_sock
        .set_read_timeout(Some(Duration::from_millis(200)))
        .expect("timeout");
    let key = FleetKey([5; 32]);
    let fleet = SimFleet::start(
        Scenario::grid(2, 9),
        SimOptions {
            fleet_key: key.clone(),
            host_addr: sock.local_addr().expect("addr"),
            pose_addr: Some(pose_sock.local_addr().expect("addr")),
            pace: Pace::RealTime,
        },
    )
    .expect("fleet");
    let mut host = Host {
        sock,
        key,
        sessions: BTreeMap::new(),
        nonces: 0,
        announces: Vec::new(),
    };
    host.pump(600);
    assert_eq!(host.sessions.len(), 2, "both robots announced");
    assert_eq!(host.sessions[&1].1, fleet.robot_addr(1).expect("robot 1"));
    // Drive robot 1 (backwards, away from robot 2) for 0.6 s at 30 Hz.
    let mut last = None;
    for _ in 0..18 {
        last = host.command(
            1,
            &HostMsg::WheelSpeed {
                left_rpm: -150.0,
                right_rpm: -150.0,
            },
        );
        host.pump(33);
    }
    let t = fleet.ground_truth();
    assert!(
        t.robot(1).unwrap().wheel_rpm[0] < -100.0,
        "{:?}",
        t.robot(1)
    );
    assert!(t.robot(2).unwrap().wheel_rpm[0].abs() < 1.0);
    // Replay the last command and send a forged one to robot 1's socket.
    let last = last.expect("sent");
    let robot1 = fleet.robot_addr(1).expect("addr");
    host.sock.send_to(&last, robot1).expect("send");
    let mut forged = last.clone();
    forged[11] ^= 0x01;
    host.sock.send_to(&forged, robot1).expect("send");
    host.pump(100);
    let r = fleet.ground_truth().robot(1).copied().expect("robot 1");
    assert_eq!(
        r.rejected[Rejection::Replay as usize],
        1,
        "{:?}",
        r.rejected
    );
    assert_eq!(
        r.rejected[Rejection::BadTag as usize],
        1,
        "{:?}",
        r.rejected
    );
    // The pose stream arrives.
    let mut buf = [0u8; 2048];
    let (n, _) = pose_sock.recv_from(&mut buf).expect("pose datagram");
    let mut ids = Vec::new();
    decode_poses(&buf[..n], |b| ids.push(b.robot_id)).expect("valid PBP1");
    assert_eq!(ids, vec![1, 2]);
    // Reboot robot 2: it announces a fresh nonce.
    let before = host.announces.len();
    fleet.set_online(2, false);
    host.pump(100);
    assert!(!fleet.ground_truth().robot(2).unwrap().online);
    fleet.set_online(2, true);
    host.pump(600);
    assert_eq!(host.announces.len(), before + 1, "a fresh boot nonce");
    fleet.stop();
}

#[test]
fn non_loopback_addresses_are_refused() {
    let err = SimFleet::start(
        Scenario::grid(1, 1),
        SimOptions {
            fleet_key: FleetKey([1; 32]),
            host_addr: "10.0.0.1:47800".parse().expect("addr"),
            pose_addr: None,
            pace: Pace::AsFastAsPossible,
        },
    )
    .expect_err("must refuse");
    assert!(err.to_string().contains("not a loopback"), "{err}");
}
