//! The physics' static tipping point of a crossing run: the farthest advance at which the
//! assembly, driven there and stopped, stands. The gate's maximum safe advance is a static
//! claim; the advance at which the driven run reports a fall is not, because a robot counts
//! as fallen only once its underside is the world's fall depth below the lowest platform,
//! and the assembly keeps driving while it tips that far. Stopping the same run at a chosen
//! advance and holding it still measures the static point itself.
//!
//! A stop stands when, after the hold, no robot fell and none is tilted past
//! [`MAX_TIP_ANGLE`], the largest tilt in the gate's small-angle picture of a tipping
//! assembly: a mesh that tips over an edge and comes to rest with its front in the gap,
//! pitched 20° on a wheel riding the corner, has lost its stance though no robot reached the
//! fall depth (which lets a robot that dips while driving climb back out). A mesh settling a
//! few degrees onto its hinges and wheels, as the gate's own settling predicts, stands.

use crate::crossing::drive3d::{self, CrossSettings};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::FleetParams;
use puzzlebot_sim::physics3d::{Event3d, World3d};
use puzzlebot_sim::Scenario;
use puzzlebot_stability::crossing::{Candidate, CrossingOptions};
use puzzlebot_stability::puzzlebot::MAX_TIP_ANGLE;

/// How the tipping point is searched.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipSearch {
    /// Resolution of the search (m of advance).
    pub resolution: f64,
    /// Step of the scan for the first stop that falls (m): a window narrower than this in
    /// which a stopped assembly falls, between two in which it stands, can be missed. The
    /// gate's own scan step.
    pub scan: f64,
    /// Standing time after the stop in which a fall counts (s). A centre of mass δ past the
    /// support line tips with the time constant τ = √((r² + k²) / (g·r)) of a body pivoting
    /// at distance r from its centre with radius of gyration k (about 0.1 s for a robot's
    /// length); from δ at the resolution to a fall depth ten times larger takes about
    /// acosh(10)·τ ≈ 3·τ. Two seconds hold well past that.
    pub hold_s: f64,
}

impl Default for TipSearch {
    fn default() -> Self {
        TipSearch {
            resolution: 0.001,
            scan: CrossingOptions::default().step,
            hold_s: 2.0,
        }
    }
}

/// One probe: drive the run's assembly `d` forward, stop, hold. Whether a robot fell or, at
/// the end of the hold, is tilted past [`MAX_TIP_ANGLE`], and the farthest
/// advance the assembly reached, its run-out after the stop included (m).
fn probe(
    scenario: &Scenario,
    cand: &Candidate,
    terrain: &Terrain,
    params: &FleetParams,
    base: &CrossSettings,
    search: &TipSearch,
    d: f64,
) -> Result<(bool, f64), String> {
    let settings = CrossSettings {
        overshoot: 0.0,
        stop_on_failure: true,
        live_gate: false,
        settle_s: search.hold_s,
        ..*base
    };
    let to_d = Candidate {
        required: d,
        ..cand.clone()
    };
    let mut w = World3d::new(scenario, settings.world).map_err(|e| e.to_string())?;
    let o = drive3d::cross(&mut w, &to_d, terrain, params, &settings);
    let tilted = |rpy: [f64; 3]| (rpy[0].cos() * rpy[1].cos()).acos() > MAX_TIP_ANGLE;
    let fell = w.events().iter().any(|e| matches!(e, Event3d::Fell { .. }))
        || w.states().iter().any(|r| tilted(r.rpy));
    Ok((fell, o.peak_advance))
}

/// The physics' static tipping point of the run of `scenario` along `cand`, driven with
/// `base`: the farthest advance (m) a stop reached, run-out included, and stood, before the
/// first stop at which a robot falls. `fell_at` is the advance at which the driven run reported its first
/// fall: the stops scan up to it every `search.scan`, and the first that falls is located
/// by bisection to `search.resolution`. `None` when the assembly falls even stopped at once.
pub fn static_tip_point(
    scenario: &Scenario,
    cand: &Candidate,
    terrain: &Terrain,
    params: &FleetParams,
    base: &CrossSettings,
    search: &TipSearch,
    fell_at: f64,
) -> Result<Option<f64>, String> {
    let res = search.resolution.max(1e-4);
    let scan = search.scan.max(res);
    let run = |d: f64| probe(scenario, cand, terrain, params, base, search, d);
    // `lo`: a stop that stands, with its farthest advance; `hi`: the first stop found to fall.
    let (fell, reach) = run(0.0)?;
    if fell {
        return Ok(None);
    }
    let (mut lo, mut reach) = (0.0, reach);
    let mut hi = fell_at;
    let mut d = scan;
    while d < fell_at {
        let (fell, r) = run(d)?;
        if fell {
            hi = d;
            break;
        }
        (lo, reach) = (d, r);
        d += scan;
    }
    while hi - lo > res {
        let mid = 0.5 * (lo + hi);
        let (fell, r) = run(mid)?;
        if fell {
            hi = mid;
        } else {
            (lo, reach) = (mid, r);
        }
    }
    Ok(Some(reach))
}
