//! Contacts and couplings between robots: a documented kinematic / constraint model.
//!
//! # Why not a physics engine
//!
//! DESIGN.md §6 asks for a well-kept physics library unless a kinematic model is simpler
//! and reproduces the behaviours. The behaviours are all planar and geometric (THESIS
//! 4.2.2, 4.4.1, 5.2.3, 5.5.2, 5.7): the anchor enters only when its head is within
//! 3.5 mm of the opening, it cannot be pulled straight out because the pull-out force
//! (> 0.6 N at 0.4 mm, rising beyond; `Coupling::anchor_hold_force`) exceeds anything one
//! robot's traction (≈ 0.5 N) can produce, a wiggle pops the legs from the slits, the
//! coupled anchor leaves ±0.5 rad and 5 mm of play, knobs need < 1 mm and are rigid.
//! THESIS itself simulated the soft anchor in Bullet as a three-bar linkage with torque
//! limits (4.4.2) and still needed hand-tuned joint limits. A rigid-body engine (rapier2d)
//! would need the same hand-made rules for leg engagement and release on top of its
//! contacts, at ~10× the cost per robot, while the drive plant ([`crate::drive`])
//! already carries all forces on the wheels. So we use position-based dynamics (PBD):
//! after each plant step, overlaps and coupling limits are removed by mass-weighted
//! projection (Gauss–Seidel, a few iterations), and the projection's displacement is fed
//! back into the robots' velocities, which makes momentum flow between robots: a driving
//! robot pushes another, its wheels slip when it is blocked, and coupled groups move
//! together.
//!
//! # Shapes
//!
//! A robot is a `length × width` rectangle plus its anchor head point a
//! (`Geometry::anchor_head`, 7 mm behind the rear face). The opening is the front face
//! centre (`Geometry::anchor_opening`), the knob the left side centre
//! (`Geometry::knob_left`), the hole the mirror point on the right side.
//!
//! # Anchor life cycle
//!
//! 1. *Free*: the head collides with other robots like a solid point.
//! 2. *Inserting*: the head reached another robot's front face with
//!    |lateral offset| ≤ `anchor_align_tolerance` (3.5 mm) and relative yaw ≤
//!    `anchor_entry_yaw` ([`Coupling::anchor_at_mouth`]) and the robots are pushed
//!    together: the head may enter, guided laterally into the opening. From here on the
//!    anchor governs the pair: their body rectangles no longer block each other (the
//!    opening sits in a recess and the front corners are rounded, THESIS Fig 4.3; the
//!    rectangles would otherwise stop a yawed anchor millimetres short of its seat while
//!    the same yaw is allowed once coupled).
//! 3. *Coupled*: once the head is within `anchor_seat` of its seat
//!    ([`Coupling::anchor_seated`], the same predicate the host's pair status machine
//!    uses for "head inserted"), the head is pinned in the opening's slits; relative yaw is limited to ±`anchor_yaw_range`
//!    and the anchor slides in its holder by up to `anchor_travel`. Both legs sit in the
//!    slits: pulling straight only takes up the 5 mm travel and drags the other robot.
//! 4. A relative yaw beyond [`LEG_RELEASE_FRACTION`] of the range pops the leg on that
//!    side (THESIS 5.4.2: "one leg within the first second"); with both legs out, a pull
//!    to full travel releases the anchor (*Releasing* until the head is clear). Pushing
//!    back in straight (zero travel, small yaw) re-seats popped legs.
//!
//! Each side carries two connection points at ±`Geometry::side_point_x` (THESIS Fig 5.12):
//! knobs on the left, holes on the right. A knob couples when it is within
//! `knob_align_tolerance` (1 mm) of a hole of the other robot along the side, the headings
//! agree within `knob_yaw_tolerance` and the sides touch ([`Coupling::knob_seated`]);
//! side by side both knobs go in, with the half-body offset of a mesh (THESIS 5.2.2) one.
//! The pair is rigid afterwards (the two robots keep their relative pose). A knob pair holds more than robots can pull (`knob_hold_force`), so it is
//! released only by a person ([`Mechanics::detach`], [`Mechanics::lift_knobs`]).

