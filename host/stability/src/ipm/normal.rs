//! The normal equations `A W⁻² Aᵀ Δy = r`: assembly with the level rows eliminated, the block
//! factorisation with w_A^max in product form, solves, and iterative refinement against the
//! exact matrix.

use super::{Block, Declined, Ipm, MAX_REG, MAX_ROWS, REFINE_STEPS};
use crate::blockchol::{BlockCholesky, Slot, B};

impl<'a> Ipm<'a> {
    /// out = A x (length neq + nlev).
    pub(super) fn a_mul(&self, x: &[f64], out: &mut [f64]) {
        let a = &self.p.a;
        for j in 0..a.n {
            let mut s = 0.0;
            for k in a.colptr[j]..a.colptr[j + 1] {
                s += a.nzval[k] * x[a.rowval[k]];
            }
            out[j] = s;
        }
    }

    /// out = Aᵀ y (length nx).
    pub(super) fn at_mul(&self, y: &[f64], out: &mut [f64]) {
        let a = &self.p.a;
        out.iter_mut().for_each(|v| *v = 0.0);
        for j in 0..a.n {
            let yj = y[j];
            if yj != 0.0 {
                for k in a.colptr[j]..a.colptr[j + 1] {
                    out[a.rowval[k]] += a.nzval[k] * yj;
                }
            }
        }
    }

