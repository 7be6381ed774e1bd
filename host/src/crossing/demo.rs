//! The end of `puzzlebot demo`: the mesh the 2-D run formed crosses a 40 mm gap that one
//! robot cannot. The lab sets the formed assembly down on the near platform of a gap
//! (host/stability/examples/gap40.toml), as THESIS's crossing experiments do; a lone
//! non-pilot goes first and falls in; the planner ranks the assembly's headings by the
//! stability gate and the host refuses to start unless the gate proves the whole crossing;
//! the mesh then drives across at the chosen heading in the 3-D world, re-checked by the gate
//! at every 5 mm of advance, and is taken apart on the far platform.

use super::drive3d::{self, CrossOutcome, CrossSettings, DissolveOutcome};
use super::formed::Formed;
use crate::assemble::AssemblyReport;
use puzzlebot_params::formation::Link;
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::{FleetParams, RobotKind};
use puzzlebot_protocol::RobotId;
use puzzlebot_sim::physics3d::{Event3d, World3d};
use puzzlebot_sim::{LinkKind, RobotSpec, Scenario};
use puzzlebot_stability::crossing::{plan, plan_formed, Candidate, CrossingOptions};
use serde::Serialize;
use std::collections::BTreeMap;

/// The demo's terrain: two platforms of equal height, 40 mm apart.
pub const TERRAIN: &str = include_str!("../../stability/examples/gap40.toml");

/// Seed of the 3-D runs.
const SEED: u64 = 1;

/// The demo's terrain, checked.
pub fn terrain() -> Result<Terrain, String> {
    let t: Terrain = toml::from_str(TERRAIN).map_err(|e| format!("gap40.toml: {e}"))?;
    t.validate_solid().map_err(|e| format!("gap40.toml: {e}"))?;
    Ok(t)
}

/// The lone robot's attempt.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Lone {
    /// Robot id.
    pub id: RobotId,
    /// What the gate proves of the advance it needs (m), and that advance.
    pub proven: f64,
    /// Advance it needs to stand on the far platform (m).
    pub required: f64,
    /// Time it fell into the gap after it started (s); None if it did not.
    pub fell_after_s: Option<f64>,
}

/// The whole crossing part of the demo.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DemoCrossing {
    /// Shape name of the formed assembly.
    pub shape: String,
    /// Robot ids at the layout's places (row-major, front first).
    pub ids: Vec<RobotId>,
    /// Pilot ids.
    pub pilots: Vec<RobotId>,
    /// Anchors and knobs that hold it.
    pub anchors: usize,
    /// Knobs that hold it.
    pub knobs: usize,
    /// Largest distance of a robot from its layout place in the 2-D run (m).
    pub fit_error: f64,
    /// The lone robot.
    pub lone: Lone,
    /// The planner's ranking of the assembly's headings, best first.
    pub plan: Vec<Candidate>,
    /// The drive across (None: refused by the gate).
    pub crossing: Option<CrossOutcome>,
    /// Taking it apart on the far platform (None: not across).
    pub dissolve: Option<DissolveOutcome>,
}

impl DemoCrossing {
    /// The crossing succeeded and the robots came apart on the far platform.
    pub fn ok(&self) -> bool {
        self.lone.fell_after_s.is_some()
            && self.crossing.as_ref().is_some_and(|c| c.crossed)
            && self
                .dissolve
                .as_ref()
                .is_some_and(|d| d.on_platform && d.spacing[1] > d.spacing[0])
    }

