//! Numeric factorisation: supernodal, right-looking between supernodes and left-looking within
//! one, on 6×6 blocks.

use super::kernels::{chol_inv, gemm_nt, load, nt6, store, sub};
use super::{BlockCholesky, FactorError, B, BB};

impl BlockCholesky {
    /// Numeric factorisation A + shift·I = L Lᵀ (permuted order) of the current input values.
    pub fn factor(&mut self, shift: f64) -> Result<(), FactorError> {
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(simd) = pulp::x86::V4::try_new() {
                return simd.vectorize(|| self.factor_impl::<true>(shift));
            }
            if let Some(simd) = pulp::x86::V3::try_new() {
                return simd.vectorize(|| self.factor_impl::<true>(shift));
            }
        }
        self.factor_impl::<false>(shift)
    }

    #[inline(always)]
    fn factor_impl<const FMA: bool>(&mut self, shift: f64) -> Result<(), FactorError> {
        let lx = &mut self.lx;
        lx.fill(0.0);
        for (k, &(off, ld)) in self.dest.iter().enumerate() {
            let v = &self.vals[k * BB..k * BB + BB];
            for c in 0..B {
                lx[off + c * ld..off + c * ld + B].copy_from_slice(&v[c * B..c * B + B]);
            }
        }
        if shift != 0.0 {
            for &(off, ld) in &self.dest[..self.n] {
                for c in 0..B {
                    lx[off + c * ld + c] += shift;
                }
            }
        }
        let ns = self.sn_first.len() - 1;
        for s in 0..ns {
            let (f, l) = (self.sn_first[s], self.sn_first[s + 1]);
            let nc = l - f;
            let rows = &self.rows[self.rows_ptr[s]..self.rows_ptr[s + 1]];
            let nr = nc + rows.len();
            let ld = B * nr;
            let (lo, hi) = lx.split_at_mut(self.sn_off[s + 1]);
            let p = &mut lo[self.sn_off[s]..];
            // Left-looking block Cholesky of the panel.
            for jb in 0..nc {
                let mut d = load(p, ld, jb, jb);
                if jb > 0 {
                    sub(&mut d, &gemm_nt::<FMA>(p, ld, B * jb, B * jb, B * jb));
                }
                let linv = chol_inv(&d).ok_or(FactorError::NotPositiveDefinite {
                    node: self.perm[f + jb],
                })?;
                store(p, ld, jb, jb, &linv);
                for ib in jb + 1..nr {
                    let mut c = load(p, ld, ib, jb);
                    if jb > 0 {
                        sub(&mut c, &gemm_nt::<FMA>(p, ld, B * ib, B * jb, B * jb));
                    }
                    store(p, ld, ib, jb, &nt6::<FMA>(&c, &linv));
                }
            }
            // Right-looking update of the ancestors.
            let p = &*p;
            let base = self.sn_off[s + 1];
            for seg in &self.segs[self.seg_ptr[s]..self.seg_ptr[s + 1]] {
                let t = seg.target;
                let ft = self.sn_first[t];
                let ldt = B * (self.sn_first[t + 1] - ft + self.rows_ptr[t + 1] - self.rows_ptr[t]);
                let tp = &mut hi[self.sn_off[t] - base..];
                let map = &self.relmap[seg.map..seg.map + rows.len() - seg.start];
                for b in seg.start..seg.end {
                    let cb = rows[b] - ft;
                    for a in b..rows.len() {
                        let acc = gemm_nt::<FMA>(p, ld, B * (nc + a), B * (nc + b), B * nc);
                        let o = B * cb * ldt + B * map[a - seg.start] as usize;
                        for c in 0..B {
                            let dst: &mut [f64; B] =
                                (&mut tp[o + c * ldt..o + c * ldt + B]).try_into().unwrap();
                            for r in 0..B {
                                dst[r] -= acc[c * B + r];
                            }
                        }
                    }
                }
            }
        }
        Ok(())
    }
}
