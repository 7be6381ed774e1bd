//! The host's side of a crossing in the 3-D world: set a formed assembly down where the
//! planner starts it, drive it along the planned heading through its firmware (every robot
//! the same wheel speed), re-check it with the stability gate at every advance from its
//! measured poses and stop it the moment the gate cannot prove it, then take it apart on the
//! far platform.

use super::controller::{CrossStop, CrossingController};
use super::formed::Formed;
use crate::control::{Controller, FleetView, RobotView};
use crate::drive::{PoseSample, Twist};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::RobotId;
use puzzlebot_sim::physics3d::{Config3d, Event3d, RobotState3d, World3d};
use puzzlebot_sim::{CouplingSpec, LinkKind, RobotSpec, Scenario};
use puzzlebot_stability::crossing::{formed_with, platform_at, Candidate, CrossingOptions};
use puzzlebot_stability::puzzlebot::LoadTransfer;
use puzzlebot_stability::sag::Settling;
use serde::Serialize;

/// How the host drives a crossing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossSettings {
    /// Driving speed (m/s): [`quasi_static_speed`], so the crossing stays near the gate's
    /// static picture.
    pub speed: f64,
    /// Advance between two gate checks of the measured poses (m): the planner's scan step.
    pub gate_every: f64,
    /// Drive on past the planner's required advance (m): half a body, a margin for the
    /// measured advance (an average over robots whose anchors slide) to pass it.
    pub overshoot: f64,
    /// Standing time before driving and after stopping (s): the assembly settles.
    pub settle_s: f64,
    /// Check the measured assembly with the gate every `gate_every` and stop when it cannot
    /// prove it (the host's crossing); off for experiments that measure the physics alone.
    pub live_gate: bool,
    /// Stop at the first fall or opened connector (the host's crossing); experiments drive
    /// on to count the robots that still reach the far platform.
    pub stop_on_failure: bool,
    /// After a gate stop short of the planned advance, back off to where the crossing
    /// started ([`super::controller::CrossingController`]) rather than stand astride the gap.
    pub back_off: bool,
    /// Through a stretch the plan proves only at speed, ask the robots to keep driving when
    /// the link falls silent ([`puzzlebot_protocol::HostMsg::WheelSpeedHold`]) until past
    /// it: there the firmware's failsafe stop would tip the assembly.
    pub hold_through_stretches: bool,
    /// Fault injection: the advance (m) at which the host's commands stop reaching the
    /// robots, which then only the firmware's failsafe stops; `None`: the link holds.
    pub link_loss_at: Option<f64>,
    /// Heading feedback of every non-pilot (1/s): each turns at this rate times its measured
    /// heading's error from the plan's. A line is free to yaw at its anchors, and pushed from
    /// behind with equal wheel speeds it snakes and folds back on itself; steered, it stays
    /// straight. [`heading_gain`]; 0: equal wheel speeds. Pilots drive straight only (THESIS
    /// 5.4.1).
    pub heading_gain: f64,
    /// How much faster than `speed` the fastest member may drive while the assembly turns
    /// back to its heading (a fraction of `speed`): the members turn as one rigid body about
    /// the innermost, the outer ones faster ([`super::controller::CrossingController`]).
    /// 0.5 is the one value measured (67 mm/s at the default speed, a wheel far inside its
    /// 450 RPM); 0: no turning of the whole body, only each non-pilot on its own.
    pub max_speed_up: f64,
    /// The 3-D world's settings.
    pub world: Config3d,
}

/// Heading feedback gain of the crossing drive (1/s): the outer heading loop a tenth as fast
/// as the firmware's wheel-speed reference, 1 / (10 · reference_tau), so that the two loops
/// do not interact.
pub fn heading_gain(params: &FleetParams) -> f64 {
    let tau = 1e-3 * f64::from(params.non_pilot.firmware.reference_tau_ms);
    if tau > 0.0 {
        1.0 / (10.0 * tau)
    } else {
        0.0
    }
}

