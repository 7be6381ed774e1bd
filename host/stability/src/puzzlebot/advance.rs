//! The gate's scan along a crossing: how far a PuzzleBot assembly can advance before it tips,
//! a connection fails, a hanging robot stalls against an edge or sags into a gap, or no wheel
//! is left on a platform to drive it.

use super::bridge::{tip_of, Tip, MAX_TIP_ANGLE};
use super::{
    assembly_level, body_corners, build_model_with, check, clearance, contact_points, touches,
    world, AdapterError, Advance, AdvanceOptions, LimitedBy, PuzzleAssembly, Touch,
    LEVEL_TOLERANCE,
};
use crate::events::{body_events, front_events, support_events};
use crate::judge::{judge_model, judge_transfer};
use crate::model::Assembly;
use crate::sag::{droop, edge_stall, settle_articulated, wheels_bear, Settling};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::FleetParams;

/// How far this assembly can advance along `heading` (rad) before it tips or a connection
/// fails, scanning contact changes every `step` m (default options: measured coupling limits,
/// 1 m horizon).
pub fn max_safe_advance(
    assembly: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    heading: f64,
    step: f64,
) -> Result<Advance, AdapterError> {
    max_safe_advance_with(
        assembly,
        params,
        terrain,
        heading,
        step,
        AdvanceOptions::default(),
    )
}

/// How far past a support event the gate judges the state it leads to (m): well inside the
/// contact's new side of the edge, far below any distance the answer is read to.
pub const EVENT_EPS: f64 = 1e-6;

