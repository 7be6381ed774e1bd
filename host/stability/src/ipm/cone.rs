//! Cone algebra: Nesterov–Todd scaling, products with W, the centring right-hand side and the
//! step to the boundary of K, cone by cone.

use super::{Ipm, SocCone};

/// Calls `$body` with `$d` bound to `$dim`, a compile-time constant for the dimensions the
/// gate's programs use (3: contact friction cones, 7: connection strength cones), so that the
/// per-cone loops unroll; any other dimension takes the general path.
macro_rules! with_dim {
    ($dim:expr, |$d:ident| $body:expr) => {
        match $dim {
            3 => {
                let $d: usize = 3;
                $body
            }
            7 => {
                let $d: usize = 7;
                $body
            }
            other => {
                let $d: usize = other;
                $body
            }
        }
    };
}

impl<'a> Ipm<'a> {
    /// Nesterov–Todd scaling of (x, s) in every cone and λ = W x.
    pub(super) fn scale(&mut self, x: &[f64], s: &[f64]) {
        for r in &self.nn_ranges {
            for v in r.clone() {
                self.w[v] = (s[v] / x[v]).sqrt();
                self.lambda[v] = (s[v] * x[v]).sqrt();
            }
        }
        for &SocCone { start, dim, block } in &self.soc_blocks {
            with_dim!(dim, |dim| {
                let r = start..start + dim;
                let (xs, ss) = (&x[r.clone()], &s[r.clone()]);
                let dx = soc_det(xs).sqrt();
                let ds = soc_det(ss).sqrt();
                let mut dot = 0.0;
                for k in 0..dim {
                    dot += xs[k] * ss[k];
                }
                let gamma = ((1.0 + dot / (dx * ds)) * 0.5).sqrt();
                let wb = &mut self.w[r.clone()];
                wb[0] = (ss[0] / ds + xs[0] / dx) / (2.0 * gamma);
                for k in 1..dim {
                    wb[k] = (ss[k] / ds - xs[k] / dx) / (2.0 * gamma);
                }
                let eta = (ds / dx).sqrt();
                self.eta[block] = eta;
                w_bar_mul(wb, xs, &mut self.lambda[r], false);
                for l in &mut self.lambda[start..start + dim] {
                    *l *= eta;
                }
            })
        }
    }

    /// out = W v (inverse: W⁻¹ v), cone by cone.
    pub(super) fn w_mul(&self, v: &[f64], out: &mut [f64], inverse: bool) {
        for r in &self.nn_ranges {
            let (w, vi, o) = (&self.w[r.clone()], &v[r.clone()], &mut out[r.clone()]);
            if inverse {
                for k in 0..o.len() {
                    o[k] = vi[k] / w[k];
                }
            } else {
                for k in 0..o.len() {
                    o[k] = vi[k] * w[k];
                }
            }
        }
        for &SocCone { start, dim, block } in &self.soc_blocks {
            with_dim!(dim, |dim| {
                let r = start..start + dim;
                w_bar_mul(
                    &self.w[r.clone()],
                    &v[r.clone()],
                    &mut out[r.clone()],
                    inverse,
                );
                let f = if inverse {
                    1.0 / self.eta[block]
                } else {
                    self.eta[block]
                };
                out[r].iter_mut().for_each(|o| *o *= f);
            })
        }
    }

    /// rc = λ \ (σμ e − λ∘λ − a∘b), cone by cone.
    pub(super) fn combined_rc(&self, sm: f64, a: &[f64], b: &[f64], rc: &mut [f64]) {
        let lam = &self.lambda;
        for r in &self.nn_ranges {
            for i in r.clone() {
                rc[i] = (sm - lam[i] * lam[i] - a[i] * b[i]) / lam[i];
            }
        }
        for &SocCone { start, dim, .. } in &self.soc_blocks {
            with_dim!(dim, |dim| {
                let r = start..start + dim;
                let (l, av, bv) = (&lam[r.clone()], &a[r.clone()], &b[r.clone()]);
                let mut t = [0.0; 8];
                let ll: f64 = l.iter().map(|v| v * v).sum();
                let ab: f64 = av.iter().zip(bv).map(|(p, q)| p * q).sum();
                t[0] = sm - ll - ab;
                for k in 1..dim {
                    t[k] = -(2.0 * l[0] * l[k]) - (av[0] * bv[k] + bv[0] * av[k]);
                }
                // u = λ \ t: u0 = (λ0 t0 − λ1ᵀt1)/det λ, u1 = (t1 − u0 λ1)/λ0.
                let mut l1t1 = 0.0;
                for k in 1..dim {
                    l1t1 += l[k] * t[k];
                }
                let u0 = (l[0] * t[0] - l1t1) / soc_det(l);
                rc[start] = u0;
                for k in 1..dim {
                    rc[start + k] = (t[k] - u0 * l[k]) / l[0];
                }
            })
        }
    }

