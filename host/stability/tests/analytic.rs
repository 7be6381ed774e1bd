//! Tests with analytic answers.

use puzzlebot_stability::gate::{evaluate_with, Options, Path, Verdict};
use puzzlebot_stability::model::*;
use puzzlebot_stability::{evaluate, load_range};
use std::collections::BTreeMap;

const G: f64 = 9.81;

fn module(id: &str, mass: f64, p: Vec3, fixed: bool) -> Module {
    Module {
        id: id.into(),
        mass,
        position: p,
        rpy: [0.0; 3],
        com: [0.0; 3],
        fixed,
    }
}

fn contact(m: &str, p: Vec3, mu: f64) -> Contact {
    Contact {
        module: m.into(),
        point: p,
        normal: None,
        mu: [mu, mu],
        x_axis: None,
        gap: 0.0,
    }
}

fn conn(child: &str, parent: &str, p: Vec3) -> Connection {
    Connection {
        child: child.into(),
        parent: parent.into(),
        connector: "c".into(),
        point: p,
        axis: None,
        x_axis: None,
    }
}

fn asm(modules: Vec<Module>) -> Assembly {
    Assembly {
        gravity: [0.0, 0.0, -G],
        modules,
        connectors: BTreeMap::new(),
        connections: vec![],
        contacts: vec![],
        module_contacts: vec![],
        loads: vec![],
        objective: Objective::default(),
    }
}

fn box_connector(f: f64, m: f64) -> ConnectorSpec {
    ConnectorSpec::Box {
        max: Limits6::uniform(f, m),
        omega_k: [1.0; 6],
        margin_weights: [1.0; 6],
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + b.abs())
}

#[test]
fn block_on_flat_ground_is_stable_and_contacts_carry_the_weight() {
    let m = 2.0;
    // Three contacts (statically determinate): forces follow from the lever rule.
    let mut a = asm(vec![module("b", m, [0.0, 0.0, 0.05], false)]);
    a.contacts = vec![
        contact("b", [0.1, 0.0, 0.0], 0.5),
        contact("b", [-0.1, 0.1, 0.0], 0.5),
        contact("b", [-0.1, -0.1, 0.0], 0.5),
    ];
    let r = evaluate(&a).unwrap();
    assert_eq!(r.verdict, Verdict::Stable);
    let fz: Vec<f64> = r.contacts.iter().map(|c| c.force[2]).collect();
    assert!(close(fz.iter().sum::<f64>(), m * G, 1e-6), "{fz:?}");
    // Moment about y: 0.1 f0 = 0.1 (f1 + f2) and f1 = f2 ⇒ f0 = W/2, f1 = f2 = W/4.
    assert!(close(fz[0], m * G / 2.0, 1e-5), "{fz:?}");
    assert!(close(fz[1], m * G / 4.0, 1e-5) && close(fz[2], m * G / 4.0, 1e-5));
    for c in &r.contacts {
        assert!(c.friction_margin > 0.0);
        assert!(c.force[0].abs() < 1e-6 && c.force[1].abs() < 1e-6);
    }
    // Four corners: the total still equals the weight.
    a.contacts.push(contact("b", [0.1, 0.1, 0.0], 0.5));
    let r = evaluate(&a).unwrap();
    assert_eq!(r.verdict, Verdict::Stable);
    let total: f64 = r.contacts.iter().map(|c| c.force[2]).sum();
    assert!(close(total, m * G, 1e-6));
}

/// Base fixed at x = 0, k modules at x = p·i, connections half-way.
fn cantilever(k: usize, m: f64, p: f64, f_lim: f64, m_lim: f64) -> Assembly {
    let mut mods = vec![module("base", 1.0, [0.0; 3], true)];
    let mut conns = vec![];
    for i in 1..=k {
        mods.push(module(&format!("m{i}"), m, [p * i as f64, 0.0, 0.0], false));
        let parent = if i == 1 {
            "base".to_string()
        } else {
            format!("m{}", i - 1)
        };
        conns.push(conn(
            &format!("m{i}"),
            &parent,
            [p * (i as f64 - 0.5), 0.0, 0.0],
        ));
    }
    let mut a = asm(mods);
    a.connectors.insert("c".into(), box_connector(f_lim, m_lim));
    a.connections = conns;
    a
}