    /// Human-readable summary.
    pub fn render(&self) -> String {
        let mut s = String::new();
        let l = &self.lone;
        s += &format!(
            "gap        40 mm between two platforms of equal height (3-D world)\n\
             lone robot robot {}: the gate proves {:.0} mm of the {:.0} mm it needs; {}\n",
            l.id,
            l.proven * 1e3,
            l.required * 1e3,
            match l.fell_after_s {
                Some(t) => format!("driven at the gap it fell in after {t:.1} s"),
                None => "driven at the gap it did not fall (unexpected)".into(),
            }
        );
        s += &format!(
            "assembly   {} from the 2-D run, robots {:?}, pilots {:?}, {} anchors and {} knob(s), \
             within {:.1} mm of its layout\n",
            self.shape,
            self.ids,
            self.pilots,
            self.anchors,
            self.knobs,
            self.fit_error * 1e3
        );
        s += "plan       heading  proven_mm  needed_mm  stability\n";
        for c in &self.plan {
            s += &format!(
                "           {:>6.0}°  {:>9.1}  {:>9.1}  {:>9}  {}\n",
                c.heading_deg,
                c.advance.distance * 1e3,
                c.required * 1e3,
                c.stability_margin
                    .map_or("-".to_string(), |m| format!("{m:.3}")),
                if c.crosses() { "proven" } else { "refused" }
            );
        }
        let best = &self.plan[0];
        match &self.crossing {
            None => {
                s += &format!(
                    "refused    the gate proves {:.1} mm of the {:.1} mm the crossing needs\n",
                    best.advance.distance * 1e3,
                    best.required * 1e3
                )
            }
            Some(c) => {
                s += &format!(
                    "crossing   at {:.0}° (the diagonal angle α is {:.1}°): {} of {} robots across after \
                     {:.1} s, advance {:.0} mm, {} gate checks{}{}{}; knobs loaded to {:.0} % of their hold\n",
                    best.heading_deg,
                    best.diagonal_deg,
                    c.across,
                    self.ids.len(),
                    c.drive_s,
                    c.advance * 1e3,
                    c.gate_checks,
                    c.gate_stop
                        .as_ref()
                        .map_or(String::new(), |(d, why)| format!(
                            ", the gate stopped it at {:.0} mm ({why})",
                            d * 1e3
                        )),
                    if c.fell.is_empty() {
                        ", none fell".to_string()
                    } else {
                        format!(", fell {:?}", c.fell)
                    },
                    if c.broke.is_empty() {
                        ", no connector opened".to_string()
                    } else {
                        format!(", opened {:?}", c.broke)
                    },
                    c.peak_knob_share * 100.0
                );
            }
        }
        if let Some(d) = &self.dissolve {
            s += &format!(
                "dissolve   {} couplings lifted open; robots spread from {:.0} mm to {:.0} mm apart, \
                 {} of {} at their goals, {}\n",
                d.opened,
                d.spacing[0] * 1e3,
                d.spacing[1] * 1e3,
                d.at_goal,
                self.ids.len(),
                if d.on_platform {
                    "all on the far platform"
                } else {
                    "some left the far platform"
                }
            );
        }
        s
    }
}

/// The 2-D part of the demo: its scenario up to the first decoupling (form the mesh, drive
/// it, hold it), which then crosses in the 3-D world and comes apart there.
pub fn formation_part(mut s: puzzlebot_assembly::Scenario) -> puzzlebot_assembly::Scenario {
    use puzzlebot_assembly::scenario::Behaviour;
    if let Some(k) = s
        .steps
        .iter()
        .position(|st| matches!(st.behaviour, Behaviour::Decouple { .. }))
    {
        s.steps.truncate(k);
    }
    s
}

/// Couplings holding at the end of a 2-D run (kind, robot with the anchor / knob, robot with
/// the opening / hole), from its ground truth.
pub fn couplings_at_end(report: &AssemblyReport) -> Vec<(LinkKind, RobotId, RobotId)> {
    let mut held: Vec<(LinkKind, RobotId, RobotId)> = Vec::new();
    for c in &report.coupling_truth {
        let kind = match c.kind {
            crate::replay::timeline::Kind::Anchor => LinkKind::Anchor,
            crate::replay::timeline::Kind::Knob => LinkKind::Knob,
        };
        let key = (kind, c.a, c.b);
        held.retain(|k| *k != key);
        if c.coupled {
            held.push(key);
        }
    }
    held
}

