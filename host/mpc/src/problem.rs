//! One robot's problem with every neighbour resolved to numbers ([`ProblemInstance`]),
//! its nonlinear cost and constraints, and its condensed QP linearisation.

// Numeric kernels index several step-aligned arrays with one step index.
#![allow(clippy::needless_range_loop)]

use crate::types::*;
use serde::{Deserialize, Serialize};

/// Largest |Δθ| used when linearising tan²(Δθ/2): keeps the Gauss–Newton weight bounded
/// near Δθ = ±π while keeping the sign of the step.
const MAX_LINEARISED_ANGLE: f64 = 2.6;

/// A point-tracking residual, the common form of THESIS (4.5), (4.6), (5.25), (5.26) and
/// the maintenance cost of (4.8): Σ_k w_k (‖p_k + R(θ_k) c − t_k‖² + h·tan²((θ_k + φ − τ_k)/2)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PointTerm {
    /// Body point c (m).
    pub point: [f64; 2],
    /// Angle φ of the tracked frame in the body frame (rad).
    pub angle: f64,
    /// Targets per step k = 0 … H (position t_k, heading τ_k); k = 0 is unused.
    pub targets: Vec<Pose>,
    /// Weight w_k per step k = 0 … H; k = 0 is unused.
    pub weights: Vec<f64>,
    /// Heading weight h relative to position (0: position only).
    pub heading: f64,
}

/// Velocity fitting, THESIS (4.7), on every input step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct VelocityTerm {
    /// Target (v*, ω*).
    pub target: Command,
    /// Weights of (v − v*)² and (ω − ω*)².
    pub w: [f64; 2],
}

/// Which side of an anchor coupling the ego robot is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Role {
    /// Ego carries the anchor; the neighbour holds the opening and the polygon.
    Anchor,
    /// Ego holds the opening; the neighbour carries the anchor.
    Opening,
}

/// An established coupling seen from the ego robot (THESIS 5.23–5.24).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CouplingInstance {
    /// Ego's side.
    pub role: Role,
    /// Neighbour id.
    pub neighbour: RobotId,
    /// Neighbour poses for k = 0 … H_c.
    pub neighbour_poses: Vec<Pose>,
}

/// One robot's fully resolved problem: every number an external solver needs to build the
/// same nonlinear program (exported as JSON for the IPOPT peer).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProblemInstance {
    /// H_m.
    pub horizon: usize,
    /// H_c.
    pub constraint_horizon: usize,
    /// Δt (s).
    pub dt: f64,
    /// Current pose x(t), THESIS (4.9).
    pub x0: Pose,
    /// Last applied command (smoothness and rate box of u_0).
    pub u_prev: Command,
    /// Linearisation point / initial guess ū_0 … ū_{H−1}.
    pub guess: Vec<Command>,
    /// Velocity limits.
    pub limits: Limits,
    /// Butterfly wing per step: +1 (v ≥ 0) or −1 (v ≤ 0); filled when the QP is built.
    pub wings: Vec<i8>,
    /// Point-tracking terms.
    pub points: Vec<PointTerm>,
    /// Velocity-fitting terms.
    pub velocities: Vec<VelocityTerm>,
    /// Smoothness weights (v, ω), THESIS (5.19).
    pub w_smooth: [f64; 2],
    /// Effort weights (v, ω), THESIS (4.8) W_s.
    pub w_effort: [f64; 2],
    /// Damping weights (v, ω) on u − ū (QP only; zero at a fixed point).
    pub w_damping: [f64; 2],
    /// Couplings with hard constraints on k = 1 … H_c.
    pub couplings: Vec<CouplingInstance>,
    /// Geometry of the couplings.
    pub geometry: GeometryF64,
    /// Constraint tightening (m).
    pub margin: f64,
}

