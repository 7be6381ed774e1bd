//! The command session and safety rules of `Robot`, against the real host session of the
//! protocol crate.

use puzzlebot_firmware_core::{
    levels_of, DriveMode, Encoder, EncoderSnapshot, MotorOutputs, Robot, Sensors,
};
use puzzlebot_params::firmware::Firmware;
use puzzlebot_protocol::{
    flags, session::HostReceived, FirmwareVersion, FleetKey, HostMsg, HostSession, Nonce,
    ParamRejection, ParamSet, PiGains, Rejection, ResetReason, RobotKey, RobotKind, RobotMsg,
    RobotSession, MAX_DATAGRAM,
};

const ID: u16 = 5;
const PERIOD: u64 = 20_000;
const VERSION: FirmwareVersion = FirmwareVersion {
    major: 0,
    minor: 1,
    patch: 0,
};

fn key() -> RobotKey {
    FleetKey([0x42; 32]).robot_key(ID)
}

fn counter_nonces(seed: u8) -> impl FnMut() -> Nonce {
    let mut n = 0u64;
    move || {
        n += 1;
        let mut out = [seed; 16];
        out[..8].copy_from_slice(&n.to_le_bytes());
        out
    }
}

type TestRobot = Robot<Box<dyn FnMut() -> Nonce>>;

fn robot_with(key: Option<RobotKey>) -> TestRobot {
    Robot::new(
        ID,
        RobotKind::NonPilot,
        key,
        Firmware::default(),
        VERSION,
        Box::new(counter_nonces(1)) as Box<dyn FnMut() -> Nonce>,
    )
    .expect("valid params")
}

fn sensors() -> Sensors {
    Sensors {
        battery_mv: 3900,
        rssi_dbm: -40,
        encoders: [EncoderSnapshot::default(); 2],
    }
}

/// A robot and a host that completed the handshake at t = 0; returns them and the time.
struct Link {
    robot: TestRobot,
    host: HostSession,
    now: u64,
    host_nonce: u8,
    /// Nonces of the current session: the robot's announce nonce, the host's welcome nonce.
    session_nonces: (Nonce, Nonce),
}

impl Link {
    fn new() -> Link {
        let mut l = Link {
            robot: robot_with(Some(key())),
            host: HostSession::new(ID, key()),
            now: 0,
            host_nonce: 100,
            session_nonces: ([0; 16], [0; 16]),
        };
        l.handshake();
        l
    }

    /// Let the robot transmit; the host answers announces; returns host-side messages.
    fn exchange(&mut self) -> Vec<RobotMsg> {
        let mut got = Vec::new();
        let mut buf = [0u8; MAX_DATAGRAM];
        let mut welcome = [0u8; MAX_DATAGRAM];
        while let Some(n) = self.robot.poll_transmit(self.now, &mut buf) {
            let hn = self.host_nonce;
            match self.host.receive(&buf[..n], || [hn; 16], &mut welcome) {
                Ok(HostReceived::Announce {
                    welcome_len,
                    announce,
                    ..
                }) => {
                    self.session_nonces = (announce.robot_nonce, [hn; 16]);
                    self.host_nonce += 1;
                    let w = welcome[..welcome_len].to_vec();
                    self.robot
                        .on_datagram(&w, self.now)
                        .expect("welcome accepted");
                }
                Ok(HostReceived::Message(_, m)) => got.push(m),
                Err(e) => panic!("host rejected robot frame: {e}"),
            }
        }
        got
    }

    fn handshake(&mut self) {
        self.robot.tick(self.now, &sensors());
        let msgs = self.exchange();
        assert!(self.robot.is_established());
        assert!(self.host.is_established(), "telemetry proves the session");
        assert!(matches!(msgs.first(), Some(RobotMsg::Telemetry(_))));
    }

    fn seal(&mut self, msg: &HostMsg) -> Vec<u8> {
        let mut buf = [0u8; MAX_DATAGRAM];
        let n = self.host.send(msg, &mut buf).expect("seal");
        buf[..n].to_vec()
    }

    fn send(&mut self, msg: &HostMsg) -> Result<(), Rejection> {
        let f = self.seal(msg);
        self.robot.on_datagram(&f, self.now)
    }

    fn tick(&mut self) -> MotorOutputs {
        self.now += PERIOD;
        self.robot.tick(self.now, &sensors())
    }
}

