//! The dense QP one robot's problem linearises into, and its row and residual builders.

// Numeric kernels index several step-aligned arrays with one step index.
#![allow(clippy::needless_range_loop)]

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
    pub(super) fn reset(&mut self, n: usize) {
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

    pub(super) fn new_row(&mut self, b: f64) -> usize {
        self.a.extend(std::iter::repeat_n(0.0, self.n));
        self.mask.extend(std::iter::repeat_n(false, self.n));
        self.b.push(b);
        self.m += 1;
        self.m - 1
    }

    pub(super) fn set(&mut self, r: usize, c: usize, v: f64) {
        self.a[r * self.n + c] = v;
        self.mask[r * self.n + c] = true;
    }

    /// Adds `v` to P\[i, j\] and P\[j, i\] (once when i = j) and marks the pattern.
    pub(super) fn add_p(&mut self, i: usize, j: usize, v: f64) {
        let n = self.n;
        self.p[i * n + j] += v;
        self.p_mask[i * n + j] = true;
        if i != j {
            self.p[j * n + i] += v;
            self.p_mask[j * n + i] = true;
        }
    }

    /// Adds w (r0 + Σ g_i z_{idx_i})² to the cost (sparse gradient; pattern always marked).
    pub(super) fn add_sparse_residual(&mut self, w: f64, r0: f64, idx: &[usize], g: &[f64]) {
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
    pub(super) fn add_residual(&mut self, w: f64, r0: f64, g: &[f64]) {
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
