//! Theorem 2 verdicts, the internal stability margin (42)/(52), potential broken connections
//! (44), friction margins, and the fast path for statically determinate trees.

use crate::model::{add, cross, dot, norm, Assembly, ConnectorSpec, ModelError, Resolved, Vec3};
use crate::socp::{self, Outcome, SLOTS};
use serde::Serialize;
use std::time::Instant;
use summary::{judge, summarize, Comps, State};

mod summary;

/// The gate's verdict (SOCP Theorem 2, plus "not proven" for solver trouble, DESIGN.md §10).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Verdict {
    /// An optimal solution of (41) exists: the configuration is stable.
    Stable,
    /// (41) is infeasible but feasible without connector limits: connectors too weak.
    InternalInstability,
    /// Infeasible even without connector limits: the whole body tips, slides or falls.
    WholeBodyInstability,
    /// The solver reached no certificate either way; never treat as stable.
    NotProven {
        /// What went wrong.
        reason: String,
    },
}

impl Verdict {
    /// True only for a proven stable verdict.
    pub fn is_stable(&self) -> bool {
        matches!(self, Verdict::Stable)
    }
    /// Short name.
    pub fn name(&self) -> &'static str {
        match self {
            Verdict::Stable => "stable",
            Verdict::InternalInstability => "internal instability",
            Verdict::WholeBodyInstability => "whole-body instability",
            Verdict::NotProven { .. } => "not proven",
        }
    }
}

/// Required connection wrench of one connection in the critical stable state x̃.
#[derive(Debug, Clone, Serialize)]
pub struct ConnectionResult {
    /// Index in `connections`.
    pub index: usize,
    /// Child module id.
    pub child: String,
    /// Parent module id.
    pub parent: String,
    /// Connector type name.
    pub connector: String,
    /// f̄_A (34): [f_x, f_y, f_con^z, m_x, m_y, m_z] in the connection frame (N, N·m).
    pub wrench: [f64; 6],
    /// Normal support force f_s (24), ≥ 0.
    pub support: f64,
    /// Characteristic strength w (40) (box) or adhesion −f_con (Lorentz, 51).
    pub strength: f64,
    /// Largest ratio of required to available wrench over limited dimensions (1 = at limit).
    pub use_of_limit: Option<f64>,
    /// Smallest W̃-weighted reserve over limited dimensions (its minimum over all is s_sm).
    pub margin: Option<f64>,
    /// Required wrench exceeds the limit.
    pub over_limit: bool,
    /// Potential broken connection point (44): strength within ε of the maximum.
    pub critical: bool,
}

/// A contact force and its friction margin.
#[derive(Debug, Clone, Serialize)]
pub struct ContactResult {
    /// Index in `contacts` (or `module_contacts`).
    pub index: usize,
    /// Module id.
    pub module: String,
    /// Force in the contact frame (f_x, f_y, f_z).
    pub force: Vec3,
    /// f_z − ‖(f_x/μ_x, f_y/μ_y)‖ (right side of (30) minus its left side), N.
    pub friction_margin: f64,
}

/// How the answer was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Path {
    /// Statically determinate tree: leaf-to-root statics, no cone program.
    DeterminateTree,
    /// Cone program(s) in Clarabel.
    Socp,
}

/// Timing and solver statistics.
#[derive(Debug, Clone, Serialize)]
pub struct Stats {
    /// Fast path or cone program.
    pub path: Path,
    /// Cone programs solved.
    pub solves: u32,
    /// Interior-point iterations in total.
    pub iterations: u32,
    /// Structured solves ([`crate::ipm`]) that gave no optimum and were handed to Clarabel.
    pub fallbacks: u32,
    /// Work of the structured solves that reached an optimum: numeric factorisations of the
    /// normal matrix, solves with it, and matrix-free products (refinement) — exact counts,
    /// for judging a change where wall-clock time is noisy.
    pub factorisations: u32,
    /// See [`Stats::factorisations`].
    pub normal_solves: u32,
    /// See [`Stats::factorisations`].
    pub normal_products: u32,
    /// Seconds building the model(s) (resolve + sparse assembly).
    pub build_seconds: f64,
    /// Seconds in the solver.
    pub solve_seconds: f64,
    /// Total seconds.
    pub total_seconds: f64,
    /// Modules, connections, contacts (environmental + module).
    pub size: [usize; 3],
}

/// Everything the gate says about an assembly.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// The verdict.
    pub verdict: Verdict,
    /// Internal stability margin s_sm (42)/(52); None when no connection has a limit or
    /// when there is no state (whole-body instability, not proven).
    pub margin: Option<f64>,
    /// Required maximum characteristic strength w_A^max of the critical state.
    pub max_strength: Option<f64>,
    /// Per-connection results of the critical state x̃ (empty without a state).
    pub connections: Vec<ConnectionResult>,
    /// Environmental contacts.
    pub contacts: Vec<ContactResult>,
    /// Non-connected module contacts.
    pub module_contacts: Vec<ContactResult>,
    /// Statistics.
    pub stats: Stats,
}