#[test]
fn cantilever_root_moment_matches_statics_and_verdict_flips_at_predicted_k() {
    let (m, p, f_lim, m_lim) = (0.1, 0.05, 100.0, 1.0);
    // Root moment m g p k²/2 ≤ M ⇒ k ≤ sqrt(2M/(m g p)).
    let k_star = (2.0 * m_lim / (m * G * p)).sqrt().floor() as usize;
    assert_eq!(k_star, 6);
    for k in [1, 3, k_star, k_star + 1, k_star + 3] {
        let a = cantilever(k, m, p, f_lim, m_lim);
        let shear = k as f64 * m * G;
        let moment = m * G * p * (k * k) as f64 / 2.0;
        for fast in [true, false] {
            let r = evaluate_with(
                &a,
                Options {
                    fast_path: fast,
                    ..Options::default()
                },
            )
            .unwrap();
            assert_eq!(
                r.stats.path,
                if fast {
                    Path::DeterminateTree
                } else {
                    Path::Socp
                }
            );
            let expect = if k <= k_star {
                Verdict::Stable
            } else {
                Verdict::InternalInstability
            };
            assert_eq!(r.verdict, expect, "k = {k}, fast = {fast}");
            let root = &r.connections[0];
            let w = root.wrench;
            let f = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            let mo = (w[3] * w[3] + w[4] * w[4] + w[5] * w[5]).sqrt();
            assert!(close(f, shear, 1e-5), "k={k} fast={fast}: {f} vs {shear}");
            assert!(
                close(mo, moment, 1e-5),
                "k={k} fast={fast}: {mo} vs {moment}"
            );
            // Required strength (40) with ωK = 1 and the margin (42).
            assert!(close(
                root.strength,
                (shear * shear + moment * moment).sqrt(),
                1e-5
            ));
            assert!(close(r.max_strength.unwrap(), root.strength, 1e-5));
            let margin = (f_lim - shear).min(m_lim - moment);
            assert!(
                close(r.margin.unwrap(), margin, 1e-4),
                "k={k}: {:?} vs {margin}",
                r.margin
            );
            if k > k_star {
                assert!(r.broken().contains(&0), "root must be a broken point");
                assert!(r.margin.unwrap() < 0.0);
            }
        }
    }
}

#[test]
fn lorentz_connector_fast_path_agrees_with_cone_program() {
    let mut a = cantilever(3, 0.1, 0.05, 1.0, 1.0);
    a.connectors.insert(
        "c".into(),
        ConnectorSpec::Lorentz {
            f_max_z: 10.0,
            mu: [0.3, 0.3, 0.01, 0.01, 0.005],
        },
    );
    let fast = evaluate_with(
        &a,
        Options {
            fast_path: true,
            ..Options::default()
        },
    )
    .unwrap();
    let socp = evaluate_with(
        &a,
        Options {
            fast_path: false,
            ..Options::default()
        },
    )
    .unwrap();
    assert_eq!(fast.verdict, socp.verdict);
    // The λ1 term is 10⁴ times lighter than λ_max: non-critical connections are only as exact
    // as the solver's relative gap allows.
    for (x, y) in fast.connections.iter().zip(&socp.connections) {
        assert!(close(x.strength, y.strength, 1e-3), "{x:?} vs {y:?}");
    }
    assert!(close(fast.margin.unwrap(), socp.margin.unwrap(), 1e-4));
}

#[test]
fn chain_hung_between_two_supports_has_symmetric_loads() {
    let (k, m, p) = (5, 0.2, 0.05);
    let mut mods = vec![module("left", 1.0, [0.0; 3], true)];
    let mut conns = vec![];
    for i in 1..=k {
        mods.push(module(&format!("m{i}"), m, [p * i as f64, 0.0, 0.0], false));
        let parent = if i == 1 {
            "left".to_string()
        } else {
            format!("m{}", i - 1)
        };
        conns.push(conn(
            &format!("m{i}"),
            &parent,
            [p * (i as f64 - 0.5), 0.0, 0.0],
        ));
    }
    mods.push(module("right", 1.0, [p * (k + 1) as f64, 0.0, 0.0], true));
    // Last connection: child m_k, parent right.
    conns.push(conn(
        &format!("m{k}"),
        "right",
        [p * (k as f64 + 0.5), 0.0, 0.0],
    ));
    let mut a = asm(mods);
    a.connectors.insert("c".into(), box_connector(100.0, 10.0));
    a.connections = conns;
    let r = evaluate(&a).unwrap();
    assert_eq!(r.verdict, Verdict::Stable);
    assert_eq!(r.stats.path, Path::Socp);
    let first = &r.connections[0];
    let last = &r.connections[k];
    // Each support carries half the weight.
    let shear = |c: &puzzlebot_stability::gate::ConnectionResult| {
        (c.wrench[0].powi(2) + c.wrench[1].powi(2)).sqrt()
    };
    let half = k as f64 * m * G / 2.0;
    assert!(
        close(shear(first), half, 1e-4),
        "{} vs {half}",
        shear(first)
    );
    assert!(close(shear(last), half, 1e-4), "{} vs {half}", shear(last));
    // Mirror-symmetric strengths.
    for i in 0..=k {
        let (a, b) = (&r.connections[i], &r.connections[k - i]);
        assert!(
            close(a.strength, b.strength, 1e-4),
            "{i}: {} vs {}",
            a.strength,
            b.strength
        );
    }
}

