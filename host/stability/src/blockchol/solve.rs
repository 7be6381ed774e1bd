//! Solves with the factor: permute, block forward/backward substitution over the panels,
//! permute back.

use super::kernels::{get6, load, matvec_sub, matvec_t_sub, put6};
use super::{BlockCholesky, B};

impl BlockCholesky {
    /// Solve A x = rhs in place (original node order, node i's rows at 6i..6i+6).
    pub fn solve(&mut self, rhs: &mut [f64]) {
        self.solve_phases(rhs, true, true);
    }

    /// Half of [`solve`](Self::solve): y = L⁻¹ P rhs, in place. The result is in the factor's
    /// (permuted) order; its Euclidean norm is what matters to a caller (‖y‖² = rhsᵀA⁻¹rhs),
    /// e.g. for a product-form rank-one update.
    pub fn solve_lower(&mut self, rhs: &mut [f64]) {
        self.solve_phases(rhs, true, false);
    }

    /// The other half: x = Pᵀ L⁻ᵀ y for y in the factor's order (from
    /// [`solve_lower`](Self::solve_lower)), in place, in the original node order.
    pub fn solve_upper(&mut self, rhs: &mut [f64]) {
        self.solve_phases(rhs, false, true);
    }

    fn solve_phases(&mut self, rhs: &mut [f64], forward: bool, backward: bool) {
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(simd) = pulp::x86::V4::try_new() {
                return simd.vectorize(|| self.solve_impl::<true>(rhs, forward, backward));
            }
            if let Some(simd) = pulp::x86::V3::try_new() {
                return simd.vectorize(|| self.solve_impl::<true>(rhs, forward, backward));
            }
        }
        self.solve_impl::<false>(rhs, forward, backward)
    }

    #[inline(always)]
    fn solve_impl<const FMA: bool>(&mut self, rhs: &mut [f64], forward: bool, backward: bool) {
        assert_eq!(rhs.len(), B * self.n, "rhs length must be 6 n");
        let w = &mut self.work;
        if forward {
            for (k, &i) in self.perm.iter().enumerate() {
                w[B * k..B * k + B].copy_from_slice(&rhs[B * i..B * i + B]);
            }
        } else {
            w.copy_from_slice(rhs);
        }
        let ns = self.sn_first.len() - 1;
        let lx = &self.lx;
        // Forward: L y = b.
        for s in (0..ns).filter(|_| forward) {
            let (f, l) = (self.sn_first[s], self.sn_first[s + 1]);
            let nc = l - f;
            let rows = &self.rows[self.rows_ptr[s]..self.rows_ptr[s + 1]];
            let ld = B * (nc + rows.len());
            let p = &lx[self.sn_off[s]..self.sn_off[s + 1]];
            for jb in 0..nc {
                let mut y = get6(w, f + jb);
                for kb in 0..jb {
                    let x = get6(w, f + kb);
                    matvec_sub::<FMA>(&mut y, p, ld, jb, kb, &x);
                }
                let linv = load(p, ld, jb, jb);
                let mut z = [0.0; B];
                matvec_sub::<FMA>(&mut z, &linv, B, 0, 0, &y);
                put6(w, f + jb, &z.map(|v| -v));
            }
            for (a, &i) in rows.iter().enumerate() {
                let mut y = get6(w, i);
                for kb in 0..nc {
                    let x = get6(w, f + kb);
                    matvec_sub::<FMA>(&mut y, p, ld, nc + a, kb, &x);
                }
                put6(w, i, &y);
            }
        }
        if !backward {
            rhs.copy_from_slice(w);
            return;
        }
        // Backward: Lᵀ x = y.
        for s in (0..ns).rev() {
            let (f, l) = (self.sn_first[s], self.sn_first[s + 1]);
            let nc = l - f;
            let rows = &self.rows[self.rows_ptr[s]..self.rows_ptr[s + 1]];
            let ld = B * (nc + rows.len());
            let p = &lx[self.sn_off[s]..self.sn_off[s + 1]];
            for jb in (0..nc).rev() {
                let mut y = get6(w, f + jb);
                for (a, &i) in rows.iter().enumerate() {
                    let x = get6(w, i);
                    matvec_t_sub::<FMA>(&mut y, p, ld, nc + a, jb, &x);
                }
                for ib in jb + 1..nc {
                    let x = get6(w, f + ib);
                    matvec_t_sub::<FMA>(&mut y, p, ld, ib, jb, &x);
                }
                let linv = load(p, ld, jb, jb);
                let mut z = [0.0; B];
                matvec_t_sub::<FMA>(&mut z, &linv, B, 0, 0, &y);
                put6(w, f + jb, &z.map(|v| -v));
            }
        }
        for (k, &i) in self.perm.iter().enumerate() {
            rhs[B * i..B * i + B].copy_from_slice(&w[B * k..B * k + B]);
        }
    }
}
