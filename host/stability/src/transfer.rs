//! The connectors' loads as the assembly's compliance sets them ([`crate::elastic`]), and
//! their peak when the support changes under a moving assembly.
//!
//! A wheel or caster that rolls off an edge hands its load to the connectors within about a
//! natural period of a robot on their springs, and a lightly damped spring loaded that fast
//! overshoots its new equilibrium: the step response of one mode of damping ratio ζ peaks at
//! the amplification A = 1 + exp(−ζπ / √(1 − ζ²)) times the change (2 undamped, 1 from
//! critical damping on). The gate checks every connector against before + A · (after −
//! before) of the elastic distributions on either side of a support event, in both support
//! limits of [`SOFT_SUPPORTS`] ([`transfer_limit`]).

use crate::elastic::{distribution_with_supports, use_of_limits, Compliance};
use crate::model::{Assembly, Resolved, GRAVITY};
use crate::puzzlebot::{AdapterError, LimitedBy};
use crate::sag::Settling;
use crate::socp::SLOTS;
use puzzlebot_params::FleetParams;

/// How much softer than the connectors the supports are in the soft-support limit of the
/// elastic check: far enough that the assembly settles as one body (the connectors' loads
/// lie within about 1/`SOFT_SUPPORTS` of the limit's).
pub const SOFT_SUPPORTS: f64 = 1e3;

/// How the connectors respond to a sudden change of the support.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadTransfer {
    /// Damping ratio ζ of a connector's load response (1): `coupling.connector_damping_ratio`
    /// of the robots (the printed TPU's, not measured on the robots; 0: the bound of an
    /// undamped spring, which any damping only lowers). Negative or not a number counts as 0.
    pub damping_ratio: f64,
    /// Advance over which a contact rolling off an edge hands its load to the connectors (m):
    /// it sinks by their deflection under a robot's weight, δ = m·g / k, over √(2·r·δ) for
    /// its rolling radius r. Support events closer together than this shed their loads
    /// together and are checked as one change as well. [`LoadTransfer::of`] takes the
    /// largest wheel and the heaviest robot of the fleet.
    pub overlap: f64,
}

impl Default for LoadTransfer {
    fn default() -> Self {
        LoadTransfer::of(&FleetParams::default())
    }
}

impl LoadTransfer {
    /// The bound for robots `params`: the least damped of their connectors, and
    /// [`LoadTransfer::overlap`] of their largest wheel and heaviest robot.
    pub fn of(params: &FleetParams) -> LoadTransfer {
        let robots = [&params.pilot, &params.non_pilot];
        let r = robots
            .iter()
            .map(|p| f64::from(p.geometry.wheel_radius.max(p.plant.caster_radius)))
            .fold(0.0, f64::max);
        let sink = robots
            .iter()
            .map(|p| f64::from(p.mass.mass) * GRAVITY / f64::from(p.coupling.connector_stiffness))
            .fold(0.0, f64::max);
        let damping_ratio = robots
            .iter()
            .map(|p| f64::from(p.coupling.connector_damping_ratio))
            .fold(f64::INFINITY, f64::min);
        LoadTransfer {
            damping_ratio,
            overlap: (2.0 * r * sink).sqrt(),
        }
    }

    /// Peak of a step response over its settled change (1): 1 + exp(−ζπ / √(1 − ζ²)) below
    /// critical damping, 1 from there on; 2 for a ratio that is negative or not a number.
    pub fn amplification(&self) -> f64 {
        let z = self.damping_ratio;
        if z.is_nan() || z <= 0.0 {
            2.0
        } else if z >= 1.0 {
            1.0
        } else {
            1.0 + (-z * std::f64::consts::PI / (1.0 - z * z).sqrt()).exp()
        }
    }
}

/// Peak wrench of every connection when its load steps from `before` to `after` with
/// amplification `a`: after + (a − 1) · (after − before), component by component (the
/// connector's pull and press slots as one axial force).
pub fn peak(before: &[[f64; SLOTS]], after: &[[f64; SLOTS]], a: f64) -> Vec<[f64; SLOTS]> {
    before
        .iter()
        .zip(after)
        .map(|(b, f)| {
            let mut p = [0.0; SLOTS];
            for s in [0, 1, 4, 5, 6] {
                p[s] = f[s] + (a - 1.0) * (f[s] - b[s]);
            }
            let (nb, nf) = (b[2] + b[3], f[2] + f[3]);
            let n = nf + (a - 1.0) * (nf - nb);
            if n < 0.0 {
                p[2] = n;
            } else {
                p[3] = n;
            }
            p
        })
        .collect()
}

