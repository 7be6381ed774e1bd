//! THESIS Algorithm 1 (FindExistPairs): the connection pairs that hold a configuration together.

use crate::geom::{dist, pair_type, ConnPoint, PointRole, Pose};
use crate::shape::{GoalPair, CONTACT_TOLERANCE};
use petgraph::data::Element;
use petgraph::graph::UnGraph;
use puzzlebot_params::geometry::Geometry;

/// The closest compatible pair of connection points of two robots and its distance.
pub fn closest_points(pa: &Pose, pb: &Pose, g: &Geometry) -> Option<(ConnPoint, ConnPoint, f64)> {
    let mut best: Option<(ConnPoint, ConnPoint, f64)> = None;
    for ca in ConnPoint::ALL {
        let wa = pa.transform(ca.position(g));
        for cb in ConnPoint::ALL {
            if pair_type(ca, cb).is_none() {
                continue;
            }
            let d = dist(wa, pb.transform(cb.position(g)));
            if best.is_none_or(|b| d < b.2) {
                best = Some((ca, cb, d));
            }
        }
    }
    best
}

/// THESIS Algorithm 1 (FindExistPairs): the pairs that hold configuration `poses` together.
///
/// Vertices are the robots, edges weighted by centre distance; the minimum spanning tree
/// (petgraph, Kruskal) picks the pairs to monitor and each edge takes the closest compatible
/// connection points. Only robot pairs whose compatible points meet within
/// [`CONTACT_TOLERANCE`] are edges, so a disconnected configuration yields fewer than n − 1
/// pairs. Each pair is oriented so that `a` carries the anchor or the knob.
pub fn find_pairs(poses: &[Pose], g: &Geometry) -> Vec<GoalPair> {
    find_pairs_within(poses, g, CONTACT_TOLERANCE)
}

/// [`find_pairs`] with an explicit contact tolerance (m).
pub fn find_pairs_within(poses: &[Pose], g: &Geometry, tolerance: f64) -> Vec<GoalPair> {
    let n = poses.len();
    let mut graph: UnGraph<usize, f64> = UnGraph::with_capacity(n, n * 2);
    let nodes: Vec<_> = (0..n).map(|i| graph.add_node(i)).collect();
    let mut contact = std::collections::HashMap::new();
    for i in 0..n {
        for j in i + 1..n {
            let centre = poses[i].distance(&poses[j]);
            // Two bodies further apart than their diagonals plus the tolerance cannot touch.
            if centre > 2.0 * f64::from(g.length.max(g.width)) + tolerance {
                continue;
            }
            if let Some((ci, cj, d)) = closest_points(&poses[i], &poses[j], g) {
                if d <= tolerance {
                    graph.add_edge(nodes[i], nodes[j], centre);
                    contact.insert((i, j), (ci, cj, d));
                }
            }
        }
    }
    let mut pairs = Vec::new();
    for e in petgraph::algo::min_spanning_tree(&graph) {
        if let Element::Edge {
            source,
            target,
            weight,
        } = e
        {
            let (i, j) = (source.min(target), source.max(target));
            let (ci, cj, d) = contact[&(i, j)];
            pairs.push(orient(i, ci, j, cj, weight, d));
        }
    }
    pairs
}

fn orient(
    i: usize,
    ci: ConnPoint,
    j: usize,
    cj: ConnPoint,
    centre: f64,
    residual: f64,
) -> GoalPair {
    let kind = pair_type(ci, cj).expect("closest_points returns compatible points");
    let i_is_male = matches!(ci.role(), PointRole::Anchor | PointRole::Knob);
    let (a, pa, b, pb) = if i_is_male {
        (i, ci, j, cj)
    } else {
        (j, cj, i, ci)
    };
    GoalPair {
        a,
        point_a: pa,
        b,
        point_b: pb,
        kind,
        centre_distance: centre,
        residual,
    }
}
