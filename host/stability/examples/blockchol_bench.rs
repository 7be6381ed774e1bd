//! Benchmark of the block sparse Cholesky (`blockchol`) on grids, chains and random trees.
//!
//! `cargo run --release -p puzzlebot-stability --example blockchol_bench`
use puzzlebot_stability::bench_problems::thread_cpu_seconds;
use puzzlebot_stability::blockchol::{BlockCholesky, B};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

/// A block graph: number of nodes and edges.
type Graph = (usize, Vec<(usize, usize)>);

fn grid(k: usize) -> Graph {
    let mut e = Vec::new();
    for y in 0..k {
        for x in 0..k {
            let i = y * k + x;
            if x + 1 < k {
                e.push((i, i + 1));
            }
            if y + 1 < k {
                e.push((i, i + k));
            }
        }
    }
    (k * k, e)
}

fn chain(n: usize) -> Graph {
    (n, (1..n).map(|i| (i - 1, i)).collect())
}

fn tree(n: usize, rng: &mut ChaCha8Rng) -> Graph {
    (n, (1..n).map(|i| (rng.random_range(0..i), i)).collect())
}

/// Thread CPU time (falls back to the wall clock).
fn now(t0: Instant) -> f64 {
    thread_cpu_seconds().unwrap_or_else(|| t0.elapsed().as_secs_f64())
}

/// The assembled blocks (i, j, A_ij), to apply A in the residual check.
type Blocks = Vec<(usize, usize, [f64; 36])>;

/// Normal-equation-like values: per edge Gᵀ G with G = [Ji Jj] random, plus 0.1·I per node.
fn assemble(c: &mut BlockCholesky, edges: &[(usize, usize)], rng: &mut ChaCha8Rng) -> Blocks {
    c.clear();
    let mut blocks = Blocks::new();
    for &(i, j) in edges {
        let ji: [f64; 36] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let jj: [f64; 36] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
        let (mut aii, mut ajj, mut aij) = ([0.0; 36], [0.0; 36], [0.0; 36]);
        for r in 0..B {
            for col in 0..B {
                for k in 0..B {
                    aii[r * B + col] += ji[k * B + r] * ji[k * B + col];
                    ajj[r * B + col] += jj[k * B + r] * jj[k * B + col];
                    aij[r * B + col] += ji[k * B + r] * jj[k * B + col];
                }
            }
        }
        c.add(c.slot(i, i).unwrap(), &aii);
        c.add(c.slot(j, j).unwrap(), &ajj);
        c.add(c.slot(i, j).unwrap(), &aij);
        blocks.extend([(i, i, aii), (j, j, ajj), (i, j, aij)]);
    }
    let mut d = [0.0; 36];
    for k in 0..B {
        d[k * B + k] = 0.1;
    }
    for i in 0..c.n() {
        c.add(c.slot(i, i).unwrap(), &d);
        blocks.push((i, i, d));
    }
    blocks
}

/// ‖A x − b‖ / ‖b‖ with A given by its blocks (off-diagonal ones once).
fn residual(blocks: &Blocks, x: &[f64], b: &[f64]) -> f64 {
    let mut r: Vec<f64> = b.iter().map(|v| -v).collect();
    for (i, j, a) in blocks {
        for row in 0..B {
            for col in 0..B {
                r[B * i + row] += a[row * B + col] * x[B * j + col];
                if i != j {
                    r[B * j + col] += a[row * B + col] * x[B * i + row];
                }
            }
        }
    }
    let nr: f64 = r.iter().map(|v| v * v).sum();
    let nb: f64 = b.iter().map(|v| v * v).sum();
    (nr / nb).sqrt()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let cases: Vec<(String, Graph)> = vec![
        ("grid 10x10".into(), grid(10)),
        ("grid 32x32".into(), grid(32)),
        ("grid 100x100".into(), grid(100)),
        ("chain 1000".into(), chain(1000)),
        ("chain 10000".into(), chain(10000)),
        ("tree 1000".into(), tree(1000, &mut rng)),
        ("tree 10000".into(), tree(10000, &mut rng)),
    ];
    println!(
        "{:<13} {:>6} {:>10} {:>9} {:>10} {:>11} {:>7} {:>10} {:>9}",
        "case",
        "n",
        "nnz(L)",
        "MFlop",
        "symb [ms]",
        "factor [ms]",
        "GFlop/s",
        "solve [ms]",
        "residual"
    );
    for (name, (n, edges)) in cases {
        let t0 = Instant::now();
        let t = now(t0);
        let mut c = BlockCholesky::new(n, &edges);
        let symb = now(t0) - t;
        let blocks = assemble(&mut c, &edges, &mut rng);
        let reps = if n >= 5000 { 10 } else { 50 };
        let mut tf = Vec::new();
        for _ in 0..reps {
            let t = now(t0);
            c.factor(0.0).expect("SPD");
            tf.push(now(t0) - t);
        }
        let b: Vec<f64> = (0..B * n).map(|_| rng.random_range(-1.0..1.0)).collect();
        let mut ts = Vec::new();
        let mut x = b.clone();
        for _ in 0..reps {
            x.copy_from_slice(&b);
            let t = now(t0);
            c.solve(&mut x);
            ts.push(now(t0) - t);
        }
        let res = residual(&blocks, &x, &b);
        let (f, s) = (median(tf), median(ts));
        println!(
            "{:<13} {:>6} {:>10} {:>9.2} {:>10.3} {:>11.3} {:>7.2} {:>10.3} {:>9.1e}",
            name,
            n,
            c.nnz_l(),
            c.flops() / 1e6,
            symb * 1e3,
            f * 1e3,
            c.flops() / f / 1e9,
            s * 1e3,
            res
        );
    }
}