/// The elastic distributions of a model in both support limits, or why there is none.
enum Settled {
    Loads(Box<Resolved>, Vec<Vec<[f64; SLOTS]>>),
    Limited(LimitedBy),
}

/// The elastic distributions of `m` on rigid supports and on supports [`SOFT_SUPPORTS`] times
/// softer than the connectors. How stiff the supports are against the connectors decides the
/// distribution and is not known (tyres, printed platforms, a simulator's soft contacts sink
/// a loaded robot by about a millimetre, where the connectors give a third of that under
/// their hold force), so both limits are checked.
///
/// Between the limits the loads need not lie between theirs when a contact stands over a
/// lower platform (`drops`): on rigid supports its gap stays open unless the hinges close it,
/// on very soft ones the whole assembly sinks past it, and on supports as soft as tyres the
/// robots behind pitch forward while the gap stays open, loading the connectors that hold the
/// overhang most. With `drops` and a [`Settling`], the distributions on supports of its
/// compliances (wheels softer than casters) and a factor √10 either side, gaps kept, are
/// checked as well.
fn settle(
    m: &Assembly,
    params: &FleetParams,
    settling: Option<&Settling>,
    drops: bool,
) -> Result<Settled, AdapterError> {
    let r = m.resolve()?;
    let c = &params.non_pilot.coupling;
    let force = 1.0 / f64::from(c.connector_stiffness);
    // A contact over a lower platform stands clear of it by the drop, a caster by its lift.
    let gaps: Vec<f64> = m.contacts.iter().map(|k| k.gap.max(0.0)).collect();
    // (compliance of a unit support, whether gaps stay, each contact's share of it)
    let mut supports = vec![(0.0, true, vec![]), (SOFT_SUPPORTS * force, false, vec![])];
    if let Some(s) = settling.filter(|_| drops) {
        let f = 10f64.sqrt();
        let w = s.wheel_compliance;
        let scale: Vec<f64> = m.contacts.iter().map(|k| s.of(k) / w).collect();
        for c in [w / f, w, w * f] {
            supports.push((c, true, scale.clone()));
        }
    }
    let mut out = Vec::with_capacity(supports.len());
    for (support, keep_gaps, scale) in supports {
        let compliance = Compliance {
            force,
            couple: 1.0 / f64::from(c.connector_angular_stiffness),
            support,
        };
        // On very soft supports a loaded robot sinks further than any drop it could rest on.
        let gaps: &[f64] = if keep_gaps { &gaps } else { &[] };
        match distribution_with_supports(&r, compliance, gaps, &scale) {
            Ok(Some(w)) => out.push(w),
            Ok(None) => return Ok(Settled::Limited(LimitedBy::Tips)),
            Err(reason) => return Ok(Settled::Limited(LimitedBy::NotProven { reason })),
        }
    }
    Ok(Settled::Loads(Box::new(r), out))
}

/// Some contact of `m` stands over a platform lower than its module's level.
pub(crate) fn has_drop(m: &Assembly) -> bool {
    m.contacts.iter().any(|k| {
        m.modules
            .iter()
            .find(|md| md.id == k.module)
            .is_some_and(|md| k.point[2] < md.position[2] - 1e-6)
    })
}

/// The connections whose loads in `w` exceed their limits, as the gate's answer.
fn over(r: &Resolved, w: &[Vec<[f64; SLOTS]>]) -> Option<LimitedBy> {
    let mut over = vec![false; r.connections.len()];
    for w in w {
        for (o, u) in over.iter_mut().zip(use_of_limits(r, w)) {
            *o |= u.is_some_and(|u| u > 1.0);
        }
    }
    let pairs: Vec<usize> = (0..over.len()).filter(|&k| over[k]).collect();
    (!pairs.is_empty()).then_some(LimitedBy::Connection { pairs })
}