fn speed(l: f32, r: f32) -> HostMsg {
    HostMsg::WheelSpeed {
        left_rpm: l,
        right_rpm: r,
    }
}

#[test]
fn unprovisioned_never_drives_or_transmits() {
    let mut r = robot_with(None);
    // Even a frame sealed with some key is refused: there is no session to check it with.
    let mut host = HostSession::new(ID, key());
    let mut buf = [0u8; MAX_DATAGRAM];
    let _ = host.receive(&[0u8; 40], || [1; 16], &mut buf);
    for t in 0..100u64 {
        let now = t * PERIOD;
        let out = r.tick(now, &sensors());
        assert_eq!(out, MotorOutputs::COAST);
        assert_eq!(r.poll_transmit(now, &mut buf), None);
        assert_eq!(
            r.on_datagram(&[1, 3, 5, 0, 0, 0, 0, 0, 0, 0, 9, 9], now),
            Err(Rejection::NoSession)
        );
    }
    let s = r.status();
    assert!(!s.provisioned);
    assert_ne!(s.flags & flags::UNPROVISIONED, 0);
    assert_eq!(s.mode, DriveMode::Idle);
}

#[test]
fn announces_until_welcomed_at_the_interval() {
    let mut r = robot_with(Some(key()));
    let mut buf = [0u8; MAX_DATAGRAM];
    let mut announces = 0;
    for t in 0..50u64 {
        let now = t * PERIOD; // one second
        r.tick(now, &sensors());
        while r.poll_transmit(now, &mut buf).is_some() {
            announces += 1;
        }
    }
    let expect = 1000 / Firmware::default().announce_interval_ms as usize;
    assert_eq!(announces, expect);
    assert!(!r.is_established());
    // Nothing drives before a session.
    assert!(r.tick(1_000_000, &sensors()).is_stopped());
}

#[test]
fn speed_command_drives_and_failsafe_stops_within_one_period() {
    let mut l = Link::new();
    l.send(&speed(200.0, -200.0)).unwrap();
    let cmd_time = l.now;
    let out = l.tick();
    assert!(!out.is_stopped());
    assert!(out.left.effective_duty().unwrap() > 0);
    assert!(out.right.effective_duty().unwrap() < 0);
    let timeout = u64::from(Firmware::default().failsafe_timeout_ms) * 1000;
    loop {
        let out = l.tick();
        if l.now < cmd_time + timeout {
            assert!(!out.is_stopped(), "stopped early at {}", l.now - cmd_time);
        } else {
            // The first tick at or after the timeout brakes: within one period.
            assert!(l.now - (cmd_time + timeout) < PERIOD);
            assert_eq!(out, MotorOutputs::BRAKE);
            assert_ne!(l.robot.status().flags & flags::FAILSAFE, 0);
            break;
        }
    }
    // A new command clears the failsafe.
    l.send(&speed(100.0, 100.0)).unwrap();
    assert!(!l.tick().is_stopped());
    assert_eq!(l.robot.status().flags & flags::FAILSAFE, 0);
}

fn hold(l: f32, r: f32, hold_ms: u16) -> HostMsg {
    HostMsg::WheelSpeedHold {
        left_rpm: l,
        right_rpm: r,
        hold_ms,
    }
}

/// Ticks from now until the robot brakes (µs after `from`), at most `limit` µs.
fn brakes_after(l: &mut Link, from: u64, limit: u64) -> Option<u64> {
    while l.now < from + limit {
        if l.tick() == MotorOutputs::BRAKE {
            return Some(l.now - from);
        }
    }
    None
}

/// A held command keeps driving through link silence for its hold, then the failsafe
/// brakes within a period; the hold never outlasts `max_hold_ms`.
#[test]
fn a_held_command_drives_through_silence_for_its_hold_only() {
    let timeout = u64::from(Firmware::default().failsafe_timeout_ms) * 1000;
    let max = u64::from(Firmware::default().max_hold_ms) * 1000;
    let mut l = Link::new();
    l.send(&hold(200.0, 200.0, 600)).unwrap();
    let from = l.now;
    let t = brakes_after(&mut l, from, 2 * max).expect("brakes");
    assert!(
        t > timeout && (600_000..600_000 + PERIOD).contains(&t),
        "{t}"
    );
    assert_ne!(l.robot.status().flags & flags::FAILSAFE, 0);

    let mut l = Link::new();
    l.send(&hold(200.0, 200.0, u16::MAX)).unwrap();
    let from = l.now;
    let t = brakes_after(&mut l, from, 3 * max).expect("brakes");
    assert!((max..max + PERIOD).contains(&t), "{t}");
}

