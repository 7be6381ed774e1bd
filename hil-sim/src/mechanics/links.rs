//! Couplings: detection, constraint projection and the anchor life cycle.

use super::solve::{limit_yaw, solve_point};
use super::{
    Body, CouplingF, Link, LinkEvent, LinkKind, LinkState, Mechanics, Shape, LEG_RELEASE_FRACTION,
};
use crate::math::{norm, sub, wrap, V2};
use puzzlebot_params::coupling::{AnchorProbe, KnobProbe};

impl Mechanics {
    /// `b`'s position in `a`'s frame for the knob/hole combination nearest to `rel` (b in
    /// a's frame): x ∈ {−2·side_x, 0, 2·side_x}, y = knob side to hole side.
    pub(super) fn knob_offset(&self, rel: V2) -> V2 {
        let sx = self.shape.side_x;
        let x = [-2.0 * sx, 0.0, 2.0 * sx]
            .into_iter()
            .min_by(|p, q| (p - rel[0]).abs().total_cmp(&(q - rel[0]).abs()))
            .unwrap_or(0.0);
        [x, 2.0 * self.shape.knob[1]]
    }

    pub(super) fn detect(&mut self, bodies: &[Body], events: &mut Vec<LinkEvent>) {
        let sh = self.shape;
        let (g, cp) = (self.geometry, self.coupling);
        let entry_yaw = f64::from(cp.anchor_entry_yaw);
        let knob_yaw = f64::from(cp.knob_yaw_tolerance);
        let pairs = std::mem::take(&mut self.pairs);
        for &(i, j) in &pairs {
            for (a, b) in [(i, j), (j, i)] {
                if self.linked(a, b) {
                    continue;
                }
                let (ba, bb) = (&bodies[a], &bodies[b]);
                let phi = wrap(ba.pose.yaw - bb.pose.yaw);
                if phi.abs() > entry_yaw && phi.abs() > knob_yaw {
                    continue;
                }
                let (fa, fb) = (ba.frame(), bb.frame());
                // Anchor of a into the opening of b (THESIS 4.2.2).
                if !self.anchor_busy(a) && !self.opening_busy(b) {
                    let probe = AnchorProbe {
                        head: fb.inverse_apply(fa.apply(sh.head)),
                        yaw: phi,
                    };
                    if cp.anchor_at_mouth(&g, &probe, 1.0) {
                        self.links.push(Link {
                            kind: LinkKind::Anchor,
                            a,
                            b,
                            state: LinkState::Inserting,
                            legs: [true, true],
                            swing: 0.0,
                            offset: [0.0; 2],
                        });
                        continue;
                    }
                }
                // A left knob of a into a right hole of b (b on a's left), THESIS Fig 5.12.
                if phi.abs() <= knob_yaw {
                    'knobs: for kx in [-sh.side_x, sh.side_x] {
                        let k = fb.inverse_apply(fa.apply([kx, sh.knob[1]]));
                        for hx in [-sh.side_x, sh.side_x] {
                            let probe = KnobProbe {
                                along: k[0] - hx,
                                gap: -sh.knob[1] - k[1],
                                yaw: phi,
                            };
                            if cp.knob_seated(&probe, 1.0) {
                                self.links.push(Link {
                                    kind: LinkKind::Knob,
                                    a,
                                    b,
                                    state: LinkState::Coupled,
                                    legs: [true, true],
                                    swing: 0.0,
                                    offset: [kx - hx, 2.0 * sh.knob[1]],
                                });
                                events.push(LinkEvent::Coupled(LinkKind::Knob, a, b));
                                break 'knobs;
                            }
                        }
                    }
                }
            }
        }
        self.pairs = pairs;
    }

    pub(super) fn project_links(&self, bodies: &mut [Body]) {
        let sh = self.shape;
        for l in &self.links {
            let (a, b) = (l.a, l.b);
            if a == b || !bodies[a].active || !bodies[b].active {
                continue;
            }
            let (ba, bb) = if a < b {
                let (lo, hi) = bodies.split_at_mut(b);
                (&mut lo[a], &mut hi[0])
            } else {
                let (lo, hi) = bodies.split_at_mut(a);
                (&mut hi[0], &mut lo[b])
            };
            match (l.kind, l.state) {
                (LinkKind::Knob, _) => {
                    // Rigid: b sits at a ∘ (offset, 0).
                    let offset = if l.offset[0].is_nan() {
                        [0.0, 2.0 * sh.knob[1]]
                    } else {
                        l.offset
                    };
                    let phi = wrap(ba.pose.yaw - bb.pose.yaw);
                    let itot = 1.0 / ba.inertia + 1.0 / bb.inertia;
                    ba.pose.yaw -= phi / ba.inertia / itot;
                    bb.pose.yaw += phi / bb.inertia / itot;
                    let target = ba.pose.apply(offset);
                    let err = sub(bb.pose.pos(), target);
                    let e = norm(err);
                    if e > 1e-12 {
                        let n = [err[0] / e, err[1] / e];
                        solve_point(bb, ba, bb.pose.pos(), target, n, -e, false);
                    }
                }
                (LinkKind::Anchor, LinkState::Inserting) => {
                    // Guided into the opening: lateral offset clamped, yaw limited.
                    let h = self.head_in(ba, bb);
                    let dy = h[1] - sh.opening[1];
                    if !Self::entering(&sh, &self.c, h, wrap(ba.pose.yaw - bb.pose.yaw)) {
                        continue; // torn away: `update_links` drops it, nothing is dragged
                    }
                    let lim = self.c.align.min(0.0005_f64.max(dy.abs() * 0.5));
                    if dy.abs() > lim {
                        let c = dy - lim * dy.signum();
                        let n = bb.pose.rotate([0.0, 1.0]);
                        let hw = ba.pose.apply(sh.head);
                        solve_point(ba, bb, hw, bb.pose.pos(), n, -c, false);
                    }
                    limit_yaw(ba, bb, self.c.yaw);
                }
                (LinkKind::Anchor, LinkState::Coupled) => {
                    limit_yaw(ba, bb, self.c.yaw);
                    // The pin (slits of b) must lie on a's anchor axis within the travel.
                    let pin_w = bb.pose.apply(sh.pin());
                    let q = ba.pose.inverse_apply(pin_w);
                    let x_hi = sh.head[0];
                    let x_lo = sh.head[0] - self.c.travel;
                    let cx = if q[0] > x_hi {
                        q[0] - x_hi
                    } else if q[0] < x_lo {
                        q[0] - x_lo
                    } else {
                        0.0
                    };
                    let cy = q[1] - sh.head[1];
                    for (local, c) in [([1.0, 0.0], cx), ([0.0, 1.0], cy)] {
                        if c.abs() > 1e-9 {
                            let n = ba.pose.rotate(local);
                            let pa = ba.pose.apply([q[0] - c * local[0], q[1] - c * local[1]]);
                            solve_point(ba, bb, pa, pin_w, n, c, true);
                        }
                    }
                }
                (LinkKind::Anchor, LinkState::Releasing) => {}
            }
            ba.retrig();
            bb.retrig();
        }
    }

    /// An inserting anchor's head `h` (in the opening robot's frame, relative yaw `phi`) is
    /// still in the opening's guide.
    fn entering(sh: &Shape, c: &CouplingF, h: V2, phi: f64) -> bool {
        h[0] <= sh.opening[0] + 5e-4
            && h[0] >= sh.pin()[0] - 2e-3
            && (h[1] - sh.opening[1]).abs() <= 2.0 * c.align
            && phi.abs() <= c.yaw
    }

    pub(super) fn update_links(&mut self, bodies: &[Body], events: &mut Vec<LinkEvent>) {
        let sh = self.shape;
        let c = self.c;
        let (g, cp) = (self.geometry, self.coupling);
        self.links.retain_mut(|l| {
            let (ba, bb) = (&bodies[l.a], &bodies[l.b]);
            if l.kind != LinkKind::Anchor {
                return true;
            }
            let h = bb.pose.inverse_apply(ba.pose.apply(sh.head));
            let phi = wrap(ba.pose.yaw - bb.pose.yaw);
            match l.state {
                LinkState::Inserting => {
                    // Backed out before it was in, or torn away sideways / turned away (only
                    // a seated anchor holds; an entering one never drags its partner along).
                    if !Self::entering(&sh, &c, h, phi) {
                        return false;
                    }
                    if cp.anchor_seated(&g, &AnchorProbe { head: h, yaw: phi }, 1.0) {
                        l.state = LinkState::Coupled;
                        l.legs = [true, true];
                        events.push(LinkEvent::Coupled(LinkKind::Anchor, l.a, l.b));
                    }
                    true
                }
                LinkState::Coupled => {
                    let thr = LEG_RELEASE_FRACTION * c.yaw;
                    match l.legs {
                        [true, true] => {
                            if phi.abs() > thr {
                                l.legs[usize::from(phi < 0.0)] = false;
                                l.swing = phi;
                            }
                        }
                        [false, true] | [true, false] => {
                            // One leg out: the anchor pivots on the other one, and swinging
                            // back by the release angle levers it out of its slit too.
                            if !l.legs[0] {
                                l.swing = l.swing.max(phi);
                            } else {
                                l.swing = l.swing.min(phi);
                            }
                            if (l.swing - phi).abs() > thr {
                                l.legs = [false, false];
                            }
                        }
                        [false, false] => {}
                    }
                    let q = ba.pose.inverse_apply(bb.pose.apply(sh.pin()));
                    let ext = sh.head[0] - q[0];
                    if ext < 0.5e-3 && phi.abs() < 0.1 {
                        l.legs = [true, true]; // pushed straight back in: re-seated
                    }
                    if !l.legs[0] && !l.legs[1] && ext >= c.travel - 0.5e-3 {
                        l.state = LinkState::Releasing;
                        events.push(LinkEvent::Decoupled(LinkKind::Anchor, l.a, l.b));
                    }
                    true
                }
                LinkState::Releasing => {
                    // Keep ignoring head contact until the head is clear of b.
                    h[0].abs() < sh.half[0] + 1e-3 && h[1].abs() < sh.half[1] + 1e-3
                }
            }
        });
    }
}