fn slope_block(theta: f64, mu: f64) -> Assembly {
    let mut a = asm(vec![Module {
        com: [0.0, 0.0, 0.01],
        ..module("b", 1.0, [0.0; 3], false)
    }]);
    a.gravity = [G * theta.sin(), 0.0, -G * theta.cos()];
    a.contacts = vec![
        contact("b", [0.05, 0.0, 0.0], mu),
        contact("b", [-0.05, 0.05, 0.0], mu),
        contact("b", [-0.05, -0.05, 0.0], mu),
    ];
    a
}

#[test]
fn block_on_slope_slides_once_tan_theta_exceeds_mu() {
    let mu: f64 = 0.4;
    let crit = mu.atan();
    let ok = evaluate(&slope_block(crit * 0.95, mu)).unwrap();
    assert_eq!(ok.verdict, Verdict::Stable);
    let bad = evaluate(&slope_block(crit * 1.05, mu)).unwrap();
    assert_eq!(bad.verdict, Verdict::WholeBodyInstability);
    // Friction margins shrink towards the critical angle.
    let near = evaluate(&slope_block(crit * 0.999, mu)).unwrap();
    let m_ok: f64 = ok.contacts.iter().map(|c| c.friction_margin).sum();
    let m_near: f64 = near.contacts.iter().map(|c| c.friction_margin).sum();
    assert!(m_near < m_ok && m_near >= -1e-6, "{m_near} vs {m_ok}");
}

#[test]
fn closed_loop_min_max_spreads_load_symmetrically() {
    let p = 0.05;
    let m = 0.1;
    // F fixed on top; A, B beside it; C, D below them; E joins C and D.
    let mods = vec![
        module("F", 1.0, [0.0, 0.0, 0.0], true),
        module("A", m, [-p, 0.0, 0.0], false),
        module("B", m, [p, 0.0, 0.0], false),
        module("C", m, [-p, 0.0, -p], false),
        module("D", m, [p, 0.0, -p], false),
        module("E", m, [0.0, 0.0, -p], false),
    ];
    let loop_conns = vec![
        conn("A", "F", [-p / 2.0, 0.0, 0.0]),
        conn("B", "F", [p / 2.0, 0.0, 0.0]),
        conn("C", "A", [-p, 0.0, -p / 2.0]),
        conn("D", "B", [p, 0.0, -p / 2.0]),
        conn("E", "C", [-p / 2.0, 0.0, -p]),
        conn("E", "D", [p / 2.0, 0.0, -p]),
    ];
    let mut a = asm(mods);
    a.connectors.insert("c".into(), box_connector(100.0, 10.0));
    a.connections = loop_conns.clone();
    let r = evaluate(&a).unwrap();
    assert_eq!(r.verdict, Verdict::Stable);
    for (i, j) in [(0, 1), (2, 3), (4, 5)] {
        let (x, y) = (&r.connections[i], &r.connections[j]);
        assert!(
            close(x.strength, y.strength, 1e-4),
            "{i}/{j}: {} vs {}",
            x.strength,
            y.strength
        );
    }
    // Cutting the loop (E hangs from C only) concentrates the load: the loop's min-max is lower.
    a.connections = loop_conns[..5].to_vec();
    let tree = evaluate(&a).unwrap();
    assert_eq!(tree.stats.path, Path::DeterminateTree);
    assert!(r.max_strength.unwrap() < tree.max_strength.unwrap() - 1e-3);
}

