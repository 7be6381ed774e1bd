//! Sparse Cholesky factorisation of symmetric positive definite matrices made of dense
//! [`B`]×[`B`] blocks over a graph (the normal equations of the interior-point solver: one
//! block row per rigid module).
//!
//! Method:
//! - **Ordering**: approximate minimum degree (the `amd` crate) of the *block* graph, then a
//!   postorder of its elimination tree, so that supernodes are contiguous column ranges.
//! - **Symbolic analysis** (in [`BlockCholesky::new`]): block column structures of L, fundamental
//!   supernodes (a column joins its predecessor when it is that column's parent and the
//!   structures nest), one dense column-major panel per supernode (its diagonal part stored as a
//!   full square), and, for every (supernode, ancestor) pair, the relative row positions of the
//!   update in the ancestor's panel, so the numeric phase never searches.
//! - **Numeric factorisation**: supernodal, right-looking between supernodes (the update of a
//!   supernode is subtracted straight into its ancestors' panels, block by block) and
//!   left-looking within one. All arithmetic is on 6×6 blocks: a block `C -= Σ_k a_k b_kᵀ`
//!   micro-kernel with 36 accumulators (the inner product of two block rows of a panel), a 6×6
//!   Cholesky whose *inverse* factor is stored on the diagonal, so that triangular solves become
//!   6×6 products. The kernels are plain fixed-size loops, compiled for AVX-512 or AVX2+FMA at
//!   run time (through `pulp`'s safe dispatch) when the CPU has it.
//! - **Solve**: permute, block forward/backward substitution over the panels, permute back.
//!
//! Input values live apart from the factor (one 6×6 block per input slot), so [`BlockCholesky::add`]
//! is O(36) and a failed factorisation leaves them untouched.

/// Block size: 6 rows (force, couple) per module.
pub const B: usize = 6;
const BB: usize = B * B;

/// Which way an input slot's block is stored in L (block of the later-eliminated node as rows).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SlotKind {
    Diag,
    /// `blk` rows belong to the row node of L: stored as given.
    Lower,
    /// `blk` rows belong to the column node of L: stored transposed.
    Upper,
}

/// Where a block (i, j) of the input matrix is stored.
#[derive(Clone, Copy, Debug)]
pub struct Slot {
    idx: u32,
    kind: SlotKind,
}

/// Failure of the numeric factorisation.
#[derive(Debug, Clone, PartialEq)]
pub enum FactorError {
    /// The pivot block of `node` (original block index) is not positive definite (or not finite).
    NotPositiveDefinite {
        /// Original block index whose pivot failed.
        node: usize,
    },
}

/// One run of a supernode's row structure whose rows are columns of the same ancestor `target`.
#[derive(Clone, Copy, Debug)]
struct Segment {
    target: usize,
    /// Range `start..end` in the supernode's row list `rows` that are columns of `target`.
    start: usize,
    end: usize,
    /// Offset in `relmap` of the positions (in `target`'s panel, in blocks) of `rows[start..]`.
    map: usize,
}

/// A sparse symmetric positive definite matrix of dense B×B blocks over an undirected graph,
/// its fill-reducing ordering, symbolic analysis and numeric Cholesky factor.
pub struct BlockCholesky {
    n: usize,
    /// `perm[k]`: original node eliminated k-th.
    perm: Vec<usize>,
    /// `iperm[i]`: elimination position of original node i.
    iperm: Vec<usize>,
    /// Original graph (CSR, sorted, no duplicates) with the slot index of every edge.
    adj_ptr: Vec<usize>,
    adj_idx: Vec<usize>,
    adj_slot: Vec<u32>,
    /// Input values: one column-major 6×6 block per slot, oriented as the block of L.
    vals: Vec<f64>,
    /// Per slot: (offset of the block in `lx`, leading dimension of its panel).
    dest: Vec<(usize, usize)>,
    /// Supernode s has columns `sn_first[s]..sn_first[s + 1]` (elimination order).
    sn_first: Vec<usize>,
    /// Rows below the diagonal part of supernode s: `rows[rows_ptr[s]..rows_ptr[s + 1]]`.
    rows_ptr: Vec<usize>,
    rows: Vec<usize>,
    /// Panel of supernode s: `lx[sn_off[s]..sn_off[s + 1]]`, column-major, `6 (nc + nrows)` rows.
    sn_off: Vec<usize>,
    seg_ptr: Vec<usize>,
    segs: Vec<Segment>,
    relmap: Vec<u32>,
    lx: Vec<f64>,
    work: Vec<f64>,
    flops: f64,
    nnz_l: usize,
}

