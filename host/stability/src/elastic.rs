//! The elastic load distribution of a statically indeterminate assembly.
//!
//! The gate's program (41) asks whether *some* distribution of the connection wrenches keeps
//! every connector within its limits, and picks the one with the smallest maximum
//! characteristic strength: the most favourable. An assembly with loops (a mesh: anchors along
//! the rows, knobs across) carries its weight the way its compliance dictates instead, and a
//! connector that snaps open when overloaded (no plastic reserve) breaks when that
//! distribution, not the most favourable one, exceeds its limits.
//!
//! For rigid modules on rigid supports joined by linear springs, the distribution that holds
//! is the one of least complementary energy among those in equilibrium (Menabrea's theorem):
//!
//!   min Σ_connections Σ_components w_i² · c_i / 2   s.t.  equilibrium (SOCP 29), contact and
//!   support cones (SOCP 24, 30–32), no connector limits,
//!
//! with c_i the connector's compliance of component i (m/N for forces, rad/(N·m) for
//! couples). Released components (limit 0) carry nothing, as in the gate.
//!
//! Supports that give under load (tyres, the platform, a simulator's soft contacts) add
//! Σ_contacts c_s · |f|² / 2 with their compliance c_s, along the normal and the surface
//! alike: a loaded robot settles into them and its connectors bend to follow, and friction
//! carries only what that settling calls on it to carry (free friction would pick the forces
//! that relieve the connectors most). Far softer than the connectors, the assembly
//! settles as one body and its weight spreads over the supports by how far each sinks; far
//! stiffer, the rigid-support distribution above holds.

use crate::model::{ConnectorSpec, Resolved};
use crate::socp::{self, connection_values_of, Outcome, SLOTS};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSolver, IPSolver, SolverStatus};

/// Compliance of the connectors: how far a unit load moves them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Compliance {
    /// Translation per unit force (m/N).
    pub force: f64,
    /// Rotation per unit couple (rad/(N·m)).
    pub couple: f64,
    /// Sink of a support under a unit normal force (m/N); 0: rigid supports.
    pub support: f64,
}

/// Elastic wrench of every connection: [f_x, f_y, f_con^z, f_s, m_x, m_y, m_z] in its frame
/// (N, N·m; f_con^z ≤ 0 pulls, f_s ≥ 0 presses). `Ok(None)`: no equilibrium exists (the whole
/// body tips, slides or falls). Errors: the solver reached no certificate.
pub fn distribution(r: &Resolved, c: Compliance) -> Result<Option<Vec<[f64; SLOTS]>>, String> {
    distribution_with_gaps(r, c, &[])
}

/// [`distribution`] with environmental contacts that stand `gaps[k]` (m, model order; missing
/// entries 0) clear of their support in the unloaded assembly, as a robot over a lower
/// platform: such a contact carries load only once the deflection of the connectors and
/// supports has closed its gap (Signorini), which adds the work gap · f_n to the
/// complementary energy. A free hinge closes it at no cost; stiff connectors hold the robot
/// up instead, and break if they cannot.
pub fn distribution_with_gaps(
    r: &Resolved,
    c: Compliance,
    gaps: &[f64],
) -> Result<Option<Vec<[f64; SLOTS]>>, String> {
    distribution_with_supports(r, c, gaps, &[])
}

