//! A scenario's `cross` step on the host: read the formed assembly from the measured poses
//! and the pairs the coordinator counts as connected, plan its crossing from where it
//! stands along its own heading ([`plan_placed`]), refuse with the number that failed when
//! the stability gate cannot prove all of it, and otherwise hand the robots to the crossing
//! behaviour ([`CrossingController`]) until it reports across or why not.

use std::collections::BTreeMap;
use std::path::PathBuf;

use puzzlebot_assembly::scenario::Behaviour;
use puzzlebot_assembly::{Coordinator, PairStatus, PairType, Pose, Scenario as AsmScenario};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::RobotId;
use puzzlebot_sim::LinkKind;
use puzzlebot_stability::crossing::{
    load_terrain, plan_formed, plan_placed, Candidate, MAX_HEADING,
};
use puzzlebot_stability::puzzlebot::RobotPose;

use crate::control::FleetView;
use crate::crossing::controller::{assembly_of, CrossStop, CrossingController};
use crate::crossing::drive3d::{crossing_options, CrossSettings};
use crate::crossing::formed::Formed;

/// The terrain of every cross step of `scenario`, loaded and checked before anything moves;
/// an error names the step and the file, line and field.
pub fn load_terrains(scenario: &AsmScenario) -> anyhow::Result<BTreeMap<PathBuf, Terrain>> {
    let mut out = BTreeMap::new();
    for step in &scenario.steps {
        if let Behaviour::Cross { terrain } = &step.behaviour {
            let t = load_terrain(terrain).map_err(|e| {
                anyhow::anyhow!("step '{}' (line {}): terrain: {e}", step.label, step.line)
            })?;
            out.insert(terrain.clone(), t);
        }
    }
    Ok(out)
}

/// The ground a fleet running `scenario` stands on from its start, when the scenario
/// crosses terrain: its first cross step's terrain (from `terrains`, as
/// [`load_terrains`] loaded them). The steps before the crossing move the robots on it too,
/// so the host's gate keeps them from its edges and a simulated world has it from the start.
pub fn ground_of(scenario: &AsmScenario, terrains: &BTreeMap<PathBuf, Terrain>) -> Option<Terrain> {
    scenario
        .steps
        .iter()
        .find_map(|step| match &step.behaviour {
            Behaviour::Cross { terrain } => terrains.get(terrain).cloned(),
            _ => None,
        })
}

/// The couplings the host believes hold (kind, robot with the anchor / knob, robot with the
/// opening / hole): the pairs the coordinator counts as connected, and every further knob
/// the measured poses of `view` show seated ([`seated_knobs`]).
pub fn believed_links(
    c: &Coordinator,
    view: &FleetView,
    params: &FleetParams,
) -> Vec<(LinkKind, RobotId, RobotId)> {
    let mut links = connected(c);
    for k in seated_knobs(view, params) {
        if !links.iter().any(|l| l.1 == k.1 && l.2 == k.2) {
            links.push(k);
        }
    }
    links
}

/// Couplings the coordinator counts as connected (kind, robot with the anchor / knob, robot
/// with the opening / hole).
fn connected(c: &Coordinator) -> Vec<(LinkKind, RobotId, RobotId)> {
    c.pairs()
        .iter()
        .filter(|p| p.status == PairStatus::Connected)
        .map(|p| {
            let kind = match p.pair.kind {
                PairType::AnchorOpening => LinkKind::Anchor,
                PairType::KnobHole => LinkKind::Knob,
            };
            (kind, p.pair.a, p.pair.b)
        })
        .collect()
}

/// Knob pairs the measured poses of `view` show seated (kind, robot with the knob, robot
/// with the hole), by the test the simulator and the coordinator use
/// ([`puzzlebot_params::coupling::Coupling::knob_seated`]) at its own tolerance: a mesh's
/// formation plans one pair per robot that joins, and neighbours set side by side seat
/// further knobs that carry load all the same. A knob the test misses only makes the
/// gate's picture weaker.
pub fn seated_knobs(view: &FleetView, params: &FleetParams) -> Vec<(LinkKind, RobotId, RobotId)> {
    use puzzlebot_assembly::pair::knob_seated_between;
    use puzzlebot_assembly::PairTolerances;
    let g = &params.non_pilot.geometry;
    let tol = PairTolerances::from_params(g, &params.non_pilot.coupling);
    let poses: Vec<(RobotId, Pose)> = view
        .robots
        .iter()
        .filter_map(|r| r.pose.map(|p| (r.id, Pose::new(p.x, p.y, p.theta))))
        .collect();
    let reach = 2.0 * f64::from(g.length.max(g.width));
    let mut out = Vec::new();
    for (a, pa) in &poses {
        for (b, pb) in &poses {
            if a == b || (pa.x - pb.x).hypot(pa.y - pb.y) > reach {
                continue;
            }
            if knob_seated_between(pa, pb, &tol, g) {
                out.push((LinkKind::Knob, *a, *b));
            }
        }
    }
    out
}