impl BlockCholesky {
    /// Symbolic analysis of the block graph with `n` nodes and off-diagonal blocks `edges`.
    pub fn new(n: usize, edges: &[(usize, usize)]) -> Self {
        // Graph (CSR, symmetric, sorted, deduplicated).
        let mut deg = vec![0usize; n + 1];
        for &(i, j) in edges {
            assert!(i < n && j < n && i != j, "bad edge ({i}, {j}) for n = {n}");
            deg[i] += 1;
            deg[j] += 1;
        }
        let mut ptr = vec![0usize; n + 1];
        for i in 0..n {
            ptr[i + 1] = ptr[i] + deg[i];
        }
        let mut fill = ptr.clone();
        let mut idx = vec![0usize; ptr[n]];
        for &(i, j) in edges {
            idx[fill[i]] = j;
            fill[i] += 1;
            idx[fill[j]] = i;
            fill[j] += 1;
        }
        let mut adj_ptr = vec![0usize; n + 1];
        let mut adj_idx = Vec::with_capacity(idx.len());
        for i in 0..n {
            let list = &mut idx[ptr[i]..ptr[i + 1]];
            list.sort_unstable();
            let mut last = usize::MAX;
            for &j in list.iter() {
                if j != last {
                    adj_idx.push(j);
                    last = j;
                }
            }
            adj_ptr[i + 1] = adj_idx.len();
        }
        let nbrs = |i: usize| &adj_idx[adj_ptr[i]..adj_ptr[i + 1]];

        // Fill-reducing ordering, then a postorder of its elimination tree.
        let amd_order: Vec<usize> = if n > 1 {
            // The pattern given to AMD includes the diagonal (its debug checks expect nz ≥ n).
            let mut ap = vec![0usize; n + 1];
            let mut ai = Vec::with_capacity(adj_idx.len() + n);
            for i in 0..n {
                let list = nbrs(i);
                let k = list.partition_point(|&j| j < i);
                ai.extend_from_slice(&list[..k]);
                ai.push(i);
                ai.extend_from_slice(&list[k..]);
                ap[i + 1] = ai.len();
            }
            match amd::order::<usize>(n, &ap, &ai, &amd::Control::default()) {
                Ok((p, _, _)) => p,
                Err(_) => (0..n).collect(),
            }
        } else {
            (0..n).collect()
        };
        let parent0 = etree(n, &amd_order, &invert(&amd_order), &nbrs);
        let post = postorder(&parent0);
        let perm: Vec<usize> = post.iter().map(|&k| amd_order[k]).collect();
        let iperm = invert(&perm);
        let parent = etree(n, &perm, &iperm, &nbrs);

        // Block column structures of L (rows below the diagonal, sorted).
        let mut head = vec![usize::MAX; n];
        let mut next = vec![usize::MAX; n];
        for j in (0..n).rev() {
            let p = parent[j];
            if p != usize::MAX {
                next[j] = head[p];
                head[p] = j;
            }
        }
        let mut mark = vec![usize::MAX; n];
        let mut cols: Vec<Vec<usize>> = Vec::with_capacity(n);
        for j in 0..n {
            let mut s = Vec::new();
            mark[j] = j;
            for &o in nbrs(perm[j]) {
                let i = iperm[o];
                if i > j && mark[i] != j {
                    mark[i] = j;
                    s.push(i);
                }
            }
            let mut c = head[j];
            while c != usize::MAX {
                for &i in &cols[c] {
                    if mark[i] != j {
                        mark[i] = j;
                        s.push(i);
                    }
                }
                c = next[c];
            }
            s.sort_unstable();
            cols.push(s);
        }

        // Fundamental supernodes.
        let mut sn_first = vec![0usize];
        for j in 1..n {
            if !(parent[j - 1] == j && cols[j - 1].len() == cols[j].len() + 1) {
                sn_first.push(j);
            }
        }
        if n == 0 {
            sn_first.clear();
        }
        sn_first.push(n);
        let ns = sn_first.len() - 1;
        let mut snode_of = vec![0usize; n];
        let mut rows_ptr = vec![0usize; ns + 1];
        let mut rows = Vec::new();
        let mut sn_off = vec![0usize; ns + 1];
        let mut flops = 0.0;
        let mut nnz_l = 0usize;
        for s in 0..ns {
            let (f, l) = (sn_first[s], sn_first[s + 1]);
            for c in snode_of.iter_mut().take(l).skip(f) {
                *c = s;
            }
            rows.extend_from_slice(&cols[l - 1]);
            rows_ptr[s + 1] = rows.len();
            let nc = l - f;
            let nr = nc + cols[l - 1].len();
            sn_off[s + 1] = sn_off[s] + BB * nr * nc;
            let (kk, rr) = (B * nc, B * (nr - nc));
            nnz_l += kk * (kk + 1) / 2 + kk * rr;
            for k in 0..kk {
                let c = (kk - k + rr) as f64;
                flops += c * c;
            }
        }
        drop(cols);

        // Relative positions of every supernode's update rows in its ancestors' panels.
        let mut seg_ptr = vec![0usize; ns + 1];
        let mut segs = Vec::new();
        let mut relmap = Vec::new();
        for s in 0..ns {
            let r = &rows[rows_ptr[s]..rows_ptr[s + 1]];
            let mut a = 0;
            while a < r.len() {
                let t = snode_of[r[a]];
                let (ft, lt) = (sn_first[t], sn_first[t + 1]);
                let mut end = a;
                while end < r.len() && r[end] < lt {
                    end += 1;
                }
                let map = relmap.len();
                for &i in &r[a..end] {
                    relmap.push((i - ft) as u32);
                }
                let rt = &rows[rows_ptr[t]..rows_ptr[t + 1]];
                let mut p = 0;
                for &i in &r[end..] {
                    while rt[p] < i {
                        p += 1;
                    }
                    debug_assert_eq!(rt[p], i);
                    relmap.push((lt - ft + p) as u32);
                }
                segs.push(Segment {
                    target: t,
                    start: a,
                    end,
                    map,
                });
                a = end;
            }
            seg_ptr[s + 1] = segs.len();
        }

        // Slots: diagonal i is slot i, edges get n, n + 1, ... (once per undirected edge).
        let mut adj_slot = vec![u32::MAX; adj_idx.len()];
        let mut dest: Vec<(usize, usize)> = Vec::with_capacity(n + adj_idx.len() / 2);
        let place = |row: usize, col: usize| -> (usize, usize) {
            let s = snode_of[col];
            let (f, l) = (sn_first[s], sn_first[s + 1]);
            let r = &rows[rows_ptr[s]..rows_ptr[s + 1]];
            let ld = B * (l - f + r.len());
            let pos = if row < l {
                row - f
            } else {
                l - f + r.binary_search(&row).expect("row in structure")
            };
            (sn_off[s] + B * (col - f) * ld + B * pos, ld)
        };
        for &pj in &iperm {
            dest.push(place(pj, pj));
        }
        for i in 0..n {
            for e in adj_ptr[i]..adj_ptr[i + 1] {
                let j = adj_idx[e];
                if i < j {
                    let id = dest.len() as u32;
                    adj_slot[e] = id;
                    let (pi, pj) = (iperm[i], iperm[j]);
                    dest.push(place(pi.max(pj), pi.min(pj)));
                    // Mirror entry in j's list.
                    let lj = &adj_idx[adj_ptr[j]..adj_ptr[j + 1]];
                    let k = lj.binary_search(&i).expect("symmetric graph");
                    adj_slot[adj_ptr[j] + k] = id;
                }
            }
        }
        let nslots = dest.len();
        BlockCholesky {
            n,
            perm,
            iperm,
            adj_ptr,
            adj_idx,
            adj_slot,
            vals: vec![0.0; BB * nslots],
            dest,
            sn_first,
            rows_ptr,
            rows,
            lx: vec![0.0; sn_off[ns]],
            sn_off,
            seg_ptr,
            segs,
            relmap,
            work: vec![0.0; B * n],
            flops,
            nnz_l,
        }
    }