/// [`distribution_with_gaps`] with supports of unequal compliance: environmental contact `k`
/// (model order) gives `scale[k]` times `c.support` (missing entries 1), as a tyre softer
/// than a steel caster ball.
pub fn distribution_with_supports(
    r: &Resolved,
    c: Compliance,
    gaps: &[f64],
    scale: &[f64],
) -> Result<Option<Vec<[f64; SLOTS]>>, String> {
    if scale.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
        return Err("support scale: must be finite and ≥ 0".into());
    }
    if !(c.force.is_finite()
        && c.force > 0.0
        && c.couple.is_finite()
        && c.couple > 0.0
        && c.support.is_finite()
        && c.support >= 0.0)
    {
        return Err("compliance: must be finite and > 0 (support ≥ 0)".into());
    }
    let mut p = socp::build(r, false);
    // Complementary energy on the connection components; nothing else costs.
    let mut diag = vec![0.0; p.n];
    for lay in &p.conns {
        for slot in 0..SLOTS {
            if let Some(v) = lay.var[slot] {
                let comp = if slot < 4 { c.force } else { c.couple };
                diag[v] = lay.scale[slot] * lay.scale[slot] * comp;
            }
        }
    }
    // A support gives along the surface as it does along the normal (a tyre, a soft
    // contact): its friction force costs the same work as its normal force, so friction holds
    // only what the deflections call on it to hold, not whatever relieves the connectors.
    let mus = r
        .contacts
        .iter()
        .chain(r.module_contacts.iter().map(|(k, _)| k))
        .map(|k| k.mu);
    for (k, (lay, mu)) in p
        .contacts
        .iter()
        .chain(&p.module_contacts)
        .zip(mus)
        .enumerate()
    {
        let cs = c.support * scale.get(k).copied().unwrap_or(1.0);
        for (slot, var) in lay.var.iter().enumerate() {
            if let Some(v) = var {
                // Tangential variables are f_t / μ.
                let m = if slot == 0 { 1.0 } else { mu[slot - 1] };
                diag[*v] = cs * m * m;
            }
        }
    }
    // Scale the energy to the order of the forces (N²·m/N → N): the solver's tolerances are
    // absolute.
    let top = diag.iter().copied().fold(0.0, f64::max);
    if top > 0.0 {
        diag.iter_mut().for_each(|d| *d /= top);
    }
    p.q.iter_mut().for_each(|q| *q = 0.0);
    for (lay, g) in p.contacts.iter().zip(gaps) {
        if let Some(v) = lay.var[0].filter(|_| *g > 0.0) {
            p.q[v] = if top > 0.0 { g / top } else { *g };
        }
    }
    let colptr: Vec<usize> = (0..=p.n).collect();
    let pm = CscMatrix::new(p.n, p.n, colptr, (0..p.n).collect(), diag);
    let mut solver = DefaultSolver::new(&pm, &p.q, &p.a, &p.b, &p.cones, socp::settings())
        .map_err(|e| format!("solver setup: {e}"))?;
    solver.solve();
    let x = match solver.solution.status {
        SolverStatus::Solved | SolverStatus::AlmostSolved => {
            Outcome::Optimal(std::mem::take(&mut solver.solution.x))
        }
        SolverStatus::PrimalInfeasible => Outcome::Infeasible,
        s => Outcome::Failed(format!("solver status {s:?}")),
    };
    match x {
        Outcome::Optimal(x) => Ok(Some(
            (0..p.conns.len())
                .map(|k| connection_values_of(&p, k, &x))
                .collect(),
        )),
        Outcome::Infeasible => Ok(None),
        Outcome::Failed(e) => Err(e),
    }
}

