//! How far the assembly settles into supports that give, and whether a robot hanging over a
//! gap sags far enough for its body to meet the edge face of the platform ahead.
//!
//! The gate's rigid translation holds every robot at the assembly's level. On supports that
//! sink under load (tyres, printed platforms, a simulator's soft contacts) the assembly
//! pitches towards its loaded side, and a robot with no wheel or caster of its own on a
//! platform hangs from its connectors and follows that pitch: near a tipping line the rear
//! supports unload and the front of the assembly drops by millimetres. A hanging robot whose
//! underside has dropped below the top of the platform ahead runs its body into that
//! platform's edge face and stalls, and the robots behind push it until a connector opens.
//! The gate calls such an advance unprovable ([`edge_stall`]).
//!
//! The settling ([`settle_articulated`]) takes every robot as a rigid body on a one-sided
//! linear spring at each of its contacts (engaging once its sink has closed the contact's gap:
//! a lifted caster, a lower platform), joined by the connectors' springs, each free about the
//! axis the gate releases (an anchor's pitch, a knob's tilt about the shared face) up to its
//! limit: a robot hanging on such couplings swings about them. [`settle`] is the same for the
//! assembly as one rigid body.

use crate::model::{Assembly, Contact};
use crate::puzzlebot::{body_corners, world, PuzzleAssembly};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotParams};

mod articulated;
pub use articulated::{resting_bodies, settle_articulated, wheels_bear, Sag};

/// How the supports give and how high the bodies stand above them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settling {
    /// Sink of a wheel under a unit normal force (m/N): a tyre on a platform. THESIS gives
    /// none; 2 mm/N, a wheel sinking about a millimetre under its share of a robot's weight.
    pub wheel_compliance: f64,
    /// Sink of a ball caster under a unit normal force (m/N): a hard ball on the chassis,
    /// several times stiffer than a tyre. THESIS gives none; 0.3 mm/N.
    pub caster_compliance: f64,
    /// Height of a robot's underside above the ground it stands on (m). THESIS gives none;
    /// 5 mm, as the 3-D physics' chassis.
    pub body_clearance: f64,
    /// How far a hanging robot's underside may sag below the lowest platform top before it
    /// counts as fallen (m): the 3-D physics' 10 mm.
    pub max_droop: f64,
    /// Stiffness of a connector's held translations (N/m): `coupling.connector_stiffness`.
    pub connector_stiffness: f64,
    /// Stiffness of a connector's held rotations (N·m/rad):
    /// `coupling.connector_angular_stiffness`.
    pub connector_angular_stiffness: f64,
    /// How far a released anchor pitches freely (rad): THESIS 4.2.2's ±0.5 rad
    /// (`coupling.anchor_yaw_range`, the same beams).
    pub anchor_pitch_range: f64,
    /// How far a released knob tilts freely about the shared face (rad):
    /// [`puzzlebot_params::coupling::Coupling::knob_tilt_limit`].
    pub knob_tilt_range: f64,
    /// Friction coefficient of a robot's underside on a platform: the 3-D physics' printed
    /// chassis, 0.3. A hanging robot whose underside comes to rest on a platform stands on it
    /// with this friction.
    pub chassis_friction: f64,
    /// Let a hanging robot whose settled underside reaches a platform rest on it
    /// ([`resting_bodies`]). Off by default: over THESIS's whole protocol it called 36 runs
    /// safe that failed in the 3-D physics: lines of 2 whose front robot hangs on its one
    /// anchor with a corner on the far platform's edge (it slides off there), and 2 × 2
    /// meshes whose front robots would swing 0.5 rad down a 48 mm step to reach it (the
    /// small-motion settling does not hold there). On, it proves 15 more 6-robot crossings,
    /// all of which the physics completes.
    pub rest_on_bodies: bool,
}

impl Default for Settling {
    fn default() -> Self {
        Settling {
            wheel_compliance: 2e-3,
            caster_compliance: 3e-4,
            ..Settling::couplings(&FleetParams::default().non_pilot)
        }
    }
}

/// The settled assembly: its supports' sink as a plane, z = −(a + b·x + c·y) (m, world).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settled {
    /// Sink at the world origin (m).
    pub a: f64,
    /// Sink per metre along world x.
    pub b: f64,
    /// Sink per metre along world y.
    pub c: f64,
}

