//! Body contacts: broad phase, rectangle overlap and its projection.

use super::solve::solve_point;
use super::{Body, Link, LinkKind, LinkState, Mechanics};
use crate::math::{dot, norm, sub, Frame, V2};

/// Separating-axis test of two rectangles: (normal from a to b, penetration) if they overlap.
fn rect_overlap(pa: &Frame, pb: &Frame, half: V2) -> Option<(V2, f64)> {
    let axes = [
        pa.rotate([1.0, 0.0]),
        pa.rotate([0.0, 1.0]),
        pb.rotate([1.0, 0.0]),
        pb.rotate([0.0, 1.0]),
    ];
    let d = sub(pb.pos(), pa.pos());
    let reach = 2.0 * norm(half);
    if dot(d, d) > reach * reach {
        return None;
    }
    let ua = [axes[0], axes[1]];
    let ub = [axes[2], axes[3]];
    let mut best: Option<(V2, f64)> = None;
    for ax in axes {
        let ra = half[0] * dot(ua[0], ax).abs() + half[1] * dot(ua[1], ax).abs();
        let rb = half[0] * dot(ub[0], ax).abs() + half[1] * dot(ub[1], ax).abs();
        let dist = dot(d, ax);
        let pen = ra + rb - dist.abs();
        if pen <= 0.0 {
            return None;
        }
        let n = if dist >= 0.0 { ax } else { [-ax[0], -ax[1]] };
        if best.is_none_or(|(_, p)| pen < p) {
            best = Some((n, pen));
        }
    }
    best
}

/// Where two overlapping rectangles touch (normal `n` from a to b): the corner of b deepest
/// against n and the corner of a deepest along n, averaged.
fn contact_point(pa: &Frame, pb: &Frame, half: V2, n: V2) -> V2 {
    let corners = |f: &Frame| {
        [
            f.apply([half[0], half[1]]),
            f.apply([half[0], -half[1]]),
            f.apply([-half[0], half[1]]),
            f.apply([-half[0], -half[1]]),
        ]
    };
    let deepest = |cs: [V2; 4], sign: f64| {
        cs.into_iter()
            .max_by(|p, q| (sign * dot(*p, n)).total_cmp(&(sign * dot(*q, n))))
            .unwrap_or(cs[0])
    };
    let ca = deepest(corners(pa), 1.0);
    let cb = deepest(corners(pb), -1.0);
    [(ca[0] + cb[0]) * 0.5, (ca[1] + cb[1]) * 0.5]
}

impl Mechanics {
    /// Pairs of active bodies whose rectangles touch (within 0.5 mm) or overlap.
    pub fn contact_count(&self, bodies: &[Body]) -> usize {
        let mut grown = self.shape.half;
        grown[0] += 2.5e-4;
        grown[1] += 2.5e-4;
        let mut n = 0;
        for (i, a) in bodies.iter().enumerate() {
            for b in &bodies[i + 1..] {
                if a.active && b.active && rect_overlap(&a.frame(), &b.frame(), grown).is_some() {
                    n += 1;
                }
            }
        }
        n
    }

    /// Candidate pairs by a sweep along x (bodies closer than two bounding radii).
    pub(super) fn broad_phase(&mut self, bodies: &[Body]) {
        self.pairs.clear();
        // The order persists between steps and is nearly sorted: insertion sort is O(n).
        if self.order.len() != bodies.len() {
            self.order = (0..bodies.len()).collect();
        }
        let key = |i: usize| bodies[i].pose.x;
        for k in 1..self.order.len() {
            let mut j = k;
            while j > 0 && key(self.order[j - 1]) > key(self.order[j]) {
                self.order.swap(j - 1, j);
                j -= 1;
            }
        }
        let reach = 2.0 * self.shape.radius + 0.002;
        for (k, &i) in self.order.iter().enumerate() {
            if !bodies[i].active {
                continue;
            }
            for &j in &self.order[k + 1..] {
                if bodies[j].pose.x - bodies[i].pose.x > reach {
                    break;
                }
                if bodies[j].active && (bodies[j].pose.y - bodies[i].pose.y).abs() <= reach {
                    self.pairs.push((i.min(j), i.max(j)));
                }
            }
        }
        self.pairs.sort_unstable();
    }

    pub(super) fn project_contacts(&self, bodies: &mut [Body], groups: &[usize]) -> bool {
        let sh = self.shape;
        let mut moved = false;
        for &(i, j) in &self.pairs {
            let link = self.link_between(i, j);
            let same_group = groups.get(i).is_some_and(|gi| groups.get(j) == Some(gi));
            let (lo, hi) = bodies.split_at_mut(j);
            let (bi, bj) = (&mut lo[i], &mut hi[0]);
            if !bi.active || !bj.active {
                continue;
            }
            // Body against body, except inside an anchor pair that is inserting or coupled
            // (the anchor and the opening's guide govern) and a knob pair (rigid).
            let skip_bodies = matches!(
                link,
                Some(Link {
                    kind: LinkKind::Anchor,
                    state: LinkState::Coupled | LinkState::Inserting,
                    ..
                }) | Some(Link {
                    kind: LinkKind::Knob,
                    ..
                })
            );
            let (fi, fj) = (bi.frame(), bj.frame());
            if !skip_bodies && !same_group {
                if let Some((n, pen)) = rect_overlap(&fi, &fj, sh.half) {
                    moved = true;
                    if self.in_assembly(i) && self.in_assembly(j) {
                        let p = contact_point(&fi, &fj, sh.half, n);
                        solve_point(bi, bj, p, p, n, -pen, true);
                        bi.retrig();
                        bj.retrig();
                    } else {
                        solve_point(bi, bj, bi.pose.pos(), bj.pose.pos(), n, -pen, false);
                    }
                }
            }
            // Anchor heads against the other body unless inserting / coupled / releasing.
            for swap in [false, true] {
                let (ba, bb) = if swap {
                    (&mut *bj, &mut *bi)
                } else {
                    (&mut *bi, &mut *bj)
                };
                let (ia, ib) = if swap { (j, i) } else { (i, j) };
                // Contacts move bodies without turning them: only positions changed.
                let (fa, fb) = if swap {
                    (fj.moved(&ba.pose), fi.moved(&bb.pose))
                } else {
                    (fi.moved(&ba.pose), fj.moved(&bb.pose))
                };
                if link.is_some_and(|l| l.kind == LinkKind::Anchor && l.a == ia && l.b == ib) {
                    continue;
                }
                let hw = fa.apply(sh.head);
                let h = fb.inverse_apply(hw);
                let px = sh.half[0] - h[0].abs();
                let py = sh.half[1] - h[1].abs();
                if px > 0.0 && py > 0.0 {
                    // Push the head out through the nearest face of bb.
                    let local = if px < py {
                        [h[0].signum(), 0.0]
                    } else {
                        [0.0, h[1].signum()]
                    };
                    let n = fb.rotate(local);
                    let pen = px.min(py);
                    moved = true;
                    solve_point(bb, ba, bb.pose.pos(), hw, n, -pen, false);
                }
            }
        }
        moved
    }
}
