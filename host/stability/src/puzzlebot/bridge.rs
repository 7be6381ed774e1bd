//! Driving across a stretch where the assembly stands on no support polygon that holds it.
//!
//! When a support leaves an edge, the centre of mass may lie a little past the remaining
//! support polygon until a contact ahead reaches the next platform a few millimetres on.
//! Stopped there, the assembly tips. Driven through at a known speed, it tips only as far as
//! an inverted pendulum falls in the time the stretch takes; the gate proves that the
//! contacts and bodies that reach the platform ahead meanwhile arrive above its top (they land
//! on it) rather than below it (they meet its face). The proof holds only while the drive
//! keeps its speed through the stretch: [`super::Advance::bridged`] names the stretches where
//! the host must not stop.

use crate::model::Assembly;

/// The largest tipping angle (rad) the small-angle pendulum is used for; a stretch that would
/// tip further is not bridged (sin φ differs from φ by 1 % there).
pub const MAX_TIP_ANGLE: f64 = 0.25;

/// How a model whose centre of mass has passed its support polygon starts to tip: an inverted
/// pendulum about the polygon's edge nearest the centre of mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tip {
    /// The support polygon's point nearest the centre of mass (world, m): on the tipping axis.
    pub pivot: [f64; 2],
    /// Horizontal unit vector from the pivot towards the centre of mass: the way it tips.
    pub dir: [f64; 2],
    /// Horizontal distance of the centre of mass past the axis (m), with the drive's inertial
    /// shift (height × acceleration / g) added.
    pub excess: f64,
    /// Height of the centre of mass above the pivot (m).
    pub height: f64,
    /// Square of the pendulum's rate, M·g·h / I (1/s²), with the modules as point masses: a
    /// lower bound on the inertia and so an upper bound on how fast it tips.
    pub rate2: f64,
}

impl Tip {
    /// Tipping angle (rad) `t` s after the assembly starts from level and at rest:
    /// I·φ'' = M·g·(e + h·φ) for small φ, so φ = (e/h)(cosh ωt − 1).
    pub fn angle_after(&self, t: f64) -> f64 {
        (self.excess / self.height) * ((self.rate2.sqrt() * t).cosh() - 1.0)
    }

    /// How far ahead of the tipping axis a world point lies (m): it drops by this times the
    /// tipping angle.
    pub fn lever(&self, p: [f64; 2]) -> f64 {
        (p[0] - self.pivot[0]) * self.dir[0] + (p[1] - self.pivot[1]) * self.dir[1]
    }
}

/// The tip of model `m` whose modules speed up or brake at up to `drive_accel` (m/s²), for a
/// state the gate cannot prove standing: about the support polygon's edge nearest the centre
/// of mass, with the distance past it (0 within) plus the inertial shift height ×
/// acceleration / g as its excess, so the proof covers the drive pushing it that way
/// throughout. `None` when nothing tips it (within the polygon and no acceleration) or it has
/// no contacts (nothing to tip about: it falls).
pub fn tip_of(m: &Assembly, drive_accel: f64) -> Option<Tip> {
    let g = -m.gravity[2];
    let (mut mass, mut c) = (0.0, [0.0; 3]);
    let com: Vec<(f64, [f64; 3])> = m
        .modules
        .iter()
        .map(|md| {
            let (s, co) = md.rpy[2].sin_cos();
            let p = [
                md.position[0] + co * md.com[0] - s * md.com[1],
                md.position[1] + s * md.com[0] + co * md.com[1],
                md.position[2] + md.com[2],
            ];
            (md.mass, p)
        })
        .collect();
    for (w, p) in &com {
        mass += w;
        for k in 0..3 {
            c[k] += w * p[k];
        }
    }
    if !(mass > 0.0 && g > 0.0) || m.contacts.is_empty() {
        return None;
    }
    c.iter_mut().for_each(|v| *v /= mass);
    let pts: Vec<[f64; 2]> = m
        .contacts
        .iter()
        .map(|k| [k.point[0], k.point[1]])
        .collect();
    let hull = convex_hull(&pts);
    let within = hull.len() >= 3 && inside(&hull, [c[0], c[1]]);
    let pivot = nearest_on_boundary(&hull, [c[0], c[1]]);
    let off = [c[0] - pivot[0], c[1] - pivot[1]];
    let dist = off[0].hypot(off[1]);
    if dist < 1e-12 {
        return None;
    }
    // Towards the centre of mass past the polygon; from it through the nearest edge within.
    let (dir, signed) = if within {
        ([-off[0] / dist, -off[1] / dist], -dist)
    } else {
        ([off[0] / dist, off[1] / dist], dist)
    };
    let z0 = m
        .contacts
        .iter()
        .map(|k| k.point[2])
        .fold(f64::NEG_INFINITY, f64::max);
    let height = c[2] - z0;
    if height <= 1e-6 {
        return None;
    }
    let excess = signed.max(0.0) + height * drive_accel.max(0.0) / g;
    if excess <= 0.0 {
        return None;
    }
    let inertia: f64 = com
        .iter()
        .map(|(w, p)| {
            let along = (p[0] - pivot[0]) * dir[0] + (p[1] - pivot[1]) * dir[1];
            w * (along * along + (p[2] - z0) * (p[2] - z0))
        })
        .sum();
    Some(Tip {
        pivot,
        dir,
        excess,
        height,
        rate2: mass * g * height / inertia.max(1e-12),
    })
}

