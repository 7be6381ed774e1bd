//! Position-based corrections: mass-weighted projection of one constraint on two bodies.

use super::Body;
use crate::math::{cross, sub, wrap, V2};

/// Apply a position-based correction `delta` (world) at world point `p` to body `b`, with
/// weight λ already divided by the inverse masses.
fn push_point(b: &mut Body, p: V2, impulse: V2) {
    b.pose.x += impulse[0] / b.mass;
    b.pose.y += impulse[1] / b.mass;
    let r = sub(p, b.pose.pos());
    b.pose.yaw += cross(r, impulse) / b.inertia;
}

/// Generalised inverse mass of body `b` for a correction along unit `n` at point `p`.
fn inv_mass(b: &Body, p: V2, n: V2) -> f64 {
    let r = sub(p, b.pose.pos());
    let rn = cross(r, n);
    1.0 / b.mass + rn * rn / b.inertia
}

/// Move points `pa` (on a) and `pb` (on b) so that `pb − pa` changes by `-c·n`
/// (c > 0 means they are `c` too far along n). Rotation included.
pub(super) fn solve_point(
    ba: &mut Body,
    bb: &mut Body,
    pa: V2,
    pb: V2,
    n: V2,
    c: f64,
    rotate: bool,
) {
    let (wa, wb) = if rotate {
        (inv_mass(ba, pa, n), inv_mass(bb, pb, n))
    } else {
        (1.0 / ba.mass, 1.0 / bb.mass)
    };
    let lambda = c / (wa + wb);
    let imp = [n[0] * lambda, n[1] * lambda];
    if rotate {
        push_point(ba, pa, imp);
        push_point(bb, pb, [-imp[0], -imp[1]]);
    } else {
        ba.pose.x += imp[0] / ba.mass;
        ba.pose.y += imp[1] / ba.mass;
        bb.pose.x -= imp[0] / bb.mass;
        bb.pose.y -= imp[1] / bb.mass;
    }
}

pub(super) fn limit_yaw(ba: &mut Body, bb: &mut Body, range: f64) {
    let phi = wrap(ba.pose.yaw - bb.pose.yaw);
    if phi.abs() > range {
        let c = phi - range * phi.signum();
        let itot = 1.0 / ba.inertia + 1.0 / bb.inertia;
        ba.pose.yaw -= c / ba.inertia / itot;
        bb.pose.yaw += c / bb.inertia / itot;
    }
}
