//! The settling of an assembly whose couplings have play: every module a rigid body, every
//! coupling a stiff spring except about its free axis, every support a one-sided spring.
//!
//! A coupling the gate releases about its local y axis (a soft anchor's pitch, THESIS 4.2.2;
//! a knob's tilt about the shared face, THESIS 2.4.1) turns freely there until its limit and
//! as a spring beyond it; its other out-of-plane motions (the vertical offset of the two
//! bodies at the connection point, the twist about the connection's z axis) are springs of
//! the connector's stiffness. A robot hanging over a gap on such couplings swings about them
//! and its underside drops by more than the assembly's own settling ([`super::settle`]): the
//! drop that lets its body meet the face of the platform ahead.
//!
//! Small motions out of the plane (sink, roll, pitch of each module) minimise the potential
//! energy, gravity's work plus the springs', subject to each free axis' range: a convex
//! quadratic program, solved with Clarabel. Units inside: mm, mrad, N, N·mm.

use super::Settling;
use crate::model::{Assembly, ConnectorSpec, Contact};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT::NonnegativeConeT,
    SupportedConeT::ZeroConeT,
};

/// The settled assembly: each module's sink and tilt.
#[derive(Debug, Clone, PartialEq)]
pub struct Sag {
    /// Per module: its origin (world x, y; m) and its sink there (m, positive down), roll
    /// about world x and pitch about world y (rad, small).
    modules: Vec<([f64; 2], [f64; 3])>,
}

impl Sag {
    /// Sink of module `i` at world point `p` (m, positive down); infinite for an unknown
    /// module.
    pub fn sink(&self, i: usize, p: [f64; 2]) -> f64 {
        self.modules.get(i).map_or(f64::INFINITY, |(o, [z, a, b])| {
            z - a * (p[1] - o[1]) + b * (p[0] - o[0])
        })
    }

    /// Roll and pitch of module `i` (rad).
    pub fn tilt(&self, i: usize) -> [f64; 2] {
        self.modules
            .get(i)
            .map_or([0.0; 2], |(_, [_, a, b])| [*a, *b])
    }
}

/// Rows of the quadratic form and of the constraints, over the variables
/// [z, a, b per module (mm, mrad, mrad); penetration per contact (mm); excess per free axis
/// (mrad)].
struct Program {
    n: usize,
    p: Vec<Vec<f64>>,
    q: Vec<f64>,
    eq: Vec<(Vec<(usize, f64)>, f64)>,
    ineq: Vec<(Vec<(usize, f64)>, f64)>,
}

impl Program {
    /// Add ½·k·(vᵀx)² to the energy.
    fn spring(&mut self, v: &[(usize, f64)], k: f64) {
        for &(i, vi) in v {
            for &(j, vj) in v {
                self.p[i][j] += k * vi * vj;
            }
        }
    }
}

/// Upward displacement (mm) of the point `d` (m, from the module origin) of module `i` as a
/// linear form over its variables.
fn lift(i: usize, d: [f64; 2]) -> [(usize, f64); 3] {
    [(3 * i, 1.0), (3 * i + 1, d[1]), (3 * i + 2, -d[0])]
}

/// The settling of `m` on its contacts (each a one-sided spring of the compliance `s` gives it,
/// engaging once its sink has closed its gap) with its couplings as `s` describes them.
/// `None` when nothing can carry it (a module or the whole falls).
pub fn settle_articulated(m: &Assembly, s: &Settling) -> Option<Sag> {
    settle_with(m, s, &|k| s.of(&m.contacts[k]))
}

/// Whether some wheel of the settled assembly `m` (a contact with friction; a caster has
/// none) touches its platform, so that its drive can push the assembly on: `false` when every
/// wheel stands clear and the assembly rests on its casters alone. A wheel just touching,
/// with no load in the settled state, counts: the small-motion settling cannot tell how the
/// drive's push shares the load out there. `None` when nothing carries it.
pub fn wheels_bear(m: &Assembly, s: &Settling) -> Option<bool> {
    /// A wheel touches when its settled sink reaches its gap to within this (m): the
    /// program's working precision (it solves in millimetres).
    const TOUCHING: f64 = 1e-6;
    let sag = settle_articulated(m, s)?;
    Some(
        m.contacts
            .iter()
            .filter(|k| k.mu[0] > 0.0 || k.mu[1] > 0.0)
            .any(|k| {
                m.modules
                    .iter()
                    .position(|md| md.id == k.module)
                    .is_some_and(|i| sag.sink(i, [k.point[0], k.point[1]]) > k.gap - TOUCHING)
            }),
    )
}