impl Settled {
    /// Sink at world point `p` (m; positive down).
    pub fn sink(&self, p: [f64; 2]) -> f64 {
        self.a + self.b * p[0] + self.c * p[1]
    }
}

impl Settling {
    /// Rigid supports (no sink) under couplings of robots `p`: their stiffness and free
    /// ranges from the parameter set; a body 5 mm clear, fallen 10 mm below the platform and
    /// sliding at μ 0.3 as in the 3-D physics (the host sets its world's own numbers).
    pub fn couplings(p: &RobotParams) -> Settling {
        let c = &p.coupling;
        Settling {
            wheel_compliance: 0.0,
            caster_compliance: 0.0,
            body_clearance: 0.005,
            max_droop: 0.01,
            connector_stiffness: f64::from(c.connector_stiffness),
            connector_angular_stiffness: f64::from(c.connector_angular_stiffness),
            anchor_pitch_range: f64::from(c.anchor_yaw_range),
            knob_tilt_range: c.knob_tilt_limit(&p.geometry),
            chassis_friction: 0.3,
            rest_on_bodies: false,
        }
    }

    /// Every support as soft as the softer of wheel and caster: the sag a hanging robot may
    /// reach (stiffer casters would only lessen it).
    pub fn softest(&self) -> Settling {
        let c = self.wheel_compliance.max(self.caster_compliance);
        Settling {
            wheel_compliance: c,
            caster_compliance: c,
            ..*self
        }
    }

    /// Compliance of contact `k` of a PuzzleBot model (m/N): a wheel holds friction, a caster
    /// none.
    pub fn of(&self, k: &Contact) -> f64 {
        if k.mu[0] > 0.0 || k.mu[1] > 0.0 {
            self.wheel_compliance
        } else {
            self.caster_compliance
        }
    }
}

/// The settling of model `m` (one rigid body under gravity) on its contacts, each a spring of
/// the compliance `s` gives it ([`Settling::of`], m/N) along the vertical that engages once
/// the sink has closed its gap: the plane of sinks where the contact forces balance the weight
/// and its moments. `None` when no contact can carry it.
pub fn settle(m: &Assembly, s: &Settling) -> Option<Settled> {
    let g = -m.gravity[2];
    let (mut w, mut wx, mut wy) = (0.0, 0.0, 0.0);
    for md in &m.modules {
        let (s, c) = md.rpy[2].sin_cos();
        let x = md.position[0] + c * md.com[0] - s * md.com[1];
        let y = md.position[1] + s * md.com[0] + c * md.com[1];
        w += md.mass * g;
        wx += md.mass * g * x;
        wy += md.mass * g * y;
    }
    if w.is_nan() || w <= 0.0 || m.contacts.is_empty() {
        return None;
    }
    let pts: Vec<([f64; 2], f64, f64)> = m
        .contacts
        .iter()
        .map(|k| ([k.point[0], k.point[1]], k.gap.max(0.0), s.of(k)))
        .filter(|p| p.2 > 0.0 && p.2.is_finite())
        .collect();
    // Active-set iteration: the engaged contacts' springs balance the weight (a 3×3 system);
    // a contact whose sink does not close its gap drops out, one that it closes joins.
    let mut active: Vec<bool> = pts.iter().map(|p| p.1 <= 0.0).collect();
    if !active.iter().any(|&a| a) {
        active.iter_mut().for_each(|a| *a = true);
    }
    for _ in 0..4 * pts.len() + 8 {
        let (mut k, mut r) = ([[0.0; 3]; 3], [w, wx, wy]);
        for ((p, gap, compliance), _) in pts.iter().zip(&active).filter(|(_, &a)| a) {
            let v = [1.0, p[0], p[1]];
            for i in 0..3 {
                for j in 0..3 {
                    k[i][j] += v[i] * v[j] / compliance;
                }
                r[i] += v[i] * gap / compliance;
            }
        }
        // A faint rotational spring (1e-9 of the supports' stiffness over a metre) picks the
        // level settling where the supports leave the tilt free (a robot on one axle under its
        // centre of mass) and a steep one where they cannot hold the moment at all.
        k[1][1] += 1e-9 * k[0][0];
        k[2][2] += 1e-9 * k[0][0];
        let x = solve3(k, r)?;
        let plane = Settled {
            a: x[0],
            b: x[1],
            c: x[2],
        };
        let next: Vec<bool> = pts
            .iter()
            .map(|(p, gap, _)| plane.sink(*p) > *gap)
            .collect();
        if next == active {
            return Some(plane);
        }
        if !next.iter().any(|&a| a) {
            return None;
        }
        active = next;
    }
    None
}

