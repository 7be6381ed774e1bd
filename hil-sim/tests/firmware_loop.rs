//! The real firmware (`puzzlebot_firmware_core::Robot`) in lockstep with the plant.

mod common;

use common::{connect, drive, key, speed, MiniHost};
use puzzlebot_protocol::{flags, HostMsg, Rejection};
use puzzlebot_sim::{Impairments, MocapConfig, Scenario, World};

fn one_robot() -> (World, MiniHost) {
    let w = World::new(&Scenario::grid(1, 3), &key()).expect("world");
    (w, MiniHost::new(key()))
}

#[test]
fn counting_speed_shows_thesis_quantisation_and_timestamp_estimator_is_10x_finer() {
    let (mut w, mut host) = one_robot();
    connect(&mut w, &mut host, 2.0);
    let epr = Scenario::default()
        .params
        .non_pilot
        .firmware
        .encoder_edges_per_rev;
    let quantum = 60.0e6 / (f64::from(epr) * 20_000.0); // RPM per edge per 20 ms window
    let (mut err_count, mut err_est, mut n) = (0.0, 0.0, 0.0);
    let mut levels = std::collections::BTreeSet::new();
    for target in [40.0f32, 95.0, 150.0, 222.0, 290.0, 345.0, 410.0] {
        drive(&mut w, &mut host, 1.0, |_, _| Some(speed(target, target)));
        // Sample every firmware tick for 0.5 s while holding the command.
        let mut last_edges = w.ground_truth().robots[0].encoder_edges[0];
        let end = w.time_us() + 500_000;
        let mut next_cmd = w.time_us();
        while w.time_us() < end {
            w.step();
            host.pump(&mut w);
            if w.time_us() >= next_cmd {
                next_cmd += 33_333;
                let f = host.seal(1, &speed(target, target)).expect("session");
                w.send_to_robot(1, &f);
            }
            if w.time_us() % 20_000 == 0 {
                let t = w.ground_truth();
                let r = &t.robots[0];
                let edges = r.encoder_edges[0];
                let counting = (edges - last_edges) as f64 * quantum;
                last_edges = edges;
                let est = f64::from(r.firmware.expect("online").measured_rpm[0]);
                let truth = r.wheel_rpm[0];
                err_count += (counting - truth).powi(2);
                err_est += (est - truth).powi(2);
                n += 1.0;
                levels.insert((counting / quantum).round() as i64);
            }
        }
    }
    let (rms_count, rms_est) = ((err_count / n).sqrt(), (err_est / n).sqrt());
    println!(
        "quantum {quantum:.1} RPM, levels seen {levels:?}, RMS error counting {rms_count:.2} RPM, \
         timestamp estimator {rms_est:.3} RPM, ratio {:.1}",
        rms_count / rms_est
    );
    // THESIS 5.2.3: about seven distinct levels within 0–450 RPM at 50 Hz.
    let top = (450.0 / quantum).floor() as i64;
    assert!((6..=8).contains(&top), "{top} levels");
    assert!(levels.iter().all(|&l| (0..=top + 1).contains(&l)));
    assert!(levels.len() >= 5, "{levels:?}");
    assert!(rms_count > 10.0 * rms_est, "{rms_count} vs {rms_est}");
}

#[test]
fn a_robot_whose_commands_stop_is_stopped_by_its_own_failsafe() {
    let (mut w, mut host) = one_robot();
    connect(&mut w, &mut host, 2.0);
    drive(&mut w, &mut host, 1.0, |_, _| Some(speed(200.0, 200.0)));
    let t = w.ground_truth();
    assert!(
        t.robots[0].wheel_rpm[0] > 150.0,
        "{:?}",
        t.robots[0].wheel_rpm
    );
    assert!(w.is_driving(1));
    // Commands stop; the host keeps listening.
    drive(&mut w, &mut host, 0.15, |_, _| None);
    assert!(w.is_driving(1), "still within the 200 ms timeout");
    drive(&mut w, &mut host, 0.6, |_, _| None);
    let t = w.ground_truth();
    let r = &t.robots[0];
    let fw = r.firmware.expect("online");
    assert!(
        fw.flags & flags::FAILSAFE != 0,
        "failsafe flag: {:#x}",
        fw.flags
    );
    assert_eq!(r.duty, [0, 0]);
    assert!(
        r.wheel_rpm[0].abs() < 1.0 && r.v.abs() < 0.005,
        "{:?} {}",
        r.wheel_rpm,
        r.v
    );
}

