//! A host [`Controller`] driving the 3-D world: where a simulated run hands an assembly to the
//! 3-D world at a scenario's `cross` step, the same controller goes on there. Every robot's
//! exact pose is the host's measurement ([`super::drive3d::view_of`]); each twist becomes
//! wheel speeds by the wheel geometry and is streamed with the controller's hold; a person's
//! hand lifts apart the couplings the controller asks for.

use puzzlebot_params::FleetParams;
use puzzlebot_sim::physics3d::{Event3d, World3d};

use super::drive3d::{held, view_at, wheel_rpms};
use crate::control::{CommandDelay, Controller, HandRequest};
use puzzlebot_protocol::RobotId;

/// How a controller's run in the 3-D world ended.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldRun {
    /// Controller time at the end (s).
    pub t_end: f64,
    /// The controller said it was done (false: the time limit ended the run).
    pub done: bool,
    /// Every event of the 3-D world (falls, opened connectors).
    pub events: Vec<Event3d>,
}

/// What the host streams over one period: every robot's wheel speeds (RPM) and the hold
/// (ms) for the whole world.
pub type Sent = (Vec<(RobotId, [f32; 2])>, u16);

/// Run `ctl` against `w` until it is done or `limit` s of controller time have passed; the
/// controller's clock goes on from `t_offset` s (where an earlier part of the run left it).
/// Its commands take effect after `delay` (the controller's latency; [`CommandDelay::new`]
/// for none). `hook` sees the world and the controller time at every controller period.
pub fn run(
    w: &mut World3d,
    ctl: &mut dyn Controller,
    params: &FleetParams,
    t_offset: f64,
    limit: f64,
    delay: &mut CommandDelay<Sent>,
    mut hook: impl FnMut(&World3d, f64),
) -> WorldRun {
    let period_us = (1e6 / ctl.rate_hz().clamp(0.1, 1000.0)) as u64;
    let start = w.time_us();
    let view = |w: &World3d| view_at(w, t_offset + (w.time_us() - start) as f64 * 1e-6);
    let mut done = false;
    delay.clear();
    loop {
        let view = view(w);
        hook(w, view.t);
        if view.t - t_offset >= limit {
            break;
        }
        let twists = ctl.update(&view);
        let rpms = view
            .robots
            .iter()
            .map(|r| {
                let rpm = twists
                    .get(&r.id)
                    .map_or([0.0, 0.0], |&t| wheel_rpms(t, params));
                (r.id, rpm)
            })
            .collect();
        // One hold for the whole world: the crossing's is the same for every robot.
        let hold = view.robots.iter().map(|r| ctl.hold_ms(r.id)).max();
        delay.push(w.time_us(), (rpms, hold.unwrap_or(0)));
        // A person's hand acts at once.
        for h in ctl.hand_requests() {
            let HandRequest::LiftKnobs { robots } = h;
            for (kind, a, b) in held(w) {
                if kind == puzzlebot_sim::LinkKind::Knob
                    && robots.contains(&a)
                    && robots.contains(&b)
                {
                    w.release(a, b);
                }
            }
        }
        if ctl.done(view.t) {
            done = true;
            break;
        }
        let end = w.time_us() + period_us;
        while let Some(at) = delay.next_due().filter(|&at| at <= end) {
            if at > w.time_us() {
                w.run_for(at - w.time_us());
            }
            if let Some((_, (rpms, hold))) = delay.pop_due(at) {
                for (id, rpm) in rpms {
                    w.command(id, Some(rpm));
                }
                w.hold_all(hold);
            }
        }
        if end > w.time_us() {
            w.run_for(end - w.time_us());
        }
    }
    w.command_all(Some([0.0, 0.0]));
    WorldRun {
        t_end: view(w).t,
        done,
        events: w.events().to_vec(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::FleetView;
    use crate::drive::Twist;
    use puzzlebot_sim::physics3d::Config3d;
    use std::collections::BTreeMap;

    /// Drives every robot forward at 0.1 m/s for one second.
    struct Forward;

    impl Controller for Forward {
        fn name(&self) -> &str {
            "forward"
        }
        fn update(&mut self, view: &FleetView) -> BTreeMap<RobotId, Twist> {
            view.robots
                .iter()
                .map(|r| (r.id, Twist::new(0.1, 0.0)))
                .collect()
        }
        fn done(&self, t: f64) -> bool {
            t >= 1.0
        }
    }

    /// How far the lone robot of a fresh world drives in one second with the commands
    /// delayed by `ms`.
    fn travelled(ms: f64) -> f64 {
        // A lone robot on the infinite floor.
        let s = crate::assemble::scattered_fleet(1, 0, 3);
        let params = s.params.clone();
        let mut w = World3d::new(&s, Config3d::default()).unwrap();
        let p0 = w.states()[0].position;
        let mut delay = CommandDelay::new(1);
        delay.set_delay_ms(ms);
        let r = run(
            &mut w,
            &mut Forward,
            &params,
            0.0,
            5.0,
            &mut delay,
            |_, _| {},
        );
        assert!(r.done);
        let p1 = w.states()[0].position;
        (p1[0] - p0[0]).hypot(p1[1] - p0[1])
    }

    #[test]
    fn the_controllers_latency_delays_its_commands_in_the_3d_world() {
        let (now, late) = (travelled(0.0), travelled(300.0));
        assert!(now > 0.05, "{now}");
        // 0.3 s later at 0.1 m/s: about 30 mm short.
        assert!(now - late > 0.015 && now - late < 0.045, "{now} {late}");
    }
}