    /// Assemble the normal matrix A W⁻² Aᵀ (level rows eliminated), factorise it, and
    /// prepare w_A^max's product-form vector p = R⁻¹ a.
    fn factor(&mut self) -> Result<(), Declined> {
        self.work.factorisations += 1;
        self.chol.clear();
        self.g.iter_mut().for_each(|v| *v = 0.0);
        self.h.iter_mut().for_each(|v| *v = 0.0);
        for (bi, blk) in self.blocks.iter().enumerate() {
            let nr = blk.rows();
            let nm = B * blk.nnode;
            if nm == 0 || blk.level.is_some() {
                continue;
            }
            let la = &self.local_a[blk.a_off..blk.a_off + nr * blk.dim];
            // G = A_loc W⁻² A_locᵀ: for a cone W⁻² = (2 u uᵀ − J)/η², u = J w̄, so
            // G = (2 (A u)(A u)ᵀ − A J Aᵀ)/η²; for a nonnegative unknown G = a aᵀ/w².
            let mut q = [0.0; MAX_ROWS];
            if blk.soc {
                let pm = &self.pre[blk.p_off..blk.p_off + nm * nm];
                let wb = &self.w[blk.start..blk.start + blk.dim];
                for c in 0..blk.dim {
                    let u = if c == 0 { wb[0] } else { -wb[c] };
                    for r in 0..nm {
                        q[r] += la[c * nr + r] * u;
                    }
                }
                let inv_e2 = 1.0 / (self.eta[bi] * self.eta[bi]);
                add_sym(
                    &mut self.chol,
                    blk.nnode,
                    &blk.diag,
                    blk.off,
                    Some(pm),
                    -inv_e2,
                    &q,
                    2.0 * inv_e2,
                );
            } else {
                let w = self.w[blk.start];
                q[..nm].copy_from_slice(&la[..nm]);
                add_sym(
                    &mut self.chol,
                    blk.nnode,
                    &blk.diag,
                    blk.off,
                    None,
                    0.0,
                    &q,
                    1.0 / (w * w),
                );
            }
        }
        // Level rows, eliminated in closed form (an explicit S −= h hᵀ/g cancels catastrophically
        // once a strength cone reaches its boundary, where W⁻² has one huge eigenvalue).
        for (l, lev) in self.levels.iter().enumerate() {
            let hb = &self.blocks[lev.head];
            let wt = self.w[self.blocks[lev.t].start];
            let d_t = 1.0 / (wt * wt);
            let nr = hb.rows();
            let nm = nr - 1; // module rows
            let la = &self.local_a[hb.a_off..hb.a_off + nr * hb.dim];
            let h = &mut self.h[l * 2 * B..(l + 1) * 2 * B];
            let g;
            if hb.soc {
                // Head column 0 (coefficient a_l on the level row only), module columns F = 1..:
                // with D = (2uuᵀ − J)/η², u = J w̄, the Schur complement of the level row is
                // F [I − κ u1 u1ᵀ] Fᵀ / η², κ = 2(1 − ε)/(2u0² − 1 + ε), ε = η² d_t / a_l².
                let wb = &self.w[hb.start..hb.start + hb.dim];
                let eta2 = self.eta[lev.head] * self.eta[lev.head];
                let al = la[nr - 1];
                let u0 = wb[0];
                let eps = eta2 * d_t / (al * al);
                let kappa = 2.0 * (1.0 - eps) / (2.0 * u0 * u0 - 1.0 + eps);
                let mut fu = [0.0; MAX_ROWS];
                for c in 1..hb.dim {
                    for r in 0..nm {
                        fu[r] -= la[c * nr + r] * wb[c]; // u1 = −w̄1
                    }
                }
                let pm = &self.pre[hb.p_off..hb.p_off + nm * nm];
                add_sym(
                    &mut self.chol,
                    lev.nnode,
                    &lev.diag,
                    lev.off,
                    Some(pm),
                    1.0 / eta2,
                    &fu,
                    -kappa / eta2,
                );
                // h = a_l F d0, d0 = 2 u0 u1 / η²; g = a_l² d00 + d_t.
                for r in 0..nm {
                    h[r] = al * 2.0 * u0 * fu[r] / eta2;
                }
                g = al * al * (2.0 * u0 * u0 - 1.0) / eta2 + d_t;
            } else {
                // Nonnegative head with column a = (a_E, a_l): S = d d_t/(d a_l² + d_t) a_E a_Eᵀ.
                let w = self.w[hb.start];
                let d = 1.0 / (w * w);
                let al = la[nr - 1];
                g = d * al * al + d_t;
                let k = d * d_t / g;
                let mut a = [0.0; MAX_ROWS];
                for r in 0..nm {
                    h[r] = d * al * la[r];
                    a[r] = la[r];
                }
                add_sym(
                    &mut self.chol,
                    lev.nnode,
                    &lev.diag,
                    lev.off,
                    None,
                    0.0,
                    &a,
                    k,
                );
            }
            if !(g > 0.0 && g.is_finite()) {
                return Err(Declined::Factor);
            }
            self.g[l] = g;
        }
        self.chol.factor(self.reg).map_err(|_| Declined::Factor)?;
        // w_A^max's column a (on the level rows) in product form (Goldfarb–Scheinberg): M =
        // M0 + d a aᵀ = R (I + d p pᵀ) Rᵀ, p = R⁻¹ a: a half-solve here. The Sherman–Morrison
        // form M0⁻¹ − … needs the full solve M0⁻¹ a instead; with the refinement and the
        // raised regularisation both reach the same iteration counts on the benchmark
        // families (measured), so the cheaper one is kept.
        self.d_wmax = 0.0;
        self.pf_pp = 0.0;
        if let Some((v, coef)) = self.wmax.take() {
            let w = self.w[v];
            self.d_wmax = 1.0 / (w * w);
            let mut r = std::mem::take(&mut self.tmp_rhs);
            r[..self.neq].iter_mut().for_each(|v| *v = 0.0);
            r[self.neq..].copy_from_slice(&coef);
            let mut p = std::mem::take(&mut self.pf_p);
            self.r_inv(&r, &mut p);
            self.pf_pp = p.iter().map(|v| v * v).sum();
            self.pf_p = p;
            self.tmp_rhs = r;
            self.wmax = Some((v, coef));
        }
        Ok(())
    }

    /// [`Self::factor`], raising the static regularisation (up to [`MAX_REG`]) while the
    /// block factorisation finds a non-positive pivot.
    pub(super) fn factor_regularised(&mut self) -> Result<(), Declined> {
        loop {
            match self.factor() {
                Err(Declined::Factor) if self.reg < MAX_REG => self.reg *= 10.0,
                r => return r,
            }
        }
    }

    /// v = R⁻¹ r, M0 = R Rᵀ, R = [[G^½, 0], [H G^-½, L]] over (level rows, module rows);
    /// v's module part is in the block factor's order.
    fn r_inv(&mut self, r: &[f64], v: &mut [f64]) {
        let neq = self.neq;
        let re = &mut self.tmp_e;
        re.copy_from_slice(&r[..neq]);
        for (l, lev) in self.levels.iter().enumerate() {
            let f = r[neq + l] / self.g[l];
            let h = &self.h[l * 2 * B..(l + 1) * 2 * B];
            for a in 0..lev.nnode {
                let base = B * lev.nodes[a];
                for k in 0..B {
                    re[base + k] -= h[a * B + k] * f;
                }
            }
            v[neq + l] = r[neq + l] / self.g[l].sqrt();
        }
        self.chol.solve_lower(re);
        v[..neq].copy_from_slice(re);
    }