/// Stop and emergency stop end a hold at once; a plain command after a hold brings the
/// ordinary failsafe back.
#[test]
fn stop_and_plain_commands_end_a_hold() {
    let timeout = u64::from(Firmware::default().failsafe_timeout_ms) * 1000;
    for end in [HostMsg::Stop, HostMsg::EmergencyStop] {
        let mut l = Link::new();
        l.send(&hold(200.0, 200.0, 900)).unwrap();
        assert!(!l.tick().is_stopped());
        l.send(&end).unwrap();
        assert_eq!(l.tick(), MotorOutputs::BRAKE);
    }
    let mut l = Link::new();
    l.send(&hold(200.0, 200.0, 900)).unwrap();
    l.tick();
    l.send(&speed(200.0, 200.0)).unwrap();
    let from = l.now;
    let t = brakes_after(&mut l, from, 900_000).expect("brakes");
    assert!((timeout..timeout + PERIOD).contains(&t), "{t}");
}

#[test]
fn commands_keep_the_failsafe_away() {
    let mut l = Link::new();
    for _ in 0..100 {
        l.send(&speed(150.0, 150.0)).unwrap();
        assert!(!l.tick().is_stopped());
        l.tick();
    }
}

#[test]
fn emergency_stop_latches_until_cleared() {
    let mut l = Link::new();
    l.send(&speed(300.0, 300.0)).unwrap();
    assert!(!l.tick().is_stopped());
    l.send(&HostMsg::EmergencyStop).unwrap();
    assert_eq!(l.tick(), MotorOutputs::BRAKE);
    for _ in 0..20 {
        l.send(&speed(300.0, 300.0)).unwrap();
        l.send(&HostMsg::RawDuty {
            left: 900,
            right: 900,
        })
        .unwrap();
        l.send(&HostMsg::Stop).unwrap();
        assert_eq!(l.tick(), MotorOutputs::BRAKE);
        assert_ne!(l.robot.status().flags & flags::ESTOP, 0);
    }
    assert!(l.robot.stats().blocked_by_estop >= 40);
    l.send(&HostMsg::ClearEmergencyStop).unwrap();
    // Cleared: still stopped until the next command.
    assert_eq!(l.tick(), MotorOutputs::BRAKE);
    assert_eq!(l.robot.status().flags & flags::ESTOP, 0);
    l.send(&speed(300.0, 300.0)).unwrap();
    assert!(!l.tick().is_stopped());
}

#[test]
fn estop_survives_relink_and_old_clear_is_ignored() {
    let mut l = Link::new();
    let old_clear = l.seal(&HostMsg::ClearEmergencyStop);
    l.send(&HostMsg::EmergencyStop).unwrap();
    // A clear sealed before the e-stop (lower counter) arriving late does not release it.
    l.robot.on_datagram(&old_clear, l.now).unwrap();
    assert_ne!(l.robot.status().flags & flags::ESTOP, 0);
    // Host falls silent: the robot relinks; the latch survives the new session.
    for _ in 0..60 {
        l.tick();
    }
    assert!(!l.robot.is_established());
    l.host.reset();
    l.exchange();
    assert!(l.robot.is_established());
    l.send(&speed(100.0, 100.0)).unwrap();
    assert_eq!(l.tick(), MotorOutputs::BRAKE);
    l.send(&HostMsg::ClearEmergencyStop).unwrap();
    l.send(&speed(100.0, 100.0)).unwrap();
    assert!(!l.tick().is_stopped());
}