/// World position of body point `c` of pose `a` expressed in the frame of pose `b`, and its
/// Jacobians with respect to a = (x, y, θ) and b (THESIS 5.11–5.15).
pub(crate) fn point_in_frame(
    a: &Pose,
    c: [f64; 2],
    b: &Pose,
) -> ([f64; 2], [[f64; 3]; 2], [[f64; 3]; 2]) {
    let (sa, ca) = a.yaw.sin_cos();
    let (sb, cb) = b.yaw.sin_cos();
    let rc = [ca * c[0] - sa * c[1], sa * c[0] + ca * c[1]];
    let w = [a.x + rc[0] - b.x, a.y + rc[1] - b.y];
    let q = [cb * w[0] + sb * w[1], -sb * w[0] + cb * w[1]];
    // d(R_b^T w)/d(p_a) = R_b^T ; d/dθa = R_b^T (−rc_y, rc_x).
    let dth_a = [-rc[1], rc[0]];
    let ja = [
        [cb, sb, cb * dth_a[0] + sb * dth_a[1]],
        [-sb, cb, -sb * dth_a[0] + cb * dth_a[1]],
    ];
    // d/dp_b = −R_b^T ; d/dθb = (q_y, −q_x).
    let jb = [[-cb, -sb, q[1]], [sb, -cb, -q[0]]];
    (q, ja, jb)
}

pub(crate) use puzzlebot_params::angle::wrap_angle as wrap;

/// One constraint g(x_k) ≤ 0 on the ego state at step k: value and gradient.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StateConstraint {
    pub k: usize,
    pub value: f64,
    pub grad: [f64; 3],
}

impl ProblemInstance {
    /// Nonlinear rollout x_0 … x_H of inputs `u` from x0, THESIS (5.2).
    pub fn rollout(&self, u: &[Command]) -> Vec<Pose> {
        let mut xs = Vec::with_capacity(u.len() + 1);
        let mut x = self.x0;
        xs.push(x);
        for &ui in u {
            x = ui.drive(&x, self.dt);
            xs.push(x);
        }
        xs
    }

    /// Nonlinear cost of inputs `u` (without the QP-only damping term).
    pub fn cost(&self, u: &[Command]) -> f64 {
        let xs = self.rollout(u);
        let mut j = 0.0;
        for t in &self.points {
            for (k, x) in xs.iter().enumerate().skip(1) {
                let w = t.weights.get(k).copied().unwrap_or(0.0);
                if w == 0.0 {
                    continue;
                }
                let tg = t.targets[k.min(t.targets.len() - 1)];
                let p = x.transform(t.point);
                let d = [p[0] - tg.x, p[1] - tg.y];
                let mut c = d[0] * d[0] + d[1] * d[1];
                if t.heading > 0.0 {
                    let r = (0.5 * (x.yaw + t.angle - tg.yaw)).tan();
                    c += t.heading * r * r;
                }
                j += w * c;
            }
        }
        for vt in &self.velocities {
            for ui in u {
                let dv = ui.v - vt.target.v;
                let dw = ui.omega - vt.target.omega;
                j += vt.w[0] * dv * dv + vt.w[1] * dw * dw;
            }
        }
        let mut prev = self.u_prev;
        for ui in u {
            let dv = ui.v - prev.v;
            let dw = ui.omega - prev.omega;
            j += self.w_smooth[0] * dv * dv + self.w_smooth[1] * dw * dw;
            j += self.w_effort[0] * ui.v * ui.v + self.w_effort[1] * ui.omega * ui.omega;
            prev = *ui;
        }
        j
    }

