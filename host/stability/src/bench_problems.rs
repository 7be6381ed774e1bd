//! Problem families for benchmarks and the CVXPY peer (exported as JSON): chains and meshes
//! standing on the ground, random trees on the ground, random trees hanging from a fixed root.

use crate::model::{
    Assembly, Connection, ConnectorSpec, Contact, Limits6, Module, Objective, Vec3,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::{BTreeMap, HashMap};

/// Pitch between neighbouring modules (m).
pub const PITCH: f64 = 0.05;
/// Module mass (kg).
pub const MASS: f64 = 0.1;

/// Benchmark families.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// A straight chain on the ground, every third module on 4 contacts (cone program).
    Chain,
    /// A square mesh on the ground, with loops; a checkerboard of supported modules.
    Mesh,
    /// A random planar tree on the ground, every other module supported (cone program).
    TreeGround,
    /// A random 3-D tree hanging from one fixed module (determinate: fast path).
    TreeHanging,
}

impl Family {
    /// Parse "chain", "mesh", "tree-ground", "tree-hanging".
    pub fn parse(s: &str) -> Option<Family> {
        match s {
            "chain" => Some(Family::Chain),
            "mesh" => Some(Family::Mesh),
            "tree-ground" => Some(Family::TreeGround),
            "tree-hanging" => Some(Family::TreeHanging),
            _ => None,
        }
    }
    /// Name as parsed.
    pub fn name(&self) -> &'static str {
        match self {
            Family::Chain => "chain",
            Family::Mesh => "mesh",
            Family::TreeGround => "tree-ground",
            Family::TreeHanging => "tree-hanging",
        }
    }
    /// Build an instance with `n` modules (seeded for trees).
    pub fn build(&self, n: usize, seed: u64) -> Assembly {
        match self {
            Family::Chain => on_ground(
                &(0..n).map(|i| (i as i64, 0)).collect::<Vec<_>>(),
                &chain_edges(n),
                |i| i % 3 == 0 || i + 1 == n,
            ),
            Family::Mesh => mesh(n),
            Family::TreeGround => tree_ground(n, seed),
            Family::TreeHanging => tree_hanging(n, seed),
        }
    }
}

fn connectors() -> BTreeMap<String, ConnectorSpec> {
    let lever = 0.025;
    let w = [1.0, 1.0, 1.0, 1.0 / lever, 1.0 / lever, 1.0 / lever];
    let mut m = BTreeMap::new();
    m.insert(
        "link".to_string(),
        ConnectorSpec::Box {
            max: Limits6::uniform(50.0, 50.0 * lever),
            omega_k: w,
            margin_weights: w,
        },
    );
    m
}

fn chain_edges(n: usize) -> Vec<(usize, usize)> {
    (1..n).map(|i| (i, i - 1)).collect()
}

fn module(i: usize, p: Vec3, fixed: bool) -> Module {
    Module {
        id: format!("m{i}"),
        mass: MASS,
        position: p,
        rpy: [0.0; 3],
        com: [0.0, 0.0, 0.02],
        fixed,
    }
}

/// Modules on grid cells, edges (child, parent); the modules with `supported(i)` stand on
/// 4 ground contacts (2 wheels with friction, 2 frictionless casters), the others hang from
/// their neighbours, so the connections carry load.
fn on_ground(
    cells: &[(i64, i64)],
    edges: &[(usize, usize)],
    supported: impl Fn(usize) -> bool,
) -> Assembly {
    let pos = |c: (i64, i64)| [c.0 as f64 * PITCH, c.1 as f64 * PITCH, 0.0];
    let modules: Vec<Module> = cells
        .iter()
        .enumerate()
        .map(|(i, c)| module(i, pos(*c), false))
        .collect();
    let mut contacts = Vec::with_capacity(cells.len() * 4);
    for (i, c) in cells.iter().enumerate() {
        if !supported(i) {
            continue;
        }
        let p = pos(*c);
        for (dx, dy, mu) in [
            (0.0, 0.02, 0.6),
            (0.0, -0.02, 0.6),
            (0.02, 0.0, 0.0),
            (-0.02, 0.0, 0.0),
        ] {
            contacts.push(Contact {
                module: format!("m{i}"),
                point: [p[0] + dx, p[1] + dy, 0.0],
                normal: None,
                mu: [mu, mu],
                x_axis: None,
                gap: 0.0,
            });
        }
    }
    let connections = edges
        .iter()
        .map(|&(c, p)| {
            let a = pos(cells[c]);
            let b = pos(cells[p]);
            Connection {
                child: format!("m{c}"),
                parent: format!("m{p}"),
                connector: "link".into(),
                point: [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5, 0.02],
                axis: None,
                x_axis: None,
            }
        })
        .collect();
    Assembly {
        gravity: [0.0, 0.0, -9.81],
        modules,
        connectors: connectors(),
        connections,
        contacts,
        module_contacts: vec![],
        loads: vec![],
        objective: Objective::default(),
    }
}