impl Report {
    /// Indices of connections over their limit or critical (44), worst first.
    pub fn worst_connections(&self, k: usize) -> Vec<&ConnectionResult> {
        let mut v: Vec<&ConnectionResult> = self.connections.iter().collect();
        v.sort_by(|a, b| {
            let ua = a.use_of_limit.unwrap_or(0.0);
            let ub = b.use_of_limit.unwrap_or(0.0);
            ub.total_cmp(&ua).then(b.strength.total_cmp(&a.strength))
        });
        v.truncate(k);
        v
    }
    /// Connections that would break: over their limit (internal instability).
    pub fn broken(&self) -> Vec<usize> {
        self.connections
            .iter()
            .filter(|c| {
                c.over_limit || (self.verdict == Verdict::InternalInstability && c.critical)
            })
            .map(|c| c.index)
            .collect()
    }
}

/// How the relaxed cone program (no connector limits) is handed to the solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Formulation {
    /// The direct form of [`socp::build`] (reference).
    Direct,
    /// The equilibrium-multiplier (dual) form of [`crate::dual`] in Clarabel (smaller KKT).
    Dual,
    /// The dual form solved by the structured interior-point method of [`crate::ipm`] (block
    /// factorisation over the module graph; default); where it gives no optimum, Clarabel.
    Structured,
}

/// Options of an evaluation.
#[derive(Debug, Clone, Copy)]
pub struct Options {
    /// Use the leaf-to-root statics fast path when the assembly is a determinate tree.
    pub fast_path: bool,
    /// Interior-point iteration limit per cone program (reaching it gives "not proven").
    pub max_iter: u32,
    /// Form of the relaxed program; the program with connector limits (41) is always solved
    /// in the direct form.
    pub formulation: Formulation,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            fast_path: true,
            max_iter: 100,
            formulation: Formulation::Structured,
        }
    }
}

/// Evaluate an assembly: resolve it (errors name the field), then run the gate.
pub fn evaluate(a: &Assembly) -> Result<Report, ModelError> {
    evaluate_with(a, Options::default())
}

/// Evaluate with options.
pub fn evaluate_with(a: &Assembly, opt: Options) -> Result<Report, ModelError> {
    let t0 = Instant::now();
    let r = a.resolve()?;
    let build = t0.elapsed().as_secs_f64();
    Ok(evaluate_resolved(&r, opt, t0, build))
}

fn size(r: &Resolved) -> [usize; 3] {
    [
        r.com.len(),
        r.connections.len(),
        r.contacts.len() + r.module_contacts.len(),
    ]
}

/// Relative distance to a connector limit below which the loosely solved relaxed problem is
/// re-solved at the default tolerance before it decides the verdict.
const NEAR_LIMIT: f64 = 1e-3;

