//! Diagnostics: AMD fill and flop estimate of the KKT pattern Clarabel factorises for a
//! benchmark problem: `cargo run --release -p puzzlebot-stability --example kkt_fill -- mesh 1000`.
//! Prints the floor set by the module graph (6 equilibrium rows per module), then the direct and
//! the dual form at AMD dense factors 10, 15 (Clarabel's) and off. `DROP_W=1` leaves out the
//! w_A^max row of the dual form (unknown 0) to show what that row costs the ordering.

use puzzlebot_stability::bench_problems::Family;
use puzzlebot_stability::socp::Program;

fn kkt_pattern(p: &Program) -> (usize, Vec<usize>, Vec<usize>) {
    // Upper triangle of [P Aᵀ; A −H] plus two columns per expanded SOC (dimension > 4).
    let n = p.n;
    let m = p.a.m;
    let mut cols: Vec<Vec<usize>> = vec![Vec::new(); n + m];
    for j in 0..n {
        cols[j].push(j);
        for k in p.a.colptr[j]..p.a.colptr[j + 1] {
            if p.dual && p.a.rowval[k] == 0 && std::env::var("DROP_W").is_ok() {
                continue;
            }
            // entry (n + row, j) lies below the diagonal: store its transpose in column n+row
            cols[n + p.a.rowval[k]].push(j);
        }
    }
    let mut row = 0;
    let mut extra = Vec::new();
    for c in &p.cones {
        use clarabel::solver::SupportedConeT::*;
        match c {
            SecondOrderConeT(d) => {
                if *d > 4 {
                    extra.push((row, *d));
                } else {
                    for a in 0..*d {
                        for b in 0..=a {
                            cols[n + row + a].push(n + row + b);
                        }
                    }
                }
                row += d;
            }
            ZeroConeT(d) | NonnegativeConeT(d) => {
                for a in 0..*d {
                    cols[n + row + a].push(n + row + a);
                }
                row += d;
            }
            _ => unreachable!(),
        }
    }
    for (r0, d) in extra {
        for a in 0..d {
            cols[n + r0 + a].push(n + r0 + a);
        }
        for _ in 0..2 {
            let mut c: Vec<usize> = (0..d).map(|a| n + r0 + a).collect();
            c.push(cols.len());
            cols.push(c);
        }
    }
    let dim = cols.len();
    let mut colptr = vec![0];
    let mut rowval = Vec::new();
    for mut c in cols {
        c.sort_unstable();
        c.dedup();
        rowval.extend(c);
        colptr.push(rowval.len());
    }
    (dim, colptr, rowval)
}

/// Fill of the reduced system every formulation contains: the 6 equilibrium rows of each free
/// module, coupled (dense 12×12) through each connection: the floor for any LDL ordering AMD
/// finds on the module graph.
fn module_graph(r: &puzzlebot_stability::model::Resolved) -> (usize, Vec<usize>, Vec<usize>) {
    let n = r.com.len();
    let mut cols: Vec<Vec<usize>> = vec![Vec::new(); 6 * n];
    let mut couple = |a: usize, b: usize| {
        for i in 0..6 {
            for j in 0..6 {
                let (p, q) = (6 * a + i, 6 * b + j);
                if q <= p {
                    cols[p].push(q);
                }
            }
        }
    };
    for i in 0..n {
        couple(i, i);
    }
    for c in &r.connections {
        couple(c.child, c.parent);
        couple(c.parent, c.child);
    }
    let mut colptr = vec![0];
    let mut rowval = Vec::new();
    for mut c in cols {
        c.sort_unstable();
        c.dedup();
        rowval.extend(c);
        colptr.push(rowval.len());
    }
    (6 * n, colptr, rowval)
}

fn main() {
    let fam = std::env::args().nth(1).unwrap_or("mesh".into());
    let n: usize = std::env::args()
        .nth(2)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1000);
    let r = Family::parse(&fam)
        .expect("family")
        .build(n, 7)
        .resolve()
        .expect("valid");
    let (dim, colptr, rowval) = module_graph(&r);
    let (_, _, info) = amd::order(dim, &colptr, &rowval, &amd::Control::default()).expect("amd");
    println!(
        "module graph (6 rows per module): dim {dim} lnz {} flops {:.2e}",
        info.lnz,
        (info.n_div + info.n_mult_subs_ldl) as f64
    );
    for (name, p) in [
        ("direct", puzzlebot_stability::socp::build(&r, false)),
        ("dual", puzzlebot_stability::dual::build_relaxed(&r)),
    ] {
        let (dim, colptr, rowval) = kkt_pattern(&p);
        for dense in [10.0, 15.0, -1.0] {
            let ctl = amd::Control {
                dense,
                ..Default::default()
            };
            let t = std::time::Instant::now();
            let (_, _, info) = amd::order(dim, &colptr, &rowval, &ctl).expect("amd");
            println!(
                "{name:6} dense={dense:>4}: KKT {dim} nnz {} lnz {} flops {:.2e} n_dense {} amd {:.1} ms",
                rowval.len(),
                info.lnz,
                (info.n_div + info.n_mult_subs_ldl) as f64,
                info.n_dense,
                t.elapsed().as_secs_f64() * 1e3
            );
        }
    }
}
