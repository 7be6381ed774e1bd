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

mod factor;
mod kernels;
mod solve;
mod symbolic;

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

#[cfg(test)]
mod tests;
