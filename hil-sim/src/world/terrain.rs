//! Terrain support: which platform carries each robot (or coupled group), and falls.

use super::*;

pub(super) fn support_points(p: &RobotParams) -> Vec<V2> {
    let g = &p.geometry;
    let half = f64::from(g.wheel_base) * 0.5;
    if p.plant.four_wheels {
        let d = f64::from(p.plant.wheel_axle_offset);
        vec![[d, half], [d, -half], [-d, half], [-d, -half]]
    } else {
        let c = f64::from(p.plant.caster_offset);
        vec![[0.0, half], [0.0, -half], [c, 0.0], [-c, 0.0]]
    }
}

impl World {
    pub(super) fn terrain_step(&mut self, t_us: u64) {
        // Coupled groups (union–find over coupled links).
        let n = self.robots.len();
        let mut groups = petgraph::unionfind::UnionFind::<usize>::new(n);
        for (a, b, _) in self.mech.coupled() {
            groups.union(a, b);
        }
        let mut blocked = Vec::new();
        for i in 0..n {
            let r = &mut self.robots[i];
            if r.fallen {
                continue;
            }
            let Some((h, _)) = self.terrain.support_at(r.pose.pos()) else {
                continue; // over a gap: decided per group below
            };
            let max_climb = f64::from(r.params.plant.max_climb);
            if h > r.z + max_climb {
                blocked.push(i);
            } else if h < r.z - DROP_REPORT {
                self.events.push(SimEvent {
                    t_us,
                    kind: EventKind::Dropped {
                        id: r.id,
                        height: r.z - h,
                    },
                });
                r.z = h;
            } else {
                r.z = h;
            }
        }
        for i in blocked {
            // Push back to where the robot came from: undo this step's motion.
            let r = &mut self.robots[i];
            let dt = self.step_us as f64 * 1e-6;
            let [s, c] = r.trig;
            r.pose.x -= (c * r.drive.v - s * r.drive.vy) * dt;
            r.pose.y -= (s * r.drive.v + c * r.drive.vy) * dt;
            r.drive.v = 0.0;
            r.drive.vy = 0.0;
            self.bodies[i].pose = r.pose;
            if !self
                .events
                .iter()
                .rev()
                .take(8)
                .any(|e| e.kind == EventKind::Blocked { id: r.id })
            {
                self.events.push(SimEvent {
                    t_us,
                    kind: EventKind::Blocked { id: r.id },
                });
            }
        }
        // Groups with a member over a gap: does the group's support polygon hold it?
        let mut roots: Vec<usize> = Vec::new();
        for i in 0..n {
            let r = &self.robots[i];
            if !r.fallen && self.terrain.support_at(r.pose.pos()).is_none() {
                let root = groups.find_mut(i);
                if !roots.contains(&root) {
                    roots.push(root);
                }
            }
        }
        for root in roots {
            let members: Vec<usize> = (0..n)
                .filter(|&i| !self.robots[i].fallen && groups.find_mut(i) == root)
                .collect();
            let mut pts = Vec::new();
            let mut com = [0.0, 0.0];
            let mut mass = 0.0;
            for &i in &members {
                let r = &self.robots[i];
                for &p in &r.support_points {
                    let w = r.pose.apply(p);
                    if self.terrain.support_at(w).is_some() {
                        pts.push(w);
                    }
                }
                com = add(com, [r.pose.x * r.model.m, r.pose.y * r.model.m]);
                mass += r.model.m;
            }
            let com = [com[0] / mass, com[1] / mass];
            if !in_convex_hull(&pts, com) {
                for &i in &members {
                    self.fall(i, t_us);
                }
            }
        }
    }

    fn fall(&mut self, i: usize, t_us: u64) {
        let r = &mut self.robots[i];
        r.fallen = true;
        r.z -= 0.1;
        r.drive.v = 0.0;
        r.drive.vy = 0.0;
        r.drive.omega = 0.0;
        self.bodies[i].active = false;
        self.events.push(SimEvent {
            t_us,
            kind: EventKind::Fell { id: r.id },
        });
        let mut ev = Vec::new();
        self.mech.detach_robot(i, &mut ev);
        for e in ev {
            if let LinkEvent::Decoupled(kind, a, b) = e {
                let (a, b) = (self.robots[a].id, self.robots[b].id);
                self.events.push(SimEvent {
                    t_us,
                    kind: EventKind::Decoupled { kind, a, b },
                });
            }
        }
    }
}