/// The sag (m, positive down) of robot `i` at a world point, `model` settled with every
/// support as soft as a wheel and its couplings free where the gate releases them
/// ([`settle_articulated`]; infinite where nothing can carry it); `None` when no robot
/// `hanging`.
fn hanging_sag(
    model: &Assembly,
    hanging: &[bool],
    s: &Settling,
) -> Option<impl Fn(usize, [f64; 2]) -> f64> {
    if !hanging.contains(&true) {
        return None;
    }
    let sag = settle_articulated(model, &s.softest());
    Some(move |i: usize, p: [f64; 2]| sag.as_ref().map_or(f64::INFINITY, |sg| sg.sink(i, p)))
}

/// The first robot of `a` (translated by `offset`, m) that hangs (`hanging`) and whose
/// settled underside sags at a corner more than `s.max_droop` below the lowest platform top of
/// `terrain` (the assembly's `level` when lower, m): it has fallen into the gap. `model` is the
/// assembly's model there, settled with every support as soft as a wheel.
#[allow(clippy::too_many_arguments)]
pub fn droop(
    a: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    level: f64,
    offset: [f64; 2],
    model: &Assembly,
    hanging: &[bool],
    s: &Settling,
) -> Option<usize> {
    let sag_at = hanging_sag(model, hanging, s)?;
    let lowest = terrain
        .platforms
        .iter()
        .map(|p| p.height)
        .fold(level, f64::min);
    a.robots
        .iter()
        .zip(hanging)
        .enumerate()
        .filter(|(_, (_, &h))| h)
        .find_map(|(i, (r, _))| {
            let moved = r.translated(offset);
            body_corners(r.kind, params)
                .iter()
                .any(|&c| {
                    let p = world(&moved, c);
                    let sag = sag_at(i, p);
                    level + s.body_clearance - sag < lowest - s.max_droop
                })
                .then_some(i)
        })
}

/// Solve the symmetric 3×3 system `k·x = r` (None: singular to working precision).
fn solve3(k: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(k);
    let scale = k[0][0] * k[1][1] * k[2][2];
    if d.is_nan() || d.abs() <= 1e-12 * scale.abs() {
        return None;
    }
    let mut x = [0.0; 3];
    for (i, xi) in x.iter_mut().enumerate() {
        let mut m = k;
        for (row, ri) in m.iter_mut().zip(r) {
            row[i] = ri;
        }
        *xi = det(m) / d;
    }
    Some(x)
}

