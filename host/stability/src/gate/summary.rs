//! The gate's report from a solved load distribution: each connection's wrench against its
//! connector's limits (SOCP (42)/(52) margins, (44) broken connections) and each contact's
//! friction margin.

use super::{ConnectionResult, ContactResult, Report, Stats, Verdict};
use crate::model::{ConnectorSpec, Resolved, Vec3};
use crate::socp::SLOTS;

/// Physical components of a connection: [f_x, f_y, f_con, f_s, m_x, m_y, m_z].
pub(super) type Comps = [f64; SLOTS];

fn wrench6(c: &Comps) -> [f64; 6] {
    [c[0], c[1], c[2], c[4], c[5], c[6]]
}

/// Strength, use of limit, W̃-weighted margin, over-limit flag of one connection.
pub(super) fn judge(spec: &ConnectorSpec, c: &Comps) -> (f64, Option<f64>, Option<f64>, bool) {
    let w6 = wrench6(c);
    match spec {
        ConnectorSpec::Box {
            max,
            omega_k,
            margin_weights,
        } => {
            let strength = (0..6)
                .map(|d| (omega_k[d] * w6[d]).powi(2))
                .sum::<f64>()
                .sqrt();
            let mut use_: Option<f64> = None;
            let mut margin: Option<f64> = None;
            let mut over = false;
            for (d, l) in max.as_array().iter().enumerate() {
                let Some(l) = *l else { continue };
                let req = w6[d].abs();
                if l == 0.0 {
                    continue; // released: the variable is identically zero
                }
                let u = req / l;
                use_ = Some(use_.map_or(u, |x: f64| x.max(u)));
                let m = margin_weights[d] * (l - req);
                margin = Some(margin.map_or(m, |x: f64| x.min(m)));
                if req > l * (1.0 + 1e-6) + 1e-9 {
                    over = true;
                }
            }
            (strength, use_, margin, over)
        }
        ConnectorSpec::Lorentz { f_max_z, .. } => {
            let req = (-c[2]).max(0.0);
            let over = req > f_max_z * (1.0 + 1e-6) + 1e-9;
            let use_ = if *f_max_z > 0.0 {
                Some(req / f_max_z)
            } else {
                None
            };
            (req, use_, Some(f_max_z - req), over)
        }
    }
}

fn friction(force: Vec3, mu: [f64; 2]) -> f64 {
    let t = |f: f64, m: f64| {
        if m > 0.0 {
            f / m
        } else if f.abs() < 1e-12 {
            0.0
        } else {
            f64::INFINITY
        }
    };
    force[2] - (t(force[0], mu[0]).powi(2) + t(force[1], mu[1]).powi(2)).sqrt()
}

pub(super) struct State {
    pub(super) conns: Vec<Comps>,
    pub(super) contacts: Vec<Vec3>,
    pub(super) module_contacts: Vec<Vec3>,
}

pub(super) fn summarize(
    r: &Resolved,
    verdict: Verdict,
    state: Option<State>,
    stats: Stats,
) -> Report {
    let Some(st) = state else {
        return Report {
            verdict,
            margin: None,
            max_strength: None,
            connections: vec![],
            contacts: vec![],
            module_contacts: vec![],
            stats,
        };
    };
    let mut conns = Vec::with_capacity(st.conns.len());
    let mut wmax: f64 = 0.0;
    let mut margin: Option<f64> = None;
    for (k, (c, rc)) in st.conns.iter().zip(&r.connections).enumerate() {
        let spec = &r.connectors[rc.connector];
        let (strength, use_of_limit, m, over_limit) = judge(spec, c);
        wmax = wmax.max(strength);
        if let Some(m) = m {
            margin = Some(margin.map_or(m, |x: f64| x.min(m)));
        }
        conns.push(ConnectionResult {
            index: k,
            child: r.ids[rc.child].clone(),
            parent: r.ids[rc.parent].clone(),
            connector: r.connector_names[rc.connector].clone(),
            wrench: wrench6(c),
            support: c[3],
            strength,
            use_of_limit,
            margin: m,
            over_limit,
            critical: false,
        });
    }
    // (44) with ε relative to w_A^max.
    let eps = 1e-4 * wmax + 1e-9;
    if wmax > 1e-9 {
        for c in &mut conns {
            c.critical = wmax - c.strength <= eps;
        }
    }
    let contacts = st
        .contacts
        .iter()
        .zip(&r.contacts)
        .enumerate()
        .map(|(k, (f, ct))| ContactResult {
            index: k,
            module: r.ids[ct.module].clone(),
            force: *f,
            friction_margin: friction(*f, ct.mu),
        })
        .collect();
    let module_contacts = st
        .module_contacts
        .iter()
        .zip(&r.module_contacts)
        .enumerate()
        .map(|(k, (f, (ct, _)))| ContactResult {
            index: k,
            module: r.ids[ct.module].clone(),
            force: *f,
            friction_margin: friction(*f, ct.mu),
        })
        .collect();
    Report {
        verdict,
        margin,
        max_strength: if r.connections.is_empty() {
            None
        } else {
            Some(wmax)
        },
        connections: conns,
        contacts,
        module_contacts,
        stats,
    }
}