    /// Number of block nodes.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Slot of block (i, j): the diagonal block if i == j, else the edge (i, j) (None if absent).
    pub fn slot(&self, i: usize, j: usize) -> Option<Slot> {
        if i >= self.n || j >= self.n {
            return None;
        }
        if i == j {
            return Some(Slot {
                idx: i as u32,
                kind: SlotKind::Diag,
            });
        }
        let list = &self.adj_idx[self.adj_ptr[i]..self.adj_ptr[i + 1]];
        let k = list.binary_search(&j).ok()?;
        let kind = if self.iperm[i] > self.iperm[j] {
            SlotKind::Lower
        } else {
            SlotKind::Upper
        };
        Some(Slot {
            idx: self.adj_slot[self.adj_ptr[i] + k],
            kind,
        })
    }

    /// Set every input block to zero (storage is reused).
    pub fn clear(&mut self) {
        self.vals.fill(0.0);
    }

    /// A[i][j] += blk (row-major) for the slot of (i, j), and A[j][i] += blkᵀ if i != j. For a
    /// diagonal slot only the lower triangle of `blk` (entries `blk[6 r + c]`, r ≥ c) is read.
    pub fn add(&mut self, slot: Slot, blk: &[f64; 36]) {
        let lower_only = slot.kind == SlotKind::Diag;
        let (v, transposed) = self.block_mut(slot);
        if transposed {
            for (x, y) in v.iter_mut().zip(blk) {
                *x += y;
            }
        } else {
            for c in 0..B {
                for r in if lower_only { c } else { 0 }..B {
                    v[c * B + r] += blk[r * B + c];
                }
            }
        }
    }