/// The connections the elastic distribution of `m` overloads (`None`: none): the connectors
/// snap open rather than yield ([`crate::puzzlebot::AdvanceOptions::elastic`]).
pub(crate) fn elastic_limit(
    m: &Assembly,
    params: &FleetParams,
    settling: Option<&Settling>,
) -> Result<Option<LimitedBy>, AdapterError> {
    Ok(match settle(m, params, settling, has_drop(m))? {
        Settled::Loads(r, w) => over(&r, &w),
        Settled::Limited(why) => Some(why),
    })
}

/// The connections the peak of the load transfer from `before` to `after` (the models on
/// either side of a support event, same pairs) overloads, in either support limit (`None`:
/// none). A side without an elastic distribution is the static check's to judge.
///
/// Only the two support limits bound the peak. On supports of a tyre's compliance between
/// them ([`settle`]'s drop cases) the change is carried by the assembly pitching on its
/// supports, a slow mode damped by them, and a wheel rolling off an edge sheds its load over
/// its contact patch rather than at once, so the undamped step bound (`t`, amplification up to
/// 2) of the connectors' own response does not apply there; the settled loads of those cases
/// are the static elastic check's ([`elastic_limit`]).
pub fn transfer_limit(
    before: &Assembly,
    after: &Assembly,
    params: &FleetParams,
    t: LoadTransfer,
) -> Result<Option<LimitedBy>, AdapterError> {
    let (Settled::Loads(_, b), Settled::Loads(r, f)) = (
        settle(before, params, None, false)?,
        settle(after, params, None, false)?,
    ) else {
        return Ok(None);
    };
    let a = t.amplification();
    let peaks: Vec<Vec<[f64; SLOTS]>> = b.iter().zip(&f).map(|(b, f)| peak(b, f, a)).collect();
    Ok(over(&r, &peaks))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wheel_sheds_its_load_over_about_two_millimetres() {
        // √(2 · 17 mm · 0.1097 kg · 9.81 m/s² / 10⁴ N/m) = 1.91 mm.
        let t = LoadTransfer::default();
        assert!((t.overlap - 1.91e-3).abs() < 0.01e-3, "{}", t.overlap);
    }

    #[test]
    fn the_least_damped_robot_sets_the_bound() {
        let mut params = FleetParams::default();
        assert_eq!(LoadTransfer::of(&params).damping_ratio, 0.025f32 as f64);
        params.pilot.coupling.connector_damping_ratio = 0.01;
        assert_eq!(LoadTransfer::of(&params).damping_ratio, 0.01f32 as f64);
        params.non_pilot.coupling.connector_damping_ratio = 0.0;
        assert_eq!(LoadTransfer::of(&params).amplification(), 2.0);
    }

    #[test]
    fn amplification_falls_from_two_to_one_with_damping() {
        let a = |z: f64| {
            LoadTransfer {
                damping_ratio: z,
                ..LoadTransfer::default()
            }
            .amplification()
        };
        assert_eq!(a(0.0), 2.0);
        assert_eq!(a(1.0), 1.0);
        assert_eq!(a(2.0), 1.0);
        assert_eq!(a(-0.5), 2.0);
        assert_eq!(a(f64::NAN), 2.0);
        // ζ = 0.5: overshoot exp(−π/√3) ≈ 0.163.
        assert!((a(0.5) - 1.163).abs() < 1e-3, "{}", a(0.5));
        assert!(a(0.1) > a(0.2) && a(0.2) > a(0.5));
    }

    #[test]
    fn the_peak_overshoots_the_change_not_the_load() {
        let b = [[1.0, 0.0, -1.0, 0.0, 0.5, 0.0, 0.0]];
        let f = [[2.0, 0.0, 0.0, 1.0, 0.5, -1.0, 0.0]];
        let p = peak(&b, &f, 2.0);
        // Shear 1 → 2 peaks at 3; an unchanged couple stays; a new one doubles.
        assert_eq!(p[0][0], 3.0);
        assert_eq!(p[0][4], 0.5);
        assert_eq!(p[0][5], -2.0);
        // Axial: a pull of 1 turning into a press of 1 peaks at a press of 3.
        assert_eq!((p[0][2], p[0][3]), (0.0, 3.0));
        // Undamped amplification 1 (critical damping): the settled load.
        assert_eq!(peak(&b, &f, 1.0)[0][0], 2.0);
    }
}
