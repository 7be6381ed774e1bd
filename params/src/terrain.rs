//! Terrain: platforms (polygons with heights); gaps and steps are what lies between them.
//! One description shared by the simulator, the host and the stability gate.

use serde::{Deserialize, Serialize};

/// A flat, horizontal platform: a convex or simple polygon (world x, y in m) at a height (m).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Platform {
    /// Human name (for reports), e.g. "start", "far side".
    #[serde(default)]
    pub name: String,
    /// Polygon vertices, counter-clockwise, world frame (m).
    pub polygon: Vec<[f64; 2]>,
    /// Height of the top surface (m); the floor is 0.
    #[serde(default)]
    pub height: f64,
    /// Coulomb friction coefficient of the surface.
    #[serde(default = "default_friction")]
    pub friction: f64,
}

fn default_friction() -> f64 {
    0.6
}

/// The world the robots drive on. No platform at all means an infinite floor at height 0.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Terrain {
    /// Platforms; a point on none of them is over a gap (nothing to stand on).
    pub platforms: Vec<Platform>,
}

impl Platform {
    /// Axis-aligned rectangular platform.
    pub fn rect(name: &str, min: [f64; 2], max: [f64; 2], height: f64) -> Self {
        Platform {
            name: name.to_string(),
            polygon: vec![min, [max[0], min[1]], max, [min[0], max[1]]],
            height,
            friction: default_friction(),
        }
    }

    /// True when `p` lies inside (or on the edge of) the polygon.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        point_in_polygon(&self.polygon, p)
    }
}

impl Terrain {
    /// An endless flat floor.
    pub fn flat() -> Self {
        Terrain::default()
    }

    /// Two rectangular platforms of equal height separated by a gap of `gap` m along x,
    /// the near edge at x = `edge_x`, each `depth` m long and `width` m wide (centred on y = 0).
    pub fn gap(edge_x: f64, gap: f64, depth: f64, width: f64, height: f64) -> Self {
        let hw = width * 0.5;
        Terrain {
            platforms: vec![
                Platform::rect("near", [edge_x - depth, -hw], [edge_x, hw], height),
                Platform::rect(
                    "far",
                    [edge_x + gap, -hw],
                    [edge_x + gap + depth, hw],
                    height,
                ),
            ],
        }
    }

