//! Collision-free routes for a robot driving alone among robots that stand still (an assembly
//! holding while a robot joins it, robots waiting their turn): A* (the `pathfinding` crate) on
//! a grid around the robots, every other robot a disc it must keep clear of, then the corners
//! of the grid path shortcut where the straight line is clear. The MPC has no obstacle terms;
//! this is what keeps a joining robot from pushing the assembly it is joining.

use pathfinding::prelude::astar;

/// Grid step of the route search (m).
pub const CELL: f64 = 0.01;

/// Cells along the longer side of the search area at most: an area wider than this many
/// [`CELL`]s (a robot routing back from metres away) is searched on a coarser grid, so one
/// search stays within ~10⁵ cells when no way is found.
pub const MAX_SIDE_CELLS: f64 = 400.0;

/// Obstacles and clearance of a route search.
#[derive(Debug, Clone, Copy)]
pub struct Field<'a> {
    /// Centres of the robots to keep clear of (m).
    pub obstacles: &'a [[f64; 2]],
    /// Smallest centre distance to any obstacle (m).
    pub clearance: f64,
}

impl Field<'_> {
    /// Distance to the nearest obstacle (∞ without obstacles).
    pub fn nearest(&self, p: [f64; 2]) -> f64 {
        self.nearest_sq(p).sqrt()
    }

    /// Squared distance to the nearest obstacle (m²; the route search's inner loop: no
    /// square root per obstacle).
    fn nearest_sq(&self, p: [f64; 2]) -> f64 {
        self.obstacles
            .iter()
            .map(|o| {
                let (dx, dy) = (o[0] - p[0], o[1] - p[1]);
                dx * dx + dy * dy
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// True when the straight segment a→b keeps the clearance (see [`Ends`] for the
    /// exceptions near its start and end).
    pub fn segment_free(&self, a: [f64; 2], b: [f64; 2], ends: &Ends) -> bool {
        // Every obstacle at least the clearance from the whole segment: free (the samples
        // below lie on it). Otherwise the samples decide (the relaxed ends).
        let (ux, uy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = ux * ux + uy * uy;
        let clear2 = self.clearance * self.clearance;
        if self.obstacles.iter().all(|o| {
            let s = if len2 > 0.0 {
                (((o[0] - a[0]) * ux + (o[1] - a[1]) * uy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (dx, dy) = (o[0] - a[0] - s * ux, o[1] - a[1] - s * uy);
            dx * dx + dy * dy >= clear2
        }) {
            return true;
        }
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        let n = (len / (0.5 * CELL)).ceil().max(1.0) as usize;
        (1..=n).all(|k| {
            let s = k as f64 / n as f64;
            ends.open(self, [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])])
        })
    }
}

/// Within [`NEAR_END`] of the start or the goal a point may be as close to an obstacle as the
/// start or goal itself is: a robot that starts close to another may leave, and the goal may
/// be beside a robot (the start of an approach along an assembly's side).
#[derive(Debug, Clone, Copy)]
pub struct Ends {
    start: [f64; 2],
    start_gap: f64,
    goal: [f64; 2],
    goal_gap: f64,
}

/// Radius around the start and the goal where [`Ends`] relaxes the clearance (m).
pub const NEAR_END: f64 = 0.1;

impl Ends {
    fn new(field: &Field<'_>, start: [f64; 2], goal: [f64; 2]) -> Self {
        Ends {
            start,
            start_gap: field.nearest(start) - 1e-9,
            goal,
            goal_gap: field.nearest(goal) - 1e-9,
        }
    }
    fn open(&self, field: &Field<'_>, p: [f64; 2]) -> bool {
        // Compared squared (every distance and gap here is ≥ 0, or a gap is ≤ 0 and any
        // distance passes it).
        let d2 = field.nearest_sq(p);
        let at_least = |gap: f64| gap <= 0.0 || d2 >= gap * gap;
        let near = |q: [f64; 2]| {
            let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
            dx * dx + dy * dy < NEAR_END * NEAR_END
        };
        at_least(field.clearance)
            || (near(self.start) && at_least(self.start_gap))
            || (near(self.goal) && at_least(self.goal_gap))
    }
}

/// The obstacles a route between `start` and `goal` can meet, and the corners of the box
/// round them, start and goal: every obstacle within `margin` of the box, the box grown by
/// each one taken in until none is left (a line of robots across the way is taken in whole;
/// a robot metres away is not, so the grid does not span the floor to reach it).
fn search_area(
    start: [f64; 2],
    goal: [f64; 2],
    field: &Field<'_>,
    margin: f64,
) -> (Vec<[f64; 2]>, [f64; 2], [f64; 2]) {
    let mut lo = [start[0].min(goal[0]), start[1].min(goal[1])];
    let mut hi = [start[0].max(goal[0]), start[1].max(goal[1])];
    let mut taken = vec![false; field.obstacles.len()];
    let reach = margin + field.clearance;
    loop {
        let mut grew = false;
        for (o, t) in field.obstacles.iter().zip(taken.iter_mut()) {
            let inside = o[0] > lo[0] - reach
                && o[0] < hi[0] + reach
                && o[1] > lo[1] - reach
                && o[1] < hi[1] + reach;
            if !*t && inside {
                *t = true;
                grew = true;
                lo = [lo[0].min(o[0]), lo[1].min(o[1])];
                hi = [hi[0].max(o[0]), hi[1].max(o[1])];
            }
        }
        if !grew {
            break;
        }
    }
    let near = field
        .obstacles
        .iter()
        .zip(&taken)
        .filter(|(_, &t)| t)
        .map(|(o, _)| *o)
        .collect();
    (near, lo, hi)
}

/// A route from `start` to `goal` keeping `field`'s clearance (relaxed near both ends, see
/// [`Ends`]): waypoints after the start, ending at `goal`; None when the goal is nearer than
/// `goal_gap` to an obstacle or unreachable within the search area (the bounding box of
/// start, goal and the obstacles near them ([`search_area`]), widened by `margin`).
pub fn route(
    start: [f64; 2],
    goal: [f64; 2],
    field: &Field<'_>,
    goal_gap: f64,
    margin: f64,
) -> Option<Vec<[f64; 2]>> {
    if field.nearest(goal) < goal_gap {
        return None;
    }
    let ends = Ends::new(field, start, goal);
    if field.segment_free(start, goal, &ends) {
        return Some(vec![goal]);
    }
    let (near, lo, hi) = search_area(start, goal, field, margin);
    let field = &Field {
        obstacles: &near,
        clearance: field.clearance,
    };
    let lo = [lo[0] - margin, lo[1] - margin];
    let extent = (hi[0] + margin - lo[0]).max(hi[1] + margin - lo[1]);
    let step = CELL.max(extent / MAX_SIDE_CELLS);
    let nx = ((hi[0] + margin - lo[0]) / step).ceil() as i32 + 1;
    let ny = ((hi[1] + margin - lo[1]) / step).ceil() as i32 + 1;
    let at = |c: (i32, i32)| [lo[0] + c.0 as f64 * step, lo[1] + c.1 as f64 * step];
    let cell = |p: [f64; 2]| {
        (
            ((p[0] - lo[0]) / step).round() as i32,
            ((p[1] - lo[1]) / step).round() as i32,
        )
    };
    let (c0, c1) = (cell(start), cell(goal));
    let open = |c: (i32, i32)| {
        c.0 >= 0 && c.1 >= 0 && c.0 < nx && c.1 < ny && (c == c1 || ends.open(field, at(c)))
    };
    const STEPS: [(i32, i32, u32); 8] = [
        (1, 0, 10),
        (-1, 0, 10),
        (0, 1, 10),
        (0, -1, 10),
        (1, 1, 14),
        (1, -1, 14),
        (-1, 1, 14),
        (-1, -1, 14),
    ];
    let (path, _) = astar(
        &c0,
        |&c| {
            STEPS
                .iter()
                .map(move |&(dx, dy, w)| ((c.0 + dx, c.1 + dy), w))
                .filter(|&(n, _)| open(n))
                .collect::<Vec<_>>()
        },
        |&c| {
            let (dx, dy) = ((c.0 - c1.0).unsigned_abs(), (c.1 - c1.1).unsigned_abs());
            10 * dx.max(dy) + 4 * dx.min(dy)
        },
        |&c| c == c1,
    )?;
    // Shortcut: from each kept point, go along the path while the straight line to the next
    // point stays clear (linear in the path's length; searching back from the far end made a
    // long winding path quadratic).
    let pts: Vec<[f64; 2]> = path.iter().map(|&c| at(c)).collect();
    let mut out = Vec::new();
    let mut from = start;
    let mut k = 0;
    while k + 1 < pts.len() {
        let mut j = k + 1;
        while j + 1 < pts.len() && field.segment_free(from, pts[j + 1], &ends) {
            j += 1;
        }
        from = pts[j];
        out.push(from);
        k = j;
    }
    if let Some(last) = out.last_mut() {
        *last = goal;
    } else {
        out.push(goal);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clear_of(path: &[[f64; 2]], start: [f64; 2], f: &Field<'_>) -> bool {
        let ends = Ends::new(f, start, *path.last().unwrap());
        let mut a = start;
        path.iter().all(|&b| {
            let ok = f.segment_free(a, b, &ends);
            a = b;
            ok
        })
    }

    #[test]
    fn an_open_floor_gives_the_straight_line() {
        let f = Field {
            obstacles: &[[1.0, 1.0]],
            clearance: 0.08,
        };
        assert_eq!(
            route([0.0, 0.0], [0.3, 0.0], &f, 0.075, 0.2),
            Some(vec![[0.3, 0.0]])
        );
    }

    #[test]
    fn a_row_of_robots_in_the_way_is_driven_round() {
        // A wall of robots across the straight line.
        let wall: Vec<[f64; 2]> = (-3..=3).map(|k| [0.2, k as f64 * 0.05]).collect();
        let f = Field {
            obstacles: &wall,
            clearance: 0.075,
        };
        let p = route([0.0, 0.0], [0.4, 0.0], &f, 0.075, 0.3).expect("a way round");
        assert!(p.len() >= 2, "{p:?}");
        assert!(clear_of(&p, [0.0, 0.0], &f), "{p:?}");
        assert_eq!(*p.last().unwrap(), [0.4, 0.0]);
        // It goes round an end of the wall.
        assert!(p.iter().any(|q| q[1].abs() > 0.15 + 0.07), "{p:?}");
    }

    #[test]
    fn a_blocked_goal_has_no_route() {
        let f = Field {
            obstacles: &[[0.3, 0.0]],
            clearance: 0.075,
        };
        assert_eq!(route([0.0, 0.0], [0.32, 0.0], &f, 0.05, 0.2), None);
    }

    #[test]
    fn a_goal_beside_a_robot_is_reached_from_the_open_side() {
        // The start of an approach along an assembly's side: 56 mm from its robots.
        let row: Vec<[f64; 2]> = (0..3).map(|k| [k as f64 * 0.05, 0.0]).collect();
        let f = Field {
            obstacles: &row,
            clearance: 0.075,
        };
        let goal = [-0.02, 0.056];
        let p = route([0.1, 0.3], goal, &f, 0.05, 0.3).expect("a route");
        assert_eq!(*p.last().unwrap(), goal);
        assert!(clear_of(&p, [0.1, 0.3], &f), "{p:?}");
    }

    #[test]
    fn a_robot_far_across_the_floor_does_not_widen_the_search() {
        // A goal enclosed by a ring of robots (no way in: the search exhausts its area) and
        // one robot 40 m away: the area stays round the ring, so the answer comes at once.
        let mut obstacles: Vec<[f64; 2]> = (0..16)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 16.0;
                [0.5 + 0.12 * a.cos(), 0.12 * a.sin()]
            })
            .collect();
        obstacles.push([40.0, 30.0]);
        let f = Field {
            obstacles: &obstacles,
            clearance: 0.075,
        };
        let t0 = std::time::Instant::now();
        assert_eq!(route([0.0, 0.0], [0.5, 0.0], &f, 0.0, 0.3), None);
        assert!(t0.elapsed().as_secs_f64() < 1.0, "{:?}", t0.elapsed());
        // Routing in from far away: a coarser grid over the long way.
        let t0 = std::time::Instant::now();
        assert_eq!(route([-30.0, 20.0], [0.5, 0.0], &f, 0.0, 0.3), None);
        assert!(t0.elapsed().as_secs_f64() < 1.0, "{:?}", t0.elapsed());
        let (near, lo, hi) = search_area([0.0, 0.0], [0.5, 0.0], &f, 0.3);
        assert_eq!(near.len(), 16);
        assert!(hi[0] - lo[0] < 1.0 && hi[1] - lo[1] < 1.0, "{lo:?} {hi:?}");
    }

    #[test]
    fn a_robot_starting_too_close_may_leave() {
        let f = Field {
            obstacles: &[[0.05, 0.0]],
            clearance: 0.075,
        };
        let p = route([0.0, 0.0], [-0.3, 0.0], &f, 0.075, 0.2).expect("it backs away");
        assert_eq!(p, vec![[-0.3, 0.0]]);
    }
}