use crate::math::{cross, dot, norm, sub, wrap, Frame, Pose, V2};
use puzzlebot_params::coupling::{AnchorProbe, Coupling, KnobProbe};
use puzzlebot_params::geometry::Geometry;

/// Fraction of the anchor yaw range beyond which a leg pops out of its slit.
pub const LEG_RELEASE_FRACTION: f64 = 0.7;
/// Projection iterations per step.
pub const ITERATIONS: usize = 4;

/// Which coupling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum LinkKind {
    /// Soft anchor of robot `a` in the front opening of robot `b`.
    Anchor,
    /// Left knob of robot `a` in the right hole of robot `b`.
    Knob,
}

/// Progress of a coupling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum LinkState {
    /// Anchor head is entering the opening.
    Inserting,
    /// Coupled.
    Coupled,
    /// Anchor released; the head is still inside the other body.
    Releasing,
}

/// A coupling between two robots (indices into the world's robot list).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// Kind.
    pub kind: LinkKind,
    /// Robot carrying the anchor / knob.
    pub a: usize,
    /// Robot carrying the opening / hole.
    pub b: usize,
    /// State.
    pub state: LinkState,
    /// Anchor legs seated (left, right).
    pub legs: [bool; 2],
    /// Relative yaw extreme reached since the first leg popped (rad).
    pub swing: f64,
    /// Knob links: `b`'s position in `a`'s frame (m), fixed when the knob clicked in
    /// (side by side: (0, width); half-body offset: (±2·side_point_x, width)).
    pub offset: [f64; 2],
}

/// What happened to a coupling in one step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkEvent {
    /// A coupling closed.
    Coupled(LinkKind, usize, usize),
    /// A coupling opened.
    Decoupled(LinkKind, usize, usize),
}

/// One body as the mechanics sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Pose.
    pub pose: Pose,
    /// Mass (kg).
    pub mass: f64,
    /// Yaw inertia (kg·m²).
    pub inertia: f64,
    /// Takes part in contacts (false: fallen or switched off the table).
    pub active: bool,
    /// sin, cos of `pose.yaw` (whoever turns the body keeps them in sync).
    pub trig: [f64; 2],
}

impl Body {
    /// A body at `pose`.
    pub fn new(pose: Pose, mass: f64, inertia: f64) -> Body {
        let (s, c) = pose.yaw.sin_cos();
        Body {
            pose,
            mass,
            inertia,
            active: true,
            trig: [s, c],
        }
    }

    fn frame(&self) -> Frame {
        Frame {
            x: self.pose.x,
            y: self.pose.y,
            s: self.trig[0],
            c: self.trig[1],
        }
    }

    fn retrig(&mut self) {
        let (s, c) = self.pose.yaw.sin_cos();
        self.trig = [s, c];
    }
}

/// Geometry numbers the mechanics needs (f64).
#[derive(Debug, Clone, Copy)]
pub struct Shape {
    half: V2,
    head: V2,
    opening: V2,
    knob: V2,
    /// x of the two connection points on each side (m).
    side_x: f64,
    /// Depth the head sits inside the other body when fully in (m).
    depth: f64,
    radius: f64,
}

impl Shape {
    /// From the shared geometry.
    pub fn new(g: &Geometry) -> Shape {
        let half = [f64::from(g.length) * 0.5, f64::from(g.width) * 0.5];
        let head = [f64::from(g.anchor_head[0]), f64::from(g.anchor_head[1])];
        let opening = [
            f64::from(g.anchor_opening[0]),
            f64::from(g.anchor_opening[1]),
        ];
        let knob = [f64::from(g.knob_left[0]), f64::from(g.knob_left[1])];
        let depth = Coupling::anchor_depth(g);
        Shape {
            half,
            head,
            opening,
            knob,
            side_x: f64::from(g.side_point_x),
            depth,
            radius: norm(half).max(norm(head)),
        }
    }

    /// Where the head sits in the opening robot's frame when fully in, zero travel.
    fn pin(&self) -> V2 {
        [self.opening[0] - self.depth, self.opening[1]]
    }
}

/// Contacts and couplings of a fleet.
#[derive(Debug, Clone)]
pub struct Mechanics {
    shape: Shape,
    geometry: Geometry,
    coupling: Coupling,
    c: CouplingF,
    links: Vec<Link>,
    pairs: Vec<(usize, usize)>,
    order: Vec<usize>,
}

