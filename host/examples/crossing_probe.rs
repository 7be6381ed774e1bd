//! One run of `puzzlebot experiment crossing` traced: every 10 ms the advance, each robot's
//! position, sag, pitch and roll (mm, degrees), each coupling's force and moment components
//! in % of its limits (physics), and the share of its limits each connection uses in the
//! gate's elastic distribution for the assembly as planned, translated by that advance.
//!
//! `cargo run --release -p puzzlebot-host --example crossing_probe -- "mesh 2x3" none 70 6 0 90`
//! (shape, pilots, gap width mm, drop mm, heading degrees, stop after mm). `SUPPORT=k` takes
//! the gate's supports k times softer than the connectors (0: rigid); `SETTLE=1` stops the
//! drive there and traces the assembly standing for a second; `TRACE_US=n` traces every n µs (default
//! 10 000) from the advance `FROM=mm` on (default 0); `SPEED=f` drives at f times the
//! crossing speed; `START_AT=mm` sets the assembly down that far along the crossing;
//! `CONTACT_HZ=f` sets the engine's contact frequency; `RUN=k` sets the assembly down as run k
//! of the experiment's case, with its start jitter; `SOFT=wheels` or `SOFT=casters` takes
//! only those supports soft in the gate's distribution.

use puzzlebot_host::crossing::drive3d;
use puzzlebot_host::experiment::crossing::{
    configs, predict, run_scenario, set_down, settings, Obstacle, Options,
};
use puzzlebot_params::FleetParams;
use puzzlebot_sim::physics3d::World3d;
use puzzlebot_stability::crossing::formed;
use puzzlebot_stability::elastic;
use puzzlebot_stability::puzzlebot::{
    assembly_level, build_model_with, max_safe_advance_with, AdvanceOptions, LoadTransfer,
};
use puzzlebot_stability::sag::settle_articulated;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let shape_name = a.get(1).cloned().unwrap_or("mesh 2x3".into());
    let pilots = a.get(2).cloned().unwrap_or("none".into());
    let num = |i: usize, d: f64| a.get(i).and_then(|s| s.parse().ok()).unwrap_or(d);
    let obstacle = Obstacle {
        width: num(3, 60.0) * 1e-3,
        drop: num(4, 0.0) * 1e-3,
    };
    let heading = num(5, 0.0);
    let until = num(6, 1e9) * 1e-3;
    let params = FleetParams::default();
    let cfgs = configs(&[2, 4, 6, 8, 9], &params);
    let cfg = cfgs
        .iter()
        .find(|c| c.shape == shape_name && c.pilots == pilots)
        .expect("configuration");
    let (cand, rigid) = predict(cfg, obstacle, heading, &params).expect("predict");
    println!(
        "gate {:.1} mm {:?}; rigid {:.1} mm {:?}; required {:.1} mm; start {:?}",
        cand.advance.distance * 1e3,
        cand.advance.limited_by,
        rigid.distance * 1e3,
        rigid.limited_by,
        cand.required * 1e3,
        cand.start
    );
    let formed_asm = set_down(cfg, &params).expect("a shape");
    let (shape, n) = (formed_asm.shape, formed_asm.ids.len());
    let terrain = obstacle.terrain();
    let mut settings = settings();
    if let Some(hz) = std::env::var("CONTACT_HZ")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
    {
        settings.world.contact_frequency = hz;
    }
    // `START_AT=mm` sets the assembly down that far along the crossing (no history).
    let start_at = std::env::var("START_AT")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(0.0)
        * 1e-3;
    let mut placed = cand.clone();
    let hd = heading.to_radians();
    placed.start = [
        cand.start[0] + start_at * hd.cos(),
        cand.start[1] + start_at * hd.sin(),
    ];
    // `RUN=k` sets it down as run k of the experiment's case (seeded start jitter from 1 on).
    let s = match std::env::var("RUN")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        Some(run) => run_scenario(
            &formed_asm,
            &placed,
            &terrain,
            &params,
            Options::full().seed,
            run,
        ),
        None => drive3d::scenario(&formed_asm, &placed, &terrain, &params, 1),
    };
    let mut w = World3d::new(&s, settings.world).expect("world");
    w.run_for((settings.settle_s * 1e6) as u64);
    let h = heading.to_radians();
    let dir = [h.cos(), h.sin()];
    let start: Vec<[f64; 3]> = w.states().iter().map(|r| r.position).collect();
    let slow = std::env::var("SPEED")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(1.0);
    let rpm = drive3d::rpm_for(settings.speed * slow, &params);
    w.command_all(Some([rpm, rpm]));
    let strength = |k: puzzlebot_sim::LinkKind| {
        let p = &params.non_pilot;
        let lever = 0.5 * f64::from(p.geometry.height);
        let f = f64::from(match k {
            puzzlebot_sim::LinkKind::Anchor => p.coupling.anchor_hold_force,
            puzzlebot_sim::LinkKind::Knob => p.coupling.knob_hold_force,
        });
        (f, f * lever)
    };
    let planned = formed(shape, &cfg.pilot_places, &params, cand.start, h);
    let level = assembly_level(&planned, &params, &terrain).expect("level");
    let aopt = drive3d::crossing_options(&settings, &params).advance_options(cand.required);
    // The gate's advance without the transfer check and with a few damping ratios.
    let transfers = [None, Some(0.0), Some(0.1), Some(0.2), Some(0.4)];
    let mut answers = String::from("gate advance by connector damping ratio:");
    for z in transfers {
        let opt = AdvanceOptions {
            transfer: z.map(|damping_ratio| LoadTransfer {
                damping_ratio,
                ..LoadTransfer::default()
            }),
            ..aopt
        };
        let adv = max_safe_advance_with(&planned, &params, &terrain, h, 0.005, opt).expect("gate");
        answers += &format!(
            " {}: {:.1} mm {:?};",
            z.map_or("static".to_string(), |z| format!("ζ {z}")),
            adv.distance * 1e3,
            adv.limited_by
        );
    }
    println!("{answers}");
    // The rigid gate's answer without one of its idealisations at a time.
    let rigid = AdvanceOptions {
        rigid_couplings: true,
        ..aopt
    };
    let mut answers = String::from("rigid gate:");
    for (name, opt) in [
        ("as planned", rigid),
        (
            "quasi-static",
            AdvanceOptions {
                drive_accel: 0.0,
                ..rigid
            },
        ),
        (
            "knob tilt held",
            AdvanceOptions {
                knob_tilt_free: false,
                ..rigid
            },
        ),
        (
            "anchor pitch held",
            AdvanceOptions {
                anchor_pitch_free: false,
                ..rigid
            },
        ),
    ] {
        let adv = max_safe_advance_with(&planned, &params, &terrain, h, 0.005, opt).expect("gate");
        answers += &format!(
            " {name}: {:.1} mm {:?};",
            adv.distance * 1e3,
            adv.limited_by
        );
    }
    println!("{answers}");
    let kinds: Vec<_> = w.couplings().iter().map(|c| (c.0, c.1, c.2)).collect();
    println!("couplings {kinds:?}");
    let mut seen = 0;
    let mut stopped: Option<u64> = None;
    let goal = cand.required + settings.overshoot;
    let env = |k: &str, d: f64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(d)
    };
    let (trace_us, from) = (env("TRACE_US", 10_000.0) as u64, env("FROM", 0.0) * 1e-3);
    while w.time_us() < 60_000_000 {
        w.run_for(trace_us);
        let st = w.states();
        let d = st
            .iter()
            .zip(&start)
            .map(|(r, p0)| (r.position[0] - p0[0]) * dir[0] + (r.position[1] - p0[1]) * dir[1])
            .sum::<f64>()
            / n as f64
            + start_at;
        if d < from && d < goal && d < until {
            continue;
        }
        let mut line = format!("t {:7.3} d {:6.2}", w.time_us() as f64 * 1e-6, d * 1e3);
        // The gate's settling of the assembly as planned there: each robot's sink at its
        // centre and its pitch.
        let off = [dir[0] * d, dir[1] * d];
        let gm = build_model_with(&planned, &params, &terrain, level, off, &aopt).expect("model");
        let sag = aopt
            .settling
            .and_then(|s| settle_articulated(&gm, &s.softest()));
        for (i, (r, p0)) in st.iter().zip(&start).enumerate() {
            let (gz, gp) = sag.as_ref().map_or((f64::NAN, f64::NAN), |sg| {
                let c = [planned.robots[i].x + off[0], planned.robots[i].y + off[1]];
                (-sg.sink(i, c), sg.tilt(i)[1])
            });
            line += &format!(
                " | x{:6.1} z{:5.2} p{:5.1} r{:5.1} gz{:5.2} gp{:5.1}",
                r.position[0] * 1e3,
                (r.position[2] - p0[2]) * 1e3,
                r.rpy[1].to_degrees(),
                r.rpy[0].to_degrees(),
                gz * 1e3,
                gp.to_degrees()
            );
        }
        line += " ||";
        for (l, k) in w.coupling_loads().iter().zip(&kinds) {
            match l {
                Some((f, m)) => {
                    let (fl, ml) = strength(k.0);
                    let fs: Vec<String> = f
                        .iter()
                        .map(|v| format!("{:4.0}", 100.0 * v / fl))
                        .collect();
                    let ms: Vec<String> = m
                        .iter()
                        .map(|v| format!("{:4.0}", 100.0 * v / ml))
                        .collect();
                    line += &format!(
                        " {}{}-{}[{}/{}]",
                        if k.0 == puzzlebot_sim::LinkKind::Anchor {
                            "A"
                        } else {
                            "K"
                        },
                        k.1,
                        k.2,
                        fs.join(""),
                        ms.join("")
                    );
                }
                None => line += " x",
            }
        }
        // The gate's elastic use of every connection limit with the assembly as planned,
        // translated by the measured advance.
        let m = build_model_with(
            &planned,
            &params,
            &terrain,
            level,
            [dir[0] * d, dir[1] * d],
            &aopt,
        )
        .expect("model");
        let mut m = m;
        if std::env::var("NOFRIC").is_ok() {
            // The supports carry no tangential force.
            m.contacts.iter_mut().for_each(|k| k.mu = [0.0, 0.0]);
        }
        let r = m.resolve().expect("resolve");
        let c = &params.non_pilot.coupling;
        let comp = elastic::Compliance {
            force: 1.0 / f64::from(c.connector_stiffness),
            couple: 1.0 / f64::from(c.connector_angular_stiffness),
            support: std::env::var("SUPPORT")
                .ok()
                .and_then(|v| v.parse::<f64>().ok())
                .unwrap_or(0.0)
                / f64::from(c.connector_stiffness),
        };
        line += " || gate";
        // `SOFT=wheels` (or `casters`): only those supports give, the others are rigid.
        let soft = std::env::var("SOFT").unwrap_or_default();
        let scale: Vec<f64> = m
            .contacts
            .iter()
            .map(|k| {
                let wheel = k.mu[0] > 0.0;
                match soft.as_str() {
                    "wheels" => f64::from(u8::from(wheel)),
                    "casters" => f64::from(u8::from(!wheel)),
                    _ => 1.0,
                }
            })
            .collect();
        match elastic::distribution_with_supports(&r, comp, &[], &scale) {
            Ok(Some(wr)) => {
                for u in elastic::use_of_limits(&r, &wr) {
                    line += &format!(" {:4.0}", 100.0 * u.unwrap_or(0.0));
                }
            }
            Ok(None) => line += " tips",
            Err(e) => line += &format!(" {e}"),
        }
        println!("{line}");
        for e in &w.events()[seen..] {
            println!("EVENT {e:?} at {:.1} mm", d * 1e3);
        }
        seen = w.events().len();
        if d >= goal || d >= until {
            match stopped {
                None if std::env::var("SETTLE").is_ok() => {
                    // Stop the drive and trace the assembly standing for a second.
                    w.command_all(Some([0.0, 0.0]));
                    println!("stopped:");
                    stopped = Some(w.time_us());
                }
                Some(t) if w.time_us() < t + 1_000_000 => {}
                _ => break,
            }
        }
    }
}
