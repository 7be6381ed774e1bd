//! Tests of `blockchol`.

use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A dense symmetric matrix (6n × 6n, row-major) assembled alongside the block matrix.
struct Dense {
    m: usize,
    a: Vec<f64>,
}

impl Dense {
    fn new(n: usize) -> Self {
        Dense {
            m: B * n,
            a: vec![0.0; B * n * B * n],
        }
    }
    fn add(&mut self, i: usize, j: usize, blk: &[f64; 36]) {
        for r in 0..B {
            for c in 0..B {
                self.a[(B * i + r) * self.m + B * j + c] += blk[r * B + c];
                if i != j {
                    self.a[(B * j + c) * self.m + B * i + r] += blk[r * B + c];
                }
            }
        }
    }
    fn mul(&self, x: &[f64]) -> Vec<f64> {
        (0..self.m)
            .map(|r| (0..self.m).map(|c| self.a[r * self.m + c] * x[c]).sum())
            .collect()
    }
    /// Dense Cholesky solve (reference); None if not positive definite.
    fn solve(&self, b: &[f64], shift: f64) -> Option<Vec<f64>> {
        let m = self.m;
        let mut l = self.a.clone();
        for k in 0..m {
            l[k * m + k] += shift;
        }
        for j in 0..m {
            let mut d = l[j * m + j];
            for k in 0..j {
                d -= l[j * m + k] * l[j * m + k];
            }
            if d <= 0.0 {
                return None;
            }
            let d = d.sqrt();
            l[j * m + j] = d;
            for i in j + 1..m {
                let mut s = l[i * m + j];
                for k in 0..j {
                    s -= l[i * m + k] * l[j * m + k];
                }
                l[i * m + j] = s / d;
            }
        }
        let mut x = b.to_vec();
        for i in 0..m {
            for k in 0..i {
                x[i] -= l[i * m + k] * x[k];
            }
            x[i] /= l[i * m + i];
        }
        for i in (0..m).rev() {
            for k in i + 1..m {
                x[i] -= l[k * m + i] * x[k];
            }
            x[i] /= l[i * m + i];
        }
        Some(x)
    }
}

fn rand_blk(rng: &mut ChaCha8Rng) -> [f64; 36] {
    std::array::from_fn(|_| rng.random_range(-1.0..1.0))
}

/// Normal-equation-like SPD matrix: per edge (i, j) a contribution Gᵀ G with G = [Ji Jj]
/// (several per edge, as the interior-point caller does), plus `diag`·I per node.
fn assemble(
    chol: &mut BlockCholesky,
    edges: &[(usize, usize)],
    diag: f64,
    rng: &mut ChaCha8Rng,
) -> Dense {
    let n = chol.n();
    let mut dense = Dense::new(n);
    chol.clear();
    for &(i, j) in edges {
        for _ in 0..2 {
            let (ji, jj) = (rand_blk(rng), rand_blk(rng));
            let mut aii = [0.0; 36];
            let mut ajj = [0.0; 36];
            let mut aij = [0.0; 36];
            for r in 0..B {
                for c in 0..B {
                    for k in 0..B {
                        aii[r * B + c] += ji[k * B + r] * ji[k * B + c];
                        ajj[r * B + c] += jj[k * B + r] * jj[k * B + c];
                        aij[r * B + c] += ji[k * B + r] * jj[k * B + c];
                    }
                }
            }
            chol.add(chol.slot(i, i).unwrap(), &aii);
            chol.add(chol.slot(j, j).unwrap(), &ajj);
            // Add the coupling block through either orientation of the slot.
            if rng.random_bool(0.5) {
                chol.add(chol.slot(i, j).unwrap(), &aij);
            } else {
                let aji: [f64; 36] = std::array::from_fn(|k| aij[(k % B) * B + k / B]);
                chol.add(chol.slot(j, i).unwrap(), &aji);
            }
            dense.add(i, i, &aii);
            dense.add(j, j, &ajj);
            dense.add(i, j, &aij);
        }
    }
    for i in 0..n {
        let mut d = [0.0; 36];
        for k in 0..B {
            d[k * B + k] = diag;
        }
        // Upper triangle garbage: must be ignored by `add` on the diagonal.
        d[1] = 1e3;
        chol.add(chol.slot(i, i).unwrap(), &d);
        d[1] = 0.0;
        dense.add(i, i, &d);
    }
    dense
}

fn rel_residual(dense: &Dense, x: &[f64], b: &[f64], shift: f64) -> f64 {
    let ax = dense.mul(x);
    let num: f64 = (0..b.len())
        .map(|k| (ax[k] + shift * x[k] - b[k]).powi(2))
        .sum();
    let den: f64 = b.iter().map(|v| v * v).sum();
    (num / den.max(1e-300)).sqrt()
}

fn check(n: usize, edges: &[(usize, usize)], seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut chol = BlockCholesky::new(n, edges);
    for round in 0..3 {
        let dense = assemble(&mut chol, edges, 0.5 + round as f64, &mut rng);
        chol.factor(0.0).expect("SPD");
        let b: Vec<f64> = (0..B * n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let mut x = b.clone();
        chol.solve(&mut x);
        let res = rel_residual(&dense, &x, &b, 0.0);
        assert!(res <= 1e-10, "n = {n}, round {round}: residual {res}");
        let xr = dense.solve(&b, 0.0).unwrap();
        let err = x
            .iter()
            .zip(&xr)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let scale = xr.iter().map(|v| v.abs()).fold(1.0, f64::max);
        assert!(err <= 1e-8 * scale, "n = {n}: differs from dense by {err}");
    }
}

fn grid(w: usize, h: usize) -> Vec<(usize, usize)> {
    let mut e = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if x + 1 < w {
                e.push((i, i + 1));
            }
            if y + 1 < h {
                e.push((i + w, i));
            }
        }
    }
    e
}

