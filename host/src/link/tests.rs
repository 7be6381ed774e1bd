//! Tests of the fleet link over loopback UDP.

use super::*;
use puzzlebot_protocol::{messages::Telemetry, RobotMsg, RobotSession};

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