    /// z = R⁻ᵀ v.
    fn rt_inv(&mut self, v: &[f64], z: &mut [f64]) {
        let neq = self.neq;
        let re = &mut self.tmp_e;
        re.copy_from_slice(&v[..neq]);
        self.chol.solve_upper(re);
        z[..neq].copy_from_slice(re);
        for (l, lev) in self.levels.iter().enumerate() {
            let h = &self.h[l * 2 * B..(l + 1) * 2 * B];
            let mut hz = 0.0;
            for a in 0..lev.nnode {
                let base = B * lev.nodes[a];
                for k in 0..B {
                    hz += h[a * B + k] * re[base + k];
                }
            }
            let g = self.g[l];
            z[neq + l] = v[neq + l] / g.sqrt() - hz / g;
        }
    }

    /// z = M⁻¹ r = R⁻ᵀ (I + d p pᵀ)⁻¹ R⁻¹ r.
    pub(super) fn solve_m(&mut self, r: &[f64], z: &mut [f64]) {
        self.work.solves += 1;
        let mut v = std::mem::take(&mut self.tmp_v);
        self.r_inv(r, &mut v);
        if self.d_wmax > 0.0 {
            let pv: f64 = self.pf_p.iter().zip(&v).map(|(a, b)| a * b).sum();
            let f = pv / (1.0 / self.d_wmax + self.pf_pp);
            for (vi, pi) in v.iter_mut().zip(&self.pf_p) {
                *vi -= f * pi;
            }
        }
        self.rt_inv(&v, z);
        self.tmp_v = v;
    }

    /// out = M v = A W⁻² Aᵀ v, matrix-free, cone block by cone block (local dense A).
    fn m_mul(&self, v: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        let neq = self.neq;
        for (bi, blk) in self.blocks.iter().enumerate() {
            // Constant shapes for the gate's blocks (strength cone on two modules and a level
            // row; contact cone, nonnegative unknowns on one or two modules or a level row).
            match (blk.rows(), blk.dim) {
                (0, _) => {}
                (13, 7) => self.m_mul_block(bi, blk, 13, 7, v, out),
                (6, 3) => self.m_mul_block(bi, blk, 6, 3, v, out),
                (12, 1) => self.m_mul_block(bi, blk, 12, 1, v, out),
                (6, 1) => self.m_mul_block(bi, blk, 6, 1, v, out),
                (1, 1) => self.m_mul_block(bi, blk, 1, 1, v, out),
                (nr, dim) => self.m_mul_block(bi, blk, nr, dim, v, out),
            }
        }
        if let Some((i, coef)) = &self.wmax {
            let w = self.w[*i];
            let av: f64 = coef.iter().zip(&v[neq..]).map(|(a, b)| a * b).sum();
            let f = av / (w * w);
            for (o, a) in out[neq..].iter_mut().zip(coef) {
                *o += f * a;
            }
        }
    }

    /// out += A_blk W_blk⁻² A_blkᵀ v for one block of `nr` local rows and dimension `dim`
    /// (inlined with constant shapes by [`Self::m_mul`]).
    #[inline(always)]
    fn m_mul_block(
        &self,
        bi: usize,
        blk: &Block,
        nr: usize,
        dim: usize,
        v: &[f64],
        out: &mut [f64],
    ) {
        let neq = self.neq;
        let nnode = nr / B; // 6 rows per module, then at most one level row
        let la = &self.local_a[blk.a_off..blk.a_off + nr * dim];
        let mut vl = [0.0; MAX_ROWS];
        for a in 0..nnode {
            let base = B * blk.nodes[a];
            vl[a * B..a * B + B].copy_from_slice(&v[base..base + B]);
        }
        if let Some(l) = blk.level {
            vl[nr - 1] = v[neq + l];
        }
        // t = A_locᵀ v, u = W⁻² t, out += A_loc u.
        let mut t = [0.0; 8];
        for c in 0..dim {
            let col = &la[c * nr..(c + 1) * nr];
            t[c] = col.iter().zip(&vl[..nr]).map(|(a, b)| a * b).sum();
        }
        let mut u = [0.0; 8];
        if blk.soc {
            // W⁻² = (2 (Jw̄)(Jw̄)ᵀ − J)/η².
            let wb = &self.w[blk.start..blk.start + dim];
            let inv_e2 = 1.0 / (self.eta[bi] * self.eta[bi]);
            let mut ut = wb[0] * t[0];
            for k in 1..dim {
                ut -= wb[k] * t[k];
            }
            u[0] = (2.0 * wb[0] * ut - t[0]) * inv_e2;
            for k in 1..dim {
                u[k] = (t[k] - 2.0 * wb[k] * ut) * inv_e2;
            }
        } else {
            let w = self.w[blk.start];
            u[0] = t[0] / (w * w);
        }
        let mut ol = [0.0; MAX_ROWS];
        for c in 0..dim {
            let col = &la[c * nr..(c + 1) * nr];
            for r in 0..nr {
                ol[r] += col[r] * u[c];
            }
        }
        for a in 0..nnode {
            let base = B * blk.nodes[a];
            for k in 0..B {
                out[base + k] += ol[a * B + k];
            }
        }
        if let Some(l) = blk.level {
            out[neq + l] += ol[nr - 1];
        }
    }

