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

use crate::math::V2;
use puzzlebot_params::coupling::Coupling;
use puzzlebot_params::geometry::Geometry;

mod body;
mod contacts;
mod links;
mod solve;

pub use body::{Body, Shape};

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

impl From<puzzlebot_params::formation::Link> for LinkKind {
    fn from(l: puzzlebot_params::formation::Link) -> Self {
        match l {
            puzzlebot_params::formation::Link::Anchor => LinkKind::Anchor,
            puzzlebot_params::formation::Link::Knob => LinkKind::Knob,
        }
    }
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
}

#[cfg(test)]
mod tests;