#[test]
fn load_ramp_strength_grows_linearly_and_crosses_the_limit_where_statics_predicts() {
    let (k, m, p, m_lim) = (3, 0.1, 0.05, 0.5);
    let mut a = cantilever(k, m, p, 100.0, m_lim);
    let tip = [p * k as f64, 0.0, 0.0];
    let arm = tip[0] - p / 2.0; // lever of the tip load about the root connection
    let m0 = m * G * p * (k * k) as f64 / 2.0;
    let t_star = (m_lim - m0) / arm;
    let mut last = None;
    for (s, t) in [0.0, 0.5, 1.0, 1.5].iter().enumerate() {
        a.loads = vec![Load {
            module: format!("m{k}"),
            force: [0.0, 0.0, -t],
            point: Some(tip),
            couple: [0.0; 3],
        }];
        let r = evaluate_with(
            &a,
            Options {
                fast_path: false,
                ..Options::default()
            },
        )
        .unwrap();
        let w = r.connections[0].wrench;
        let mo = (w[3] * w[3] + w[4] * w[4] + w[5] * w[5]).sqrt();
        assert!(close(mo, m0 + t * arm, 1e-5), "step {s}: {mo}");
        if let Some(prev) = last {
            let _: f64 = prev;
            assert!(close(mo - prev, 0.5 * arm, 1e-4), "linear growth");
        }
        last = Some(mo);
    }
    a.loads.clear();
    let range = load_range(&a, &format!("m{k}"), tip, [0.0, 0.0, -1.0], 20.0, 1e-4).unwrap();
    let found = range.max_along.unwrap();
    assert!((found - t_star).abs() < 1e-3, "{found} vs {t_star}");
    assert_eq!(range.along_limited_by, Some(Verdict::InternalInstability));
    // Lifting the tip first relieves the root, then bends it the other way: limit (M + m0)/arm.
    let up = range.max_against.unwrap();
    assert!((up - (m_lim + m0) / arm).abs() < 1e-3, "{up}");
}

#[test]
fn errors_name_the_field() {
    let mut a = cantilever(2, 0.1, 0.05, 1.0, 1.0);
    a.connections[1].parent = "nope".into();
    let e = a.resolve().unwrap_err();
    assert_eq!(e.field, "connections[1].parent");
    let mut a = cantilever(2, 0.1, 0.05, 1.0, 1.0);
    a.modules[2].mass = -1.0;
    assert_eq!(a.resolve().unwrap_err().field, "modules[2].mass");
    let mut a = cantilever(2, 0.1, 0.05, 1.0, 1.0);
    a.connections[0].connector = "x".into();
    assert_eq!(a.resolve().unwrap_err().field, "connections[0].connector");
    // Non-finite numbers: the field names are built only for the error, and still exact.
    let mut a = cantilever(2, 0.1, 0.05, 1.0, 1.0);
    a.modules[1].position[2] = f64::NAN;
    let e = a.resolve().unwrap_err();
    assert_eq!(
        (e.field.as_str(), e.message.as_str()),
        ("modules[1].position", "non-finite number")
    );
    let mut a = cantilever(2, 0.1, 0.05, 1.0, 1.0);
    a.connections[1].point[0] = f64::INFINITY;
    assert_eq!(a.resolve().unwrap_err().field, "connections[1].point");
    let mut a = cantilever(2, 0.1, 0.05, 1.0, 1.0);
    a.gravity[1] = f64::NAN;
    assert_eq!(a.resolve().unwrap_err().field, "gravity");
    let mut a = cantilever(2, 0.1, 0.05, 1.0, 1.0);
    a.connections[0].child = "ghost".into();
    let e = a.resolve().unwrap_err();
    assert_eq!(e.field, "connections[0].child");
    assert!(e.message.contains("ghost"), "{}", e.message);
}

#[test]
fn floating_body_without_support_is_whole_body_unstable() {
    let a = asm(vec![module("b", 1.0, [0.0; 3], false)]);
    let r = evaluate(&a).unwrap();
    assert_eq!(r.verdict, Verdict::WholeBodyInstability);
    assert!(r.margin.is_none());
}

#[test]
fn solver_trouble_is_not_proven_never_stable() {
    // A stable assembly, but the solver is stopped after one iteration: no certificate.
    let a = cantilever(3, 0.1, 0.05, 100.0, 1.0);
    let opt = Options {
        fast_path: false,
        max_iter: 1,
        ..Options::default()
    };
    let r = evaluate_with(&a, opt).unwrap();
    assert!(
        matches!(r.verdict, Verdict::NotProven { .. }),
        "{:?}",
        r.verdict
    );
    assert!(!r.verdict.is_stable());
    assert!(r.margin.is_none());
    // With the normal limit it is proven stable.
    assert_eq!(
        evaluate_with(
            &a,
            Options {
                fast_path: false,
                ..Options::default()
            }
        )
        .unwrap()
        .verdict,
        Verdict::Stable
    );
}