    /// Iterative refinement of M dy = rhs against the exact (unfactorised) M.
    /// Returns the final residual relative to ‖rhs‖.
    pub(super) fn refine(&mut self, rhs: &[f64], dy: &mut [f64], target: f64) -> f64 {
        if target.is_infinite() {
            return 0.0;
        }
        let m = rhs.len();
        let norm = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let scale = norm(rhs).max(1e-300);
        let mut res = std::mem::take(&mut self.tmp_res);
        let mut corr = std::mem::take(&mut self.tmp_corr);
        let mut last = f64::INFINITY;
        let mut out = f64::INFINITY;
        for step in 0..=REFINE_STEPS {
            self.work.products += 1;
            self.m_mul(dy, &mut res);
            for j in 0..m {
                res[j] = rhs[j] - res[j];
            }
            let e = norm(&res) / scale;
            if e <= target || e >= 0.5 * last || step == REFINE_STEPS {
                out = e.min(last);
                break;
            }
            last = e;
            self.solve_m(&res, &mut corr);
            for j in 0..m {
                dy[j] += corr[j];
            }
        }
        self.tmp_res = res;
        self.tmp_corr = corr;
        out
    }
}

/// Add c1·P + c2·q qᵀ (module rows: 6 per node, P row-major, 6·nnode square; no P: c2·q qᵀ
/// only) to the block matrix, block by block.
#[allow(clippy::too_many_arguments)]
fn add_sym(
    chol: &mut BlockCholesky,
    nnode: usize,
    diag: &[Option<Slot>; 2],
    off: Option<Slot>,
    pm: Option<&[f64]>,
    c1: f64,
    q: &[f64; MAX_ROWS],
    c2: f64,
) {
    let nm = B * nnode;
    // Block (a, b) is c2 q_a q_bᵀ + c1 P_ab; stored column-major in L's orientation, i.e. as
    // (x, y) = (a, b) or, for a transposed slot, (b, a): column c gets c2 q_y[c] q_x +
    // c1 P[y c, x ·] (P is symmetric, so that column of P_xy is contiguous). The products are
    // rounded as (c2 q_a[r]) q_b[c] either way (the iteration counts are sensitive to it).
    let put = |chol: &mut BlockCholesky, slot: Slot, a: usize, b: usize| {
        let (v, transposed) = chol.block_mut(slot);
        let (x, y) = if transposed { (b, a) } else { (a, b) };
        let qx: &[f64; B] = q[x * B..x * B + B].try_into().unwrap();
        let qy: &[f64; B] = q[y * B..y * B + B].try_into().unwrap();
        let mut blk = [0.0; 36];
        if transposed {
            for c in 0..B {
                let f = c2 * qy[c];
                for r in 0..B {
                    blk[c * B + r] = f * qx[r];
                }
            }
        } else {
            let cqx = qx.map(|e| c2 * e);
            for c in 0..B {
                for r in 0..B {
                    blk[c * B + r] = cqx[r] * qy[c];
                }
            }
        }
        if let Some(pm) = pm {
            for c in 0..B {
                let o = (y * B + c) * nm + x * B;
                let pc: &[f64; B] = pm[o..o + B].try_into().unwrap();
                for r in 0..B {
                    blk[c * B + r] += c1 * pc[r];
                }
            }
        }
        for (vi, bi) in v.iter_mut().zip(&blk) {
            *vi += bi;
        }
    };
    for a in 0..nnode {
        if let Some(slot) = diag[a] {
            put(chol, slot, a, a);
        }
    }
    if let (2, Some(slot)) = (nnode, off) {
        put(chol, slot, 0, 1);
    }
}
