//! Property tests of connection-pair assignment over random fleets.

use super::*;
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any fleet of 2–9 scattered robots gets a spanning tree of pairs over all robots,
    /// each robot in exactly one slot, and pairs in non-decreasing distance order.
    #[test]
    fn plans_are_spanning_trees(
        pts in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -3.0f64..3.0), 2..10),
        mesh in any::<bool>(),
    ) {
        let g = Geometry::default();
        let robots: Vec<RobotState> = pts.iter().enumerate().map(|(i, &(x, y, yaw))| RobotState {
            id: i as RobotId * 3 + 1,
            kind: RobotKind::NonPilot,
            pose: Pose::new(x, y, yaw),
        }).collect();
        let spec = if mesh { ShapeSpec::Mesh { rows: 2 } } else { ShapeSpec::Line };
        let plan = assign_connection_pairs(&spec, &robots, None, &g).unwrap();
        let n = robots.len();
        prop_assert_eq!(plan.pairs.len(), n - 1);
        let mut ids = plan.slot_robot.clone();
        ids.sort_unstable();
        ids.dedup();
        prop_assert_eq!(ids.len(), n);
        // Union-find: the pairs connect every robot (n − 1 pairs and no cycle).
        let index = |r: RobotId| plan.slot_robot.iter().position(|&x| x == r).expect("planned robot");
        let mut groups = petgraph::unionfind::UnionFind::<usize>::new(n);
        for pp in &plan.pairs {
            prop_assert!(groups.union(index(pp.a), index(pp.b)), "pairs must not form a cycle");
        }
        for w in plan.pairs.windows(2) {
            prop_assert!(distance_bucket(w[0].centre_distance) <= distance_bucket(w[1].centre_distance));
        }
    }
}