#[test]
fn replayed_reordered_and_forged_commands_never_change_a_duty() {
    let mut l = Link::new();
    let fwd = l.seal(&speed(400.0, 400.0));
    let slow = l.seal(&speed(50.0, 50.0));
    l.robot.on_datagram(&slow, l.now).unwrap();
    // The older command arriving late is authentic but stale: ignored.
    l.robot.on_datagram(&fwd, l.now).unwrap();
    assert_eq!(l.robot.status().target_rpm, [50.0, 50.0]);
    assert_eq!(l.robot.stats().stale_commands, 1);
    // Replays are refused by the session.
    assert_eq!(l.robot.on_datagram(&slow, l.now), Err(Rejection::Replay));
    assert_eq!(l.robot.on_datagram(&fwd, l.now), Err(Rejection::Replay));
    // Forgeries: every single-bit flip of a fresh command is refused.
    let genuine = l.seal(&speed(-450.0, 450.0));
    for i in 0..genuine.len() * 8 {
        let mut f = genuine.clone();
        f[i / 8] ^= 1 << (i % 8);
        assert!(l.robot.on_datagram(&f, l.now).is_err(), "bit {i}");
    }
    // Frames sealed under another robot's or another fleet's key, by a host whose session
    // with that key is established (so the frame is well-formed in every other respect).
    let wrong_keys = [
        FleetKey([0x42; 32]).robot_key(ID + 1),
        FleetKey([0x43; 32]).robot_key(ID),
    ];
    let fast = speed(-450.0, 450.0);
    for wrong in wrong_keys {
        let frame = sealed_by_foreign_host(wrong, l.session_nonces, &fast);
        assert_eq!(l.robot.on_datagram(&frame, l.now), Err(Rejection::BadTag));
    }
    // Control: the same construction with the right key authenticates (it is refused only
    // as an old counter), so the refusals above are the keys' doing.
    let frame = sealed_by_foreign_host(key(), l.session_nonces, &fast);
    let control = l.robot.on_datagram(&frame, l.now);
    assert!(
        matches!(control, Err(Rejection::Replay | Rejection::TooOld)),
        "{control:?}"
    );
    assert_eq!(l.robot.status().target_rpm, [50.0, 50.0]);
    // The genuine frame still works after all that noise.
    l.robot.on_datagram(&genuine, l.now).unwrap();
    assert_eq!(l.robot.status().target_rpm, [-450.0, 450.0]);
}

/// `msg` sealed by a host that completed a handshake with `nonces` (robot, host) with a
/// robot holding `robot_key` (and this test's robot id), so the host's session is
/// established and `send` succeeds.
fn sealed_by_foreign_host(robot_key: RobotKey, nonces: (Nonce, Nonce), msg: &HostMsg) -> Vec<u8> {
    let mut robot = RobotSession::new(ID, robot_key.clone(), nonces.0);
    let mut host = HostSession::new(ID, robot_key);
    let mut a = [0u8; MAX_DATAGRAM];
    let mut w = [0u8; MAX_DATAGRAM];
    let n = robot
        .announce(RobotKind::NonPilot, VERSION, &mut a)
        .expect("announce");
    let welcome_len = match host.receive(&a[..n], || nonces.1, &mut w) {
        Ok(HostReceived::Announce { welcome_len, .. }) => welcome_len,
        other => panic!("foreign host refused its robot's announce: {other:?}"),
    };
    robot.receive(&w[..welcome_len]).expect("welcome");
    let n = robot
        .send(
            &RobotMsg::Pong {
                seq: 1,
                host_time_us: 2,
            },
            &mut a,
        )
        .expect("first session frame");
    host.receive(&a[..n], || [7; 16], &mut w)
        .expect("the foreign host opens its robot's frame");
    assert!(host.is_established());
    let n = host
        .send(msg, &mut a)
        .expect("an established session seals");
    a[..n].to_vec()
}

#[test]
fn frames_of_an_earlier_session_are_refused_after_relink() {
    let mut l = Link::new();
    let captured = l.seal(&speed(300.0, 300.0));
    for _ in 0..60 {
        l.tick();
    }
    assert!(!l.robot.is_established());
    l.host.reset();
    l.exchange();
    assert!(l.robot.is_established());
    assert!(l.robot.on_datagram(&captured, l.now).is_err());
    assert_eq!(l.robot.status().target_rpm, [0.0, 0.0]);
    assert!(l.tick().is_stopped());
}

#[test]
fn relink_after_silence_uses_a_fresh_nonce_and_counts() {
    let mut l = Link::new();
    let relink = u64::from(Firmware::default().relink_after_ms) * 1000;
    let start = l.now;
    while l.robot.is_established() {
        l.tick();
    }
    assert!(l.now - start >= relink && l.now - start < relink + PERIOD);
    assert_eq!(l.robot.stats().relinks, 1);
    // A restarted host (fresh state) is welcomed again.
    l.host = HostSession::new(ID, key());
    l.exchange();
    assert!(l.robot.is_established() && l.host.is_established());
    assert_eq!(l.robot.stats().sessions, 2);
}

