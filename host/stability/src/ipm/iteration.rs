//! The predictor–corrector iteration: initial point, termination tests and the Newton
//! direction.

use super::{
    Declined, Ipm, IpmInfo, DIVERGED, MAX_REG, REFINE_FROM_GAP, REFINE_OK, REFINE_TARGET,
    STALL_WINDOW, STEP_FRACTION,
};

impl<'a> Ipm<'a> {
    pub(super) fn run(&mut self, tol: f64, max_iter: u32) -> Result<(Vec<f64>, IpmInfo), Declined> {
        let (nx, m) = (self.nx, self.neq + self.nlev);
        let nu = (self.blocks.len() + usize::from(self.wmax.is_some())) as f64;
        // Initial point (as CVXOPT): least-norm x with Ax = b and least-squares s = c − Aᵀy,
        // each shifted into the interior of K.
        let mut x = vec![0.0; nx];
        let mut s = vec![0.0; nx];
        let mut y = vec![0.0; m];
        self.identity(&mut x);
        self.identity(&mut s);
        self.scale(&x, &s);
        self.factor_regularised()?;
        let mut tm = vec![0.0; m];
        let mut tx = vec![0.0; nx];
        let b = self.b.clone();
        self.solve_m(&b, &mut tm);
        self.at_mul(&tm, &mut x);
        let c = self.c.clone();
        self.a_mul(&c, &mut tm);
        self.solve_m(&tm.clone(), &mut y);
        self.at_mul(&y, &mut tx);
        for i in 0..nx {
            s[i] = c[i] - tx[i];
        }
        self.shift_interior(&mut x);
        self.shift_interior(&mut s);

        let nb = 1.0 + b.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let nc = 1.0 + c.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let mut rp = vec![0.0; m];
        let mut rd = vec![0.0; nx];
        let (mut dx, mut dy, mut ds) = (vec![0.0; nx], vec![0.0; m], vec![0.0; nx]);
        let (mut dxa, mut dsa) = (vec![0.0; nx], vec![0.0; nx]);
        let mut rc = vec![0.0; nx];
        let mut t1 = vec![0.0; nx];
        let mut t2 = vec![0.0; nx];
        let mut pres_hist = [f64::INFINITY; STALL_WINDOW];
        for iter in 0..=max_iter {
            // Residuals rp = b − Ax, rd = c − Aᵀy − s.
            self.a_mul(&x, &mut rp);
            for j in 0..m {
                rp[j] = b[j] - rp[j];
            }
            self.at_mul(&y, &mut rd);
            for i in 0..nx {
                rd[i] = c[i] - rd[i] - s[i];
            }
            let gap: f64 = x.iter().zip(&s).map(|(a, b)| a * b).sum();
            let pcost: f64 = c.iter().zip(&x).map(|(a, b)| a * b).sum();
            let dcost: f64 = b.iter().zip(&y).map(|(a, b)| a * b).sum();
            let pres = rp.iter().fold(0.0f64, |a, v| a.max(v.abs())) / nb;
            let dres = rd.iter().fold(0.0f64, |a, v| a.max(v.abs())) / nc;
            let scale = pcost.abs().min(dcost.abs()).max(1.0);
            let gap_ok = gap <= tol * scale && (pcost - dcost).abs() <= tol * scale;
            if pres <= tol && dres <= tol && gap_ok {
                return Ok((
                    x,
                    IpmInfo {
                        iterations: iter,
                        ..self.work
                    },
                ));
            }
            if iter == max_iter || !(gap.is_finite() && pcost.is_finite()) {
                break;
            }
            // No certificate of infeasibility here (Clarabel gives it): stop once the primal
            // residual stalls, as it does when Zx = b has no solution in the cones.
            let k = iter as usize % STALL_WINDOW;
            let diverging = dcost > pcost.abs() + DIVERGED * scale;
            if (iter as usize >= STALL_WINDOW && pres > 0.5 * pres_hist[k] && pres > tol)
                || (iter >= 5 && diverging)
            {
                return Err(Declined::NotConverged { iterations: iter });
            }
            pres_hist[k] = pres;
            self.scale(&x, &s);
            let mu = gap / nu;
            // Far from the optimum an inexact direction does as well (measured: the same
            // iteration counts, ~10 % less time); refinement starts near it.
            let refine_to = if gap > REFINE_FROM_GAP * scale {
                f64::INFINITY
            } else {
                REFINE_TARGET
            };
            // A direction the refinement cannot make accurate is retried with a stronger
            // static regularisation (kept for the following iterations).
            loop {
                self.factor_regularised()?;
                // Predictor: rc = −λ.
                for i in 0..nx {
                    rc[i] = -self.lambda[i];
                }
                // The predictor only sets the step and the centring: not refined (measured: the
                // same iteration counts, 15–20 % less time).
                self.newton(
                    &rp,
                    &rd,
                    &rc,
                    &mut dxa,
                    &mut dy,
                    &mut dsa,
                    &mut t1,
                    &mut t2,
                    f64::INFINITY,
                );
                let alpha_a = self
                    .max_step(&x, &dxa)
                    .min(self.max_step(&s, &dsa))
                    .min(1.0);
                // Centring (1 − α_aff)³, as Clarabel (Mehrotra's (μ_aff/μ)³ measured no better).
                let sigma = (1.0 - alpha_a).powi(3);
                // Corrector: rc = λ \ (σμe − λ∘λ − (W⁻¹Δs_a)∘(WΔx_a)).
                self.w_mul(&dsa, &mut t1, true);
                self.w_mul(&dxa, &mut t2, false);
                self.combined_rc(sigma * mu, &t1, &t2, &mut rc);
                let e2 = self.newton(
                    &rp, &rd, &rc, &mut dx, &mut dy, &mut ds, &mut t1, &mut t2, refine_to,
                );
                if e2 <= REFINE_OK || self.reg >= MAX_REG || refine_to.is_infinite() {
                    break;
                }
                self.reg *= 10.0;
            }
            let alpha =
                (STEP_FRACTION * self.max_step(&x, &dx).min(self.max_step(&s, &ds))).min(1.0);
            if alpha.is_nan() || alpha <= 1e-10 {
                return Err(Declined::NotConverged { iterations: iter });
            }
            for i in 0..nx {
                x[i] += alpha * dx[i];
                s[i] += alpha * ds[i];
            }
            for j in 0..m {
                y[j] += alpha * dy[j];
            }
        }
        Err(Declined::NotConverged {
            iterations: max_iter,
        })
    }