fn mesh(n: usize) -> Assembly {
    let cols = (n as f64).sqrt().ceil().max(1.0) as usize;
    let cells: Vec<(i64, i64)> = (0..n)
        .map(|i| ((i % cols) as i64, (i / cols) as i64))
        .collect();
    let mut edges = Vec::new();
    for i in 0..n {
        if i % cols > 0 {
            edges.push((i, i - 1));
        }
        if i >= cols {
            edges.push((i, i - cols));
        }
    }
    on_ground(&cells, &edges, |i| {
        ((i % cols) + (i / cols)).is_multiple_of(2)
    })
}

fn tree_ground(n: usize, seed: u64) -> Assembly {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut cells = vec![(0i64, 0i64)];
    let mut taken: HashMap<(i64, i64), usize> = HashMap::new();
    taken.insert((0, 0), 0);
    let mut edges = Vec::new();
    let dirs = [(1, 0), (-1, 0), (0, 1), (0, -1)];
    while cells.len() < n {
        let p = rng.random_range(0..cells.len());
        let d = dirs[rng.random_range(0..4)];
        let c = (cells[p].0 + d.0, cells[p].1 + d.1);
        if taken.contains_key(&c) {
            continue;
        }
        taken.insert(c, cells.len());
        edges.push((cells.len(), p));
        cells.push(c);
    }
    on_ground(&cells, &edges, |i| i % 2 == 0)
}

fn tree_hanging(n: usize, seed: u64) -> Assembly {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dirs: [Vec3; 5] = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, -1.0],
    ];
    let mut pos: Vec<Vec3> = vec![[0.0; 3]];
    let mut modules = vec![module(0, [0.0; 3], true)];
    let mut connections = Vec::new();
    for i in 1..n.max(1) {
        let p = rng.random_range(0..i);
        let d = dirs[rng.random_range(0..5)];
        let q = [
            pos[p][0] + d[0] * PITCH,
            pos[p][1] + d[1] * PITCH,
            pos[p][2] + d[2] * PITCH,
        ];
        pos.push(q);
        modules.push(module(i, q, false));
        connections.push(Connection {
            child: format!("m{i}"),
            parent: format!("m{p}"),
            connector: "link".into(),
            point: [
                (q[0] + pos[p][0]) * 0.5,
                (q[1] + pos[p][1]) * 0.5,
                (q[2] + pos[p][2]) * 0.5 + 0.02,
            ],
            axis: Some(d),
            x_axis: None,
        });
    }
    Assembly {
        gravity: [0.0, 0.0, -9.81],
        modules,
        connectors: connectors(),
        connections,
        contacts: vec![],
        module_contacts: vec![],
        loads: vec![],
        objective: Objective::default(),
    }
}

/// CPU time of the calling thread in seconds (`CLOCK_THREAD_CPUTIME_ID`, ns resolution), or
/// None where unavailable. Benchmarks report it next to the wall-clock time because the
/// machine is shared: time spent waiting for a core is not counted.
#[allow(unsafe_code)]
pub fn thread_cpu_seconds() -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; clock_gettime only writes into it.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}
