//! A robot whose control task stalls: its motors keep their last duties only until the
//! watchdog resets it (DESIGN.md §10), then coast; it boots again, announces
//! with reset reason `Hang` and drives again under a new session. Its neighbour, whose
//! loop runs normally, is never reset.

mod common;

use common::*;
use puzzlebot_firmware_core::{DriveMode, MotorOutputs, FAULT_OUTPUTS, WATCHDOG_TIMEOUT_MS};
use puzzlebot_protocol::{open, peek_header, MacKey, ResetReason, RobotId, RobotMsg, Stream};
use puzzlebot_sim::{Scenario, World};

const STALLED: RobotId = 1;
const HEALTHY: RobotId = 2;

/// One step: the world, then every datagram to the host; announces are opened with the
/// robot's hello key and their reset reasons returned.
fn step(w: &mut World, host: &mut MiniHost) -> Vec<(RobotId, ResetReason)> {
    w.step();
    let mut announced = Vec::new();
    for (id, frame) in w.take_from_robots() {
        if peek_header(&frame).is_ok_and(|h| h.stream == Stream::Hello) {
            let hello = MacKey::new(&key().robot_key(id).hello_key());
            if let Ok((_, RobotMsg::Announce(a))) = open::<RobotMsg>(&hello, &frame) {
                announced.push((id, a.reset_reason));
            }
        }
        if let Some(reply) = host.receive(id, &frame) {
            w.send_to_robot(id, &reply);
        }
    }
    announced
}

fn bridges(w: &World, id: RobotId) -> MotorOutputs {
    let t = w.ground_truth();
    let r = t.robot(id).expect("robot");
    MotorOutputs {
        left: r.bridge[0],
        right: r.bridge[1],
    }
}

fn wheel_rpm(w: &World, id: RobotId) -> f64 {
    let t = w.ground_truth();
    let r = t.robot(id).expect("robot");
    r.wheel_rpm[0].abs().max(r.wheel_rpm[1].abs())
}

/// Send a wheel-speed command to every established robot.
fn command(w: &mut World, host: &mut MiniHost, rpm: f32) {
    for id in [STALLED, HEALTHY] {
        if host.established(id) {
            if let Some(f) = host.seal(id, &speed(rpm, rpm)) {
                w.send_to_robot(id, &f);
            }
        }
    }
}