    /// Largest α with v + α d in K (infinite when d never leaves).
    pub(super) fn max_step(&self, v: &[f64], d: &[f64]) -> f64 {
        let mut alpha = f64::INFINITY;
        for r in &self.nn_ranges {
            for i in r.clone() {
                if d[i] < 0.0 {
                    alpha = alpha.min(-v[i] / d[i]);
                }
            }
        }
        for &SocCone { start, dim, .. } in &self.soc_blocks {
            with_dim!(dim, |dim| {
                let r = start..start + dim;
                alpha = alpha.min(soc_step(&v[r.clone()], &d[r]));
            })
        }
        alpha
    }

    /// The identity element e of K.
    pub(super) fn identity(&self, v: &mut [f64]) {
        v.iter_mut().for_each(|x| *x = 0.0);
        for blk in &self.blocks {
            v[blk.start] = 1.0;
        }
        if let Some((i, _)) = &self.wmax {
            v[*i] = 1.0;
        }
    }

    /// v + (1 + t) e with t the largest violation, when v is not strictly inside K.
    pub(super) fn shift_interior(&self, v: &mut [f64]) {
        let mut worst = f64::NEG_INFINITY;
        if let Some((i, _)) = &self.wmax {
            worst = worst.max(-v[*i]);
        }
        for blk in &self.blocks {
            let r = blk.start..blk.start + blk.dim;
            let viol = if blk.soc {
                let n1: f64 = v[blk.start + 1..r.end].iter().map(|x| x * x).sum();
                n1.sqrt() - v[blk.start]
            } else {
                -v[blk.start]
            };
            worst = worst.max(viol);
        }
        if worst >= -1e-8 {
            let t = 1.0 + worst.max(0.0);
            for blk in &self.blocks {
                v[blk.start] += t;
            }
            if let Some((i, _)) = &self.wmax {
                v[*i] += t;
            }
        }
    }
}

/// x0² − ‖x1‖² of a second-order-cone vector.
#[inline(always)]
pub(super) fn soc_det(x: &[f64]) -> f64 {
    let n1: f64 = x[1..].iter().map(|v| v * v).sum();
    (x[0] - n1.sqrt()) * (x[0] + n1.sqrt())
}

/// out = W̄ v (or W̄⁻¹ v = J W̄ J v) for the normalised scaling point w̄ (det w̄ = 1):
/// W̄ = [[w̄0, w̄1ᵀ], [w̄1, I + w̄1 w̄1ᵀ/(1 + w̄0)]].
#[inline(always)]
pub(super) fn w_bar_mul(wb: &[f64], v: &[f64], out: &mut [f64], inverse: bool) {
    let sgn = if inverse { -1.0 } else { 1.0 };
    let mut w1v1 = 0.0;
    for k in 1..wb.len() {
        w1v1 += wb[k] * v[k];
    }
    out[0] = wb[0] * v[0] + sgn * w1v1;
    let f = sgn * v[0] + w1v1 / (1.0 + wb[0]);
    for k in 1..wb.len() {
        out[k] = v[k] + f * wb[k];
    }
}

/// Largest α ≥ 0 with x + α d in the second-order cone (x strictly inside).
#[inline(always)]
pub(super) fn soc_step(x: &[f64], d: &[f64]) -> f64 {
    let a = soc_det(d);
    let mut xd1 = 0.0;
    for k in 1..x.len() {
        xd1 += x[k] * d[k];
    }
    let b = 2.0 * (x[0] * d[0] - xd1);
    let c = soc_det(x).max(0.0);
    let disc = b * b - 4.0 * a * c;
    if (a > 0.0 && b > 0.0) || disc < 0.0 {
        return if d[0] >= 0.0 || a > 0.0 {
            f64::INFINITY
        } else {
            -x[0] / d[0]
        };
    }
    if a == 0.0 {
        return if b < 0.0 { -c / b } else { f64::INFINITY };
    }
    // Roots of a α² + b α + c (numerically stable form).
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let r1 = q / a;
    let r2 = c / q;
    let mut alpha = f64::INFINITY;
    for r in [r1, r2] {
        if r > 0.0 && r.is_finite() {
            alpha = alpha.min(r);
        }
    }
    alpha
}