    /// The support under `p`: the highest platform containing it, its height and friction.
    /// `None` means a gap (nothing underneath). With no platforms, the floor is everywhere.
    pub fn support_at(&self, p: [f64; 2]) -> Option<(f64, f64)> {
        if self.platforms.is_empty() {
            return Some((0.0, default_friction()));
        }
        self.platforms
            .iter()
            .filter(|pl| pl.contains(p))
            .map(|pl| (pl.height, pl.friction))
            .max_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// Check the description: at least three vertices, finite numbers, friction ≥ 0.
    /// Errors name the platform index and field.
    pub fn validate(&self) -> Result<(), String> {
        for (i, pl) in self.platforms.iter().enumerate() {
            if pl.polygon.len() < 3 {
                return Err(format!("platforms[{i}].polygon: needs at least 3 vertices"));
            }
            if pl.polygon.iter().flatten().any(|v| !v.is_finite()) {
                return Err(format!("platforms[{i}].polygon: non-finite coordinate"));
            }
            if !pl.height.is_finite() {
                return Err(format!("platforms[{i}].height: not finite"));
            }
            if !(pl.friction.is_finite() && pl.friction >= 0.0) {
                return Err(format!("platforms[{i}].friction: must be ≥ 0"));
            }
        }
        Ok(())
    }

    /// [`Terrain::validate`], and solid platforms as the 3-D world and the crossing planner
    /// need them: convex counter-clockwise polygons with positive area that do not overlap.
    /// Errors name the platform index and field.
    pub fn validate_solid(&self) -> Result<(), String> {
        self.validate()?;
        let t = self;
        for (i, p) in t.platforms.iter().enumerate() {
            let area = signed_area(&p.polygon);
            if area <= 1e-12 {
                return Err(format!(
                    "platforms[{i}].polygon: needs a positive area, counter-clockwise (area {area:.3e} m²)"
                ));
            }
            if !is_convex(&p.polygon) {
                return Err(format!("platforms[{i}].polygon: must be convex"));
            }
        }
        for i in 0..t.platforms.len() {
            for j in i + 1..t.platforms.len() {
                if overlap(&t.platforms[i].polygon, &t.platforms[j].polygon) {
                    return Err(format!(
                        "platforms[{j}].polygon: overlaps platforms[{i}] ({:?} and {:?})",
                        t.platforms[j].name, t.platforms[i].name
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Even-odd point-in-polygon test; points on an edge count as inside.
pub fn point_in_polygon(poly: &[[f64; 2]], p: [f64; 2]) -> bool {
    let n = poly.len();
    if n < 3 {
        return false;
    }
    let mut inside = false;
    let mut j = n - 1;
    for i in 0..n {
        let (a, b) = (poly[i], poly[j]);
        // On-edge check (collinear and within the segment's box).
        let cross = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        if cross.abs() < 1e-12
            && p[0] >= a[0].min(b[0]) - 1e-12
            && p[0] <= a[0].max(b[0]) + 1e-12
            && p[1] >= a[1].min(b[1]) - 1e-12
            && p[1] <= a[1].max(b[1]) + 1e-12
        {
            return true;
        }
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

fn signed_area(poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        * 0.5
}

fn is_convex(poly: &[[f64; 2]]) -> bool {
    let n = poly.len();
    (0..n).all(|i| {
        let (a, b, c) = (poly[i], poly[(i + 1) % n], poly[(i + 2) % n]);
        (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]) >= -1e-12
    })
}

/// Interiors intersect (separating-axis test; touching edges do not count).
fn overlap(p: &[[f64; 2]], q: &[[f64; 2]]) -> bool {
    for poly in [p, q] {
        let n = poly.len();
        for i in 0..n {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            let axis = [b[1] - a[1], a[0] - b[0]];
            let proj = |s: &[[f64; 2]]| {
                s.iter().fold((f64::MAX, f64::MIN), |(lo, hi), v| {
                    let d = v[0] * axis[0] + v[1] * axis[1];
                    (lo.min(d), hi.max(d))
                })
            };
            let (p0, p1) = proj(p);
            let (q0, q1) = proj(q);
            let tol = 1e-9 * (axis[0].abs() + axis[1].abs());
            if p1 <= q0 + tol || q1 <= p0 + tol {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gap_terrain_supports_both_sides_but_not_the_gap() {
        let t = Terrain::gap(0.0, 0.03, 1.0, 1.0, 0.1);
        assert_eq!(t.support_at([-0.1, 0.0]).map(|s| s.0), Some(0.1));
        assert_eq!(t.support_at([0.015, 0.0]), None);
        assert_eq!(t.support_at([0.05, 0.0]).map(|s| s.0), Some(0.1));
        assert!(Terrain::flat().support_at([5.0, 5.0]).is_some());
        assert!(t.validate().is_ok());
    }

    #[test]
    fn bad_platforms_are_named() {
        let mut t = Terrain::gap(0.0, 0.04, 0.5, 0.5, 0.0);
        assert!(t.validate_solid().is_ok());
        t.platforms[1].polygon[0][0] = -0.1; // far platform now reaches over the near one
        let e = t.validate_solid().unwrap_err();
        assert!(e.starts_with("platforms[1].polygon"), "{e}");
        let mut t = Terrain::gap(0.0, 0.04, 0.5, 0.5, 0.0);
        t.platforms[0].polygon.reverse();
        assert!(t
            .validate_solid()
            .unwrap_err()
            .contains("counter-clockwise"));
        let mut t = Terrain::gap(0.0, 0.04, 0.5, 0.5, 0.0);
        t.platforms[0].height = f64::NAN;
        assert!(t
            .validate_solid()
            .unwrap_err()
            .starts_with("platforms[0].height"));
        let mut t = Terrain::gap(0.0, 0.04, 0.5, 0.5, 0.0);
        t.platforms[0].polygon = vec![[0.0, 0.0], [1.0, 0.0], [0.2, 0.2], [0.0, 1.0]];
        assert!(t.validate_solid().unwrap_err().contains("convex"));
    }
}
