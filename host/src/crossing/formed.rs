//! The assembly a formation left behind, read from the simulator's ground truth: its shape
//! (a line or a mesh of `params::formation`), which robot holds which place of the layout, and
//! the couplings that actually hold it (a formation may close fewer knobs than the layout has).

use puzzlebot_params::formation::{self, Link, Shape};
use puzzlebot_params::geometry::Geometry;
use puzzlebot_params::RobotKind;
use puzzlebot_protocol::RobotId;
use puzzlebot_sim::LinkKind;
use std::collections::BTreeMap;

/// Largest distance of a robot from its place in the fitted layout (m) for the assembly to
/// count as that shape: a quarter of the anchor pitch.
pub fn fit_tolerance(g: &Geometry) -> f64 {
    0.25 * formation::anchor_pitch(g)
}

/// A formed assembly.
#[derive(Debug, Clone, PartialEq)]
pub struct Formed {
    /// Line or mesh.
    pub shape: Shape,
    /// Robot id at each place (row-major, front robot of each row first, as the layout).
    pub ids: Vec<RobotId>,
    /// Kind of the robot at each place.
    pub kinds: Vec<RobotKind>,
    /// Couplings (link, place with the anchor / knob, place with the opening / hole).
    pub links: Vec<(Link, usize, usize)>,
    /// Largest distance of a robot from its place in the layout fitted to its poses (m).
    pub fit_error: f64,
}

impl Formed {
    /// Places of the pilots.
    pub fn pilots(&self) -> Vec<usize> {
        (0..self.kinds.len())
            .filter(|&k| self.kinds[k] == RobotKind::Pilot)
            .collect()
    }

    /// Number of couplings of `kind`.
    pub fn count(&self, kind: Link) -> usize {
        self.links.iter().filter(|l| l.0 == kind).count()
    }

    /// Read the assembly from the robots' poses (id → x, y, θ), their kinds and the couplings
    /// that hold (kind, robot with the anchor / knob, robot with the opening / hole). Every
    /// coupled robot belongs to it; anchors make the rows (front to back), knobs put each row
    /// to the left of the one before it. The error says which robot or coupling does not fit.
    pub fn read(
        poses: &BTreeMap<RobotId, [f64; 3]>,
        kinds: &BTreeMap<RobotId, RobotKind>,
        couplings: &[(LinkKind, RobotId, RobotId)],
        g: &Geometry,
    ) -> Result<Formed, String> {
        let mut members: Vec<RobotId> = couplings.iter().flat_map(|c| [c.1, c.2]).collect();
        members.sort_unstable();
        members.dedup();
        if members.is_empty() {
            return Err("no couplings: there is no assembly".into());
        }
        let mut behind: BTreeMap<RobotId, RobotId> = BTreeMap::new();
        let mut ahead: BTreeMap<RobotId, RobotId> = BTreeMap::new();
        for &(k, a, b) in couplings {
            if k == LinkKind::Anchor
                && (behind.insert(a, b).is_some() || ahead.insert(b, a).is_some())
            {
                return Err(format!(
                    "anchor {a}→{b}: a robot with two robots behind or ahead of it"
                ));
            }
        }
        // Rows: chains of anchors from a robot with none ahead of it.
        let mut rows: Vec<Vec<RobotId>> = Vec::new();
        for &id in members.iter().filter(|id| !ahead.contains_key(id)) {
            let mut row = vec![id];
            while let Some(&b) = behind.get(row.last().unwrap_or(&id)) {
                if row.contains(&b) || row.len() > members.len() {
                    return Err(format!("anchors form a ring through robot {b}"));
                }
                row.push(b);
            }
            rows.push(row);
        }
        let row_of = |id: RobotId| rows.iter().position(|r| r.contains(&id));
        if members.iter().any(|&id| row_of(id).is_none()) {
            return Err("anchors form a ring".into());
        }
        // Row order: the hole of a knob is in the row to the left.
        let mut left: BTreeMap<usize, usize> = BTreeMap::new();
        for &(k, a, b) in couplings.iter().filter(|c| c.0 == LinkKind::Knob) {
            let (ra, rb) = (row_of(a).unwrap_or(0), row_of(b).unwrap_or(0));
            if ra == rb || left.get(&ra).is_some_and(|&l| l != rb) {
                return Err(format!(
                    "knob {a}→{b} ({k:?}): rows do not stack side by side"
                ));
            }
            left.insert(ra, rb);
        }
        let Some(first) = (0..rows.len()).find(|r| !left.values().any(|v| v == r)) else {
            return Err("knobs form a ring of rows".into());
        };
        let mut order = vec![first];
        while let Some(&next) = left.get(order.last().unwrap_or(&first)) {
            if order.contains(&next) {
                return Err("knobs form a ring of rows".into());
            }
            order.push(next);
        }
        if order.len() != rows.len() {
            return Err(format!(
                "{} rows, {} joined by knobs: the assembly is in pieces",
                rows.len(),
                order.len()
            ));
        }
        // Full rows, or the rows of an uneven mesh as the formation lays them out: the
        // longer rows first (rightmost), a shorter row nested behind its neighbour's front.
        let sizes: Vec<usize> = order.iter().map(|&r| rows[r].len()).collect();
        let expected = Shape::mesh_of(rows.len(), members.len());
        let shape = expected.filter(|s| s.row_sizes() == sizes).ok_or_else(|| {
            let listed: Vec<String> = sizes.iter().map(|n| n.to_string()).collect();
            let want = expected.map_or_else(String::new, |s| {
                format!(" ({}, longer rows to the right)", s.name())
            });
            format!(
                "rows of {} robots, right to left: not a mesh of {} in {} rows{want}",
                listed.join(", "),
                members.len(),
                rows.len(),
            )
        })?;
        let ids: Vec<RobotId> = order.iter().flat_map(|&r| rows[r].clone()).collect();
        let place = |id: RobotId| ids.iter().position(|&x| x == id).unwrap_or(0);
        let links = couplings
            .iter()
            .map(|&(k, a, b)| {
                let l = match k {
                    LinkKind::Anchor => Link::Anchor,
                    LinkKind::Knob => Link::Knob,
                };
                (l, place(a), place(b))
            })
            .collect();
        let mut kinds_at = Vec::with_capacity(ids.len());
        let mut at = Vec::with_capacity(ids.len());
        for id in &ids {
            kinds_at.push(
                *kinds
                    .get(id)
                    .ok_or_else(|| format!("robot {id}: kind unknown"))?,
            );
            let p = poses
                .get(id)
                .ok_or_else(|| format!("robot {id}: pose unknown"))?;
            at.push([p[0], p[1]]);
        }
        let layout = formation::layout(shape, g).0;
        let (fit_error, worst) = fit(&layout, &at);
        if fit_error > fit_tolerance(g) {
            return Err(format!(
                "robot {} is {:.0} mm from its place in a {} (tolerance {:.0} mm)",
                ids[worst],
                fit_error * 1e3,
                shape.name(),
                fit_tolerance(g) * 1e3
            ));
        }
        Ok(Formed {
            shape,
            ids,
            kinds: kinds_at,
            links,
            fit_error,
        })
    }
}