/// The crossing of the assembly of `view` held by `links` over `terrain`, from where it
/// stands along its heading; the host's crossing behaviour when the gate proves it all,
/// otherwise why not, with the number that failed and the heading that would cross, if any.
pub fn start(
    view: &FleetView,
    links: &[(LinkKind, RobotId, RobotId)],
    terrain: &Terrain,
    params: &FleetParams,
) -> Result<CrossingController, String> {
    let poses: BTreeMap<RobotId, [f64; 3]> = view
        .robots
        .iter()
        .filter_map(|r| r.pose.map(|p| (r.id, [p.x, p.y, p.theta])))
        .collect();
    let kinds: BTreeMap<RobotId, RobotKind> = view.robots.iter().map(|r| (r.id, r.kind)).collect();
    let g = &params.non_pilot.geometry;
    let formed =
        Formed::read(&poses, &kinds, links, g).map_err(|e| format!("the assembly: {e}"))?;
    let members: Vec<(RobotId, RobotPose)> = formed
        .ids
        .iter()
        .zip(&formed.kinds)
        .map(|(&id, &kind)| {
            let p = poses[&id];
            let pose = RobotPose {
                kind,
                x: p[0],
                y: p[1],
                yaw: p[2],
            };
            (id, pose)
        })
        .collect();
    // The assembly's heading: the mean of its robots' headings.
    let yaws: Vec<Pose> = members
        .iter()
        .map(|m| Pose::new(m.1.x, m.1.y, m.1.yaw))
        .collect();
    let heading = puzzlebot_assembly::assign::mean_heading(&yaws);
    let links: Vec<(LinkKind, RobotId, RobotId)> = formed
        .links
        .iter()
        .map(|&(l, a, b)| (l.into(), formed.ids[a], formed.ids[b]))
        .collect();
    if !heading.is_finite() || heading.abs() >= MAX_HEADING {
        return Err(format!(
            "refused: the {} heads {:.0}° from the crossing direction, where its straight \
             path runs along the edge (the planner takes headings within ±{:.0}°); form it \
             facing the gap",
            formed.shape.name(),
            heading.to_degrees(),
            MAX_HEADING.to_degrees()
        ));
    }
    let a = assembly_of(&members, &links, g);
    let settings = CrossSettings::for_params(params);
    let opt = crossing_options(&settings, params);
    let pilots = formed.pilots();
    // Nothing has moved: whatever keeps the planner from an answer is a refusal.
    let here = plan_placed(terrain, params, formed.shape, &pilots, &a, heading, &opt)
        .map_err(|e| format!("refused: {e}"))?;
    if !here.crosses() {
        let better = plan_formed(terrain, params, formed.shape, &pilots, &formed.links, &opt)
            .ok()
            .and_then(|r| r.into_iter().find(Candidate::crosses))
            .map_or("at no heading of the planner's".to_string(), |b| {
                format!("at {:.0}° from the crossing direction", b.heading_deg)
            });
        // Whole degrees, without a sign on 0.
        let heading_deg = match heading.to_degrees().round() {
            d if d.abs() < 0.5 => 0.0,
            d => d,
        };
        return Err(format!(
            "refused: along its heading ({:.0}° from the crossing direction) the gate proves \
             {:.0} mm of the {:.0} mm the {} needs ({:?}); it proves the crossing {better}",
            heading_deg,
            here.advance.distance * 1e3,
            here.required * 1e3,
            formed.shape.name(),
            here.advance.limited_by,
        ));
    }
    Ok(CrossingController::new(
        here,
        terrain.clone(),
        params.clone(),
        settings,
        formed.ids.clone(),
        links,
    ))
}