#[test]
fn set_params_checked_and_answered() {
    let mut l = Link::new();
    let mut set = Firmware::default().param_set();
    set.failsafe_timeout_ms = 5;
    l.send(&HostMsg::SetParams(set)).unwrap();
    let replies = l.exchange();
    assert!(replies.contains(&RobotMsg::ParamsReply {
        rejected: Some(ParamRejection::FailsafeTimeoutOutOfRange)
    }));
    assert_eq!(l.robot.params().failsafe_timeout_ms, 200);
    let good = ParamSet {
        pi: [PiGains { kp: 0.5, ki: 5.0 }; 3],
        failsafe_timeout_ms: 400,
        telemetry_hz: 10,
    };
    l.send(&HostMsg::SetParams(good)).unwrap();
    let replies = l.exchange();
    assert!(replies.contains(&RobotMsg::ParamsReply { rejected: None }));
    assert_eq!(l.robot.params().failsafe_timeout_ms, 400);
    assert_eq!(l.robot.params().telemetry_hz, 10);
    assert_eq!(l.robot.params().pi, good.pi);
}

#[test]
fn ping_is_answered_with_pong() {
    let mut l = Link::new();
    l.send(&HostMsg::Ping {
        seq: 77,
        host_time_us: 123_456,
    })
    .unwrap();
    let replies = l.exchange();
    assert!(replies.contains(&RobotMsg::Pong {
        seq: 77,
        host_time_us: 123_456
    }));
}

#[test]
fn telemetry_at_the_configured_rate_with_fields() {
    let mut l = Link::new();
    l.send(&speed(120.0, 80.0)).unwrap();
    let mut n = 0;
    let mut last = None;
    for _ in 0..50 {
        l.tick();
        for m in l.exchange() {
            if let RobotMsg::Telemetry(t) = m {
                n += 1;
                last = Some(t);
            }
        }
        l.send(&speed(120.0, 80.0)).unwrap();
    }
    assert!((49..=51).contains(&n), "{n} telemetry frames in 1 s");
    let t = last.unwrap();
    assert_eq!(t.target_rpm, [120.0, 80.0]);
    assert_eq!(t.battery_mv, 3900);
    assert_eq!(t.rssi_dbm, -40);
    assert!(t.duty[0] > 0 && t.duty[1] > 0);
    assert!(t.last_command_counter > 0);
    assert_eq!(t.uptime_ms as u64, l.now / 1000);
}

#[test]
fn raw_duty_is_applied_open_loop_and_flagged() {
    let mut l = Link::new();
    l.send(&HostMsg::RawDuty {
        left: 300,
        right: -700,
    })
    .unwrap();
    let out = l.tick();
    assert_eq!(out.left.effective_duty(), Some(300));
    assert_eq!(out.right.effective_duty(), Some(-700));
    assert_ne!(l.robot.status().flags & flags::RAW_DUTY, 0);
    l.send(&HostMsg::Stop).unwrap();
    assert_eq!(l.tick(), MotorOutputs::BRAKE);
}

#[test]
fn closed_loop_reaches_speed_on_measured_encoders() {
    // Feed the encoders a wheel turning at exactly the commanded speed: the estimate
    // matches and the duty settles near the feed-forward.
    let mut l = Link::new();
    let mut enc = [Encoder::new(), Encoder::new()];
    for e in &mut enc {
        e.init_levels(false, false);
    }
    let epr = f64::from(Firmware::default().encoder_edges_per_rev);
    let rpm = 240.0f64;
    let us_per_edge = 60.0e6 / (rpm * epr);
    let mut k = 0u64;
    let mut duty = 0;
    for _ in 0..30 {
        l.send(&speed(rpm as f32, rpm as f32)).unwrap();
        let next = l.now + PERIOD;
        while ((k + 1) as f64 * us_per_edge) as u64 <= next {
            k += 1;
            let (a, b) = levels_of(k as i32);
            for e in &mut enc {
                e.on_edge(a, b, (k as f64 * us_per_edge) as u64);
            }
        }
        l.now = next;
        let s = Sensors {
            battery_mv: 3900,
            rssi_dbm: -40,
            encoders: [enc[0].snapshot(), enc[1].snapshot()],
        };
        let out = l.robot.tick(l.now, &s);
        duty = out.left.effective_duty().unwrap();
    }
    let st = l.robot.status();
    assert!(
        (st.measured_rpm[0] - rpm as f32).abs() < 0.5,
        "{:?}",
        st.measured_rpm
    );
    let p = Firmware::default();
    let ff = p.ff_deadband_duty + p.ff_duty_per_rpm * rpm as f32;
    assert!(
        (f32::from(duty) - ff).abs() < 30.0,
        "duty {duty} vs ff {ff}"
    );
}