/// Convex hull of `pts` counter-clockwise (Andrew's monotone chain), collinear points dropped.
fn convex_hull(pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut p = pts.to_vec();
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut h: Vec<[f64; 2]> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = h.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while h.len() >= start + 2 && cross(h[h.len() - 2], h[h.len() - 1], q) <= 0.0 {
                h.pop();
            }
            h.push(q);
        }
        h.pop();
    }
    h
}

/// `p` lies inside or on the counter-clockwise convex polygon `hull`.
fn inside(hull: &[[f64; 2]], p: [f64; 2]) -> bool {
    (0..hull.len()).all(|i| {
        let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= 0.0
    })
}

/// The point of the polygon `hull`'s boundary (a point or a segment for fewer than 3
/// vertices) nearest `p`.
fn nearest_on_boundary(hull: &[[f64; 2]], p: [f64; 2]) -> [f64; 2] {
    let seg = |a: [f64; 2], b: [f64; 2]| {
        let ab = [b[0] - a[0], b[1] - a[1]];
        let l2 = ab[0] * ab[0] + ab[1] * ab[1];
        let t = if l2 > 0.0 {
            (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / l2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        [a[0] + t * ab[0], a[1] + t * ab[1]]
    };
    let n = hull.len();
    (0..n.max(1))
        .map(|i| seg(hull[i], hull[(i + 1) % n]))
        .min_by(|a, b| {
            let d = |q: &[f64; 2]| (q[0] - p[0]).hypot(q[1] - p[1]);
            d(a).total_cmp(&d(b))
        })
        .unwrap_or(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sag::tests::plate;

    #[test]
    fn a_plate_over_its_contacts_does_not_tip_and_one_past_them_tips_about_the_nearest_edge() {
        let sq = [
            ([0.05, 0.05], 0.0),
            ([0.05, -0.05], 0.0),
            ([-0.05, 0.05], 0.0),
            ([-0.05, -0.05], 0.0),
        ];
        assert_eq!(tip_of(&plate(&sq, [0.01, 0.0]), 0.0), None);
        // Braking at 1 m/s² moves the apparent centre of mass forward by h/10 — but a plate
        // with its centre of mass in its contact plane has no height to tip with.
        assert_eq!(tip_of(&plate(&sq, [0.07, 0.0]), 1.0), None);
        let mut m = plate(&sq, [0.07, 0.01]);
        m.modules[0].com = [0.0, 0.0, 0.02];
        let t = tip_of(&m, 0.0).expect("tips");
        assert!((t.excess - 0.02).abs() < 1e-12 && (t.height - 0.02).abs() < 1e-12);
        assert!(
            (t.dir[0] - 1.0).abs() < 1e-12 && t.dir[1].abs() < 1e-12,
            "{t:?}"
        );
        assert!((t.pivot[0] - 0.05).abs() < 1e-12 && (t.pivot[1] - 0.01).abs() < 1e-12);
        // One point mass 20 mm out and 20 mm up: I = m(e² + h²), ω² = g h / (e² + h²).
        assert!((t.rate2 - 10.0 * 0.02 / 8e-4).abs() < 1e-9);
        // Starting from level, it has tipped (e/h)(cosh ωt − 1) after t.
        let w = t.rate2.sqrt();
        assert!((t.angle_after(0.1) - ((w * 0.1).cosh() - 1.0)).abs() < 1e-12);
        assert_eq!(t.angle_after(0.0), 0.0);
        assert!((t.lever([0.15, 0.3]) - 0.1).abs() < 1e-12);
        // The drive's braking adds h·a/g to how far past the edge it stands.
        let braked = tip_of(&m, 1.0).expect("tips");
        assert!((braked.excess - (0.02 + 0.02 * 0.1)).abs() < 1e-12);
        // 1 mm inside the front edge it stands; braking that shifts it 2 mm forward tips it
        // about that edge as if it stood on the edge and were pushed the whole 2 mm.
        let mut near = plate(&sq, [0.049, 0.0]);
        near.modules[0].com = [0.0, 0.0, 0.02];
        assert_eq!(tip_of(&near, 0.0), None);
        let t = tip_of(&near, 1.0).expect("braking tips it");
        assert!(
            (t.excess - 0.002).abs() < 1e-12 && t.dir == [1.0, 0.0],
            "{t:?}"
        );
    }

    #[test]
    fn a_plate_on_one_axle_tips_about_it_and_a_plate_without_contacts_does_not_tip() {
        let axle = [([0.0, 0.05], 0.0), ([0.0, -0.05], 0.0)];
        let mut m = plate(&axle, [-0.01, 0.0]);
        m.modules[0].com = [0.0, 0.0, 0.02];
        let t = tip_of(&m, 0.0).expect("tips backwards");
        assert!((t.dir[0] + 1.0).abs() < 1e-12, "{t:?}");
        assert!((t.excess - 0.01).abs() < 1e-12);
        let mut none = plate(&[], [0.0, 0.0]);
        none.modules[0].com = [0.0, 0.0, 0.02];
        assert_eq!(tip_of(&none, 0.0), None);
    }

    #[test]
    fn the_hull_drops_inner_and_collinear_points() {
        let h = convex_hull(&[
            [0.0, 0.0],
            [1.0, 0.0],
            [0.5, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.5, 0.5],
        ]);
        assert_eq!(h.len(), 4);
        assert!(inside(&h, [0.5, 0.5]) && !inside(&h, [1.5, 0.5]));
    }
}