/// The step's result from how the crossing behaviour stopped (and where it backed off to).
pub fn result(stop: &CrossStop, advance: f64, backed_off_to: Option<f64>) -> Result<(), String> {
    match stop {
        CrossStop::Reached => Ok(()),
        CrossStop::Gate(why) => Err(format!(
            "stopped by the gate at {:.0} mm: {why}{}",
            advance * 1e3,
            backed_off_to.map_or(String::new(), |d| format!(
                "; backed off to the start ({:.0} mm from it)",
                d.abs() * 1e3
            ))
        )),
        CrossStop::Short => Err(format!(
            "stopped at {:.0} mm, the end of the advance the gate proved, with a robot not \
             across: the assembly left its heading, and the gate proves no advance from where \
             it stands that takes every robot across (the drive extends itself once)",
            advance * 1e3
        )),
        CrossStop::PoseLost(id) => Err(format!(
            "stopped at {:.0} mm: no pose of robot {id}",
            advance * 1e3
        )),
        CrossStop::OffHeading(err) => Err(format!(
            "stopped at {:.0} mm: the assembly turned {:.0}° off the heading the gate proved, \
             beyond an anchor's yaw range",
            advance * 1e3,
            err.to_degrees()
        )),
        CrossStop::TimedOut => Err(format!(
            "stopped at {:.0} mm: the crossing took too long",
            advance * 1e3
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::RobotView;
    use crate::drive::PoseSample;
    use puzzlebot_params::formation::{self, Shape};

    /// The robots of `shape`'s layout (robot k + 1 at place k, the first a pilot when
    /// `pilot`) with its front robot at `front`, heading `heading`.
    fn view_of(shape: Shape, front: [f64; 2], heading: f64, pilot: bool) -> FleetView {
        let p = FleetParams::default();
        let at = formation::layout(shape, &p.non_pilot.geometry).0;
        let (s, c) = heading.sin_cos();
        FleetView {
            t: 0.0,
            robots: at
                .iter()
                .enumerate()
                .map(|(k, o)| RobotView {
                    id: k as RobotId + 1,
                    kind: if pilot && k == 0 {
                        RobotKind::Pilot
                    } else {
                        RobotKind::NonPilot
                    },
                    pose: Some(PoseSample {
                        t: 0.0,
                        x: front[0] + c * o[0] - s * o[1],
                        y: front[1] + s * o[0] + c * o[1],
                        theta: heading,
                    }),
                    velocity: None,
                })
                .collect(),
            latency_s: 0.0,
        }
    }

    #[test]
    fn an_assembly_formed_along_the_edge_is_refused_with_its_heading() {
        let p = FleetParams::default();
        let terrain = Terrain::gap(0.30, 0.025, 1.0, 2.0, 0.0);
        let mesh = Shape::Mesh {
            rows: 2,
            per_row: 2,
        };
        let links: Vec<(LinkKind, RobotId, RobotId)> =
            formation::layout(mesh, &p.non_pilot.geometry)
                .1
                .iter()
                .map(|&(l, a, b)| (l.into(), a as RobotId + 1, b as RobotId + 1))
                .collect();
        let view = view_of(mesh, [0.0, 0.0], 1.6, true);
        let why = start(&view, &links, &terrain, &p).err().expect("refused");
        assert!(
            why.starts_with("refused: the mesh 2x2 heads 92° from the crossing direction")
                && why.contains("±86°"),
            "{why}"
        );
        // Facing the gap at 50°, the same mesh is planned and proven.
        let view = view_of(mesh, [0.0, 0.0], 50f64.to_radians(), true);
        assert!(start(&view, &links, &terrain, &p).is_ok());
    }

    #[test]
    fn the_knobs_a_mesh_layout_seats_are_read_from_its_poses() {
        let p = FleetParams::default();
        let mesh = Shape::Mesh {
            rows: 2,
            per_row: 2,
        };
        let links = formation::layout(mesh, &p.non_pilot.geometry).1;
        for heading in [0.0_f64, 0.7, -2.0] {
            let (s, c) = heading.sin_cos();
            let view = view_of(mesh, [0.3, -0.2], heading, false);
            let mut got: Vec<(RobotId, RobotId)> = seated_knobs(&view, &p)
                .into_iter()
                .map(|k| {
                    assert_eq!(k.0, LinkKind::Knob);
                    (k.1, k.2)
                })
                .collect();
            got.sort_unstable();
            let mut want: Vec<(RobotId, RobotId)> = links
                .iter()
                .filter(|l| l.0 == formation::Link::Knob)
                .map(|l| (l.1 as RobotId + 1, l.2 as RobotId + 1))
                .collect();
            want.sort_unstable();
            assert_eq!(got, want, "at {heading} rad");
            // Set apart by a centimetre sideways, no knob is seated.
            let mut apart = view.clone();
            for r in apart.robots.iter_mut().filter(|r| r.id > 2) {
                let q = r.pose.as_mut().unwrap();
                q.x -= s * 0.01;
                q.y += c * 0.01;
            }
            assert!(seated_knobs(&apart, &p).is_empty());
        }
    }
}
