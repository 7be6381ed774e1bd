//! A host [`Controller`] driving the 3-D world: where a simulated run hands an assembly to the
//! 3-D world at a scenario's `cross` step, the same controller goes on there. Every robot's
//! exact pose is the host's measurement ([`super::drive3d::view_of`]); each twist becomes
//! wheel speeds by the wheel geometry and is streamed with the controller's hold; a person's
//! hand lifts apart the couplings the controller asks for.

use puzzlebot_params::FleetParams;
use puzzlebot_sim::physics3d::{Event3d, World3d};

use super::drive3d::{held, view_at, wheel_rpms};
use crate::control::{Controller, HandRequest};

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

/// Run `ctl` against `w` until it is done or `limit` s of controller time have passed; the
/// controller's clock goes on from `t_offset` s (where an earlier part of the run left it).
/// `hook` sees the world and the controller time at every controller period.
pub fn run(
    w: &mut World3d,
    ctl: &mut dyn Controller,
    params: &FleetParams,
    t_offset: f64,
    limit: f64,
    mut hook: impl FnMut(&World3d, f64),
) -> WorldRun {
    let period_us = (1e6 / ctl.rate_hz().clamp(0.1, 1000.0)) as u64;
    let start = w.time_us();
    let view = |w: &World3d| view_at(w, t_offset + (w.time_us() - start) as f64 * 1e-6);
    let mut done = false;
    loop {
        let view = view(w);
        hook(w, view.t);
        if view.t - t_offset >= limit {
            break;
        }
        let twists = ctl.update(&view);
        for r in &view.robots {
            let rpm = twists
                .get(&r.id)
                .map_or([0.0, 0.0], |&t| wheel_rpms(t, params));
            w.command(r.id, Some(rpm));
        }
        // One hold for the whole world: the crossing's is the same for every robot.
        let hold = view.robots.iter().map(|r| ctl.hold_ms(r.id)).max();
        w.hold_all(hold.unwrap_or(0));
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
        w.run_for(period_us);
    }
    w.command_all(Some([0.0, 0.0]));
    WorldRun {
        t_end: view(w).t,
        done,
        events: w.events().to_vec(),
    }
}
