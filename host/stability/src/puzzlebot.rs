//! PuzzleBot adapter: builds the general model from fleet state (poses, established pairs),
//! the shared parameter set and the terrain, and answers "how far can this assembly advance
//! along this heading before it tips or a connection fails" ([`max_safe_advance`]).
//!
//! Modelling choices (not in THESIS; stated here, kept out of `puzzlebot_params`):
//! - non-pilot robots rest on 2 wheels at (`plant.wheel_axle_offset`, ±L/2) and 2 frictionless
//!   ball casters at (±`plant.caster_offset`, 0); pilots on 4 wheels at
//!   (±`plant.wheel_axle_offset`, ±L/2) (body frame, L = wheel base), as the 3-D physics;
//!   wheels hold friction in both directions (geared motors are not back-drivable); the
//!   casters stand `plant.caster_lift` clear of the ground, a gap the elastic distribution
//!   must close before they carry;
//! - a contact touches when the platform under it is at the assembly's level (±1 mm);
//! - connections sit at the centre-of-mass height; the frame has x up, z horizontal into the
//!   child; moment limits are the hold force times a lever of half the body height;
//!   the anchor is free in yaw (THESIS 4.2.2: ±0.5 rad), so its yaw couple is released.

pub use crate::events::support_events;
pub use crate::judge::judge_model;
use crate::model::{
    Assembly, Connection, ConnectorSpec, Contact, Limits6, Module, Objective, Vec3,
};
use crate::sag::{resting_bodies, Settling};
pub use crate::transfer::{LoadTransfer, SOFT_SUPPORTS};
pub use advance::{max_safe_advance, max_safe_advance_with, EVENT_EPS};
pub use bridge::{tip_of, Tip, MAX_TIP_ANGLE};

mod advance;
pub mod bridge;
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Pose of one robot (world, m and rad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobotPose {
    /// Pilot (4 wheels) or non-pilot (2 wheels + 2 casters).
    pub kind: RobotKind,
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Heading (rad).
    pub yaw: f64,
}

impl RobotPose {
    /// The same robot moved by `offset` (m, world).
    pub fn translated(&self, offset: [f64; 2]) -> RobotPose {
        RobotPose {
            x: self.x + offset[0],
            y: self.y + offset[1],
            ..*self
        }
    }
}

/// Type of an established coupling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PairKind {
    /// Robot `a`'s anchor (back) sits in robot `b`'s front opening.
    Anchor,
    /// Robot `a`'s left knob sits in robot `b`'s right hole.
    Knob,
}

/// An established pair (indices into `robots`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pair {
    /// Robot carrying the anchor head / the knob.
    pub a: usize,
    /// Robot carrying the opening / the hole.
    pub b: usize,
    /// Anchor or knob.
    pub kind: PairKind,
    /// Connection point in robot `a`'s body frame (m); default the anchor head
    /// (`geometry.anchor_head`) or the knob centre (`geometry.knob_left`). Use it for the two
    /// side points at x = ±`geometry.side_point_x`.
    #[serde(default)]
    pub point: Option<[f64; 2]>,
}

/// Fleet state of one assembly.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PuzzleAssembly {
    /// Robot poses.
    pub robots: Vec<RobotPose>,
    /// Established pairs.
    pub pairs: Vec<Pair>,
}