#[test]
fn forged_and_replayed_datagrams_are_rejected_by_the_firmware() {
    let (mut w, mut host) = one_robot();
    connect(&mut w, &mut host, 2.0);
    drive(&mut w, &mut host, 0.5, |_, _| Some(speed(100.0, 100.0)));
    // A fresh valid command is accepted.
    let good = host.seal(1, &speed(120.0, 120.0)).expect("session");
    assert_eq!(w.inject(1, &good), Some(Ok(())));
    // The same bytes again: replay.
    assert_eq!(w.inject(1, &good), Some(Err(Rejection::Replay)));
    // A forged command (payload changed, tag kept): bad tag, and it changes nothing.
    let mut forged = host.seal(1, &speed(-400.0, 400.0)).expect("session");
    forged[12] ^= 0x55;
    assert_eq!(w.inject(1, &forged), Some(Err(Rejection::BadTag)));
    let t = w.ground_truth();
    let r = &t.robots[0];
    assert_eq!(r.rejected[Rejection::Replay as usize], 1);
    assert_eq!(r.rejected[Rejection::BadTag as usize], 1);
    assert_eq!(r.rejected.iter().sum::<u32>(), 2);
    assert_eq!(r.firmware.expect("online").target_rpm, [120.0, 120.0]);
    // Through the radio the same happens (the firmware counts it).
    w.send_to_robot(1, &good);
    w.step();
    assert_eq!(
        w.ground_truth().robots[0].rejected[Rejection::Replay as usize],
        2
    );
}

fn run_script(seed: u64) -> String {
    let mut s = Scenario::grid(3, seed);
    s.impairments = Impairments {
        latency_ms: 3.0,
        jitter_ms: 4.0,
        loss: 0.05,
        duplicate: 0.02,
        reorder: 0.02,
    };
    s.mocap = MocapConfig {
        dropout: 0.05,
        ..MocapConfig::default()
    };
    let mut w = World::new(&s, &key()).expect("world");
    let mut host = MiniHost::new(key());
    drive(&mut w, &mut host, 2.0, |t, id| {
        Some(speed(
            100.0 + 50.0 * (t * f64::from(id)).sin() as f32,
            150.0,
        ))
    });
    let mocap = w.take_mocap();
    let t = w.ground_truth();
    format!("{:?}\n{:?}\n{:?}", t.robots, t.events, mocap.last())
}

#[test]
fn the_same_seed_gives_bit_identical_runs() {
    let a = run_script(11);
    let b = run_script(11);
    assert_eq!(a, b);
    let c = run_script(12);
    assert_ne!(
        a, c,
        "a different seed must change something (nonces, loss, noise)"
    );
}

#[test]
fn a_rebooted_robot_announces_a_fresh_nonce_and_reconnects() {
    let (mut w, mut host) = one_robot();
    connect(&mut w, &mut host, 2.0);
    assert!(w.set_online(1, false));
    drive(&mut w, &mut host, 0.3, |_, _| Some(HostMsg::Stop));
    assert!(!w.ground_truth().robots[0].online);
    assert!(w.set_online(1, true));
    // The host's old session is stale; a new announce (new nonce) opens a new one.
    let mut saw_new = false;
    for _ in 0..2000 {
        w.step();
        for (id, frame) in w.take_from_robots() {
            if let Some(reply) = host.receive(id, &frame) {
                saw_new = true;
                w.send_to_robot(id, &reply);
            }
        }
    }
    assert!(saw_new, "the rebooted robot announced and was welcomed");
    drive(&mut w, &mut host, 1.0, |_, _| Some(speed(150.0, 150.0)));
    assert!(w.ground_truth().robots[0].wheel_rpm[0] > 100.0);
    assert!(w
        .events()
        .iter()
        .any(|e| e.kind == puzzlebot_sim::EventKind::Booted { id: 1, boot: 2 }));
}
