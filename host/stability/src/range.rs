//! Admissible range of an unknown external load at a point, by bisection (SOCP 4.1).
//!
//! The set of load magnitudes t for which (41) is feasible is an interval (it is the projection
//! of a convex set), so bisection on t finds its ends.

use crate::gate::{evaluate_resolved, Options, Verdict};
use crate::model::{add, cross, norm, scale, sub, Assembly, ModelError, Vec3};
use serde::Serialize;
use std::time::Instant;

/// Range of a load t·d (N) at a point on a module, along a unit direction d.
#[derive(Debug, Clone, Serialize)]
pub struct LoadRange {
    /// Largest t ≥ 0 proven stable along +d (None: not stable even without the load).
    pub max_along: Option<f64>,
    /// Largest t ≥ 0 proven stable along −d.
    pub max_against: Option<f64>,
    /// True when `max_along` reached the search bound `t_max` (the real limit is higher).
    pub along_unbounded: bool,
    /// True when `max_against` reached `t_max`.
    pub against_unbounded: bool,
    /// Verdict just beyond `max_along` (why it stops).
    pub along_limited_by: Option<Verdict>,
    /// Verdict just beyond `max_against`.
    pub against_limited_by: Option<Verdict>,
    /// Gate evaluations used.
    pub evaluations: u32,
}

/// Find the admissible range of a force along `direction` at `point` on `module`, searching
/// t ∈ [0, t_max] to resolution `tol` (N).
pub fn load_range(
    a: &Assembly,
    module: &str,
    point: Vec3,
    direction: Vec3,
    t_max: f64,
    tol: f64,
) -> Result<LoadRange, ModelError> {
    let mut r = a.resolve()?;
    let mi = r.ids.iter().position(|id| id == module).ok_or(ModelError {
        field: "module".into(),
        message: format!("unknown module {module:?}"),
    })?;
    let nd = norm(direction);
    if !(nd > 0.0 && nd.is_finite() && point.iter().all(|x| x.is_finite())) {
        return Err(ModelError {
            field: "direction".into(),
            message: "direction must be a finite non-zero vector and the point finite".into(),
        });
    }
    if !(t_max.is_finite() && t_max > 0.0 && tol.is_finite() && tol > 0.0) {
        return Err(ModelError {
            field: "t_max".into(),
            message: "t_max and tol must be finite and > 0".into(),
        });
    }
    let d = scale(direction, 1.0 / nd);
    let base = r.ext[mi];
    let arm = sub(point, r.com[mi]);
    let mut evals = 0u32;
    let mut check = |t: f64, r: &mut crate::model::Resolved| {
        let f = scale(d, t);
        r.ext[mi] = (add(base.0, f), add(base.1, cross(arm, f)));
        evals += 1;
        evaluate_resolved(r, Options::default(), Instant::now(), 0.0).verdict
    };
    let mut side = |sign: f64, r: &mut crate::model::Resolved| {
        let v0 = check(0.0, r);
        if !v0.is_stable() {
            return (None, false, Some(v0));
        }
        let vmax = check(sign * t_max, r);
        if vmax.is_stable() {
            return (Some(t_max), true, None);
        }
        let (mut lo, mut hi, mut why) = (0.0, t_max, vmax);
        while hi - lo > tol {
            let mid = 0.5 * (lo + hi);
            let v = check(sign * mid, r);
            if v.is_stable() {
                lo = mid;
            } else {
                hi = mid;
                why = v;
            }
        }
        (Some(lo), false, Some(why))
    };
    let (max_along, along_unbounded, along_limited_by) = side(1.0, &mut r);
    let (max_against, against_unbounded, against_limited_by) = side(-1.0, &mut r);
    Ok(LoadRange {
        max_along,
        max_against,
        along_unbounded,
        against_unbounded,
        along_limited_by,
        against_limited_by,
        evaluations: evals,
    })
}
