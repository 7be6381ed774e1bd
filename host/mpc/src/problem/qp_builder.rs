//! Linearisation of one robot's problem around a plan into a condensed (inputs only) or
//! sparse (states as variables) QP.

// Numeric kernels index several step-aligned arrays with one step index.
#![allow(clippy::needless_range_loop)]

use super::{wrap, DenseQp, ProblemInstance, StateConstraint};
use crate::types::*;

/// Largest |Δθ| used when linearising tan²(Δθ/2): keeps the Gauss–Newton weight bounded
/// near Δθ = ±π while keeping the sign of the step.
const MAX_LINEARISED_ANGLE: f64 = 2.6;

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
}