/// Run the gate on a resolved model (Algorithm 2, solving the relaxed problem first).
pub fn evaluate_resolved(r: &Resolved, opt: Options, t0: Instant, build0: f64) -> Report {
    if opt.fast_path {
        if let Some((verdict, state)) = determinate_tree(r) {
            let total = t0.elapsed().as_secs_f64();
            let stats = Stats {
                path: Path::DeterminateTree,
                solves: 0,
                iterations: 0,
                fallbacks: 0,
                factorisations: 0,
                normal_solves: 0,
                normal_products: 0,
                build_seconds: total,
                solve_seconds: 0.0,
                total_seconds: total,
                size: size(r),
            };
            return summarize(r, verdict, state, stats);
        }
    }
    let mut stats = Stats {
        path: Path::Socp,
        solves: 0,
        iterations: 0,
        fallbacks: 0,
        factorisations: 0,
        normal_solves: 0,
        normal_products: 0,
        build_seconds: build0,
        solve_seconds: 0.0,
        total_seconds: 0.0,
        size: size(r),
    };
    let run = |with_limits: bool, tol: f64, stats: &mut Stats| {
        let tb = Instant::now();
        let dual_form = opt.formulation != Formulation::Direct;
        let p = if !with_limits && dual_form {
            crate::dual::build_relaxed(r)
        } else {
            socp::build(r, with_limits)
        };
        stats.build_seconds += tb.elapsed().as_secs_f64();
        stats.solves += 1;
        if p.dual && opt.formulation == Formulation::Structured {
            let ts = Instant::now();
            let res = crate::ipm::solve(&p, tol, opt.max_iter);
            stats.solve_seconds += ts.elapsed().as_secs_f64();
            match res {
                Ok((x, info)) => {
                    stats.iterations += info.iterations;
                    stats.factorisations += info.factorisations;
                    stats.normal_solves += info.solves;
                    stats.normal_products += info.products;
                    return (p, Outcome::Optimal(x));
                }
                Err(crate::ipm::Declined::NotConverged { iterations }) => {
                    stats.iterations += iterations;
                    stats.fallbacks += 1;
                }
                Err(_) => stats.fallbacks += 1,
            }
        }
        let (out, info) = socp::solve_tol(&p, opt.max_iter, tol);
        stats.iterations += info.iterations;
        stats.solve_seconds += info.seconds;
        (p, out)
    };
    let state_of = |p: &socp::Program, x: &[f64]| State {
        conns: (0..p.conns.len())
            .map(|k| socp::connection_values_of(p, k, x))
            .collect(),
        contacts: p
            .contacts
            .iter()
            .zip(&r.contacts)
            .map(|(l, c)| socp::contact_force(l, c.mu, x))
            .collect(),
        module_contacts: p
            .module_contacts
            .iter()
            .zip(&r.module_contacts)
            .map(|(l, (c, _))| socp::contact_force(l, c.mu, x))
            .collect(),
    };
    // Relaxed problem first (𝕏, Definition 1): infeasible ⇒ whole-body instability. Its optimum
    // is also optimal for (41) when it satisfies every connector limit.
    // It is solved at the looser tolerance first; when a connection's required wrench is within
    // `NEAR_LIMIT` of its limit (the verdict could hinge on the last digits) it is solved
    // again at the default tolerance and that solution decides, exactly as before.
    let (mut p, mut out) = run(false, socp::LOOSE_TOL, &mut stats);
    if let Outcome::Optimal(x) = &out {
        let st = state_of(&p, x);
        let near = st.conns.iter().zip(&r.connections).any(|(c, rc)| {
            judge(&r.connectors[rc.connector], c)
                .1
                .is_some_and(|u| u > 1.0 - NEAR_LIMIT)
        });
        if near {
            (p, out) = run(false, socp::TIGHT_TOL, &mut stats);
        }
    }
    let (verdict, state) = match out {
        Outcome::Infeasible => (Verdict::WholeBodyInstability, None),
        Outcome::Failed(reason) => (Verdict::NotProven { reason }, None),
        Outcome::Optimal(x) => {
            let st = state_of(&p, &x);
            let within = st
                .conns
                .iter()
                .zip(&r.connections)
                .all(|(c, rc)| !judge(&r.connectors[rc.connector], c).3);
            if within {
                (Verdict::Stable, Some(st))
            } else {
                let (p2, out2) = run(true, socp::TIGHT_TOL, &mut stats);
                match out2 {
                    Outcome::Optimal(x2) => (Verdict::Stable, Some(state_of(&p2, &x2))),
                    Outcome::Infeasible => (Verdict::InternalInstability, Some(st)),
                    Outcome::Failed(reason) => (Verdict::NotProven { reason }, Some(st)),
                }
            }
        }
    };
    stats.total_seconds = t0.elapsed().as_secs_f64();
    summarize(r, verdict, state, stats)
}