/// Which of `bodies` (contacts of the robots' undersides, each `gap` clear of the platform
/// below it) `m` comes to rest on: settled ([`settle_articulated`]) with them as one-sided
/// springs of `s.caster_compliance` (a hard chassis on a platform, as stiff as a caster), the
/// ones whose sink closes their gap. `None` when even they cannot carry it.
pub fn resting_bodies(m: &Assembly, s: &Settling, bodies: &[Contact]) -> Option<Vec<bool>> {
    if bodies.is_empty() {
        return Some(vec![]);
    }
    let n = m.contacts.len();
    let mut with = m.clone();
    with.contacts.extend(bodies.iter().cloned());
    let sag = settle_with(&with, s, &|k| {
        if k < n {
            s.of(&with.contacts[k])
        } else {
            s.caster_compliance
        }
    })?;
    Some(
        bodies
            .iter()
            .map(|b| {
                let i = m.modules.iter().position(|md| md.id == b.module);
                i.is_some_and(|i| sag.sink(i, [b.point[0], b.point[1]]) > b.gap)
            })
            .collect(),
    )
}

/// [`settle_articulated`] with contact `k`'s compliance `compliance(k)` (m/N).
fn settle_with(m: &Assembly, s: &Settling, compliance: &dyn Fn(usize) -> f64) -> Option<Sag> {
    let g = -m.gravity[2];
    let nm = m.modules.len();
    let index = |id: &str| m.modules.iter().position(|md| md.id == id);
    let origin: Vec<[f64; 2]> = m
        .modules
        .iter()
        .map(|md| [md.position[0], md.position[1]])
        .collect();
    // A coupling's free range about its local y axis (rad), 0 where it holds that tilt.
    let free_range = |name: &str| -> f64 {
        let released = matches!(
            m.connectors.get(name),
            Some(ConnectorSpec::Box { max, .. }) if max.my == Some(0.0)
        );
        if !released {
            return 0.0;
        }
        match name {
            "anchor" => s.anchor_pitch_range,
            "knob" => s.knob_tilt_range,
            _ => 0.0,
        }
    };
    let free: Vec<f64> = m
        .connections
        .iter()
        .map(|c| free_range(&c.connector))
        .collect();
    let nfree = free.iter().filter(|&&r| r > 0.0).count();
    let n = 3 * nm + m.contacts.len() + nfree;
    let mut pr = Program {
        n,
        p: vec![vec![0.0; n]; n],
        q: vec![0.0; n],
        eq: vec![],
        ineq: vec![],
    };
    // Gravity's work.
    for (i, md) in m.modules.iter().enumerate() {
        let (sn, cs) = md.rpy[2].sin_cos();
        let c = [
            md.position[0] + cs * md.com[0] - sn * md.com[1],
            md.position[1] + sn * md.com[0] + cs * md.com[1],
        ];
        let w = md.mass * g;
        for (k, v) in lift(i, [c[0] - origin[i][0], c[1] - origin[i][1]]) {
            pr.q[k] += w * v;
        }
        if md.fixed {
            for k in 0..3 {
                pr.eq.push((vec![(3 * i + k, 1.0)], 0.0));
            }
        }
    }
    // Supports: penetration t ≥ sink − gap, t ≥ 0, energy ½·t²/compliance.
    for (k, c) in m.contacts.iter().enumerate() {
        let i = index(&c.module)?;
        let compliance = compliance(k);
        if !(compliance.is_finite() && compliance > 0.0) {
            return None;
        }
        let t = 3 * nm + k;
        let d = [c.point[0] - origin[i][0], c.point[1] - origin[i][1]];
        let mut row: Vec<(usize, f64)> = lift(i, d).iter().map(|&(j, v)| (j, -v)).collect();
        row.push((t, -1.0));
        pr.ineq.push((row, 1e3 * c.gap.max(0.0)));
        pr.ineq.push((vec![(t, -1.0)], 0.0));
        pr.p[t][t] += 1e-3 / compliance;
    }
    // Couplings.
    let (k_lin, k_ang) = (
        1e-3 * s.connector_stiffness,
        1e-3 * s.connector_angular_stiffness,
    );
    let mut next_free = 3 * nm + m.contacts.len();
    for (c, &range) in m.connections.iter().zip(&free) {
        let (Some(ch), Some(pa)) = (index(&c.child), index(&c.parent)) else {
            return None;
        };
        let at = |i: usize| [c.point[0] - origin[i][0], c.point[1] - origin[i][1]];
        let mut offset: Vec<(usize, f64)> = lift(ch, at(ch)).to_vec();
        offset.extend(lift(pa, at(pa)).iter().map(|&(j, v)| (j, -v)));
        pr.spring(&offset, k_lin);
        // The connection's z axis (horizontal) and its free axis y = z × up.
        let z = c.axis.unwrap_or([1.0, 0.0, 0.0]);
        let len = z[0].hypot(z[1]);
        let z = if len > 1e-12 {
            [z[0] / len, z[1] / len]
        } else {
            [1.0, 0.0]
        };
        let y = [z[1], -z[0]];
        let about = |u: [f64; 2]| {
            vec![
                (3 * ch + 1, u[0]),
                (3 * ch + 2, u[1]),
                (3 * pa + 1, -u[0]),
                (3 * pa + 2, -u[1]),
            ]
        };
        pr.spring(&about(z), k_ang);
        if range > 0.0 {
            let e = next_free;
            next_free += 1;
            let r = 1e3 * range;
            let mut up = about(y);
            up.push((e, -1.0));
            pr.ineq.push((up, r));
            let mut down: Vec<(usize, f64)> = about(y).into_iter().map(|(j, v)| (j, -v)).collect();
            down.push((e, -1.0));
            pr.ineq.push((down, r));
            pr.ineq.push((vec![(e, -1.0)], 0.0));
            pr.p[e][e] += k_ang;
        } else {
            pr.spring(&about(y), k_ang);
        }
    }
    let x = solve(&pr)?;
    // A module turned past a radian or sunk a metre has fallen: nothing holds it (the faint
    // stiffness of `solve` alone bounds it), and the small-motion model ends long before.
    if (0..nm).any(|i| x[3 * i].abs() > 1e6 || x[3 * i + 1].abs().max(x[3 * i + 2].abs()) > 1e3) {
        return None;
    }
    Some(Sag {
        modules: (0..nm)
            .map(|i| {
                (
                    origin[i],
                    [-1e-3 * x[3 * i], 1e-3 * x[3 * i + 1], 1e-3 * x[3 * i + 2]],
                )
            })
            .collect(),
    })
}