#[test]
fn chain() {
    let e: Vec<_> = (1..40).map(|i| (i - 1, i)).collect();
    check(40, &e, 1);
}

#[test]
fn random_tree() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let e: Vec<_> = (1..60).map(|i| (rng.random_range(0..i), i)).collect();
    check(60, &e, 2);
}

#[test]
fn grids() {
    check(9, &grid(3, 3), 3);
    check(80, &grid(10, 8), 4);
}

#[test]
fn grid_with_diagonals_and_disconnected_component() {
    // An 6×5 grid with some diagonals, plus a separate triangle and an isolated node.
    let mut e = grid(6, 5);
    e.extend([(0, 7), (8, 15), (20, 27)]);
    e.extend([(30, 31), (31, 32), (32, 30)]);
    check(34, &e, 5);
}

#[test]
fn duplicated_and_reversed_edges() {
    let e = vec![(0, 1), (1, 0), (1, 2), (1, 2), (3, 2), (2, 3), (0, 3)];
    check(4, &e, 6);
    let chol = BlockCholesky::new(4, &e);
    assert!(chol.slot(0, 2).is_none());
    assert!(chol.slot(1, 3).is_none());
    assert!(chol.slot(0, 4).is_none());
    assert!(chol.slot(3, 0).is_some());
}

#[test]
fn tiny_and_isolated() {
    let mut c = BlockCholesky::new(0, &[]);
    assert_eq!(c.n(), 0);
    c.clear();
    c.factor(0.0).unwrap();
    c.solve(&mut []);
    check(1, &[], 8);
    check(5, &[], 9);
    check(6, &[(1, 4)], 10);
}

#[test]
fn shift_and_singular() {
    // A pure block Laplacian of a chain is singular (PSD): fails without shift.
    let n = 12;
    let e: Vec<_> = (1..n).map(|i| (i - 1, i)).collect();
    let mut chol = BlockCholesky::new(n, &e);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    chol.clear();
    let mut dense = Dense::new(n);
    for &(i, j) in &e {
        let g = rand_blk(&mut rng);
        let mut w = [0.0; 36];
        for r in 0..B {
            for c in 0..B {
                for k in 0..B {
                    w[r * B + c] += g[k * B + r] * g[k * B + c];
                }
            }
        }
        let neg = w.map(|v| -v);
        for (a, b, blk) in [(i, i, &w), (j, j, &w), (i, j, &neg)] {
            chol.add(chol.slot(a, b).unwrap(), blk);
            dense.add(a, b, blk);
        }
    }
    assert!(matches!(
        chol.factor(0.0),
        Err(FactorError::NotPositiveDefinite { .. })
    ));
    let shift = 0.3;
    chol.factor(shift).expect("shifted is SPD");
    let b: Vec<f64> = (0..B * n).map(|_| rng.random_range(-1.0..1.0)).collect();
    let mut x = b.clone();
    chol.solve(&mut x);
    assert!(rel_residual(&dense, &x, &b, shift) <= 1e-10);
    let xr = dense.solve(&b, shift).unwrap();
    for (a, r) in x.iter().zip(&xr) {
        assert!((a - r).abs() <= 1e-8 * (1.0 + r.abs()));
    }
}

#[test]
fn indefinite_fails_and_keeps_input() {
    let e = grid(4, 4);
    let n = 16;
    let mut chol = BlockCholesky::new(n, &e);
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let dense = assemble(&mut chol, &e, 1.0, &mut rng);
    // Make node 9 strongly indefinite.
    let mut d = [0.0; 36];
    d[3 * B + 3] = -1e4;
    chol.add(chol.slot(9, 9).unwrap(), &d);
    assert!(matches!(
        chol.factor(0.0),
        Err(FactorError::NotPositiveDefinite { .. })
    ));
    // Undo: input values were kept, so the factorisation now succeeds and is right.
    d[3 * B + 3] = 1e4;
    chol.add(chol.slot(9, 9).unwrap(), &d);
    chol.factor(0.0).unwrap();
    let b: Vec<f64> = (0..B * n).map(|_| rng.random_range(-1.0..1.0)).collect();
    let mut x = b.clone();
    chol.solve(&mut x);
    assert!(rel_residual(&dense, &x, &b, 0.0) <= 1e-10);
    // A NaN pivot is reported too.
    let mut d = [0.0; 36];
    d[0] = f64::NAN;
    chol.add(chol.slot(0, 0).unwrap(), &d);
    assert!(chol.factor(0.0).is_err());
}

#[test]
fn single_node_failure_names_the_node() {
    let mut chol = BlockCholesky::new(3, &[]);
    for i in 0..3 {
        let mut d = [0.0; 36];
        for k in 0..B {
            d[k * B + k] = if i == 2 && k == 4 { -1.0 } else { 1.0 };
        }
        chol.add(chol.slot(i, i).unwrap(), &d);
    }
    assert_eq!(
        chol.factor(0.0),
        Err(FactorError::NotPositiveDefinite { node: 2 })
    );
}