/// Fast path (DESIGN.md §7): when every free module hangs from exactly one fixed module through
/// a tree of connections and touches nothing else, the connection wrenches follow from statics
/// by one leaf-to-root pass, and the decoupling (24) that minimises (41) is in closed form.
/// Returns None when the assembly is not such a tree.
fn determinate_tree(r: &Resolved) -> Option<(Verdict, Option<State>)> {
    let n = r.com.len();
    if r.connections.is_empty() {
        return None;
    }
    if r.contacts.iter().any(|c| !r.fixed[c.module])
        || r.module_contacts
            .iter()
            .any(|(c, o)| !r.fixed[c.module] || !r.fixed[*o])
    {
        return None;
    }
    let free = r.fixed.iter().filter(|f| !**f).count();
    // adjacency (CSR) over connections touching a free module
    let mut deg = vec![0usize; n + 1];
    let mut edges = 0;
    for c in &r.connections {
        if r.fixed[c.child] && r.fixed[c.parent] {
            continue;
        }
        deg[c.child + 1] += 1;
        deg[c.parent + 1] += 1;
        edges += 1;
    }
    if edges != free {
        return None;
    }
    for i in 0..n {
        deg[i + 1] += deg[i];
    }
    let mut fill = deg.clone();
    let mut adj = vec![0usize; deg[n]];
    for (k, c) in r.connections.iter().enumerate() {
        if r.fixed[c.child] && r.fixed[c.parent] {
            continue;
        }
        adj[fill[c.child]] = k;
        fill[c.child] += 1;
        adj[fill[c.parent]] = k;
        fill[c.parent] += 1;
    }
    // BFS from the fixed modules.
    let mut up = vec![usize::MAX; n]; // connection towards the ground
    let mut seen = r.fixed.clone();
    let mut order = Vec::with_capacity(free);
    let mut queue: Vec<usize> = (0..n).filter(|&i| r.fixed[i]).collect();
    let mut head = 0;
    while head < queue.len() {
        let i = queue[head];
        head += 1;
        for &k in &adj[deg[i]..deg[i + 1]] {
            let c = &r.connections[k];
            let j = if c.child == i { c.parent } else { c.child };
            if seen[j] {
                if r.fixed[i] && r.fixed[j] {
                    continue;
                }
                if up[i] == k {
                    continue;
                }
                return None; // a loop (or two fixed roots): indeterminate
            }
            seen[j] = true;
            up[j] = k;
            order.push(j);
            queue.push(j);
        }
    }
    if order.len() != free {
        return None; // floating parts: let the cone program decide
    }
    // Leaf-to-root: subtree force and moment about the world origin.
    let mut sf: Vec<Vec3> = (0..n).map(|i| r.ext[i].0).collect();
    let mut sm: Vec<Vec3> = (0..n)
        .map(|i| add(r.ext[i].1, cross(r.com[i], r.ext[i].0)))
        .collect();
    let mut conns: Vec<Comps> = vec![[0.0; SLOTS]; r.connections.len()];
    let mut scale_f: f64 = 1e-12;
    for f in &sf {
        scale_f = scale_f.max(norm(*f));
    }
    let mut mechanism = false;
    for &i in order.iter().rev() {
        let k = up[i];
        let c = &r.connections[k];
        let p = c.point;
        // Wrench the connection applies to module i (world): balances the subtree.
        let fe = [-sf[i][0], -sf[i][1], -sf[i][2]];
        let mp = add([-sm[i][0], -sm[i][1], -sm[i][2]], cross(p, sf[i]));
        let (fw, mw) = if c.child == i {
            (fe, mp)
        } else {
            ([-fe[0], -fe[1], -fe[2]], [-mp[0], -mp[1], -mp[2]])
        };
        let fl = [
            dot(c.frame[0], fw),
            dot(c.frame[1], fw),
            dot(c.frame[2], fw),
        ];
        let ml = [
            dot(c.frame[0], mw),
            dot(c.frame[1], mw),
            dot(c.frame[2], mw),
        ];
        let j = if c.child == i { c.parent } else { c.child };
        sf[j] = add(sf[j], sf[i]);
        sm[j] = add(sm[j], sm[i]);
        let tol = 1e-9 * scale_f * (1.0 + norm(p));
        let comps = &mut conns[k];
        match &r.connectors[c.connector] {
            ConnectorSpec::Box { max, .. } => {
                let lim = max.as_array();
                let vals = [fl[0], fl[1], fl[2], ml[0], ml[1], ml[2]];
                for d in 0..6 {
                    if lim[d] == Some(0.0) && d != 2 && vals[d].abs() > tol {
                        mechanism = true;
                    }
                }
                let (fcon, fs) = if lim[2] == Some(0.0) {
                    if fl[2] < -tol {
                        mechanism = true;
                    }
                    (0.0, fl[2].max(0.0))
                } else {
                    (fl[2].min(0.0), fl[2].max(0.0))
                };
                *comps = [fl[0], fl[1], fcon, fs, ml[0], ml[1], ml[2]];
            }
            ConnectorSpec::Lorentz { mu, .. } => {
                let vals = [fl[0], fl[1], ml[0], ml[1], ml[2]];
                let mut g2 = 0.0;
                for d in 0..5 {
                    if mu[d] == 0.0 {
                        if vals[d].abs() > tol {
                            mechanism = true;
                        }
                    } else {
                        g2 += (vals[d] / mu[d]).powi(2);
                    }
                }
                let fs = g2.sqrt().max(fl[2]);
                *comps = [fl[0], fl[1], fl[2] - fs, fs, ml[0], ml[1], ml[2]];
            }
        }
    }
    if mechanism {
        return Some((Verdict::WholeBodyInstability, None));
    }
    let over = conns
        .iter()
        .zip(&r.connections)
        .any(|(c, rc)| judge(&r.connectors[rc.connector], c).3);
    let verdict = if over {
        Verdict::InternalInstability
    } else {
        Verdict::Stable
    };
    Some((
        verdict,
        Some(State {
            conns,
            contacts: r.contacts.iter().map(|_| [0.0; 3]).collect(),
            module_contacts: r.module_contacts.iter().map(|_| [0.0; 3]).collect(),
        }),
    ))
}