/// Share of its limit each connection's elastic wrench uses (the largest over its limited
/// components, as the gate's box (35): shear and couples both ways, pull only), or `None`
/// for a connection without box limits.
pub fn use_of_limits(r: &Resolved, w: &[[f64; SLOTS]]) -> Vec<Option<f64>> {
    r.connections
        .iter()
        .zip(w)
        .map(|(c, v)| match &r.connectors[c.connector] {
            ConnectorSpec::Box { max, .. } => {
                let lim = max.as_array();
                let comps = [
                    v[0].abs(),
                    v[1].abs(),
                    (-v[2]).max(0.0),
                    v[4].abs(),
                    v[5].abs(),
                    v[6].abs(),
                ];
                comps
                    .iter()
                    .zip(lim)
                    .filter_map(|(x, l)| l.filter(|l| *l > 0.0).map(|l| x / l))
                    .reduce(f64::max)
            }
            ConnectorSpec::Lorentz { .. } => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Assembly, Connection, Contact, Limits6, Module};
    use std::collections::BTreeMap;

    /// Three modules in a row joined by two equal connectors, the middle one of `mid_mass`;
    /// the outer two stand on four ground contacts each, and so does the middle one when
    /// `mid_on_ground`.
    fn row(mid_mass: f64, mid_on_ground: bool) -> Assembly {
        let m = |id: &str, x: f64, mass: f64| Module {
            id: id.into(),
            mass,
            position: [x, 0.0, 0.0],
            rpy: [0.0; 3],
            com: [0.0, 0.0, 0.02],
            fixed: false,
        };
        let mut connectors = BTreeMap::new();
        let w = [1.0, 1.0, 1.0, 40.0, 40.0, 40.0];
        connectors.insert(
            "c".to_string(),
            ConnectorSpec::Box {
                max: Limits6::uniform(10.0, 0.3),
                omega_k: w,
                margin_weights: w,
            },
        );
        let conn = |parent: &str, x: f64, dir: f64| Connection {
            child: "mid".into(),
            parent: parent.into(),
            connector: "c".into(),
            point: [x, 0.0, 0.02],
            axis: Some([dir, 0.0, 0.0]),
            x_axis: Some([0.0, 0.0, 1.0]),
        };
        let on_ground: Vec<(&str, f64)> = if mid_on_ground {
            vec![("left", -0.05), ("mid", 0.0), ("right", 0.05)]
        } else {
            vec![("left", -0.05), ("right", 0.05)]
        };
        let contacts = on_ground
            .iter()
            .flat_map(|&(id, x)| {
                [[-0.02, -0.02], [-0.02, 0.02], [0.02, -0.02], [0.02, 0.02]].map(|[dx, dy]| {
                    Contact {
                        module: id.into(),
                        point: [x + dx, dy, 0.0],
                        normal: None,
                        mu: [0.5, 0.5],
                        x_axis: None,
                        gap: 0.0,
                    }
                })
            })
            .collect();
        Assembly {
            gravity: [0.0, 0.0, -9.81],
            modules: vec![
                m("left", -0.05, 0.1),
                m("mid", 0.0, mid_mass),
                m("right", 0.05, 0.1),
            ],
            connectors,
            connections: vec![conn("left", -0.025, 1.0), conn("right", 0.025, -1.0)],
            contacts,
            module_contacts: vec![],
            loads: vec![],
            objective: Default::default(),
        }
    }

    const RIGID_SUPPORTS: Compliance = Compliance {
        force: 1e-4,
        couple: 0.1,
        support: 0.0,
    };

    /// A beam over two supports with a load in the middle: the middle module hangs on its two
    /// neighbours. Its weight splits evenly; the gate's most favourable split may not.
    #[test]
    fn a_symmetric_load_splits_evenly() {
        let r = row(0.1, false).resolve().unwrap();
        let w = distribution(&r, RIGID_SUPPORTS).unwrap().unwrap();
        // Each side carries half the weight in shear (local x is up).
        let half = 0.5 * 0.1 * 9.81;
        for v in &w {
            assert!((v[0].abs() - half).abs() < 1e-3 * half, "{w:?}");
        }
        let u = use_of_limits(&r, &w);
        assert!(
            u.iter().all(|x| x.is_some_and(|x| x > 0.0 && x < 1.0)),
            "{u:?}"
        );
    }

    /// A heavy module between two light ones, all on the ground: on rigid supports it stands
    /// on its own and the connectors carry nothing; on supports far softer than the
    /// connectors the row settles as one body, every contact carries the same share and the
    /// connectors pass the heavy module's excess to its neighbours.
    #[test]
    fn soft_supports_spread_a_heavy_module_over_its_neighbours() {
        let r = row(0.3, true).resolve().unwrap();
        let rigid = distribution(&r, RIGID_SUPPORTS).unwrap().unwrap();
        assert!(rigid.iter().flatten().all(|v| v.abs() < 1e-3), "{rigid:?}");
        let soft = Compliance {
            support: 1e3 * RIGID_SUPPORTS.force,
            ..RIGID_SUPPORTS
        };
        let w = distribution(&r, soft).unwrap().unwrap();
        let g = 9.81;
        let share = (0.1 + 0.3 + 0.1) * g / 12.0;
        let excess = 0.5 * (0.3 * g - 4.0 * share);
        for v in &w {
            assert!(
                (v[0].abs() - excess).abs() < 1e-2 * excess,
                "{w:?} vs {excess}"
            );
        }
    }

    /// The middle module over a platform 6 mm lower: its contacts stand clear of it, the
    /// stiff connectors bend far less than that holding it, so it hangs on its neighbours as
    /// if those contacts were not there.
    #[test]
    fn a_module_over_a_lower_platform_hangs_on_stiff_connectors() {
        let r = row(0.1, true).resolve().unwrap();
        let mut gaps = vec![0.0; 12];
        gaps[4..8].iter_mut().for_each(|g| *g = 0.006);
        let w = distribution_with_gaps(&r, RIGID_SUPPORTS, &gaps)
            .unwrap()
            .unwrap();
        let half = 0.5 * 0.1 * 9.81;
        for v in &w {
            assert!((v[0].abs() - half).abs() < 1e-2 * half, "{w:?}");
        }
    }
}
