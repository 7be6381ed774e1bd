//! 6×6 block kernels: fused or plain multiply-add, panel block load/store, the `A Bᵀ`
//! micro-kernel, the inverse Cholesky factor of a pivot block, block matrix-vector products.

use super::{B, BB};

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
pub(super) fn load(p: &[f64], ld: usize, ib: usize, jb: usize) -> [f64; BB] {
    let mut out = [0.0; BB];
    let o = B * jb * ld + B * ib;
    for c in 0..B {
        out[c * B..c * B + B].copy_from_slice(&p[o + c * ld..o + c * ld + B]);
    }
    out
}

#[inline(always)]
pub(super) fn store(p: &mut [f64], ld: usize, ib: usize, jb: usize, blk: &[f64; BB]) {
    let o = B * jb * ld + B * ib;
    for c in 0..B {
        p[o + c * ld..o + c * ld + B].copy_from_slice(&blk[c * B..c * B + B]);
    }
}

#[inline(always)]
pub(super) fn sub(a: &mut [f64; BB], b: &[f64; BB]) {
    for (x, y) in a.iter_mut().zip(b) {
        *x -= y;
    }
}

/// `Σ_{k < kk} p[k ld + ra .. +6] p[k ld + rb .. +6]ᵀ` as a column-major 6×6 block: the product
/// of two 6-row strips of a column-major panel, `A Bᵀ`.
#[inline(always)]
pub(super) fn gemm_nt<const FMA: bool>(
    p: &[f64],
    ld: usize,
    ra: usize,
    rb: usize,
    kk: usize,
) -> [f64; BB] {
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
pub(super) fn nt6<const FMA: bool>(a: &[f64; BB], b: &[f64; BB]) -> [f64; BB] {
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
pub(super) fn chol_inv(d: &[f64; BB]) -> Option<[f64; BB]> {
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
pub(super) fn get6(w: &[f64], k: usize) -> [f64; B] {
    w[B * k..B * k + B].try_into().unwrap()
}

#[inline(always)]
pub(super) fn put6(w: &mut [f64], k: usize, v: &[f64; B]) {
    w[B * k..B * k + B].copy_from_slice(v);
}

/// `y -= P(ib, jb) x` for block (ib, jb) of a column-major panel.
#[inline(always)]
pub(super) fn matvec_sub<const FMA: bool>(
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
pub(super) fn matvec_t_sub<const FMA: bool>(
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