/// Driving speed at which a crossing stays close to the gate's quasi-static picture (m/s).
/// When a support rolls off an edge, its load moves onto the connectors while the contact
/// sinks by the connectors' static deflection under a robot's weight, δ = m·g / k; a caster
/// of radius r sinks that far over an advance √(2·r·δ). Driven at this speed, that transfer
/// takes one natural period T = 2π·√(m / k) of one robot on the connector springs. A load
/// ramped linearly over a time t ≥ T leaves an undamped spring ringing by at most
/// T / (π·t) ≤ 1/π of the change (none at t = T exactly), against the whole change for a
/// sudden step. The transfer at an edge is no linear ramp, though: the sink follows the
/// caster's arc, a parabola in the advance that puts most of the change at its end (a
/// parabolic ramp over one period leaves 1/π), and the robots around the one that drops add
/// their mass and lengthen the period. Crossings in the 3-D physics overshoot by up to about
/// half the change, so the speed lowers the overshoot without bounding it; the gate's check
/// does not rely on it and bounds the peak by the undamped step's twice the change
/// (`puzzlebot_stability::transfer::LoadTransfer`).
pub fn quasi_static_speed(params: &FleetParams) -> f64 {
    let p = &params.non_pilot;
    let m = f64::from(p.mass.mass);
    let k = f64::from(p.coupling.connector_stiffness);
    let r = f64::from(p.plant.caster_radius.min(p.geometry.wheel_radius));
    let delta = m * puzzlebot_sim::drive::G / k;
    let transfer = (2.0 * r * delta).sqrt();
    let period = std::f64::consts::TAU * (m / k).sqrt();
    transfer / period
}

/// The planner's options for a crossing driven with `settings`: the gate's proof covers the
/// drive speeding up to and braking from `settings.speed` along the firmware's reference
/// response (time constant `firmware.reference_tau_ms`), a = v / τ; the supports give as the
/// 3-D world's soft contacts, whose stiffness is m·(2π·f)² for the mass m of the body they
/// hold at the engine's contact frequency f (a wheel's own, a caster's the chassis'), and the
/// bodies stand its chassis clearance high.
pub fn crossing_options(settings: &CrossSettings, params: &FleetParams) -> CrossingOptions {
    let tau = [&params.pilot, &params.non_pilot]
        .iter()
        .map(|p| 1e-3 * f64::from(p.firmware.reference_tau_ms))
        .fold(f64::INFINITY, f64::min);
    let w = &settings.world;
    let per_kg = (std::f64::consts::TAU * w.contact_frequency).powi(2);
    // A non-pilot's chassis: its mass less its two wheels'.
    let chassis = f64::from(params.non_pilot.mass.mass) - 2.0 * w.wheel_mass;
    CrossingOptions {
        drive_accel: if tau > 0.0 { settings.speed / tau } else { 0.0 },
        settling: Some(Settling {
            wheel_compliance: 1.0 / (w.wheel_mass * per_kg),
            caster_compliance: 1.0 / (chassis.max(w.wheel_mass) * per_kg),
            body_clearance: w.chassis_clearance,
            max_droop: w.fall_depth,
            chassis_friction: w.chassis_friction,
            ..Settling::couplings(&params.non_pilot)
        }),
        bridge_speed: settings.speed,
        transfer: LoadTransfer::of(params),
        ..CrossingOptions::default()
    }
}

impl Default for CrossSettings {
    fn default() -> Self {
        CrossSettings::for_params(&FleetParams::default())
    }
}

impl CrossSettings {
    /// The host's crossing of robots with `params`: at their quasi-static speed, steered
    /// with their heading gain, the gate checking every 5 mm, holds through the stretches
    /// proven only at speed, stopping at the first failure.
    pub fn for_params(params: &FleetParams) -> Self {
        CrossSettings {
            speed: quasi_static_speed(params),
            gate_every: 0.005,
            overshoot: 0.025,
            settle_s: 0.5,
            live_gate: true,
            stop_on_failure: true,
            back_off: true,
            hold_through_stretches: true,
            link_loss_at: None,
            heading_gain: heading_gain(params),
            max_speed_up: 0.5,
            world: Config3d::default(),
        }
    }
}

/// Wheel speeds (RPM, left and right) that drive a robot at the twist `t`.
pub fn wheel_rpms(t: Twist, params: &FleetParams) -> [f32; 2] {
    let half_base = 0.5 * f64::from(params.non_pilot.geometry.wheel_base);
    let [l, r] = [t.v - t.omega * half_base, t.v + t.omega * half_base];
    [rpm_for(l, params), rpm_for(r, params)]
}

/// Wheel speed (RPM) that drives a robot at `v` (m/s).
pub fn rpm_for(v: f64, params: &FleetParams) -> f32 {
    let r = f64::from(params.non_pilot.geometry.wheel_radius);
    (v / r * 60.0 / std::f64::consts::TAU) as f32
}