/// Options of the adapter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdvanceOptions {
    /// Treat couplings as unbreakable (rigid mesh): only tipping/sliding limits the advance.
    pub rigid_couplings: bool,
    /// A soft anchor carries no pitch couple: it swings freely within its ±0.5 rad pitch
    /// range (THESIS 4.2.2), so a robot past an edge hangs on it instead of being held level,
    /// as in the 3-D physics. The crossing planner sets it; off, the anchor is modelled as
    /// holding pitch up to its box limit.
    pub anchor_pitch_free: bool,
    /// A soft anchor carries no pull along the chain: its head slides out of the opening over
    /// its travel (THESIS 4.2.2: 5 mm, `coupling.anchor_travel`) before anything holds it, as
    /// in the 3-D physics, so a robot hanging past an edge cannot lean on the anchor's tension
    /// (with its wheels' friction) to stay level. It still pushes. The crossing planner sets
    /// it; off, the anchor holds a pull up to `anchor_hold_force`.
    pub anchor_slides: bool,
    /// A knob carries no couple about the shared face: it tilts freely until its hooks
    /// catch (THESIS 2.4.1; the 1 mm play over the knob and its 1.5 mm hook leave about
    /// ±12°), far beyond the small deflections of a standing assembly, as in the 3-D physics.
    /// The crossing planner sets it; off, the knob holds that tilt up to its box limit.
    pub knob_tilt_free: bool,
    /// Connectors snap open when overloaded: besides the gate's proof that some distribution
    /// of the loads keeps every connector within its limits, the distribution the assembly's
    /// compliance sets ([`crate::elastic`], `coupling.connector_stiffness`) must. The
    /// crossing planner sets it.
    pub elastic: bool,
    /// Horizontal acceleration along the direction of travel the proof covers, speeding up
    /// and braking (m/s²): the host starts and stops a crossing at any checked advance, its
    /// drive following the firmware's reference response, and the inertial load m·a at every
    /// centre of mass tilts the apparent gravity (d'Alembert). Without it, a state with the
    /// centre of mass exactly over a support line (a four-wheeled pilot on three wheels at an
    /// oblique edge) passes as stable though the slightest push tips it. 0: quasi-static.
    pub drive_accel: f64,
    /// A contact over a platform at most this much lower than the one the assembly stands on
    /// rests on it (m): the assembly's compliance lets a robot settle onto a platform a few
    /// millimetres down (THESIS 3.5.2's 5 mm, 3.5.3's 6 mm). 0: only the assembly's level.
    pub max_drop: f64,
    /// Check the connectors against the peak of the load they take over at every support
    /// event ([`crate::transfer`]) with this response; None: the settled loads only. Needs
    /// `elastic`.
    pub transfer: Option<LoadTransfer>,
    /// How the supports give and how high the bodies stand ([`crate::sag`]): a robot hanging
    /// over a gap whose settled underside meets the edge face of the platform ahead stops the
    /// advance ([`LimitedBy::StepUp`]), and the elastic check covers supports of that
    /// compliance where a contact stands over a lower platform ([`crate::transfer`]). None:
    /// neither.
    pub settling: Option<Settling>,
    /// The speed the drive holds through a stretch where the assembly's centre of mass lies
    /// past its supports (m/s, [`bridge`]): such a stretch is proven if the assembly, tipping
    /// as an inverted pendulum for the time the stretch takes, lands every contact and body
    /// that reaches the platform ahead on its top, and the state after it is proven. The host
    /// must not stop there ([`Advance::bridged`]). 0: no such stretch is proven.
    pub bridge_speed: f64,
    /// Search no further than this (m).
    pub horizon: f64,
}

impl Default for AdvanceOptions {
    fn default() -> Self {
        AdvanceOptions {
            rigid_couplings: false,
            anchor_pitch_free: false,
            anchor_slides: false,
            knob_tilt_free: false,
            elastic: false,
            drive_accel: 0.0,
            max_drop: 0.0,
            transfer: None,
            settling: None,
            bridge_speed: 0.0,
            horizon: 1.0,
        }
    }
}

/// Why the advance stops.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum LimitedBy {
    /// Nothing within the search horizon.
    Horizon,
    /// Whole-body instability: the assembly would tip, slide or fall (support lost).
    Tips,
    /// Internal instability: these pairs (indices into `pairs`) would break.
    Connection {
        /// Pair indices.
        pairs: Vec<usize>,
    },
    /// A contact would run into a platform higher than the assembly stands on, or the body of
    /// a robot hanging over a gap into the edge face of the platform ahead.
    StepUp {
        /// Robot index.
        robot: usize,
    },
    /// No wheel touches a platform in the settled assembly: it rests on its casters and its
    /// drive cannot push it on.
    Stalls,
    /// The solver reached no certificate: stop (never assume stable).
    NotProven {
        /// Solver message.
        reason: String,
    },
}

/// Answer of [`max_safe_advance`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Advance {
    /// Distance (m) the assembly can advance and still be proven stable.
    pub distance: f64,
    /// What stops it there.
    pub limited_by: LimitedBy,
    /// Stretches `[from, to]` (m of advance) proven only while the drive keeps its speed
    /// through them ([`AdvanceOptions::bridge_speed`]): stopped there, the assembly tips.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bridged: Vec<[f64; 2]>,
}