#[test]
fn bad_parameters_are_refused_at_construction() {
    let p = Firmware {
        loop_hz: 0.0,
        ..Firmware::default()
    };
    assert!(Robot::new(1, RobotKind::Pilot, None, p, VERSION, counter_nonces(0)).is_err());
    let p = Firmware {
        schedule_rpm: [300.0, 200.0, 100.0],
        ..Firmware::default()
    };
    assert!(Robot::new(1, RobotKind::Pilot, None, p, VERSION, counter_nonces(0)).is_err());
    let mut p = Firmware::default();
    p.pi[1].kp = f32::NAN;
    assert!(Robot::new(1, RobotKind::Pilot, None, p, VERSION, counter_nonces(0)).is_err());
}

mod fuzz {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Arbitrary bytes, and arbitrary corruptions of a genuine command, never panic
        /// and never change what the motors do.
        #[test]
        fn garbage_never_changes_a_duty(
            junk in proptest::collection::vec(any::<u8>(), 0..200),
            flips in proptest::collection::vec((0usize..64, 1u8..=255), 1..4),
        ) {
            let mut l = Link::new();
            l.send(&speed(120.0, -60.0)).unwrap();
            let before = l.robot.status();
            prop_assert!(l.robot.on_datagram(&junk, l.now).is_err());
            let genuine = l.seal(&speed(450.0, 450.0));
            let mut forged = genuine.clone();
            for (i, x) in flips {
                let i = i % forged.len();
                forged[i] ^= x;
            }
            // Flips can cancel (the same byte twice with the same mask): that frame is the
            // genuine one, and accepting it is right.
            prop_assume!(forged != genuine);
            prop_assert!(l.robot.on_datagram(&forged, l.now).is_err());
            let after = l.robot.status();
            prop_assert_eq!(before.target_rpm, after.target_rpm);
            prop_assert_eq!(before.mode, after.mode);
        }
    }
}

#[test]
fn raw_duty_also_falls_to_the_failsafe() {
    let mut l = Link::new();
    l.send(&HostMsg::RawDuty {
        left: 500,
        right: 500,
    })
    .unwrap();
    let start = l.now;
    let timeout = u64::from(Firmware::default().failsafe_timeout_ms) * 1000;
    while l.now < start + timeout {
        assert!(!l.tick().is_stopped() || l.now >= start + timeout);
    }
    assert_eq!(l.robot.status().mode, DriveMode::Stopped);
    assert_ne!(l.robot.status().flags & flags::FAILSAFE, 0);
}

#[test]
fn every_announce_of_a_boot_carries_its_reset_reason() {
    let mut robot = robot_with(Some(key()));
    robot.set_reset_reason(ResetReason::Hang);
    let mut host = HostSession::new(ID, key());
    let mut buf = [0u8; MAX_DATAGRAM];
    let mut w = [0u8; MAX_DATAGRAM];
    let mut seen = Vec::new();
    let mut now = 0;
    // Announces at boot, then again after a relink (no host answer for 1 s).
    while now <= 1_500_000 {
        robot.tick(now, &sensors());
        while let Some(n) = robot.poll_transmit(now, &mut buf) {
            if let Ok(HostReceived::Announce { announce, .. }) =
                host.receive(&buf[..n], || [3; 16], &mut w)
            {
                seen.push(announce.reset_reason);
            }
        }
        now += PERIOD;
    }
    assert!(seen.len() >= 5, "announces every 250 ms: {}", seen.len());
    assert!(seen.iter().all(|r| *r == ResetReason::Hang), "{seen:?}");
    // A robot that was never told announces `Unknown`.
    let mut plain = robot_with(Some(key()));
    plain.tick(0, &sensors());
    let n = plain.poll_transmit(0, &mut buf).expect("announce");
    match HostSession::new(ID, key()).receive(&buf[..n], || [3; 16], &mut w) {
        Ok(HostReceived::Announce { announce, .. }) => {
            assert_eq!(announce.reset_reason, ResetReason::Unknown)
        }
        other => panic!("{other:?}"),
    }
}