#[derive(Debug, Clone, Copy)]
struct CouplingF {
    align: f64,
    yaw: f64,
    travel: f64,
}

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
fn solve_point(ba: &mut Body, bb: &mut Body, pa: V2, pb: V2, n: V2, c: f64, rotate: bool) {
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
    /// Mechanics for robots of geometry `g` with couplings `c`.
    pub fn new(g: &Geometry, c: &Coupling) -> Mechanics {
        Mechanics {
            shape: Shape::new(g),
            geometry: *g,
            coupling: *c,
            c: CouplingF {
                align: f64::from(c.anchor_align_tolerance),
                yaw: f64::from(c.anchor_yaw_range),
                travel: f64::from(c.anchor_travel),
            },
            links: Vec::new(),
            pairs: Vec::new(),
            order: Vec::new(),
        }
    }

    /// Current couplings (every state).
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// Pairs (a, b, kind) that are coupled now.
    pub fn coupled(&self) -> impl Iterator<Item = (usize, usize, LinkKind)> + '_ {
        self.links
            .iter()
            .filter(|l| l.state == LinkState::Coupled)
            .map(|l| (l.a, l.b, l.kind))
    }

    /// Start with robots `a` and `b` already coupled (scenario setup). The poses should
    /// already be in the coupled relation; the constraints pull them into it otherwise
    /// (a knob takes the knob/hole combination nearest to the poses at the next step).
    pub fn attach(&mut self, kind: LinkKind, a: usize, b: usize) {
        self.links
            .retain(|l| !(l.a == a && l.b == b && l.kind == kind));
        self.links.push(Link {
            kind,
            a,
            b,
            state: LinkState::Coupled,
            legs: [true, true],
            swing: 0.0,
            offset: [f64::NAN; 2],
        });
    }

    /// `b`'s position in `a`'s frame for the knob/hole combination nearest to `rel` (b in
    /// a's frame): x ∈ {−2·side_x, 0, 2·side_x}, y = knob side to hole side.
    fn knob_offset(&self, rel: V2) -> V2 {
        let sx = self.shape.side_x;
        let x = [-2.0 * sx, 0.0, 2.0 * sx]
            .into_iter()
            .min_by(|p, q| (p - rel[0]).abs().total_cmp(&(q - rel[0]).abs()))
            .unwrap_or(0.0);
        [x, 2.0 * self.shape.knob[1]]
    }

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

    /// Remove every coupling that involves robot `i` (fallen, switched off and lifted).
    pub fn detach_robot(&mut self, i: usize, events: &mut Vec<LinkEvent>) {
        self.links.retain(|l| {
            let hit = l.a == i || l.b == i;
            if hit && l.state == LinkState::Coupled {
                events.push(LinkEvent::Decoupled(l.kind, l.a, l.b));
            }
            !hit
        });
    }

    /// Remove the coupling of `kind` between `a` and `b` (by hand). True when one existed.
    pub fn detach(&mut self, kind: LinkKind, a: usize, b: usize) -> bool {
        let n = self.links.len();
        self.links
            .retain(|l| !(l.kind == kind && l.a == a && l.b == b));
        self.links.len() != n
    }

    /// Remove every coupled knob link between two of `members` (a person lifting the knob
    /// pairs apart, THESIS 5.5.3: robots cannot pull a knob out of its hole). Returns the
    /// removed links (a, b).
    pub fn lift_knobs(&mut self, members: &[usize]) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        self.links.retain(|l| {
            let hit = l.kind == LinkKind::Knob
                && l.state == LinkState::Coupled
                && members.contains(&l.a)
                && members.contains(&l.b);
            if hit {
                out.push((l.a, l.b));
            }
            !hit
        });
        out
    }

    /// Groups of bodies joined by the remaining links (any kind, any state): a label per
    /// body, equal within a group.
    pub fn linked_groups(&self, n: usize) -> Vec<usize> {
        self.groups(n, |_| true)
    }

    /// Islands of bodies that can act on each other this step (joined by a link or a
    /// broad-phase pair): a label per body, equal within an island.
    pub fn islands(&self, n: usize) -> Vec<usize> {
        let mut g = petgraph::unionfind::UnionFind::<usize>::new(n);
        for l in &self.links {
            if l.a < n && l.b < n {
                g.union(l.a, l.b);
            }
        }
        for &(i, j) in &self.pairs {
            if i < n && j < n {
                g.union(i, j);
            }
        }
        g.into_labeling()
    }

    fn linked(&self, i: usize, j: usize) -> bool {
        self.links
            .iter()
            .any(|l| (l.a == i && l.b == j) || (l.a == j && l.b == i))
    }

    fn in_assembly(&self, i: usize) -> bool {
        self.links
            .iter()
            .any(|l| l.state == LinkState::Coupled && (l.a == i || l.b == i))
    }

    fn anchor_busy(&self, a: usize) -> bool {
        self.links
            .iter()
            .any(|l| l.kind == LinkKind::Anchor && l.a == a)
    }

    fn opening_busy(&self, b: usize) -> bool {
        self.links
            .iter()
            .any(|l| l.kind == LinkKind::Anchor && l.b == b)
    }

    /// Candidate pairs by a sweep along x (bodies closer than two bounding radii).
    fn broad_phase(&mut self, bodies: &[Body]) {
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

    /// Head of `a` in `b`'s frame.
    fn head_in(&self, a: &Body, b: &Body) -> V2 {
        b.pose.inverse_apply(a.pose.apply(self.shape.head))
    }

    /// Detect new couplings, enforce contacts and couplings, update link states.
    /// `bodies` are moved in place; returns what changed.
    pub fn resolve(&mut self, bodies: &mut [Body], events: &mut Vec<LinkEvent>) {
        self.broad_phase(bodies);
        if self.pairs.is_empty() && self.links.is_empty() {
            return;
        }
        for k in 0..self.links.len() {
            let l = self.links[k];
            if l.kind == LinkKind::Knob && l.offset[0].is_nan() {
                let rel = bodies[l.a].pose.inverse_apply(bodies[l.b].pose.pos());
                self.links[k].offset = self.knob_offset(rel);
            }
        }
        self.detect(bodies, events);
        let groups = self.rigid_groups(bodies.len());
        for _ in 0..ITERATIONS {
            let moved = self.project_contacts(bodies, &groups);
            if self.links.is_empty() && !moved {
                break;
            }
            self.project_links(bodies);
        }
        self.update_links(bodies, events);
    }

    fn detect(&mut self, bodies: &[Body], events: &mut Vec<LinkEvent>) {
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

    fn link_between(&self, i: usize, j: usize) -> Option<Link> {
        self.links
            .iter()
            .copied()
            .find(|l| (l.a == i && l.b == j) || (l.a == j && l.b == i))
    }

    /// Group of every body over coupled links (assemblies): robots in one assembly hold
    /// their places through the couplings, so their bodies do not also push each other (a
    /// mesh's neighbours touch by design; contacts and couplings would fight).
    fn rigid_groups(&self, n: usize) -> Vec<usize> {
        self.groups(n, |l| l.state == LinkState::Coupled)
    }

    /// Union–find over the links that pass `keep`: a group label per body.
    fn groups(&self, n: usize, keep: impl Fn(&Link) -> bool) -> Vec<usize> {
        let mut g = petgraph::unionfind::UnionFind::<usize>::new(n);
        for l in self.links.iter().filter(|l| keep(l)) {
            if l.a < n && l.b < n {
                g.union(l.a, l.b);
            }
        }
        g.into_labeling()
    }

    fn project_contacts(&self, bodies: &mut [Body], groups: &[usize]) -> bool {
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

    fn project_links(&self, bodies: &mut [Body]) {
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

    fn update_links(&mut self, bodies: &[Body], events: &mut Vec<LinkEvent>) {
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

fn limit_yaw(ba: &mut Body, bb: &mut Body, range: f64) {
    let phi = wrap(ba.pose.yaw - bb.pose.yaw);
    if phi.abs() > range {
        let c = phi - range * phi.signum();
        let itot = 1.0 / ba.inertia + 1.0 / bb.inertia;
        ba.pose.yaw -= c / ba.inertia / itot;
        bb.pose.yaw += c / bb.inertia / itot;
    }
}

#[cfg(test)]
mod tests;