    /// Newton direction for the residuals (rp, rd) and scaled complementarity rc:
    /// A Δx = rp, AᵀΔy + Δs = rd, WΔx + W⁻¹Δs = rc.
    #[allow(clippy::too_many_arguments)]
    fn newton(
        &mut self,
        rp: &[f64],
        rd: &[f64],
        rc: &[f64],
        dx: &mut [f64],
        dy: &mut [f64],
        ds: &mut [f64],
        t1: &mut [f64],
        t2: &mut [f64],
        target: f64,
    ) -> f64 {
        let nx = self.nx;
        // rhs = rp + A (W⁻² rd − W⁻¹ rc)
        self.w_mul(rd, t1, true);
        for i in 0..nx {
            t1[i] -= rc[i];
        }
        self.w_mul(t1, t2, true);
        let mut rhs = std::mem::take(&mut self.tmp_rhs);
        self.a_mul(t2, &mut rhs);
        for j in 0..rhs.len() {
            rhs[j] += rp[j];
        }
        self.solve_m(&rhs, dy);
        let e = self.refine(&rhs, dy, target);
        self.tmp_rhs = rhs;
        // Δs = rd − AᵀΔy; Δx = W⁻¹(rc − W⁻¹Δs).
        self.at_mul(dy, ds);
        for i in 0..nx {
            ds[i] = rd[i] - ds[i];
        }
        self.w_mul(ds, t1, true);
        for i in 0..nx {
            t1[i] = rc[i] - t1[i];
        }
        self.w_mul(t1, dx, true);
        e
    }
}
