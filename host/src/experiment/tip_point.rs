//! The physics' static tipping point of a crossing run: the farthest advance at which the
//! assembly, driven there and stopped, stands. The gate's maximum safe advance is a static
//! claim; the advance at which the driven run reports a fall is not, because a robot counts
//! as fallen only once its underside is the world's fall depth below the lowest platform,
//! and the assembly keeps driving while it tips that far. Stopping the same run at a chosen
//! advance and holding it still measures the static point itself.

use crate::crossing::drive3d::{self, CrossSettings};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::FleetParams;
use puzzlebot_sim::physics3d::{Event3d, World3d};
use puzzlebot_sim::Scenario;
use puzzlebot_stability::crossing::Candidate;

/// How the tipping point is searched.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipSearch {
    /// Resolution of the search (m of advance).
    pub resolution: f64,
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
            hold_s: 2.0,
        }
    }
}

/// One probe: drive the run's assembly `d` forward, stop, hold. Whether a robot fell, and
/// the advance at which the assembly came to rest (m).
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
    let fell = w.events().iter().any(|e| matches!(e, Event3d::Fell { .. }));
    Ok((fell, o.rest_advance))
}

/// The farthest advance (m) at which the run of `scenario` along `cand`, driven with `base`
/// and stopped, stands without a robot falling; `fell_at` is the advance at which the
/// driven run reported its first fall (the search's upper end). Probes step back from
/// `fell_at` by doubling distances until one stands, then bisect to `search.resolution`.
/// `None` when the assembly falls even stopped at once.
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
    let run = |d: f64| probe(scenario, cand, terrain, params, base, search, d);
    // `hi`: a stop advance that falls; `lo`: one that stands, with its rest advance.
    let mut hi = fell_at;
    let mut back = 2.0 * res;
    let mut lo: Option<(f64, f64)> = None;
    while lo.is_none() {
        let d = (fell_at - back).max(0.0);
        let (fell, rest) = run(d)?;
        if fell {
            if d <= 0.0 {
                return Ok(None);
            }
            hi = d;
            back *= 2.0;
        } else {
            lo = Some((d, rest));
        }
    }
    let Some((mut lo_d, mut rest)) = lo else {
        return Ok(None);
    };
    while hi - lo_d > res {
        let mid = 0.5 * (lo_d + hi);
        let (fell, r) = run(mid)?;
        if fell {
            hi = mid;
        } else {
            lo_d = mid;
            rest = r;
        }
    }
    Ok(Some(rest))
}