/// The first robot of `a` that hangs (`hanging`: no wheel or caster of its own on a
/// platform) and whose front corner reaches a platform as the assembly moves from the offset
/// `reach[0]` to `reach[1]` (m) with its settled underside there below that platform's top:
/// its body meets the platform's edge face. A corner already over the platform passed its
/// edge higher up and rests on it if it sinks onto it. `level` is the assembly's (m), `model`
/// its model at `reach[1]`, settled with every support as soft as a wheel (the larger sag);
/// a model that cannot settle ([`settle`]) leaves every hanging robot's sag unbounded.
#[allow(clippy::too_many_arguments)]
pub fn edge_stall(
    a: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    level: f64,
    reach: [[f64; 2]; 2],
    model: &Assembly,
    hanging: &[bool],
    s: &Settling,
) -> Option<usize> {
    let sag_at = hanging_sag(model, hanging, s)?;
    a.robots
        .iter()
        .zip(hanging)
        .enumerate()
        .filter(|(_, (_, &h))| h)
        .find_map(|(i, (r, _))| {
            let [hl, hw] = params.robot(r.kind).geometry.half_extents();
            let (hl, hw) = (f64::from(hl), f64::from(hw));
            [[hl, hw], [hl, -hw], [hl, 0.0]].iter().find_map(|&c| {
                let p = world(&r.translated(reach[1]), c);
                let (h, _) = terrain.support_at(p)?;
                let before = terrain.support_at(world(&r.translated(reach[0]), c));
                if before.is_some_and(|(hb, _)| hb == h) {
                    return None;
                }
                let sag = sag_at(i, p);
                (h > level + s.body_clearance - sag).then_some(i)
            })
        })
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::model::{Module, Objective};
    use std::collections::BTreeMap;

    /// Every contact of the test plates (wheels: they hold friction) 1 mm/N.
    const MM_PER_N: Settling = Settling {
        wheel_compliance: 1e-3,
        caster_compliance: 1e-4,
        body_clearance: 0.005,
        max_droop: 0.01,
        connector_stiffness: 1e4,
        connector_angular_stiffness: 10.0,
        anchor_pitch_range: 0.5,
        knob_tilt_range: 0.2,
        chassis_friction: 0.3,
        rest_on_bodies: false,
    };

    /// A 1 kg plate under 10 N/kg with its centre of mass at `com`, on wheel-like contacts
    /// (point, gap).
    pub(crate) fn plate(contacts: &[([f64; 2], f64)], com: [f64; 2]) -> Assembly {
        Assembly {
            gravity: [0.0, 0.0, -10.0],
            modules: vec![Module {
                id: "m".into(),
                mass: 1.0,
                position: [com[0], com[1], 0.0],
                rpy: [0.0; 3],
                com: [0.0; 3],
                fixed: false,
            }],
            connectors: BTreeMap::new(),
            connections: vec![],
            contacts: contacts
                .iter()
                .map(|&(p, gap)| Contact {
                    module: "m".into(),
                    point: [p[0], p[1], 0.0],
                    normal: None,
                    mu: [0.5, 0.5],
                    x_axis: None,
                    gap,
                })
                .collect(),
            module_contacts: vec![],
            loads: vec![],
            objective: Objective::default(),
        }
    }

    #[test]
    fn a_centred_plate_sinks_evenly_and_an_offset_one_pitches() {
        let sq = [
            ([1.0, 1.0], 0.0),
            ([1.0, -1.0], 0.0),
            ([-1.0, 1.0], 0.0),
            ([-1.0, -1.0], 0.0),
        ];
        // 10 N on four springs of 1 mm/N: 2.5 mm each, level.
        let s = settle(&plate(&sq, [0.0, 0.0]), &MM_PER_N).unwrap();
        assert!((s.a - 2.5e-3).abs() < 1e-9 && s.b.abs() < 1e-9 && s.c.abs() < 1e-9);
        // The weight at x = 0.5: the front springs carry 3.75 N each, the rear 1.25 N.
        let s = settle(&plate(&sq, [0.5, 0.0]), &MM_PER_N).unwrap();
        assert!((s.sink([1.0, 0.0]) - 3.75e-3).abs() < 1e-9, "{s:?}");
        assert!((s.sink([-1.0, 0.0]) - 1.25e-3).abs() < 1e-9, "{s:?}");
        // Past the front line the rear springs would pull: they lift off, and the front line
        // alone holds it only by tilting without bound.
        let s = settle(&plate(&sq, [1.2, 0.0]), &MM_PER_N).unwrap();
        assert!(s.b > 1e3, "{s:?}");
    }

    #[test]
    fn a_gap_carries_only_once_the_sink_closes_it() {
        let mut c = vec![([1.0, 1.0], 0.0), ([1.0, -1.0], 0.0), ([-1.0, 1.0], 0.0)];
        c.push(([-1.0, -1.0], 0.0));
        c.push(([0.0, 0.0], 1.0)); // a contact 1 m clear: never reached
        let s = settle(&plate(&c, [0.0, 0.0]), &MM_PER_N).unwrap();
        assert!((s.a - 2.5e-3).abs() < 1e-9);
        c[4].1 = 1e-3; // 1 mm clear: reached
        let s = settle(&plate(&c, [0.0, 0.0]), &MM_PER_N).unwrap();
        // Five springs, one 1 mm clear: 5·a − 1 mm = 10 N · 1 mm/N.
        assert!((s.a - 2.2e-3).abs() < 1e-9, "{s:?}");
    }
}