    /// Ego-state constraints g(x_k) ≤ 0 (already tightened by the margin) of all couplings
    /// at the poses `xs` (k = 1 … H_c): point-in-polygon (THESIS 5.9/5.16) then the two
    /// cutting planes (5.17, 5.18), each for both corners of the facing side.
    pub(crate) fn coupling_constraints(&self, xs: &[Pose], out: &mut Vec<StateConstraint>) {
        let g = &self.geometry;
        let m = self.margin;
        let half_l = 0.5 * g.length;
        let half_w = 0.5 * g.width;
        let s_a = g.anchor_head[0].signum();
        let s_o = g.anchor_opening[0].signum();
        let poly = &g.anchor_polygon;
        for c in &self.couplings {
            for k in 1..=self.constraint_horizon.min(xs.len() - 1) {
                let ego = &xs[k];
                let nb = &c.neighbour_poses[k.min(c.neighbour_poses.len() - 1)];
                let (anchor_pose, opening_pose) = match c.role {
                    Role::Anchor => (ego, nb),
                    Role::Opening => (nb, ego),
                };
                let pick = |ja: [[f64; 3]; 2], jb: [[f64; 3]; 2]| match c.role {
                    Role::Anchor => ja,
                    Role::Opening => jb,
                };
                // Projected anchor head in the opening robot's frame.
                let (q, ja, jb) = point_in_frame(anchor_pose, g.anchor_head, opening_pose);
                let jq = pick(ja, jb);
                for e in 0..poly.len() {
                    let v0 = poly[e];
                    let v1 = poly[(e + 1) % poly.len()];
                    let n = [v1[1] - v0[1], -(v1[0] - v0[0])];
                    let len = (n[0] * n[0] + n[1] * n[1]).sqrt();
                    let n = [n[0] / len, n[1] / len];
                    let value = n[0] * (q[0] - v0[0]) + n[1] * (q[1] - v0[1]) + m;
                    let grad = [
                        n[0] * jq[0][0] + n[1] * jq[1][0],
                        n[0] * jq[0][1] + n[1] * jq[1][1],
                        n[0] * jq[0][2] + n[1] * jq[1][2],
                    ];
                    out.push(StateConstraint { k, value, grad });
                }
                // (5.17): opening-face corners of the opening robot, in the anchor robot's
                // frame, lie beyond its anchor face: s_a·x ≥ L/2 + margin.
                for sy in [-1.0, 1.0] {
                    let corner = [s_o * half_l, sy * half_w];
                    let (q, ja, jb) = point_in_frame(opening_pose, corner, anchor_pose);
                    let jq = match c.role {
                        Role::Anchor => jb,
                        Role::Opening => ja,
                    };
                    let value = -s_a * q[0] + half_l + m;
                    let grad = [-s_a * jq[0][0], -s_a * jq[0][1], -s_a * jq[0][2]];
                    out.push(StateConstraint { k, value, grad });
                }
                // (5.18): anchor-face corners of the anchor robot, in the opening robot's
                // frame, lie beyond its opening face: s_o·x ≥ L/2 + margin.
                for sy in [-1.0, 1.0] {
                    let corner = [s_a * half_l, sy * half_w];
                    let (q, ja, jb) = point_in_frame(anchor_pose, corner, opening_pose);
                    let jq = pick(ja, jb);
                    let value = -s_o * q[0] + half_l + m;
                    let grad = [-s_o * jq[0][0], -s_o * jq[0][1], -s_o * jq[0][2]];
                    out.push(StateConstraint { k, value, grad });
                }
            }
        }
    }