/// The 3-D scenario of `formed` standing where candidate `c` starts, at its heading.
pub fn scenario(
    formed: &Formed,
    c: &Candidate,
    terrain: &Terrain,
    params: &FleetParams,
    seed: u64,
) -> Scenario {
    let a = formed_with(
        formed.shape,
        &formed.pilots(),
        &formed.links,
        params,
        c.start,
        c.heading_deg.to_radians(),
    );
    let robots = a
        .robots
        .iter()
        .zip(&formed.ids)
        .map(|(r, &id)| RobotSpec {
            id,
            kind: r.kind,
            pose: [r.x, r.y, r.yaw],
            impairments: None,
            offline: false,
            mismatch: Default::default(),
        })
        .collect();
    let couplings = formed
        .links
        .iter()
        .map(|&(l, a, b)| CouplingSpec {
            kind: l.into(),
            a: formed.ids[a],
            b: formed.ids[b],
        })
        .collect();
    Scenario {
        seed,
        robots,
        couplings,
        terrain: terrain.clone(),
        params: params.clone(),
        ..Scenario::default()
    }
}

/// A connector that opened.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Broken {
    /// Anchor or knob.
    pub kind: LinkKind,
    /// Robot with the anchor / knob.
    pub a: RobotId,
    /// Robot with the opening / hole.
    pub b: RobotId,
    /// Advance at the break (m).
    pub advance: f64,
}

/// What a driven crossing did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CrossOutcome {
    /// Every robot stands on a platform other than the start one, none fell, no connector
    /// opened, the gate never stopped it.
    pub crossed: bool,
    /// Advance of the assembly along the heading when it stopped (m).
    pub advance: f64,
    /// Advance after it stopped and stood for `settle_s` (m): where it came to rest.
    pub rest_advance: f64,
    /// Farthest advance it reached, the run-out after the stop included (m).
    pub peak_advance: f64,
    /// Simulated time of the drive (s).
    pub drive_s: f64,
    /// Gate checks of the measured poses.
    pub gate_checks: usize,
    /// Advance at which the gate could not prove the measured assembly, and its verdict.
    pub gate_stop: Option<(f64, String)>,
    /// Robots that fell, with the advance (m).
    pub fell: Vec<(RobotId, f64)>,
    /// Connectors that opened.
    pub broke: Vec<Broken>,
    /// Largest load a knob carried, as a share of its hold force.
    pub peak_knob_share: f64,
    /// Robots across (on another platform than the start one, at its height ± 2 mm).
    pub across: usize,
}

/// Couplings still holding (kind, a, b).
pub fn held(w: &World3d) -> Vec<(LinkKind, RobotId, RobotId)> {
    w.couplings()
        .into_iter()
        .filter(|c| c.3)
        .map(|c| (c.0, c.1, c.2))
        .collect()
}

