//! Which robots hang together: segments (connected assemblies) and the pairs that hold them.

use super::*;

impl Coordinator {
    /// Robots seen and not lost, by id.
    pub(super) fn live_ids(&self) -> Vec<RobotId> {
        self.robots
            .keys()
            .copied()
            .filter(|id| !self.lost.contains(id))
            .collect()
    }

    /// Segments (connected assemblies) from the connected, unreleased pairs: robot → segment.
    pub fn segments(&self) -> BTreeMap<RobotId, usize> {
        let ids = self.live_ids();
        let index: BTreeMap<RobotId, usize> =
            ids.iter().enumerate().map(|(i, &id)| (id, i)).collect();
        let mut groups = petgraph::unionfind::UnionFind::<usize>::new(ids.len());
        for (i, tp) in self.pairs.iter().enumerate() {
            if tp.status != PairStatus::Connected || self.released.contains(&i) {
                continue;
            }
            if let (Some(&a), Some(&b)) = (index.get(&tp.pair.a), index.get(&tp.pair.b)) {
                groups.union(a, b);
            }
        }
        // Renumber roots densely in id order.
        let mut dense = BTreeMap::new();
        let mut out = BTreeMap::new();
        for (i, &id) in ids.iter().enumerate() {
            let r = groups.find_mut(i);
            let n = dense.len();
            let s = *dense.entry(r).or_insert(n);
            out.insert(id, s);
        }
        out
    }

    /// Largest relative yaw over the connected anchor pairs inside `members` (rad).
    pub(super) fn chain_bend(&self, members: &[RobotId]) -> f64 {
        self.live_pairs(members)
            .into_iter()
            .map(|i| &self.pairs[i])
            .filter(|p| p.pair.kind == PairType::AnchorOpening)
            .filter_map(|p| {
                let (a, b) = (self.robots.get(&p.pair.a)?, self.robots.get(&p.pair.b)?);
                Some(wrap_angle(a.pose.yaw - b.pose.yaw - p.pair.relative_yaw).abs())
            })
            .fold(0.0, f64::max)
    }

    /// Indices of connected pairs that involve `robot` (for decoupling it).
    pub fn connected_pairs_of(&self, robot: RobotId) -> Vec<usize> {
        self.pairs
            .iter()
            .enumerate()
            .filter(|(i, p)| {
                p.pair.involves(robot)
                    && !self.released.contains(i)
                    && p.status != PairStatus::Decoupled
            })
            .map(|(i, _)| i)
            .collect()
    }

    /// Indices of all tracked, unreleased pairs that are not decoupled.
    pub fn coupled_pairs(&self) -> Vec<usize> {
        self.pairs
            .iter()
            .enumerate()
            .filter(|(i, p)| !self.released.contains(i) && p.status != PairStatus::Decoupled)
            .map(|(i, _)| i)
            .collect()
    }
}
