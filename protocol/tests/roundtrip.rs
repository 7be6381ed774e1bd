//! Property tests: every message variant survives seal/open and the sessions unchanged;
//! non-finite and out-of-range numbers never reach control code.

mod common;

use common::*;
use proptest::prelude::*;
use puzzlebot_protocol::session::HostReceived;
use puzzlebot_protocol::*;

fn header_for<M: Message>(msg: &M, counter: u64) -> Header {
    Header {
        direction: M::DIRECTION,
        stream: if msg.hello() {
            Stream::Hello
        } else {
            Stream::Session
        },
        robot_id: ID,
        counter,
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 512,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn host_messages_round_trip_through_the_envelope(
        msg in host_msg(), counter in 0..=MAX_COUNTER, key in any::<[u8; 32]>()
    ) {
        let key = SessionKey(key);
        let h = header_for(&msg, counter);
        let mut out = [0u8; MAX_DATAGRAM];
        let n = seal(&key, h, &msg, &mut out).expect("every host message fits a datagram");
        prop_assert!(n <= MAX_DATAGRAM);
        prop_assert_eq!(peek_header(&out[..n]), Ok(h));
        prop_assert_eq!(open::<HostMsg>(&key, &out[..n]), Ok((h, msg)));
    }

    #[test]
    fn robot_messages_round_trip_through_the_envelope(
        msg in robot_msg(), counter in 0..=MAX_COUNTER, key in any::<[u8; 32]>()
    ) {
        let key = SessionKey(key);
        let h = header_for(&msg, counter);
        let mut out = [0u8; MAX_DATAGRAM];
        let n = seal(&key, h, &msg, &mut out).expect("every robot message fits a datagram");
        prop_assert!(n <= MAX_DATAGRAM);
        prop_assert_eq!(peek_header(&out[..n]), Ok(h));
        prop_assert_eq!(open::<RobotMsg>(&key, &out[..n]), Ok((h, msg)));
    }

    /// Host → robot through the sessions, in order, counters strictly increasing.
    #[test]
    fn host_messages_round_trip_through_the_sessions(
        msgs in prop::collection::vec(host_session_msg(), 1..12)
    ) {
        let (mut host, mut robot) = pair();
        let mut last = None;
        for m in msgs {
            let f = host_frame(&mut host, &m);
            let (h, got) = robot.receive(&f).expect("accepted");
            prop_assert_eq!(got, m);
            prop_assert_eq!(h.direction, Direction::HostToRobot);
            prop_assert!(last.is_none_or(|l| h.counter > l));
            last = Some(h.counter);
        }
    }

    /// Robot → host through the sessions.
    #[test]
    fn robot_messages_round_trip_through_the_sessions(
        msgs in prop::collection::vec(robot_session_msg(), 1..12)
    ) {
        let (mut host, mut robot) = pair();
        for m in msgs {
            let f = robot_frame(&mut robot, &m);
            match to_host(&mut host, &f) {
                Ok(HostReceived::Message(h, got)) => {
                    prop_assert_eq!(got, m);
                    prop_assert_eq!(h.robot_id, ID);
                }
                other => prop_assert!(false, "not accepted: {:?}", other),
            }
        }
    }

    /// The handshake carries announce and welcome fields exactly.
    #[test]
    fn handshake_round_trips_announce_and_welcome(
        kind in robot_kind(), fw in firmware(), robot_nonce in any_nonce(), host_nonce in any_nonce(),
        reset_reason in prop::sample::select(ResetReason::ALL.to_vec())
    ) {
        let mut host = HostSession::new(ID, robot_key());
        let mut robot = RobotSession::new(ID, robot_key(), robot_nonce);
        robot.set_reset_reason(reset_reason);
        let mut a = [0u8; MAX_DATAGRAM];
        let mut w = [0u8; MAX_DATAGRAM];
        let n = robot.announce(kind, fw, &mut a).expect("announce");
        let welcome_len = match host.receive(&a[..n], || host_nonce, &mut w) {
            Ok(HostReceived::Announce { announce, welcome_len, new_session }) => {
                prop_assert_eq!(announce, Announce {
                    kind, firmware: fw, protocol_version: PROTOCOL_VERSION, robot_nonce, reset_reason
                });
                prop_assert!(new_session);
                welcome_len
            }
            other => { prop_assert!(false, "announce refused: {:?}", other); unreachable!() }
        };
        let (_, got) = robot.receive(&w[..welcome_len]).expect("welcome");
        prop_assert_eq!(got, HostMsg::Welcome { robot_nonce, host_nonce });
    }

    /// Any wheel speed that is not finite or beyond MAX_COMMAND_RPM is refused.
    #[test]
    fn out_of_range_wheel_speeds_are_malformed(
        bad in prop_oneof![
            Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY),
            (MAX_COMMAND_RPM + 0.1f32)..f32::MAX, f32::MIN..(-MAX_COMMAND_RPM - 0.1f32),
        ],
        ok in command_rpm(), left in any::<bool>()
    ) {
        let (mut host, mut robot) = pair();
        let (left_rpm, right_rpm) = if left { (bad, ok) } else { (ok, bad) };
        let f = host_frame(&mut host, &HostMsg::WheelSpeed { left_rpm, right_rpm });
        prop_assert_eq!(robot.receive(&f), Err(Rejection::MalformedPayload));
    }

    /// Raw duties beyond full scale are refused.
    #[test]
    fn out_of_range_duties_are_malformed(
        bad in prop_oneof![i16::MIN..-1000i16, 1001i16..=i16::MAX], ok in duty(), left in any::<bool>()
    ) {
        let (mut host, mut robot) = pair();
        let (l, r) = if left { (bad, ok) } else { (ok, bad) };
        let f = host_frame(&mut host, &HostMsg::RawDuty { left: l, right: r });
        prop_assert_eq!(robot.receive(&f), Err(Rejection::MalformedPayload));
    }

    /// Telemetry with a non-finite speed is refused by the host.
    #[test]
    fn non_finite_telemetry_is_malformed(t in telemetry(), slot in 0usize..4, which in 0usize..3) {
        let (mut host, mut robot) = pair();
        let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][which];
        let mut t = t;
        if slot < 2 { t.measured_rpm[slot] = bad } else { t.target_rpm[slot - 2] = bad }
        let f = robot_frame(&mut robot, &RobotMsg::Telemetry(t));
        prop_assert_eq!(to_host(&mut host, &f), Err(Rejection::MalformedPayload));
    }
}

#[test]
fn param_set_check_names_the_bad_field() {
    let good = ParamSet {
        pi: [PiGains { kp: 1.0, ki: 2.0 }; 3],
        failsafe_timeout_ms: 200,
        telemetry_hz: 20,
    };
    assert_eq!(good.check(), Ok(()));
    let mut g = good;
    g.pi[2].ki = f32::NAN;
    assert_eq!(g.check(), Err(ParamRejection::GainOutOfRange));
    let mut g = good;
    g.pi[0].kp = -0.1;
    assert_eq!(g.check(), Err(ParamRejection::GainOutOfRange));
    let mut g = good;
    g.failsafe_timeout_ms = 19;
    assert_eq!(g.check(), Err(ParamRejection::FailsafeTimeoutOutOfRange));
    let mut g = good;
    g.telemetry_hz = 101;
    assert_eq!(g.check(), Err(ParamRejection::TelemetryRateOutOfRange));
}