#[test]
fn a_stalled_control_task_is_reset_by_the_watchdog_and_comes_back() {
    let mut w = World::new(&Scenario::grid(2, 3), &key()).expect("world");
    let mut host = MiniHost::new(key());
    let mut first = Vec::new();
    while !(host.established(STALLED) && host.established(HEALTHY)) {
        first.extend(step(&mut w, &mut host));
        assert!(w.time_us() < 2_000_000, "robots did not connect");
    }
    assert!(
        first.iter().all(|(_, r)| *r == ResetReason::PowerOn),
        "first boot announces power-on: {first:?}"
    );

    // Drive both at 200 RPM (commands at 30 Hz, as the host does).
    let drive_until = w.time_us() + 1_000_000;
    let mut next_cmd = 0;
    while w.time_us() < drive_until {
        step(&mut w, &mut host);
        if w.time_us() >= next_cmd {
            next_cmd = w.time_us() + 33_333;
            command(&mut w, &mut host, 200.0);
        }
    }
    assert!(wheel_rpm(&w, STALLED) > 150.0, "driving before the stall");
    let driving = bridges(&w, STALLED);
    assert!(!driving.is_stopped());

    // The stall: the host keeps commanding, the robot's loop does not run.
    assert!(w.stall_control(STALLED));
    let t_stall = w.time_us();
    let timeout_us = u64::from(WATCHDOG_TIMEOUT_MS) * 1000;
    let mut t_safe = None;
    let mut after = Vec::new();
    let mut held_before_reset = true;
    while w.time_us() < t_stall + 2_000_000 {
        after.extend(step(&mut w, &mut host));
        if w.time_us() >= next_cmd {
            next_cmd = w.time_us() + 33_333;
            command(&mut w, &mut host, 200.0);
        }
        let b = bridges(&w, STALLED);
        if t_safe.is_none() {
            if b == FAULT_OUTPUTS {
                t_safe = Some(w.time_us());
            } else if b != driving {
                held_before_reset = false;
            }
        }
    }
    let t_safe = t_safe.expect("the stalled robot's motors reached the fault outputs");
    // The stall is real: the PWM held its duties (what the watchdog is for) until the reset.
    assert!(
        held_before_reset,
        "a stalled loop cannot change its outputs"
    );
    assert!(
        t_safe - t_stall <= timeout_us,
        "coast {} µs after the stall, watchdog period {timeout_us} µs",
        t_safe - t_stall
    );
    assert!(
        t_safe - t_stall > timeout_us / 2,
        "not before the watchdog could fire"
    );
    assert_eq!(w.watchdog_resets(STALLED), Some(1));
    assert_eq!(
        w.watchdog_resets(HEALTHY),
        Some(0),
        "a healthy loop is never reset"
    );

    // It came back: announced with the hang as its reset reason, a new session, driving.
    let reasons: Vec<_> = after
        .iter()
        .filter(|(id, _)| *id == STALLED)
        .map(|(_, r)| *r)
        .collect();
    assert!(
        !reasons.is_empty(),
        "the robot announced again after its reset"
    );
    assert!(
        reasons.iter().all(|r| *r == ResetReason::Hang),
        "{reasons:?}"
    );
    assert!(host.established(STALLED), "a new session after the reboot");
    let fw = w.firmware(STALLED).expect("online");
    assert_eq!(fw.status().mode, DriveMode::Speed, "driving again");
    assert!(wheel_rpm(&w, STALLED) > 150.0, "wheels back at speed");
    assert!(wheel_rpm(&w, HEALTHY) > 150.0);
}

#[test]
fn a_stalled_robot_coasts_to_a_stop_after_its_reset() {
    let mut w = World::new(&Scenario::grid(1, 4), &key()).expect("world");
    let mut host = MiniHost::new(key());
    while !host.established(STALLED) {
        step(&mut w, &mut host);
        assert!(w.time_us() < 2_000_000, "robot did not connect");
    }
    let end = w.time_us() + 1_000_000;
    let mut next_cmd = 0;
    while w.time_us() < end {
        step(&mut w, &mut host);
        if w.time_us() >= next_cmd {
            next_cmd = w.time_us() + 33_333;
            command(&mut w, &mut host, 300.0);
        }
    }
    assert!(wheel_rpm(&w, STALLED) > 250.0);
    w.stall_control(STALLED);
    // No host commands from now on: the rebooted robot stays idle (coast), the wheels stop.
    let t_stall = w.time_us();
    while w.time_us() < t_stall + 1_000_000 {
        step(&mut w, &mut host);
    }
    assert_eq!(bridges(&w, STALLED), FAULT_OUTPUTS);
    assert!(
        wheel_rpm(&w, STALLED) < 1.0,
        "wheels still at {} RPM",
        wheel_rpm(&w, STALLED)
    );
}

#[test]
fn a_robot_switched_off_stays_off() {
    let mut w = World::new(&Scenario::grid(1, 5), &key()).expect("world");
    let mut host = MiniHost::new(key());
    while !host.established(STALLED) {
        step(&mut w, &mut host);
        assert!(w.time_us() < 2_000_000, "robot did not connect");
    }
    assert!(w.set_online(STALLED, false));
    let t_off = w.time_us();
    let mut announced = Vec::new();
    while w.time_us() < t_off + 1_000_000 {
        announced.extend(step(&mut w, &mut host));
    }
    assert!(
        w.firmware(STALLED).is_none(),
        "no watchdog boots a robot that is off"
    );
    assert!(announced.is_empty(), "{announced:?}");
    assert_eq!(w.watchdog_resets(STALLED), Some(0));
}
