//! The gate's judgement of a built PuzzleBot model: the static proof, the elastic check of
//! the connectors ([`crate::transfer`]), both standing and under the drive's acceleration,
//! and the peak of the load transfer at a support event.

use crate::gate::{evaluate, Verdict};
use crate::model::Assembly;
use crate::puzzlebot::{AdapterError, AdvanceOptions, LimitedBy};
use crate::transfer::{elastic_limit, transfer_limit};
use puzzlebot_params::FleetParams;

/// The gate's judgement of a built model (`None`: proven stable) travelling along `heading`
/// (rad), with the elastic check of [`AdvanceOptions::elastic`] and the drive's acceleration
/// both ways of [`AdvanceOptions::drive_accel`].
pub fn judge_model(
    m: &Assembly,
    params: &FleetParams,
    opt: &AdvanceOptions,
    heading: f64,
) -> Result<Option<LimitedBy>, AdapterError> {
    if let Some(why) = judge_one(m, params, opt)? {
        return Ok(Some(why));
    }
    for tilted in driven(m, opt, heading)? {
        if let Some(why) = judge_one(&tilted, params, opt)? {
            return Ok(Some(why));
        }
    }
    Ok(None)
}

/// `m` speeding up and braking at the drive's acceleration along `heading` (rad): none when
/// quasi-static ([`AdvanceOptions::drive_accel`] 0).
fn driven(m: &Assembly, opt: &AdvanceOptions, heading: f64) -> Result<Vec<Assembly>, AdapterError> {
    let a = opt.drive_accel;
    if !(a.is_finite() && a >= 0.0) {
        return Err(AdapterError::BadNumber("drive_accel"));
    }
    if a == 0.0 {
        return Ok(vec![]);
    }
    let (s, c) = heading.sin_cos();
    Ok([1.0, -1.0]
        .map(|sign| {
            // d'Alembert: accelerating at a along the travel loads every module with −m·a.
            let mut tilted = m.clone();
            tilted.gravity[0] -= sign * a * c;
            tilted.gravity[1] -= sign * a * s;
            tilted
        })
        .to_vec())
}

/// The peak of the load transfer from `before` to `after` (either side of a support event)
/// overloads a connector, standing and driven ([`transfer_limit`]; `None`: it does not, or
/// the options ask for no such check).
pub(crate) fn judge_transfer(
    before: &Assembly,
    after: &Assembly,
    params: &FleetParams,
    opt: &AdvanceOptions,
    heading: f64,
) -> Result<Option<LimitedBy>, AdapterError> {
    let Some(t) = opt.transfer.filter(|_| opt.elastic && !opt.rigid_couplings) else {
        return Ok(None);
    };
    let pairs = [(before.clone(), after.clone())].into_iter().chain(
        driven(before, opt, heading)?
            .into_iter()
            .zip(driven(after, opt, heading)?),
    );
    for (b, a) in pairs {
        if let Some(why) = transfer_limit(&b, &a, params, t)? {
            return Ok(Some(why));
        }
    }
    Ok(None)
}

/// The gate's judgement of a model under its own gravity.
fn judge_one(
    m: &Assembly,
    params: &FleetParams,
    opt: &AdvanceOptions,
) -> Result<Option<LimitedBy>, AdapterError> {
    let rep = evaluate(m)?;
    Ok(match rep.verdict {
        Verdict::Stable if opt.elastic && !opt.rigid_couplings => {
            elastic_limit(m, params, opt.settling.as_ref())?
        }
        Verdict::Stable => None,
        Verdict::WholeBodyInstability => Some(LimitedBy::Tips),
        Verdict::InternalInstability => Some(LimitedBy::Connection {
            pairs: rep.broken(),
        }),
        Verdict::NotProven { reason } => Some(LimitedBy::NotProven { reason }),
    })
}