    /// Largest coupling-constraint violation of inputs `u` without the margin (m; ≤ 0: all hold).
    pub fn max_coupling_violation(&self, u: &[Command]) -> f64 {
        let xs = self.rollout(u);
        let mut out = Vec::new();
        self.coupling_constraints(&xs, &mut out);
        out.iter()
            .map(|c| c.value - self.margin)
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

/// A dense condensed QP: minimise ½ zᵀPz + qᵀz s.t. Az ≤ b, z = (v_0, ω_0, …).
#[derive(Debug, Clone, Default)]
pub(crate) struct DenseQp {
    pub n: usize,
    pub m: usize,
    /// n × n, symmetric (full storage).
    pub p: Vec<f64>,
    /// n × n structural pattern of P (symmetric).
    pub p_mask: Vec<bool>,
    /// Leading rows of A that are equalities (zero cone).
    pub n_eq: usize,
    pub q: Vec<f64>,
    /// m × n row-major.
    pub a: Vec<f64>,
    /// m × n structural pattern.
    pub mask: Vec<bool>,
    pub b: Vec<f64>,
}

impl DenseQp {
    fn reset(&mut self, n: usize) {
        self.n = n;
        self.m = 0;
        self.p.clear();
        self.p.resize(n * n, 0.0);
        self.p_mask.clear();
        self.p_mask.resize(n * n, false);
        self.n_eq = 0;
        self.q.clear();
        self.q.resize(n, 0.0);
        self.a.clear();
        self.mask.clear();
        self.b.clear();
    }

    fn new_row(&mut self, b: f64) -> usize {
        self.a.extend(std::iter::repeat_n(0.0, self.n));
        self.mask.extend(std::iter::repeat_n(false, self.n));
        self.b.push(b);
        self.m += 1;
        self.m - 1
    }

    fn set(&mut self, r: usize, c: usize, v: f64) {
        self.a[r * self.n + c] = v;
        self.mask[r * self.n + c] = true;
    }

    /// Adds `v` to P\[i, j\] and P\[j, i\] (once when i = j) and marks the pattern.
    fn add_p(&mut self, i: usize, j: usize, v: f64) {
        let n = self.n;
        self.p[i * n + j] += v;
        self.p_mask[i * n + j] = true;
        if i != j {
            self.p[j * n + i] += v;
            self.p_mask[j * n + i] = true;
        }
    }

    /// Adds w (r0 + Σ g_i z_{idx_i})² to the cost (sparse gradient; pattern always marked).
    fn add_sparse_residual(&mut self, w: f64, r0: f64, idx: &[usize], g: &[f64]) {
        let n = self.n;
        for (a, (&i, &gi)) in idx.iter().zip(g).enumerate() {
            self.q[i] += 2.0 * w * r0 * gi;
            for (&j, &gj) in idx[a..].iter().zip(&g[a..]) {
                if i == j {
                    self.p[i * n + i] += 2.0 * w * gi * gj;
                    self.p_mask[i * n + i] = true;
                } else {
                    self.add_p(i, j, 2.0 * w * gi * gj);
                }
            }
        }
    }

    /// Adds w (r0 + g·z)² to the cost (g dense over its first `len` entries).
    fn add_residual(&mut self, w: f64, r0: f64, g: &[f64]) {
        let n = self.n;
        let len = g.len();
        for i in 0..len {
            let gi = g[i];
            if gi == 0.0 {
                continue;
            }
            self.q[i] += 2.0 * w * r0 * gi;
            let row = &mut self.p[i * n..i * n + len];
            let s = 2.0 * w * gi;
            for (pj, &gj) in row.iter_mut().zip(g) {
                *pj += s * gj;
            }
        }
    }
}

/// Scratch space of one robot's QP construction (reused across ticks).
#[derive(Debug, Default)]
pub(crate) struct Builder {
    pub qp: DenseQp,
    /// Sensitivities S_k (3 × n) for k = 0 … H, flattened.
    sens: Vec<f64>,
    g: Vec<f64>,
    cons: Vec<StateConstraint>,
    condensed: bool,
    xbar: Vec<Pose>,
}

impl Builder {
    /// Linearises `inst` around `ubar` (length H) and fills `self.qp`; sets `inst.wings`.
    /// `condensed`: inputs only (states eliminated through the sensitivities); otherwise
    /// states x_1 … x_H are variables too, tied by linearised dynamics equalities.
    pub fn build(&mut self, inst: &mut ProblemInstance, ubar: &[Command], condensed: bool) {
        let h = inst.horizon;
        let nu = 2 * h;
        let n = if condensed { nu } else { nu + 3 * h };
        let dt = inst.dt;
        self.condensed = condensed;
        self.qp.reset(n);
        let xs = inst.rollout(ubar);
        let mut zbar: Vec<f64> = ubar.iter().flat_map(|u| [u.v, u.omega]).collect();
        if !condensed {
            zbar.extend(xs[1..].iter().flat_map(|x| [x.x, x.y, x.yaw]));
        }
        self.xbar = xs.clone();
        if !condensed {
            // Linearised dynamics (5.2) as equalities, first rows:
            // x_{k+1} − A_k x_k − B_k u_k = x̄_{k+1} − A_k x̄_k − B_k ū_k.
            for k in 0..h {
                let (sn, cs) = xs[k].yaw.sin_cos();
                let v = ubar[k].v;
                let nx = nu + 3 * k; // columns of x_{k+1}
                let a = [
                    [1.0, 0.0, -dt * v * sn],
                    [0.0, 1.0, dt * v * cs],
                    [0.0, 0.0, 1.0],
                ];
                let b = [[dt * cs, 0.0], [dt * sn, 0.0], [0.0, dt]];
                let xk = [xs[k].x, xs[k].y, xs[k].yaw];
                let xk1 = [xs[k + 1].x, xs[k + 1].y, xs[k + 1].yaw];
                for r in 0..3 {
                    let mut rhs = xk1[r];
                    for c in 0..3 {
                        rhs -= a[r][c] * xk[c];
                    }
                    rhs -= b[r][0] * ubar[k].v + b[r][1] * ubar[k].omega;
                    if k == 0 {
                        // x_0 is data: move A_0 x_0 to the right-hand side.
                        for c in 0..3 {
                            rhs += a[r][c] * xk[c];
                        }
                    }
                    let row = self.qp.new_row(rhs);
                    self.qp.set(row, nx + r, 1.0);
                    if k > 0 {
                        let px = nu + 3 * (k - 1);
                        for c in 0..3 {
                            self.qp.set(row, px + c, -a[r][c]);
                        }
                    }
                    self.qp.set(row, 2 * k, -b[r][0]);
                    self.qp.set(row, 2 * k + 1, -b[r][1]);
                }
            }
            self.qp.n_eq = self.qp.m;
        }

        // Sensitivities δx_k = S_k δz of the Euler dynamics (5.2) linearised along x̄.
        self.sens.clear();
        self.sens.resize(3 * n * (h + 1), 0.0);
        for k in 0..h {
            let (s, c) = xs[k].yaw.sin_cos();
            let v = ubar[k].v;
            let (cur, next) = self.sens.split_at_mut(3 * n * (k + 1));
            let cur = &cur[3 * n * k..];
            let next = &mut next[..3 * n];
            for col in 0..2 * k {
                let s2 = cur[2 * n + col];
                next[col] = cur[col] - dt * v * s * s2;
                next[n + col] = cur[n + col] + dt * v * c * s2;
                next[2 * n + col] = s2;
            }
            next[2 * k] = dt * c;
            next[n + 2 * k] = dt * s;
            next[2 * n + 2 * k + 1] = dt;
        }

        // Point terms: Gauss–Newton residuals.
        for t in &inst.points {
            for k in 1..=h {
                let w = t.weights.get(k).copied().unwrap_or(0.0);
                if w == 0.0 {
                    continue;
                }
                let x = &xs[k];
                let tg = t.targets[k.min(t.targets.len() - 1)];
                let (sn, cs) = x.yaw.sin_cos();
                let p = x.transform(t.point);
                let dth = [
                    -sn * t.point[0] - cs * t.point[1],
                    cs * t.point[0] - sn * t.point[1],
                ];
                self.state_residual(k, w, p[0] - tg.x, [1.0, 0.0, dth[0]], &zbar);
                self.state_residual(k, w, p[1] - tg.y, [0.0, 1.0, dth[1]], &zbar);
                if t.heading > 0.0 {
                    let d = wrap(x.yaw + t.angle - tg.yaw)
                        .clamp(-MAX_LINEARISED_ANGLE, MAX_LINEARISED_ANGLE);
                    let r = (0.5 * d).tan();
                    let jr = 0.5 * (1.0 + r * r);
                    self.state_residual(k, w * t.heading, r, [0.0, 0.0, jr], &zbar);
                }
            }
        }
        // Input terms (exactly quadratic): velocity fitting, smoothness, effort, damping.
        for k in 0..h {
            for (i, uval) in [(0, ubar[k].v), (1, ubar[k].omega)] {
                let col = 2 * k + i;
                let mut diag = 0.0;
                let mut lin = 0.0;
                for vt in &inst.velocities {
                    let tgt = if i == 0 { vt.target.v } else { vt.target.omega };
                    diag += vt.w[i];
                    lin -= vt.w[i] * tgt;
                }
                diag += inst.w_effort[i] + inst.w_damping[i];
                lin -= inst.w_damping[i] * uval;
                // Smoothness (5.19): (u_k − u_{k−1})², u_{−1} = last applied command.
                let ws = inst.w_smooth[i];
                diag += ws;
                if k == 0 {
                    let prev = if i == 0 {
                        inst.u_prev.v
                    } else {
                        inst.u_prev.omega
                    };
                    lin -= ws * prev;
                } else {
                    let pc = col - 2;
                    self.qp.add_p(pc, pc, 2.0 * ws);
                    self.qp.add_p(pc, col, -2.0 * ws);
                }
                self.qp.add_p(col, col, 2.0 * diag);
                self.qp.q[col] += 2.0 * lin;
            }
        }

        // Butterfly wing per step: sign of ū_k's v, else the sign the cost gradient prefers.
        inst.wings.clear();
        for k in 0..h {
            let v = ubar[k].v;
            let wing = if v > 1e-6 {
                1
            } else if v < -1e-6 {
                -1
            } else {
                let col = 2 * k;
                let grad: f64 = self.qp.q[col]
                    + (0..n)
                        .map(|j| self.qp.p[col * n + j] * zbar[j])
                        .sum::<f64>();
                if grad > 0.0 {
                    -1
                } else {
                    1
                }
            };
            inst.wings.push(wing);
        }

        // Rows: butterfly wing (THESIS 3.5.1), boxes, rate box, couplings.
        let lim = inst.limits;
        let (av, aw, bv) = (
            lim.butterfly_a[0],
            lim.butterfly_a[1].abs(),
            lim.butterfly_b[0],
        );
        let s1 = aw / av;
        let s2 = aw / (bv - av);
        let v_box = lim.v_max < bv;
        let w_box = lim.omega_max < aw;
        for k in 0..h {
            let (cv, cw) = (2 * k, 2 * k + 1);
            let sg = f64::from(inst.wings[k]);
            // ±ω − s1·σv ≤ 0 (edges O–A, O–A').
            for sw in [1.0, -1.0] {
                let r = self.qp.new_row(0.0);
                self.qp.set(r, cw, sw);
                self.qp.set(r, cv, -s1 * sg);
            }
            // ±ω + s2·σv ≤ s2·b (edges A–B, A'–B).
            for sw in [1.0, -1.0] {
                let r = self.qp.new_row(s2 * bv);
                self.qp.set(r, cw, sw);
                self.qp.set(r, cv, s2 * sg);
            }
            if v_box {
                for sv in [1.0, -1.0] {
                    let r = self.qp.new_row(lim.v_max);
                    self.qp.set(r, cv, sv);
                }
            }
            if w_box {
                for sw in [1.0, -1.0] {
                    let r = self.qp.new_row(lim.omega_max);
                    self.qp.set(r, cw, sw);
                }
            }
            if let Some(acc) = lim.accel_max {
                for i in 0..2 {
                    let col = 2 * k + i;
                    let d = acc[i] * dt;
                    for sg in [1.0, -1.0] {
                        if k == 0 {
                            let prev = if i == 0 {
                                inst.u_prev.v
                            } else {
                                inst.u_prev.omega
                            };
                            let r = self.qp.new_row(d + sg * prev);
                            self.qp.set(r, col, sg);
                        } else {
                            let r = self.qp.new_row(d);
                            self.qp.set(r, col, sg);
                            self.qp.set(r, col - 2, -sg);
                        }
                    }
                }
            }
        }
        // Coupling constraints linearised: ∇g S_k z ≤ −ḡ + ∇g S_k z̄.
        self.cons.clear();
        let mut cons = std::mem::take(&mut self.cons);
        inst.coupling_constraints(&xs, &mut cons);
        for c in &cons {
            if !condensed {
                let base = nu + 3 * (c.k - 1);
                let xk = [xs[c.k].x, xs[c.k].y, xs[c.k].yaw];
                let rhs = -c.value + (0..3).map(|i| c.grad[i] * xk[i]).sum::<f64>();
                let r = self.qp.new_row(rhs);
                for i in 0..3 {
                    self.qp.set(r, base + i, c.grad[i]);
                }
                continue;
            }
            let len = 2 * c.k;
            self.row_gradient(c.k, c.grad);
            let rhs = -c.value
                + self.g[..len]
                    .iter()
                    .zip(&zbar)
                    .map(|(a, b)| a * b)
                    .sum::<f64>();
            let r = self.qp.new_row(rhs);
            for col in 0..len {
                let v = self.g[col];
                self.qp.set(r, col, v);
            }
        }
        self.cons = cons;
        if condensed {
            // Dense P: full pattern.
            self.qp.p_mask.iter_mut().for_each(|m| *m = true);
        }
    }

    /// g = jx · S_k over the first 2k columns.
    fn row_gradient(&mut self, k: usize, jx: [f64; 3]) {
        let n = self.qp.n;
        let len = 2 * k;
        self.g.clear();
        self.g.resize(len, 0.0);
        let base = 3 * n * k;
        for (col, gv) in self.g.iter_mut().enumerate() {
            *gv = jx[0] * self.sens[base + col]
                + jx[1] * self.sens[base + n + col]
                + jx[2] * self.sens[base + 2 * n + col];
        }
    }

    /// Adds w (r̄ + jx·δx_k)² with δx_k = S_k (z − z̄).
    fn state_residual(&mut self, k: usize, w: f64, rbar: f64, jx: [f64; 3], zbar: &[f64]) {
        if !self.condensed {
            let base = 2 * (self.xbar.len() - 1) + 3 * (k - 1);
            let x = &self.xbar[k];
            let r0 = rbar - (jx[0] * x.x + jx[1] * x.y + jx[2] * x.yaw);
            self.qp
                .add_sparse_residual(w, r0, &[base, base + 1, base + 2], &jx);
            return;
        }
        self.row_gradient(k, jx);
        let r0 = rbar - self.g.iter().zip(zbar).map(|(a, b)| a * b).sum::<f64>();
        let g = std::mem::take(&mut self.g);
        self.qp.add_residual(w, r0, &g);
        self.g = g;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::robot_instance;

    #[test]
    fn point_in_frame_jacobians_match_finite_differences() {
        let a = Pose::new(0.3, -0.2, 0.7);
        let b = Pose::new(0.1, 0.25, -1.1);
        let c = [-0.032, 0.01];
        let (q, ja, jb) = point_in_frame(&a, c, &b);
        let direct = b.inverse_transform(a.transform(c));
        assert!((q[0] - direct[0]).abs() < 1e-12 && (q[1] - direct[1]).abs() < 1e-12);
        let h = 1e-6;
        for i in 0..3 {
            let bump = |p: &Pose, s: f64| {
                let mut p = *p;
                match i {
                    0 => p.x += s,
                    1 => p.y += s,
                    _ => p.yaw += s,
                }
                p
            };
            let qa = |s| point_in_frame(&bump(&a, s), c, &b).0;
            let qb = |s| point_in_frame(&a, c, &bump(&b, s)).0;
            for r in 0..2 {
                let fa = (qa(h)[r] - qa(-h)[r]) / (2.0 * h);
                let fb = (qb(h)[r] - qb(-h)[r]) / (2.0 * h);
                assert!(
                    (fa - ja[r][i]).abs() < 1e-7,
                    "d q{r}/d a{i}: {fa} vs {}",
                    ja[r][i]
                );
                assert!(
                    (fb - jb[r][i]).abs() < 1e-7,
                    "d q{r}/d b{i}: {fb} vs {}",
                    jb[r][i]
                );
            }
        }
    }

    /// The QP is the Gauss–Newton model of the nonlinear cost: its gradient at ū equals the
    /// finite-difference gradient of the nonlinear cost (damping has zero gradient at ū),
    /// and its constraint rows are the linearised coupling constraints.
    #[test]
    fn qp_model_matches_nonlinear_problem_at_linearisation_point() {
        let cfg = MpcConfig::default();
        let mut inst = robot_instance(2, &cfg).unwrap();
        let ubar = inst.guess.clone();
        let mut b = Builder::default();
        b.build(&mut inst, &ubar, true);
        let qp = &b.qp;
        let n = qp.n;
        let z: Vec<f64> = ubar.iter().flat_map(|u| [u.v, u.omega]).collect();
        let h = 1e-7;
        for j in 0..n {
            let grad_qp = qp.q[j] + (0..n).map(|i| qp.p[j * n + i] * z[i]).sum::<f64>();
            let mut up = ubar.clone();
            let mut dn = ubar.clone();
            let f = |u: &mut Vec<Command>, s: f64| {
                if j % 2 == 0 {
                    u[j / 2].v += s
                } else {
                    u[j / 2].omega += s
                }
            };
            f(&mut up, h);
            f(&mut dn, -h);
            let fd = (inst.cost(&up) - inst.cost(&dn)) / (2.0 * h);
            assert!(
                (fd - grad_qp).abs() < 1e-4 * (1.0 + fd.abs()),
                "∂J/∂z{j}: fd {fd} vs qp {grad_qp}"
            );
        }
        // Coupling rows: the last rows; their residual at ū equals the nonlinear value.
        let xs = inst.rollout(&ubar);
        let mut cons = Vec::new();
        inst.coupling_constraints(&xs, &mut cons);
        assert_eq!(
            cons.len(),
            2 * cfg.constraint_horizon * (cfg.geometry.anchor_polygon.len() + 4)
        );
        let first = qp.m - cons.len();
        for (r, c) in cons.iter().enumerate() {
            let row = &qp.a[(first + r) * n..(first + r + 1) * n];
            let lhs: f64 = row.iter().zip(&z).map(|(a, b)| a * b).sum();
            // A z̄ − b = g(x̄).
            assert!((lhs - qp.b[first + r] - c.value).abs() < 1e-12);
        }
    }

    /// The sparse (states as variables) and condensed QPs are the same problem.
    #[test]
    fn sparse_and_condensed_qps_agree() {
        for c in 0..=2 {
            let cfg = MpcConfig::default();
            let inst = robot_instance(c, &cfg).unwrap();
            let sparse = MpcConfig {
                condensed: false,
                ..cfg.clone()
            };
            let mut a = inst.clone();
            let mut b = inst.clone();
            let pa = crate::RobotController::new().step(&cfg, &mut a, 0);
            let pb = crate::RobotController::new().step(&sparse, &mut b, 0);
            assert!(
                pa.status.is_solved() && pb.status.is_solved(),
                "{:?} {:?}",
                pa.status,
                pb.status
            );
            assert_eq!(a.wings, b.wings);
            for (x, y) in pa.plan.iter().zip(&pb.plan) {
                assert!(
                    (x.v - y.v).abs() < 1e-4 && (x.omega - y.omega).abs() < 1e-3,
                    "{c}: {x:?} vs {y:?}"
                );
            }
        }
    }

    #[test]
    fn wrap_stays_in_half_open_interval() {
        for a in [
            -7.0,
            -std::f64::consts::PI,
            0.0,
            3.0,
            std::f64::consts::PI,
            10.0,
        ] {
            let w = wrap(a);
            assert!(w > -std::f64::consts::PI - 1e-12 && w <= std::f64::consts::PI + 1e-12);
            assert!(
                ((a - w) / std::f64::consts::TAU).fract().abs() < 1e-9
                    || ((a - w) / std::f64::consts::TAU).fract().abs() > 1.0 - 1e-9
            );
        }
    }
}
