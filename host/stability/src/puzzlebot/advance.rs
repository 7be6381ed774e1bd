//! The gate's scan along a crossing: how far a PuzzleBot assembly can advance before it tips,
//! a connection fails, or a hanging robot stalls against an edge or sags into a gap.

use super::{
    assembly_level, body_corners, build_model_with, check, touches, world, AdapterError, Advance,
    AdvanceOptions, LimitedBy, PuzzleAssembly, Touch,
};
use crate::events::{body_events, front_events, support_events};
use crate::judge::{judge_model, judge_transfer};
use crate::model::Assembly;
use crate::sag::{droop, edge_stall, Settling};
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
        });
    };
    let dir = [heading.cos(), heading.sin()];
    let at = |d: f64| [dir[0] * d, dir[1] * d];
    let state = |d: f64| touches(assembly, params, terrain, level, at(d), opt.max_drop);
    let resting = opt.settling.is_some_and(|s| s.rest_on_bodies);
    // With resting bodies on, the platform under each robot's underside corners as well: a
    // robot may come to rest on it ([`crate::sag::resting_bodies`]).
    let topology = |d: f64| {
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
    // The connectors' peak as the support changes between the states at `lo` and `hi`.
    let transfer = |lo: f64, hi: f64| -> Result<Option<LimitedBy>, AdapterError> {
        if opt.transfer.is_none() {
            return Ok(None);
        }
        let before = build_model_with(assembly, params, terrain, level, at(lo), &opt)?;
        let after = build_model_with(assembly, params, terrain, level, at(hi), &opt)?;
        judge_transfer(&before, &after, params, &opt, heading)
    };
    let mut cur = topology(0.0);
    if let Some(why) = judge(0.0, &cur.0)? {
        return Ok(Advance {
            distance: 0.0,
            limited_by: why,
        });
    }
    // Just after every support event, and every `step` (a change found there is located by
    // bisection to 1 µm).
    let mut events = support_events(assembly, params, terrain, heading, opt.horizon);
    if resting {
        events.extend(body_events(assembly, params, terrain, heading, opt.horizon));
    }
    let mut checks: Vec<(f64, bool)> = events
        .into_iter()
        .map(|e| (e + EVENT_EPS, true))
        .filter(|&(d, _)| d < opt.horizon)
        .collect();
    let n = (opt.horizon / step).ceil() as usize;
    checks.extend((1..=n).map(|k| ((k as f64 * step).min(opt.horizon), false)));
    checks.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Where a front corner reaches a platform, and whether a hanging robot's body meets its
    // edge face there.
    let mut fronts: Vec<f64> = if opt.settling.is_some() {
        front_events(assembly, params, terrain, heading, opt.horizon)
    } else {
        vec![]
    };
    fronts.reverse();
    let mut last = 0.0;
    for (d, event) in checks {
        while fronts.last().is_some_and(|&e| e < d) {
            let e = fronts.pop().unwrap_or(d);
            if let Some(why) = stall(e - EVENT_EPS, e + EVENT_EPS)? {
                return Ok(Advance {
                    distance: (e - EVENT_EPS).max(last),
                    limited_by: why,
                });
            }
        }
        // The sag grows with the advance: the last check before is the answer.
        if let Some(why) = droops(d)? {
            return Ok(Advance {
                distance: last,
                limited_by: why,
            });
        }
        let mut st = topology(d);
        if st == cur {
            last = d;
            continue;
        }
        let (mut lo, mut hi) = if event {
            ((d - 2.0 * EVENT_EPS).max(last), d)
        } else {
            (last, d)
        };
        if !event {
            while hi - lo > 1e-6 {
                let mid = 0.5 * (lo + hi);
                if topology(mid) == cur {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            st = topology(hi);
        }
        if let Some(why) = judge(hi, &st.0)?.map_or_else(|| transfer(lo, hi), |w| Ok(Some(w)))? {
            return Ok(Advance {
                distance: lo,
                limited_by: why,
            });
        }
        cur = st;
        last = hi;
    }
    Ok(Advance {
        distance: opt.horizon,
        limited_by: LimitedBy::Horizon,
    })
}