/// [`max_safe_advance`] with options.
///
/// A rigid translation changes the model only when a contact leaves or reaches a platform
/// ([`support_events`]), so the gate judges the start and the state just after every such
/// event (the state just before one is the one judged after the event before). `step` bounds
/// the distance between checks as well, so the scan also covers a terrain whose edges the
/// contacts pass without crossing.
pub fn max_safe_advance_with(
    assembly: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    heading: f64,
    step: f64,
    opt: AdvanceOptions,
) -> Result<Advance, AdapterError> {
    check(assembly)?;
    terrain.validate().map_err(AdapterError::Terrain)?;
    if !(heading.is_finite()) {
        return Err(AdapterError::BadNumber("heading"));
    }
    if !(step.is_finite() && step > 0.0) {
        return Err(AdapterError::BadNumber("step"));
    }
    if !(opt.horizon.is_finite() && opt.horizon > 0.0) {
        return Err(AdapterError::BadNumber("horizon"));
    }
    let Some(level) = assembly_level(assembly, params, terrain) else {
        return Ok(Advance {
            distance: 0.0,
            limited_by: LimitedBy::Tips,
            bridged: vec![],
        });
    };
    let dir = [heading.cos(), heading.sin()];
    let at = |d: f64| [dir[0] * d, dir[1] * d];
    let state = |d: f64| touches(assembly, params, terrain, level, at(d), opt.max_drop);
    let resting = opt.settling.is_some_and(|s| s.rest_on_bodies);
    // With resting bodies on, the platform under each robot's underside corners as well: a
    // robot may come to rest on it ([`crate::sag::resting_bodies`]).
    type Topology = (Vec<Vec<Touch>>, Vec<Option<(f64, f64)>>);
    let topology = |d: f64| -> Topology {
        let corners: Vec<Option<(f64, f64)>> = if resting {
            assembly
                .robots
                .iter()
                .flat_map(|r| {
                    let moved = r.translated(at(d));
                    body_corners(r.kind, params).map(|c| terrain.support_at(world(&moved, c)))
                })
                .collect()
        } else {
            vec![]
        };
        (state(d), corners)
    };
    let judge = |d: f64, st: &Vec<Vec<Touch>>| -> Result<Option<LimitedBy>, AdapterError> {
        if let Some(robot) = st.iter().position(|r| r.contains(&Touch::Blocked)) {
            return Ok(Some(LimitedBy::StepUp { robot }));
        }
        let m = build_model_with(assembly, params, terrain, level, at(d), &opt)?;
        judge_model(&m, params, &opt, heading)
    };
    // With settling on and a robot hanging (no wheel or caster on a platform) at advance
    // `d`: the settling, which robots hang, and the assembly's model there.
    type Hanging<'s> = Option<(&'s Settling, Vec<bool>, Assembly)>;
    let hanging_model = |d: f64| -> Result<Hanging, AdapterError> {
        let Some(s) = &opt.settling else {
            return Ok(None);
        };
        let hanging: Vec<bool> = state(d)
            .iter()
            .map(|r| !r.iter().any(|t| matches!(t, Touch::On(..))))
            .collect();
        if !hanging.contains(&true) {
            return Ok(None);
        }
        let m = build_model_with(assembly, params, terrain, level, at(d), &opt)?;
        Ok(Some((s, hanging, m)))
    };
    // A hanging robot's body running into the platform a front corner reaches between the
    // advances `lo` and `hi` ([`edge_stall`]).
    let stall = |lo: f64, hi: f64| -> Result<Option<LimitedBy>, AdapterError> {
        let Some((s, hanging, m)) = hanging_model(hi)? else {
            return Ok(None);
        };
        let reach = [at(lo), at(hi)];
        Ok(
            edge_stall(assembly, params, terrain, level, reach, &m, &hanging, s)
                .map(|robot| LimitedBy::StepUp { robot }),
        )
    };
    // A hanging robot sagging into the gap ([`droop`]).
    let droops = |d: f64| -> Result<Option<LimitedBy>, AdapterError> {
        let Some((s, hanging, m)) = hanging_model(d)? else {
            return Ok(None);
        };
        Ok(
            droop(assembly, params, terrain, level, at(d), &m, &hanging, s)
                .map(|_| LimitedBy::Tips),
        )
    };
    // No wheel touches a platform in the assembly settled at advance `d`: the robots rest on
    // their casters and nothing drives them on. Bodies resting on a platform
    // ([`Settling::rest_on_bodies`]) drive nothing, so the assembly is settled without them.
    let stalls = |d: f64| -> Result<bool, AdapterError> {
        let Some(s) = opt.settling else {
            return Ok(false);
        };
        let s = Settling {
            rest_on_bodies: false,
            ..s
        };
        let bare = AdvanceOptions {
            settling: Some(s),
            ..opt
        };
        let m = build_model_with(assembly, params, terrain, level, at(d), &bare)?;
        Ok(wheels_bear(&m, &s) == Some(false))
    };
    // Where the contacts leave or reach a platform, in order.
    let mut events = support_events(assembly, params, terrain, heading, opt.horizon);
    if resting {
        events.extend(body_events(assembly, params, terrain, heading, opt.horizon));
    }
    events.sort_by(f64::total_cmp);
    // The connectors' peak as the support changes between the states at `lo` and `hi`, and
    // from `lo` on past every later event within the transfer's overlap of `hi`
    // ([`crate::transfer::LoadTransfer::overlap`]): contacts rolling off edges a fraction
    // of a millimetre apart (an assembly a degree off square to the edge) shed their loads
    // together.
    let transfer = |lo: f64, hi: f64| -> Result<Option<LimitedBy>, AdapterError> {
        let Some(t) = opt.transfer else {
            return Ok(None);
        };
        let before = build_model_with(assembly, params, terrain, level, at(lo), &opt)?;
        let mut to = hi;
        loop {
            let after = build_model_with(assembly, params, terrain, level, at(to), &opt)?;
            if let Some(why) = judge_transfer(&before, &after, params, &opt, heading)? {
                return Ok(Some(why));
            }
            let next = events
                .iter()
                .map(|&e| e + EVENT_EPS)
                .find(|&e| e > to + EVENT_EPS && e <= hi + t.overlap && e < opt.horizon);
            match next {
                Some(e) => to = e,
                None => return Ok(None),
            }
        }
    };
    let mut cur = topology(0.0);
    if let Some(why) = judge(0.0, &cur.0)? {
        return Ok(Advance {
            distance: 0.0,
            limited_by: why,
            bridged: vec![],
        });
    }
    // Just after every support event, and every `step` (a change found there is located by
    // bisection to 1 µm).
    let mut checks: Vec<(f64, bool)> = events
        .iter()
        .map(|e| (e + EVENT_EPS, true))
        .filter(|&(d, _)| d < opt.horizon)
        .collect();
    let n = (opt.horizon / step).ceil() as usize;
    checks.extend((1..=n).map(|k| ((k as f64 * step).min(opt.horizon), false)));
    checks.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The first topology change after `from` (whose topology is `was`) up to the check `d`:
    // the advances just before and just after it, and the topology after.
    let locate = |from: f64, d: f64, event: bool, was: &Topology| -> (f64, f64, Topology) {
        if event {
            return ((d - 2.0 * EVENT_EPS).max(from), d, topology(d));
        }
        let (mut lo, mut hi) = (from, d);
        while hi - lo > 1e-6 {
            let mid = 0.5 * (lo + hi);
            if topology(mid) == *was {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (lo, hi, topology(hi))
    };
    // Whether the assembly, tipping from `lo` on as `tips` say for `(to − lo)` / speed s,
    // lands every contact of `after` that `before` lacks on its platform (within the
    // tolerance a contact rolls up onto), and every body corner that reaches a platform
    // between `lo` and `to` on its top ([`bridge`]).
    // Each point's drop adds robot i's settled sink there before the stretch (`sag`).
    let lands = |lo: f64,
                 to: f64,
                 tips: &[Tip],
                 before: &Topology,
                 after: &Topology,
                 sag: &dyn Fn(usize, [f64; 2]) -> f64| {
        let t = (to - lo) / opt.bridge_speed;
        let angles: Vec<f64> = tips.iter().map(|tip| tip.angle_after(t)).collect();
        let tipped = |p: [f64; 2]| {
            tips.iter()
                .zip(&angles)
                .map(|(tip, a)| tip.lever(p).max(0.0) * a)
                .fold(0.0, f64::max)
        };
        for (i, r) in assembly.robots.iter().enumerate() {
            let moved = r.translated(at(to));
            for (j, (b, wheel)) in contact_points(r.kind, params).iter().enumerate() {
                let (Some(Touch::On(_, h)), Some(was)) = (after.0[i].get(j), before.0[i].get(j))
                else {
                    continue;
                };
                let clear = clearance(params.robot(r.kind), *wheel, level, *h);
                let q = world(&moved, *b);
                if !matches!(was, Touch::On(..)) && sag(i, q) + tipped(q) > clear + LEVEL_TOLERANCE
                {
                    return Some(LimitedBy::StepUp { robot: i });
                }
            }
            let Some(s) = &opt.settling else {
                continue;
            };
            let from = r.translated(at(lo));
            for c in body_corners(r.kind, params) {
                let q = world(&moved, c);
                let Some((h, _)) = terrain.support_at(q) else {
                    continue;
                };
                let was = terrain.support_at(world(&from, c)).map(|x| x.0);
                if was != Some(h) && sag(i, q) + tipped(q) > level + s.body_clearance - h + 1e-9 {
                    return Some(LimitedBy::StepUp { robot: i });
                }
            }
        }
        None
    };
    // Drive on from `hi` (just past `lo`), where the assembly starts to tip as `first` says,
    // over the checks from `k` on: the advance where it stands again, landed and proven, and
    // the index of the next check; or why not.
    type Bridged = Result<(f64, usize), LimitedBy>;
    let bridge = |lo: f64, hi: f64, first: Tip, mut k: usize| -> Result<Bridged, AdapterError> {
        let mut tips = vec![first];
        let (mut was, mut was_at) = (topology(hi), hi);
        // The sag the supports settle to before the stretch, as the gate's settling gives it.
        let before = build_model_with(assembly, params, terrain, level, at(lo), &opt)?;
        let settled = opt.settling.map(|s| settle_articulated(&before, &s));
        let sag = |i: usize, p: [f64; 2]| match &settled {
            None => 0.0,
            Some(None) => f64::INFINITY,
            Some(Some(sg)) => sg.sink(i, p).max(0.0),
        };
        while let Some(&(d, event)) = checks.get(k) {
            k += 1;
            let t = (was_at - lo) / opt.bridge_speed;
            if tips.iter().any(|tip| tip.angle_after(t) > MAX_TIP_ANGLE) {
                return Ok(Err(LimitedBy::Tips));
            }
            let st = topology(d);
            if st == was {
                was_at = d;
                continue;
            }
            let (_, h, st) = locate(was_at, d, event, &was);
            match judge(h, &st.0)? {
                Some(LimitedBy::Tips) => {
                    let m = build_model_with(assembly, params, terrain, level, at(h), &opt)?;
                    let Some(tip) = tip_of(&m, opt.drive_accel) else {
                        return Ok(Err(LimitedBy::Tips));
                    };
                    tips.push(tip);
                    (was, was_at) = (st, h);
                    continue;
                }
                Some(why) => return Ok(Err(why)),
                None => {}
            }
            if let Some(why) = lands(lo, h, &tips, &was, &st, &sag) {
                return Ok(Err(why));
            }
            let why = transfer(lo, h)?.map_or_else(|| droops(h), |w| Ok(Some(w)))?;
            return Ok(why.map_or(Ok((h, k)), Err));
        }
        Ok(Err(LimitedBy::Tips))
    };
    // Where a front corner reaches a platform, and whether a hanging robot's body meets its
    // edge face there.
    let mut fronts: Vec<f64> = if opt.settling.is_some() {
        front_events(assembly, params, terrain, heading, opt.horizon)
    } else {
        vec![]
    };
    fronts.reverse();
    let mut last = 0.0;
    let mut bridged: Vec<[f64; 2]> = vec![];
    // Fronts reached within a bridged stretch have landed: [`bridge`] proved them.
    let mut landed_until = f64::NEG_INFINITY;
    let mut k = 0;
    while let Some(&(d, event)) = checks.get(k) {
        k += 1;
        while fronts.last().is_some_and(|&e| e < d) {
            let e = fronts.pop().unwrap_or(d);
            if e <= landed_until {
                continue;
            }
            if let Some(why) = stall(e - EVENT_EPS, e + EVENT_EPS)? {
                return Ok(Advance {
                    distance: (e - EVENT_EPS).max(last),
                    limited_by: why,
                    bridged,
                });
            }
        }
        let st = topology(d);
        // A support left and the assembly cannot stand: drive through to the next state that
        // stands, if it lands. A stretch that cannot be proven falls through to the checks
        // below, which reuse the change located and judged here.
        let mut judged = None;
        if opt.bridge_speed > 0.0 && st != cur {
            let (lo, hi, after) = locate(last, d, event, &cur);
            let why = judge(hi, &after.0)?;
            let tips = why == Some(LimitedBy::Tips);
            judged = Some((lo, hi, after, why));
            if tips {
                let m = build_model_with(assembly, params, terrain, level, at(hi), &opt)?;
                if let Some(tip) = tip_of(&m, opt.drive_accel) {
                    if let Ok((to, next)) = bridge(lo, hi, tip, k)? {
                        bridged.push([lo, to]);
                        (cur, last, k, landed_until) = (topology(to), to, next, to);
                        continue;
                    }
                }
            }
        }
        // The sag grows with the advance: the last check before is the answer.
        if let Some(why) = droops(d)? {
            return Ok(Advance {
                distance: last,
                limited_by: why,
                bridged,
            });
        }
        if stalls(d)? {
            return Ok(Advance {
                distance: last,
                limited_by: LimitedBy::Stalls,
                bridged,
            });
        }
        if st == cur {
            last = d;
            continue;
        }
        let (lo, hi, st, why) = match judged {
            Some(j) => j,
            None => {
                let (lo, hi, st) = locate(last, d, event, &cur);
                let why = judge(hi, &st.0)?;
                (lo, hi, st, why)
            }
        };
        if let Some(why) = why.map_or_else(|| transfer(lo, hi), |w| Ok(Some(w)))? {
            return Ok(Advance {
                distance: lo,
                limited_by: why,
                bridged,
            });
        }
        cur = st;
        last = hi;
    }
    Ok(Advance {
        distance: opt.horizon,
        limited_by: LimitedBy::Horizon,
        bridged,
    })
}
