//! The cheaper solver settings (one refinement step, looser first tolerance) must give the
//! same verdicts and the same critical state as Clarabel's full defaults at 1e-7.

use puzzlebot_stability::bench_problems::Family;
use puzzlebot_stability::gate::{evaluate_with, Options, Verdict};
use puzzlebot_stability::socp::{self, Outcome};

/// Objective value qᵀx of the relaxed program solved with the full default settings.
fn reference_wmax(fam: Family, n: usize) -> f64 {
    let r = fam.build(n, 7).resolve().expect("valid benchmark");
    let p = socp::build(&r, false);
    let (out, _) = socp::solve_with(&p, 100, socp::settings());
    let Outcome::Optimal(x) = out else {
        panic!("reference solve of {} {n}: {out:?}", fam.name());
    };
    // w_A^max is the first variable (41).
    x[0]
}

#[test]
fn fast_settings_match_full_refinement_on_benchmark_families() {
    for fam in [
        Family::parse("chain"),
        Family::parse("mesh"),
        Family::parse("tree-ground"),
    ] {
        let fam = fam.expect("known family");
        for n in [10, 40] {
            let a = fam.build(n, 7);
            let rep = evaluate_with(
                &a,
                Options {
                    fast_path: false,
                    ..Options::default()
                },
            )
            .expect("valid");
            assert_eq!(rep.verdict, Verdict::Stable, "{} {n}", fam.name());
            let w = rep.max_strength.expect("has connections");
            let w_ref = reference_wmax(fam, n);
            assert!(
                (w - w_ref).abs() <= 1e-5 * (1.0 + w_ref.abs()),
                "{} {n}: fast {w} vs full {w_ref}",
                fam.name()
            );
        }
    }
}

#[test]
fn fast_attempt_alone_certifies_the_same_status() {
    let r = Family::parse("mesh")
        .expect("known family")
        .build(20, 3)
        .resolve()
        .expect("valid");
    for with_limits in [false, true] {
        let p = socp::build(&r, with_limits);
        let (fast, _) = socp::solve_with(&p, 100, socp::fast_settings());
        let (full, _) = socp::solve_with(&p, 100, socp::settings());
        assert_eq!(
            std::mem::discriminant(&fast),
            std::mem::discriminant(&full),
            "limits {with_limits}: {fast:?} vs {full:?}"
        );
    }
}

#[test]
fn the_structured_solvers_work_is_counted() {
    // The exact counts `puzzlebot-gate time` prints (the measure of a solver change where
    // wall-clock time is noisy): one factorisation for the initial point and one per
    // iteration at least, a predictor and a corrector solve per iteration plus the initial
    // point's two, a refinement product only where a solve refines.
    let a = Family::parse("mesh").expect("known family").build(100, 7);
    let s = evaluate_with(&a, Options::default()).expect("valid").stats;
    assert_eq!(s.fallbacks, 0);
    assert!(s.iterations > 0);
    assert!(s.factorisations > s.iterations, "{s:?}");
    assert!(s.normal_solves >= 2 * s.iterations + 2, "{s:?}");
    assert!(s.normal_products <= s.normal_solves, "{s:?}");
    // The fast path solves no cone program: no work counted.
    let tree = Family::parse("tree-hanging")
        .expect("known family")
        .build(30, 7);
    let s = evaluate_with(&tree, Options::default())
        .expect("valid")
        .stats;
    assert_eq!(
        (
            s.iterations,
            s.factorisations,
            s.normal_solves,
            s.normal_products
        ),
        (0, 0, 0, 0)
    );
}
