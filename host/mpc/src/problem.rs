//! One robot's problem with every neighbour resolved to numbers ([`ProblemInstance`]) and
//! its nonlinear cost and constraints; [`dense_qp`] holds the QP it linearises into and
//! [`qp_builder`] the linearisation.

// Numeric kernels index several step-aligned arrays with one step index.
#![allow(clippy::needless_range_loop)]

mod dense_qp;
mod qp_builder;

pub(crate) use dense_qp::DenseQp;
pub(crate) use qp_builder::Builder;

use crate::types::*;
use serde::{Deserialize, Serialize};

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

#[cfg(test)]
mod tests {
    use super::*;

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