    /// The stored input block of `slot` (column-major, in L's orientation: row node of L as
    /// rows), and whether that is the transpose of the block (i, j) the slot was asked for. A
    /// caller that adds into it directly adds (i, j)'s block, transposed when so told; on a
    /// diagonal slot only the lower triangle is read.
    #[inline(always)]
    pub fn block_mut(&mut self, slot: Slot) -> (&mut [f64; 36], bool) {
        let o = slot.idx as usize * BB;
        let v: &mut [f64; BB] = (&mut self.vals[o..o + BB]).try_into().unwrap();
        (v, slot.kind == SlotKind::Upper)
    }

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

    /// Floating-point operations of one factorisation (Σ over columns of L of count², the usual
    /// estimate), for reporting GFlop/s.
    pub fn flops(&self) -> f64 {
        self.flops
    }

    /// Number of stored scalar entries of L (lower triangle, including explicit zeros).
    pub fn nnz_l(&self) -> usize {
        self.nnz_l
    }
}

fn invert(p: &[usize]) -> Vec<usize> {
    let mut ip = vec![0; p.len()];
    for (k, &i) in p.iter().enumerate() {
        ip[i] = k;
    }
    ip
}

/// Elimination tree of the graph in the order `perm` (Liu's algorithm, path compression).
fn etree<'a>(
    n: usize,
    perm: &[usize],
    iperm: &[usize],
    nbrs: &impl Fn(usize) -> &'a [usize],
) -> Vec<usize> {
    let mut parent = vec![usize::MAX; n];
    let mut ancestor = vec![usize::MAX; n];
    for (k, &pk) in perm.iter().enumerate() {
        for &o in nbrs(pk) {
            let mut j = iperm[o];
            if j >= k {
                continue;
            }
            while ancestor[j] != usize::MAX && ancestor[j] != k {
                let nx = ancestor[j];
                ancestor[j] = k;
                j = nx;
            }
            if ancestor[j] == usize::MAX {
                ancestor[j] = k;
                parent[j] = k;
            }
        }
    }
    parent
}

/// Postorder of a forest: `post[k]` is the k-th node visited.
fn postorder(parent: &[usize]) -> Vec<usize> {
    let n = parent.len();
    let mut head = vec![usize::MAX; n];
    let mut next = vec![usize::MAX; n];
    for j in (0..n).rev() {
        let p = parent[j];
        if p != usize::MAX {
            next[j] = head[p];
            head[p] = j;
        }
    }
    let mut post = Vec::with_capacity(n);
    let mut stack = Vec::new();
    for (root, &p) in parent.iter().enumerate() {
        if p != usize::MAX {
            continue;
        }
        stack.push(root);
        while let Some(&j) = stack.last() {
            let c = head[j];
            if c == usize::MAX {
                stack.pop();
                post.push(j);
            } else {
                head[j] = next[c];
                stack.push(c);
            }
        }
    }
    post
}

#[inline(always)]
fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// Block (ib, jb) of a column-major panel with leading dimension `ld` (column-major 6×6).
#[inline(always)]
fn load(p: &[f64], ld: usize, ib: usize, jb: usize) -> [f64; BB] {
    let mut out = [0.0; BB];
    let o = B * jb * ld + B * ib;
    for c in 0..B {
        out[c * B..c * B + B].copy_from_slice(&p[o + c * ld..o + c * ld + B]);
    }
    out
}

#[inline(always)]
fn store(p: &mut [f64], ld: usize, ib: usize, jb: usize, blk: &[f64; BB]) {
    let o = B * jb * ld + B * ib;
    for c in 0..B {
        p[o + c * ld..o + c * ld + B].copy_from_slice(&blk[c * B..c * B + B]);
    }
}