/// Minimise ½xᵀPx + qᵀx over the program's constraints; `None` when unbounded or unsolved.
fn solve(pr: &Program) -> Option<Vec<f64>> {
    let n = pr.n;
    // A faint stiffness on every variable (1e-9 of the stiffest) picks one settling where the
    // springs leave a motion free (a robot on one axle under its centre of mass) without
    // holding one that gravity drives.
    let top = (0..n).map(|i| pr.p[i][i]).fold(0.0, f64::max).max(1e-12);
    let (mut colptr, mut rowval, mut nzval) = (vec![0], vec![], vec![]);
    for j in 0..n {
        for i in 0..=j {
            let v = pr.p[i][j] + if i == j { 1e-9 * top } else { 0.0 };
            if v != 0.0 {
                rowval.push(i);
                nzval.push(v);
            }
        }
        colptr.push(rowval.len());
    }
    let pm = CscMatrix::new(n, n, colptr, rowval, nzval);
    let rows: Vec<&(Vec<(usize, f64)>, f64)> = pr.eq.iter().chain(&pr.ineq).collect();
    let mut cols: Vec<Vec<(usize, f64)>> = vec![vec![]; n];
    for (r, (row, _)) in rows.iter().enumerate() {
        for &(j, v) in row {
            match cols[j].last_mut() {
                Some((last, acc)) if *last == r => *acc += v,
                _ => cols[j].push((r, v)),
            }
        }
    }
    let (mut colptr, mut rowval, mut nzval) = (vec![0], vec![], vec![]);
    for col in &cols {
        for &(r, v) in col {
            rowval.push(r);
            nzval.push(v);
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(rows.len(), n, colptr, rowval, nzval);
    let b: Vec<f64> = rows.iter().map(|(_, b)| *b).collect();
    let mut cones = vec![];
    if !pr.eq.is_empty() {
        cones.push(ZeroConeT(pr.eq.len()));
    }
    if !pr.ineq.is_empty() {
        cones.push(NonnegativeConeT(pr.ineq.len()));
    }
    let settings = DefaultSettings {
        verbose: false,
        max_iter: 100,
        ..DefaultSettings::default()
    };
    let mut solver = DefaultSolver::new(&pm, &pr.q, &a, &b, &cones, settings).ok()?;
    solver.solve();
    match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {
            let x = std::mem::take(&mut solver.solution.x);
            x.iter().all(|v| v.is_finite()).then_some(x)
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Connection, Limits6, Module, Objective};
    use crate::sag::settle;
    use crate::sag::tests::plate;
    use std::collections::BTreeMap;

    const S: Settling = Settling {
        wheel_compliance: 1e-3,
        caster_compliance: 1e-3,
        body_clearance: 0.005,
        max_droop: 0.01,
        connector_stiffness: 1e4,
        connector_angular_stiffness: 10.0,
        anchor_pitch_range: 0.5,
        knob_tilt_range: 0.2,
        chassis_friction: 0.3,
        rest_on_bodies: true,
    };

    fn module(id: &str, x: f64, com_x: f64, fixed: bool) -> Module {
        Module {
            id: id.into(),
            mass: 1.0,
            position: [x, 0.0, 0.0],
            rpy: [0.0; 3],
            com: [com_x, 0.0, 0.0],
            fixed,
        }
    }

    /// A fixed root and a 1 kg arm whose centre of mass is 50 mm out along x, joined at the
    /// origin by an "anchor" whose pitch is released or held.
    fn arm(released: bool) -> Assembly {
        let max = Limits6 {
            my: released.then_some(0.0),
            ..Limits6::default()
        };
        let spec = ConnectorSpec::Box {
            max,
            omega_k: [1.0; 6],
            margin_weights: [1.0; 6],
        };
        Assembly {
            gravity: [0.0, 0.0, -10.0],
            modules: vec![
                module("root", 0.0, 0.0, true),
                module("arm", 0.0, 0.05, false),
            ],
            connectors: BTreeMap::from([("anchor".to_string(), spec)]),
            connections: vec![Connection {
                child: "arm".into(),
                parent: "root".into(),
                connector: "anchor".into(),
                point: [0.0; 3],
                axis: Some([1.0, 0.0, 0.0]),
                x_axis: Some([0.0, 0.0, 1.0]),
            }],
            contacts: vec![],
            module_contacts: vec![],
            loads: vec![],
            objective: Objective::default(),
        }
    }

    #[test]
    fn a_held_joint_bends_by_its_stiffness_and_a_free_one_swings_to_its_limit() {
        // Held: 10 N at 50 mm on 10 N·m/rad turns it 50 mrad.
        let sag = settle_articulated(&arm(false), &S).unwrap();
        assert!((sag.tilt(1)[1] - 0.05).abs() < 1e-4, "{sag:?}");
        assert!(sag.sink(0, [0.1, 0.0]).abs() < 1e-9);
        // Free within ±0.5 rad: to the limit, then 50 mrad more on the spring.
        let sag = settle_articulated(&arm(true), &S).unwrap();
        assert!((sag.tilt(1)[1] - 0.55).abs() < 1e-4, "{sag:?}");
        // Its far end drops by the (small-angle) tilt times the reach.
        // Its far end drops by the (small-angle) tilt times the reach, and 1 mm more on the
        // joint's vertical spring (10 N on 10⁴ N/m).
        assert!((sag.sink(1, [0.1, 0.0]) - 0.056).abs() < 1e-5, "{sag:?}");
    }

    #[test]
    fn a_swinging_arm_comes_to_rest_on_a_platform_within_its_reach() {
        // The free arm's far end (100 mm out) would drop 56 mm: a platform 20 mm below it
        // catches it, one 80 mm below does not.
        let under = |gap: f64| Contact {
            module: "arm".into(),
            point: [0.1, 0.0, -gap],
            normal: None,
            mu: [0.3, 0.3],
            x_axis: None,
            gap,
        };
        let m = arm(true);
        assert_eq!(resting_bodies(&m, &S, &[under(0.02)]), Some(vec![true]));
        assert_eq!(resting_bodies(&m, &S, &[under(0.08)]), Some(vec![false]));
        // Held stiff, it sinks 6 mm there and reaches neither.
        assert_eq!(
            resting_bodies(&arm(false), &S, &[under(0.02)]),
            Some(vec![false])
        );
    }

    #[test]
    fn a_plate_on_springs_settles_as_the_rigid_model_does() {
        let corners = [
            ([1.0, 1.0], 0.0),
            ([1.0, -1.0], 0.0),
            ([-1.0, 1.0], 0.0),
            ([-1.0, -1.0], 0.0),
        ];
        let m = plate(&corners, [0.5, 0.0]);
        // 10 N at x = 0.5 on four 1 mm/N springs: 3.75 mm at the front, 1.25 at the back.
        let sag = settle_articulated(&m, &S).unwrap();
        assert!((sag.sink(0, [1.0, 0.0]) - 3.75e-3).abs() < 1e-6, "{sag:?}");
        assert!((sag.sink(0, [-1.0, 0.0]) - 1.25e-3).abs() < 1e-6, "{sag:?}");
        // The same as the one-body settling.
        let rigid = settle(&m, &S).unwrap();
        assert!((sag.sink(0, [1.0, 1.0]) - rigid.sink([1.0, 1.0])).abs() < 1e-6);
        // Past the front line nothing holds it.
        assert_eq!(settle_articulated(&plate(&corners, [1.2, 0.0]), &S), None);
    }
}