impl Advance {
    /// The farthest advance at which the assembly may stand still: the start of the first
    /// bridged stretch, or the whole distance.
    pub fn stop_limit(&self) -> f64 {
        self.bridged.first().map_or(self.distance, |b| b[0])
    }
}

/// Adapter input errors.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AdapterError {
    /// A pair names a robot that does not exist or itself.
    #[error("pairs[{0}]: robot index out of range or a robot paired with itself")]
    BadPair(usize),
    /// A pose or argument is not finite / not positive.
    #[error("{0}: must be finite (and step/horizon > 0)")]
    BadNumber(&'static str),
    /// Terrain description is invalid.
    #[error("terrain: {0}")]
    Terrain(String),
    /// The general model rejected the input.
    #[error("model: {0}")]
    Model(#[from] crate::model::ModelError),
}

/// Contact points of a robot in its body frame, and whether each is a wheel (friction): the
/// wheels at (±`plant.wheel_axle_offset`, ±L/2) (one axle on a non-pilot, two on a pilot) and
/// a non-pilot's casters at (±`plant.caster_offset`, 0), as the 3-D physics builds them.
pub fn contact_points(kind: RobotKind, params: &FleetParams) -> Vec<([f64; 2], bool)> {
    let p = params.robot(kind);
    let hy = 0.5 * f64::from(p.geometry.wheel_base);
    let d = f64::from(p.plant.wheel_axle_offset);
    let axles: &[f64] = if p.plant.four_wheels { &[d, -d] } else { &[d] };
    let mut out: Vec<([f64; 2], bool)> = axles
        .iter()
        .flat_map(|&x| [([x, hy], true), ([x, -hy], true)])
        .collect();
    if !p.plant.four_wheels {
        let c = f64::from(p.plant.caster_offset);
        out.push(([c, 0.0], false));
        out.push(([-c, 0.0], false));
    }
    out
}

/// The world position of body-frame point `b` (m) of robot `p`.
pub fn world(p: &RobotPose, b: [f64; 2]) -> [f64; 2] {
    let (s, c) = p.yaw.sin_cos();
    [p.x + c * b[0] - s * b[1], p.y + s * b[0] + c * b[1]]
}

/// A contact touches a platform within this of its height (m): it rolls onto a platform up
/// to this much higher than the assembly stands on.
pub const LEVEL_TOLERANCE: f64 = 1e-3;

/// Contact of each robot contact point with the terrain at the assembly level.
#[derive(Debug, Clone, PartialEq)]
enum Touch {
    Free,
    On(f64, f64), // friction, platform height
    Blocked,
}

fn touches(
    a: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    level: f64,
    offset: [f64; 2],
    max_drop: f64,
) -> Vec<Vec<Touch>> {
    a.robots
        .iter()
        .map(|r| {
            let moved = r.translated(offset);
            contact_points(r.kind, params)
                .iter()
                .map(|(b, _)| match terrain.support_at(world(&moved, *b)) {
                    Some((h, mu))
                        if h <= level + LEVEL_TOLERANCE
                            && h >= level - max_drop - LEVEL_TOLERANCE =>
                    {
                        Touch::On(mu, h)
                    }
                    Some((h, _)) if h > level + LEVEL_TOLERANCE => Touch::Blocked,
                    _ => Touch::Free,
                })
                .collect()
        })
        .collect()
}

/// The level the assembly stands on: the highest platform under any of its contacts.
pub fn assembly_level(a: &PuzzleAssembly, params: &FleetParams, terrain: &Terrain) -> Option<f64> {
    let mut level: Option<f64> = None;
    for r in &a.robots {
        for (b, _) in contact_points(r.kind, params) {
            if let Some((h, _)) = terrain.support_at(world(r, b)) {
                level = Some(level.map_or(h, |l: f64| l.max(h)));
            }
        }
    }
    level
}

fn check(a: &PuzzleAssembly) -> Result<(), AdapterError> {
    for r in &a.robots {
        if !(r.x.is_finite() && r.y.is_finite() && r.yaw.is_finite()) {
            return Err(AdapterError::BadNumber("robots[].x/y/yaw"));
        }
    }
    for (k, p) in a.pairs.iter().enumerate() {
        if p.a >= a.robots.len() || p.b >= a.robots.len() || p.a == p.b {
            return Err(AdapterError::BadPair(k));
        }
        if p.point
            .is_some_and(|q| !(q[0].is_finite() && q[1].is_finite()))
        {
            return Err(AdapterError::BadNumber("pairs[].point"));
        }
    }
    Ok(())
}

/// Build the general model of the assembly translated by `offset` (m), standing at `level`.
pub fn build_model(
    a: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    level: f64,
    offset: [f64; 2],
    rigid: bool,
) -> Result<Assembly, AdapterError> {
    let opt = AdvanceOptions {
        rigid_couplings: rigid,
        ..AdvanceOptions::default()
    };
    build_model_with(a, params, terrain, level, offset, &opt)
}

/// [`build_model`] with the options of [`AdvanceOptions`] (couplings rigid, the anchor's
/// pitch free, contacts on lower platforms).
pub fn build_model_with(
    a: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    level: f64,
    offset: [f64; 2],
    opt: &AdvanceOptions,
) -> Result<Assembly, AdapterError> {
    let (rigid, anchor_pitch_free) = (opt.rigid_couplings, opt.anchor_pitch_free);
    check(a)?;
    let t = touches(a, params, terrain, level, offset, opt.max_drop);
    let mut modules = Vec::with_capacity(a.robots.len());
    let mut contacts = Vec::new();
    for (i, r) in a.robots.iter().enumerate() {
        let p = params.robot(r.kind);
        let moved = r.translated(offset);
        modules.push(Module {
            id: format!("r{i}"),
            mass: p.mass.mass as f64,
            position: [moved.x, moved.y, level],
            rpy: [0.0, 0.0, r.yaw],
            com: [
                p.mass.com[0] as f64,
                p.mass.com[1] as f64,
                p.geometry.com_height as f64,
            ],
            fixed: false,
        });
        for ((b, wheel), touch) in contact_points(r.kind, params).iter().zip(&t[i]) {
            if let Touch::On(mu, h) = touch {
                let w = world(&moved, *b);
                let m = if *wheel { *mu } else { 0.0 };
                contacts.push(Contact {
                    module: format!("r{i}"),
                    point: [w[0], w[1], *h],
                    normal: None,
                    mu: [m, m],
                    x_axis: Some([r.yaw.cos(), r.yaw.sin(), 0.0]),
                    gap: clearance(p, *wheel, level, *h),
                });
            }
        }
    }
    let mut connectors = BTreeMap::new();
    let c = &params.non_pilot.coupling;
    let g = &params.non_pilot.geometry;
    let lever = 0.5 * g.height as f64;
    let weights = [1.0, 1.0, 1.0, 1.0 / lever, 1.0 / lever, 1.0 / lever];
    let (mut anchor, mut knob) = if rigid {
        (Limits6::default(), Limits6::default())
    } else {
        let ah = c.anchor_hold_force as f64;
        let kh = c.knob_hold_force as f64;
        let mut anchor = Limits6::uniform(ah, ah * lever);
        anchor.mx = Some(0.0); // yaw about the vertical local x axis: free
        (anchor, Limits6::uniform(kh, kh * lever))
    };
    if anchor_pitch_free {
        // Pitch about the horizontal axis across the chain (local y; x up, z into the child).
        anchor.my = Some(0.0);
    }
    if opt.anchor_slides {
        // Pull along the chain (local z): the head slides out over its travel.
        anchor.fz = Some(0.0);
    }
    if opt.knob_tilt_free {
        // Tilt about the shared face: about the body's forward axis (local y; x up, z across
        // into the robot with the hole).
        knob.my = Some(0.0);
    }
    for (name, max) in [("anchor", anchor), ("knob", knob)] {
        connectors.insert(
            name.to_string(),
            ConnectorSpec::Box {
                max,
                omega_k: weights,
                margin_weights: weights,
            },
        );
    }
    let mut connections = Vec::with_capacity(a.pairs.len());
    for p in &a.pairs {
        let ra = &a.robots[p.a];
        let ga = &params.robot(ra.kind).geometry;
        let moved = ra.translated(offset);
        let (body, name) = match p.kind {
            PairKind::Anchor => (ga.anchor_head, "anchor"),
            PairKind::Knob => (ga.knob_left, "knob"),
        };
        let w = world(&moved, p.point.unwrap_or([body[0] as f64, body[1] as f64]));
        let rb = &a.robots[p.b];
        let zc = level + params.robot(rb.kind).geometry.com_height as f64;
        let point: Vec3 = [w[0], w[1], zc];
        // z horizontal from the point into the child b.
        let cb = world(&rb.translated(offset), [0.0, 0.0]);
        // A knob's frame is its own: z across the shared face into the robot with the hole
        // (`a`'s left), as the connector's limits and the 3-D physics measure it; an anchor's
        // z runs along the chain into the robot behind.
        let mut axis = match p.kind {
            PairKind::Knob => [-ra.yaw.sin(), ra.yaw.cos(), 0.0],
            PairKind::Anchor => [cb[0] - w[0], cb[1] - w[1], 0.0],
        };
        if axis[0].hypot(axis[1]) < 1e-9 {
            axis = [ra.yaw.cos(), ra.yaw.sin(), 0.0];
        }
        connections.push(Connection {
            child: format!("r{}", p.b),
            parent: format!("r{}", p.a),
            connector: name.to_string(),
            point,
            axis: Some(axis),
            x_axis: Some([0.0, 0.0, 1.0]),
        });
    }
    let mut m = Assembly {
        gravity: [0.0, 0.0, -crate::model::GRAVITY],
        modules,
        connectors,
        connections,
        contacts,
        module_contacts: vec![],
        loads: vec![],
        objective: Objective::default(),
    };
    if let Some(s) = opt.settling.as_ref().filter(|s| s.rest_on_bodies) {
        let bodies = body_contacts(a, params, terrain, level, offset, s);
        if let Some(rests) = resting_bodies(&m, s, &bodies) {
            m.contacts.extend(
                bodies
                    .into_iter()
                    .zip(rests)
                    .filter(|(_, r)| *r)
                    .map(|(b, _)| b),
            );
        }
    }
    Ok(m)
}

/// The underside corners of every robot over a platform it could come to rest on (below its
/// underside at `level`), as contacts of the chassis' friction on that platform
/// ([`Settling::chassis_friction`], the platform's when lower) standing their clearance
/// above it.
fn body_contacts(
    a: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    level: f64,
    offset: [f64; 2],
    s: &Settling,
) -> Vec<Contact> {
    let mut out = vec![];
    for (i, r) in a.robots.iter().enumerate() {
        let moved = r.translated(offset);
        for c in body_corners(r.kind, params) {
            let w = world(&moved, c);
            let Some((h, mu)) = terrain.support_at(w) else {
                continue;
            };
            let gap = level + s.body_clearance - h;
            if gap > 0.0 {
                let mu = mu.min(s.chassis_friction);
                out.push(Contact {
                    module: format!("r{i}"),
                    point: [w[0], w[1], h],
                    normal: None,
                    mu: [mu, mu],
                    x_axis: Some([r.yaw.cos(), r.yaw.sin(), 0.0]),
                    gap,
                });
            }
        }
    }
    out
}

/// How far a contact (a wheel, else a caster) of a robot with parameters `p` at the
/// assembly's `level` stands clear of a platform of height `h` (m): the drop to a lower
/// platform, and a caster's lift.
pub(crate) fn clearance(p: &puzzlebot_params::RobotParams, wheel: bool, level: f64, h: f64) -> f64 {
    let lift = if wheel {
        0.0
    } else {
        f64::from(p.plant.caster_lift)
    };
    (level - h).max(0.0) + lift.max(0.0)
}

/// The four corners of a robot's underside in its body frame (m).
pub fn body_corners(kind: RobotKind, params: &FleetParams) -> [[f64; 2]; 4] {
    let [hl, hw] = params.robot(kind).geometry.half_extents();
    let (hl, hw) = (f64::from(hl), f64::from(hw));
    [[hl, hw], [hl, -hw], [-hl, hw], [-hl, -hw]]
}