/// Drive the assembly of `w` (standing where `c` starts) across along `c`'s heading with
/// the host's [`CrossingController`] on the world's poses (its own gate checks them against
/// the couplings holding at the start); stop once it advanced `c.required + overshoot`, the
/// gate cannot prove the measured assembly, or (with `stop_on_failure`) a robot fell or a
/// connector opened.
pub fn cross(
    w: &mut World3d,
    c: &Candidate,
    terrain: &Terrain,
    params: &FleetParams,
    s: &CrossSettings,
) -> CrossOutcome {
    w.run_for((s.settle_s * 1e6) as u64);
    let start: Vec<[f64; 3]> = w.states().iter().map(|r| r.position).collect();
    let start_platform = start
        .first()
        .and_then(|p| platform_at(terrain, [p[0], p[1]]));
    let members = w.states().iter().map(|r| r.id).collect();
    let mut ctl = CrossingController::new(
        c.clone(),
        terrain.clone(),
        params.clone(),
        *s,
        members,
        held(w),
    );
    let t_limit = w.time_us() + (ctl.time_limit_s() * 1e6) as u64;
    let t0 = w.time_us();
    let tick_us = (1e6 / ctl.rate_hz()).round() as u64;
    let mut out = CrossOutcome {
        crossed: false,
        advance: 0.0,
        rest_advance: 0.0,
        peak_advance: 0.0,
        drive_s: 0.0,
        gate_checks: 0,
        gate_stop: None,
        fell: vec![],
        broke: vec![],
        peak_knob_share: 0.0,
        across: 0,
    };
    // The host's commands to the world: each twist as wheel speeds, with its hold.
    let apply = |w: &mut World3d, ctl: &mut CrossingController, view: &FleetView| {
        for (id, t) in ctl.update(view) {
            w.command(id, Some(wheel_rpms(t, params)));
        }
        w.hold_all(ctl.hold_ms(0));
    };
    let mut seen_events = w.events().len();
    let mut linked = true;
    // Without the link the robots stop on their own: by the longest hold and the failsafe
    // timeout, and a second to come to rest.
    let fw = [&params.pilot, &params.non_pilot].map(|p| p.firmware);
    let silence_us = fw
        .iter()
        .map(|f| (u64::from(f.max_hold_ms) + u64::from(f.failsafe_timeout_ms)) * 1000)
        .max()
        .unwrap_or(0)
        + 1_000_000;
    let mut lost_us = u64::MAX;
    apply(w, &mut ctl, &view_of(w));
    while (w.time_us() < t_limit || ctl.backing())
        && w.time_us().saturating_sub(lost_us) < silence_us
    {
        w.run_for(tick_us);
        let view = view_of(w);
        let d = ctl.advance(&view);
        out.advance = d;
        if linked && s.link_loss_at.is_some_and(|at| d >= at) {
            linked = false;
            lost_us = w.time_us();
            w.command_all(None);
        }
        for e in &w.events()[seen_events..] {
            match *e {
                Event3d::Fell { id, .. } => out.fell.push((id, d)),
                Event3d::Broke { kind, a, b, .. } => out.broke.push(Broken {
                    kind,
                    a,
                    b,
                    advance: d,
                }),
            }
        }
        seen_events = w.events().len();
        let failed = !out.fell.is_empty() || !out.broke.is_empty();
        if (failed && s.stop_on_failure) || d >= ctl.goal() {
            break;
        }
        if linked {
            apply(w, &mut ctl, &view);
            if ctl.done(view.t) {
                break;
            }
        }
    }
    if linked {
        w.hold_all(0);
        w.command_all(Some([0.0, 0.0]));
    }
    out.gate_checks = ctl.progress().gate_checks;
    if let Some((_, d, CrossStop::Gate(why))) = &ctl.progress().stopped {
        out.gate_stop = Some((*d, why.clone()));
    }
    out.drive_s = (w.time_us() - t0) as f64 * 1e-6;
    let t_stop = w.time_us();
    out.peak_advance = out.advance;
    while w.time_us() < t_stop + (s.settle_s * 1e6) as u64 {
        w.run_for(tick_us);
        out.rest_advance = ctl.advance(&view_of(w));
        out.peak_advance = out.peak_advance.max(out.rest_advance);
    }
    let knob = f64::from(params.non_pilot.coupling.knob_hold_force);
    out.peak_knob_share = w
        .couplings()
        .iter()
        .filter(|c| c.0 == LinkKind::Knob)
        .map(|c| c.4 / knob)
        .fold(0.0, f64::max);
    out.across = w
        .states()
        .iter()
        .filter(|r| {
            platform_at(terrain, [r.position[0], r.position[1]]).is_some_and(|i| {
                Some(i) != start_platform
                    && (r.position[2] - terrain.platforms[i].height).abs() < 0.002
            })
        })
        .count();
    out.crossed = out.across == start.len()
        && out.fell.is_empty()
        && out.broke.is_empty()
        && out.gate_stop.is_none();
    out
}

/// What the host sees of the world now: every robot's exact pose (the world's motion
/// capture), no velocity estimate, at the world's time.
pub fn view_of(w: &World3d) -> FleetView {
    view_at(w, w.time_us() as f64 * 1e-6)
}

/// [`view_of`] at host time `t` (s): a host whose clock started before the world's.
pub fn view_at(w: &World3d, t: f64) -> FleetView {
    FleetView {
        t,
        robots: w
            .states()
            .iter()
            .map(|r| RobotView {
                id: r.id,
                kind: r.kind,
                pose: Some(PoseSample {
                    t,
                    x: r.position[0],
                    y: r.position[1],
                    theta: r.rpy[2],
                }),
                velocity: None,
            })
            .collect(),
        latency_s: 0.0,
    }
}

/// How the assembly came apart on the far platform.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DissolveOutcome {
    /// Couplings opened by hand.
    pub opened: usize,
    /// Smallest distance between two robots' centres before and after (m).
    pub spacing: [f64; 2],
    /// Robots that reached their goals within `tolerance`.
    pub at_goal: usize,
    /// Every robot still stands on the platform it started on, none fell.
    pub on_platform: bool,
}