/// Run the crossing part of the demo on the assembly `report`'s 2-D run formed (robots of
/// kinds `kinds`), with its poses and couplings at the end of that run.
pub fn run(
    report: &AssemblyReport,
    kinds: &BTreeMap<RobotId, RobotKind>,
) -> Result<DemoCrossing, String> {
    run_with(
        &report.final_poses,
        kinds,
        &couplings_at_end(report),
        &CrossSettings::default(),
    )
}

/// [`run`] from the poses, kinds and couplings of the formed assembly.
pub fn run_with(
    poses: &BTreeMap<RobotId, [f64; 3]>,
    kinds: &BTreeMap<RobotId, RobotKind>,
    couplings: &[(LinkKind, RobotId, RobotId)],
    settings: &CrossSettings,
) -> Result<DemoCrossing, String> {
    let params = FleetParams::default();
    let terrain = terrain()?;
    let formed = Formed::read(poses, kinds, couplings, &params.non_pilot.geometry)
        .map_err(|e| format!("the formed assembly: {e}"))?;
    let opt = drive3d::crossing_options(settings, &params);
    let lone_id = formed
        .ids
        .iter()
        .zip(&formed.kinds)
        .find(|(_, k)| **k == RobotKind::NonPilot)
        .map_or(formed.ids[0], |(id, _)| *id);
    let lone = lone_attempt(lone_id, &terrain, &params, &opt, settings)?;
    let ranked = plan_formed(
        &terrain,
        &params,
        formed.shape,
        &formed.pilots(),
        &formed.links,
        &opt,
    )
    .map_err(|e| e.to_string())?;
    let mut out = DemoCrossing {
        shape: formed.shape.name(),
        ids: formed.ids.clone(),
        pilots: formed.pilots().iter().map(|&k| formed.ids[k]).collect(),
        anchors: formed.count(Link::Anchor),
        knobs: formed.count(Link::Knob),
        fit_error: formed.fit_error,
        lone,
        plan: ranked,
        crossing: None,
        dissolve: None,
    };
    let best = out.plan[0].clone();
    if !best.crosses() {
        return Ok(out); // the host never starts a crossing the gate cannot prove
    }
    let s = drive3d::scenario(&formed, &best, &terrain, &params, SEED);
    let mut w = World3d::new(&s, settings.world).map_err(|e| e.to_string())?;
    let c = drive3d::cross(&mut w, &best, &terrain, &params, settings);
    if c.crossed {
        out.dissolve = Some(drive3d::dissolve(
            &mut w,
            best.heading_deg.to_radians(),
            &terrain,
            &params,
            6.0,
        ));
    }
    out.crossing = Some(c);
    Ok(out)
}

/// A lone robot `id` (a non-pilot) at the gap: the gate's answer, then the physics.
fn lone_attempt(
    id: RobotId,
    terrain: &Terrain,
    params: &FleetParams,
    opt: &CrossingOptions,
    settings: &CrossSettings,
) -> Result<Lone, String> {
    let straight = CrossingOptions {
        headings: vec![0.0],
        ..opt.clone()
    };
    let c = plan(terrain, params, 1, 0, &straight).map_err(|e| e.to_string())?;
    let c = &c[0];
    let s = Scenario {
        seed: SEED,
        robots: vec![RobotSpec {
            id,
            kind: RobotKind::NonPilot,
            pose: [c.start[0], c.start[1], 0.0],
            impairments: None,
            offline: false,
            mismatch: Default::default(),
        }],
        terrain: terrain.clone(),
        params: params.clone(),
        ..Scenario::default()
    };
    let mut w = World3d::new(&s, settings.world).map_err(|e| e.to_string())?;
    w.run_for((settings.settle_s * 1e6) as u64);
    let t0 = w.time_us();
    let rpm = drive3d::rpm_for(settings.speed, params);
    w.command_all(Some([rpm, rpm]));
    w.run_for(((c.required / settings.speed + 2.0) * 1e6) as u64);
    let fell_after_s = w.events().iter().find_map(|e| match e {
        Event3d::Fell { t_us, .. } => Some((t_us - t0) as f64 * 1e-6),
        _ => None,
    });
    Ok(Lone {
        id,
        proven: c.advance.distance,
        required: c.required,
        fell_after_s,
    })
}
