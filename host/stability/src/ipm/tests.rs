//! Tests of `ipm`.

use super::cone::{soc_det, soc_step, w_bar_mul};
use super::*;
use crate::bench_problems::Family;

/// The structured solver reaches Clarabel's optimum on the benchmark families, and
/// declines (no certificate of its own) where Clarabel finds the program infeasible.
#[test]
fn the_structured_solver_matches_clarabel_on_the_benchmark_families() {
    for fam in ["chain", "mesh", "tree-ground"] {
        for n in [2usize, 3, 4, 10, 40] {
            let a = Family::parse(fam).unwrap().build(n, 1);
            let r = a.resolve().unwrap();
            let p = crate::dual::build_relaxed(&r);
            let ours = solve(&p, 1e-7, 100);
            let (out, _) = crate::socp::solve_tol(&p, 100, 1e-7);
            let xc = match out {
                crate::socp::Outcome::Optimal(xc) => xc,
                other => {
                    assert!(ours.is_err(), "{fam} {n}: Clarabel {other:?}, ours optimal");
                    continue;
                }
            };
            let (x, info) = ours.unwrap_or_else(|e| panic!("{fam} {n}: {e:?}"));
            let obj = |x: &[f64]| -> f64 { p.b.iter().zip(x).map(|(c, v)| c * v).sum() };
            let (o1, o2) = (obj(&x), obj(&xc));
            assert!(
                (o1 - o2).abs() <= 1e-5 * o2.abs().max(1.0),
                "{fam} {n}: {o1} vs {o2} ({} iterations)",
                info.iterations
            );
        }
    }
}

/// Random points strictly inside a second-order cone of dimension `d`.
fn inside(rng: &mut rand_chacha::ChaCha8Rng, d: usize) -> Vec<f64> {
    use rand::Rng;
    let mut v: Vec<f64> = (0..d).map(|_| rng.random_range(-1.0..1.0)).collect();
    let n1: f64 = v[1..].iter().map(|x| x * x).sum::<f64>().sqrt();
    v[0] = n1 + rng.random_range(1e-3..1.0);
    v
}

/// The Nesterov–Todd scaling of the second-order cone: W̄ has det 1, W = η W̄ maps x to
/// λ = W x = W⁻¹ s (so W² x = s), and W̄⁻¹ undoes W̄; the step to the boundary is the
/// largest α keeping x + α d inside (checked against bisection).
#[test]
fn cone_scaling_and_step_to_the_boundary_are_exact() {
    use rand::SeedableRng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    for d in [2usize, 3, 7] {
        for _ in 0..50 {
            let (x, s) = (inside(&mut rng, d), inside(&mut rng, d));
            // The scaling as `Ipm::scale` computes it.
            let (dx, ds) = (soc_det(&x).sqrt(), soc_det(&s).sqrt());
            let dot: f64 = x.iter().zip(&s).map(|(a, b)| a * b).sum();
            let gamma = ((1.0 + dot / (dx * ds)) * 0.5).sqrt();
            let mut wb = vec![0.0; d];
            wb[0] = (s[0] / ds + x[0] / dx) / (2.0 * gamma);
            for k in 1..d {
                wb[k] = (s[k] / ds - x[k] / dx) / (2.0 * gamma);
            }
            let eta = (ds / dx).sqrt();
            assert!(
                (soc_det(&wb) - 1.0).abs() < 1e-9,
                "det w̄ = {}",
                soc_det(&wb)
            );
            let (mut wx, mut wis) = (vec![0.0; d], vec![0.0; d]);
            w_bar_mul(&wb, &x, &mut wx, false);
            w_bar_mul(&wb, &s, &mut wis, true);
            for k in 0..d {
                let (l1, l2) = (eta * wx[k], wis[k] / eta);
                assert!(
                    (l1 - l2).abs() < 1e-9 * (1.0 + l1.abs()),
                    "W x ≠ W⁻¹ s: {l1} {l2}"
                );
            }
            let mut back = vec![0.0; d];
            w_bar_mul(&wb, &wx, &mut back, true);
            for k in 0..d {
                assert!((back[k] - x[k]).abs() < 1e-9 * (1.0 + x[k].abs()));
            }
            // Step to the boundary along a random direction.
            let dir: Vec<f64> = {
                use rand::Rng;
                (0..d).map(|_| rng.random_range(-3.0..3.0)).collect()
            };
            let a = soc_step(&x, &dir);
            let at = |t: f64| -> Vec<f64> { x.iter().zip(&dir).map(|(p, q)| p + t * q).collect() };
            let inside_at = |t: f64| {
                let v = at(t);
                v[0] >= v[1..].iter().map(|x| x * x).sum::<f64>().sqrt()
            };
            if a.is_finite() {
                assert!(inside_at(a * (1.0 - 1e-9)), "inside before α = {a}");
                assert!(
                    !inside_at(a * (1.0 + 1e-6) + 1e-12),
                    "outside after α = {a}"
                );
            } else {
                assert!(inside_at(1e3), "α = ∞ but x + 1000 d leaves the cone");
            }
        }
    }
}