/// Take the assembly apart where it stands: a person lifts the couplings open (THESIS 5.5.3;
/// here the simulator's hand), then every robot drives to its place in the assembly spread
/// to twice its size about its centre, moved forward by half its length (the back row stays,
/// away from the gap). Pilots drive straight only (THESIS 5.4.1), along their axis.
pub fn dissolve(
    w: &mut World3d,
    heading: f64,
    terrain: &Terrain,
    params: &FleetParams,
    duration_s: f64,
) -> DissolveOutcome {
    let tolerance = 0.01;
    let before = w.states();
    let mut opened = 0;
    for (_, a, b) in held(w) {
        opened += usize::from(w.release(a, b));
    }
    let n = before.len().max(1) as f64;
    let centre = before.iter().fold([0.0, 0.0], |s, r| {
        [s[0] + r.position[0] / n, s[1] + r.position[1] / n]
    });
    let dir = [heading.cos(), heading.sin()];
    let along = |p: [f64; 3]| (p[0] - centre[0]) * dir[0] + (p[1] - centre[1]) * dir[1];
    let back = before.iter().map(|r| along(r.position)).fold(0.0, f64::min);
    let goals: Vec<[f64; 2]> = before
        .iter()
        .map(|r| {
            let (dx, dy) = (r.position[0] - centre[0], r.position[1] - centre[1]);
            let g = [
                centre[0] + 2.0 * dx - back * dir[0],
                centre[1] + 2.0 * dy - back * dir[1],
            ];
            if r.kind == RobotKind::Pilot {
                // On its own axis: a pilot drives straight.
                let (s, c) = r.rpy[2].sin_cos();
                let f = (g[0] - r.position[0]) * c + (g[1] - r.position[1]) * s;
                [r.position[0] + f * c, r.position[1] + f * s]
            } else {
                g
            }
        })
        .collect();
    let platforms: Vec<Option<usize>> = before
        .iter()
        .map(|r| platform_at(terrain, [r.position[0], r.position[1]]))
        .collect();
    let end = w.time_us() + (duration_s * 1e6) as u64;
    while w.time_us() < end {
        for (r, goal) in w.states().iter().zip(&goals) {
            let (ex, ey) = (goal[0] - r.position[0], goal[1] - r.position[1]);
            let yaw = r.rpy[2];
            let fwd = ex * yaw.cos() + ey * yaw.sin();
            let dist = ex.hypot(ey);
            let (v, om) = if dist < 0.5 * tolerance {
                (0.0, 0.0)
            } else if r.kind == RobotKind::Pilot {
                ((1.5 * fwd).clamp(-0.06, 0.06), 0.0)
            } else {
                // Unicycle go-to-goal, reversing when the goal is behind.
                let mut bearing = ey.atan2(ex) - yaw;
                bearing = bearing.sin().atan2(bearing.cos());
                let sign = if bearing.abs() > std::f64::consts::FRAC_PI_2 {
                    -1.0
                } else {
                    1.0
                };
                let turn = if sign < 0.0 {
                    let b = bearing + std::f64::consts::PI;
                    b.sin().atan2(b.cos())
                } else {
                    bearing
                };
                (
                    (1.5 * dist * turn.cos().max(0.0) * sign).clamp(-0.06, 0.06),
                    (3.0 * turn).clamp(-2.0, 2.0),
                )
            };
            w.command(r.id, Some(wheel_rpms(Twist::new(v, om), params)));
        }
        w.run_for(20_000);
    }
    w.command_all(Some([0.0, 0.0]));
    w.run_for(300_000);
    let after = w.states();
    let spacing = |st: &[RobotState3d]| {
        let mut m = f64::INFINITY;
        for (i, a) in st.iter().enumerate() {
            for b in &st[i + 1..] {
                m = m.min((a.position[0] - b.position[0]).hypot(a.position[1] - b.position[1]));
            }
        }
        m
    };
    DissolveOutcome {
        opened,
        spacing: [spacing(&before), spacing(&after)],
        at_goal: after
            .iter()
            .zip(&goals)
            .filter(|(r, g)| (r.position[0] - g[0]).hypot(r.position[1] - g[1]) < tolerance)
            .count(),
        on_platform: after
            .iter()
            .zip(&platforms)
            .all(|(r, p)| !r.fallen && platform_at(terrain, [r.position[0], r.position[1]]) == *p),
    }
}