#[inline(always)]
fn sub(a: &mut [f64; BB], b: &[f64; BB]) {
    for (x, y) in a.iter_mut().zip(b) {
        *x -= y;
    }
}

/// `Σ_{k < kk} p[k ld + ra .. +6] p[k ld + rb .. +6]ᵀ` as a column-major 6×6 block: the product
/// of two 6-row strips of a column-major panel, `A Bᵀ`.
#[inline(always)]
fn gemm_nt<const FMA: bool>(p: &[f64], ld: usize, ra: usize, rb: usize, kk: usize) -> [f64; BB] {
    let mut acc = [0.0; BB];
    for k in 0..kk {
        let col = &p[k * ld..];
        let a: &[f64; B] = col[ra..ra + B].try_into().unwrap();
        let b: &[f64; B] = col[rb..rb + B].try_into().unwrap();
        for c in 0..B {
            for r in 0..B {
                acc[c * B + r] = madd::<FMA>(a[r], b[c], acc[c * B + r]);
            }
        }
    }
    acc
}

/// `A Bᵀ` of two column-major 6×6 blocks.
#[inline(always)]
fn nt6<const FMA: bool>(a: &[f64; BB], b: &[f64; BB]) -> [f64; BB] {
    let mut acc = [0.0; BB];
    for k in 0..B {
        for c in 0..B {
            for r in 0..B {
                acc[c * B + r] = madd::<FMA>(a[k * B + r], b[k * B + c], acc[c * B + r]);
            }
        }
    }
    acc
}

/// Cholesky factor of a symmetric 6×6 block (lower triangle read), returned as the inverse of
/// the lower factor (lower triangular, column-major, zero upper part). None if a pivot fails.
#[inline(always)]
fn chol_inv(d: &[f64; BB]) -> Option<[f64; BB]> {
    let mut l = [0.0; BB];
    for j in 0..B {
        let mut s = d[j * B + j];
        for k in 0..j {
            s -= l[k * B + j] * l[k * B + j];
        }
        if !(s > 0.0 && s.is_finite()) {
            return None;
        }
        let ljj = s.sqrt();
        l[j * B + j] = ljj;
        for i in j + 1..B {
            let mut s = d[j * B + i];
            for k in 0..j {
                s -= l[k * B + i] * l[k * B + j];
            }
            l[j * B + i] = s / ljj;
        }
    }
    let mut x = [0.0; BB];
    for j in 0..B {
        x[j * B + j] = 1.0 / l[j * B + j];
        for i in j + 1..B {
            let mut s = 0.0;
            for k in j..i {
                s += l[k * B + i] * x[j * B + k];
            }
            x[j * B + i] = -s / l[i * B + i];
        }
    }
    Some(x)
}

#[inline(always)]
fn get6(w: &[f64], k: usize) -> [f64; B] {
    w[B * k..B * k + B].try_into().unwrap()
}

#[inline(always)]
fn put6(w: &mut [f64], k: usize, v: &[f64; B]) {
    w[B * k..B * k + B].copy_from_slice(v);
}

/// `y -= P(ib, jb) x` for block (ib, jb) of a column-major panel.
#[inline(always)]
fn matvec_sub<const FMA: bool>(
    y: &mut [f64; B],
    p: &[f64],
    ld: usize,
    ib: usize,
    jb: usize,
    x: &[f64; B],
) {
    let o = B * jb * ld + B * ib;
    for c in 0..B {
        let col: &[f64; B] = p[o + c * ld..o + c * ld + B].try_into().unwrap();
        for r in 0..B {
            y[r] = madd::<FMA>(-col[r], x[c], y[r]);
        }
    }
}

/// `y -= P(ib, jb)ᵀ x` for block (ib, jb) of a column-major panel.
#[inline(always)]
fn matvec_t_sub<const FMA: bool>(
    y: &mut [f64; B],
    p: &[f64],
    ld: usize,
    ib: usize,
    jb: usize,
    x: &[f64; B],
) {
    let o = B * jb * ld + B * ib;
    for c in 0..B {
        let col: &[f64; B] = p[o + c * ld..o + c * ld + B].try_into().unwrap();
        let mut s = 0.0;
        for r in 0..B {
            s = madd::<FMA>(col[r], x[r], s);
        }
        y[c] -= s;
    }
}

#[cfg(test)]
mod tests;