/// Fit `layout` (body-centre offsets) to the points `at` by a rotation and a translation
/// (least squares): the largest remaining distance and the index of that point.
pub fn fit(layout: &[[f64; 2]], at: &[[f64; 2]]) -> (f64, usize) {
    let n = layout.len().min(at.len()).max(1) as f64;
    let mean = |v: &[[f64; 2]]| {
        let s = v.iter().fold([0.0, 0.0], |s, p| [s[0] + p[0], s[1] + p[1]]);
        [s[0] / n, s[1] / n]
    };
    let (ml, ma) = (mean(layout), mean(at));
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (l, a) in layout.iter().zip(at) {
        let (lx, ly) = (l[0] - ml[0], l[1] - ml[1]);
        let (ax, ay) = (a[0] - ma[0], a[1] - ma[1]);
        sxx += lx * ax + ly * ay;
        sxy += lx * ay - ly * ax;
    }
    let th = sxy.atan2(sxx);
    let (s, c) = th.sin_cos();
    layout
        .iter()
        .zip(at)
        .enumerate()
        .map(|(k, (l, a))| {
            let (lx, ly) = (l[0] - ml[0], l[1] - ml[1]);
            let p = [ma[0] + c * lx - s * ly, ma[1] + s * lx + c * ly];
            ((p[0] - a[0]).hypot(p[1] - a[1]), k)
        })
        .fold((0.0, 0), |m, x| if x.0 > m.0 { x } else { m })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The poses (id → x, y, θ) of `shape`'s layout at `heading`, robot k + 1 at place k,
    /// and its couplings by id.
    #[allow(clippy::type_complexity)]
    fn laid_out(
        shape: Shape,
        heading: f64,
        g: &Geometry,
    ) -> (
        BTreeMap<RobotId, [f64; 3]>,
        Vec<(LinkKind, RobotId, RobotId)>,
    ) {
        let (at, links) = formation::layout(shape, g);
        let (s, c) = heading.sin_cos();
        let poses = at
            .iter()
            .enumerate()
            .map(|(k, o)| {
                let id = k as RobotId + 1;
                (
                    id,
                    [
                        0.2 + c * o[0] - s * o[1],
                        -0.1 + s * o[0] + c * o[1],
                        heading,
                    ],
                )
            })
            .collect();
        let couplings = links
            .iter()
            .map(|&(l, a, b)| (l.into(), a as RobotId + 1, b as RobotId + 1))
            .collect();
        (poses, couplings)
    }

    #[test]
    fn uneven_meshes_are_read_with_their_rows_and_a_misfit_is_named() {
        let g = Geometry::default();
        for (rows, robots) in [(2, 5), (2, 7), (3, 7), (2, 4)] {
            let shape = Shape::mesh_of(rows, robots).unwrap();
            for heading in [0.0, 0.9, -2.5] {
                let (poses, couplings) = laid_out(shape, heading, &g);
                let kinds = poses.keys().map(|&id| (id, RobotKind::NonPilot)).collect();
                let f = Formed::read(&poses, &kinds, &couplings, &g).unwrap();
                assert_eq!(f.shape, shape);
                assert_eq!(f.ids, (1..=robots as RobotId).collect::<Vec<_>>());
                assert!(f.fit_error < 1e-9, "{}: {}", shape.name(), f.fit_error);
            }
        }
        // A row of 3 with one robot knobbed beside it: not the 2 × 2 mesh of 4 robots.
        let poses: BTreeMap<RobotId, [f64; 3]> = (1..=4)
            .map(|id| (id, [-0.05 * f64::from(id), 0.0, 0.0]))
            .collect();
        let kinds = poses.keys().map(|&id| (id, RobotKind::NonPilot)).collect();
        let couplings = [
            (LinkKind::Anchor, 1, 2),
            (LinkKind::Anchor, 2, 3),
            (LinkKind::Knob, 2, 4),
        ];
        let err = Formed::read(&poses, &kinds, &couplings, &g).unwrap_err();
        assert_eq!(
            err,
            "rows of 3, 1 robots, right to left: not a mesh of 4 in 2 rows (mesh 2x2, longer \
             rows to the right)"
        );
    }
}
