//! Crossing planner: which formed shape, pilot places and heading carry `n` robots across the
//! gap ahead, ranked by the gate's margin (THESIS 5.2.4: heading θ against the diagonal angle
//! α; SPHERE's terrain-driven choice of configuration).
//!
//! Every candidate (each shape of [`Shape::candidates`], each distinct set of pilot places,
//! each heading) starts with its foremost body corner `clearance` behind the start platform's
//! far edge, its front robot on the line y = `start_y`, and drives along its heading. It
//! needs to advance `required` metres until every robot stands wholly on another platform
//! (its underside over it, no wheel still on the start platform's edge);
//! the gate ([`max_safe_advance_with`]) says how far it may advance proven stable. The margin
//! is the gate's distance less the required one: ≥ 0 crosses. Candidates that cross are
//! ranked first by whether they may stop anywhere (no stretch proven only at the crossing
//! speed), then by the smallest internal stability margin (SOCP (42)) the gate finds at
//! samples along the crossing; those that do not cross by how far short they stop.

use crate::gate::evaluate;
use crate::puzzlebot::{
    assembly_level, body_corners, build_model_with, contact_points, max_safe_advance_with,
    support_events, world, AdapterError, Advance, AdvanceOptions, LimitedBy, LoadTransfer,
    PuzzleAssembly, RobotPose, EVENT_EPS,
};
use crate::sag::Settling;
use puzzlebot_params::formation::{self, Link, Shape};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::FleetParams;
use serde::Serialize;

mod assembly;
mod command;

use assembly::place_of;
pub use assembly::{formed, formed_with, pilot_sets};
pub use command::{crossing_command, load_terrain, render, CrossingArgs, Drive};

/// Planner settings.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossingOptions {
    /// Headings to try (rad), measured from the +x crossing direction.
    pub headings: Vec<f64>,
    /// y of the front robot's start (m).
    pub start_y: f64,
    /// Gap between the foremost body corner and the start platform's edge at the start (m).
    pub clearance: f64,
    /// Scan step of the gate along the advance (m).
    pub step: f64,
    /// A robot over a platform at most this much lower rests on it (m,
    /// [`AdvanceOptions::max_drop`]); THESIS's crossings step down 5–6 mm.
    pub max_drop: f64,
    /// Acceleration of the drive the proof covers both ways (m/s²,
    /// [`AdvanceOptions::drive_accel`]): the crossing speed over the firmware's reference
    /// time constant. 0 (the default): quasi-static; the host sets its drive's.
    pub drive_accel: f64,
    /// The connectors' response to a sudden change of the support
    /// ([`AdvanceOptions::transfer`]).
    pub transfer: LoadTransfer,
    /// How the supports give and how high the bodies stand ([`AdvanceOptions::settling`]).
    pub settling: Option<Settling>,
    /// The speed the drive holds through a stretch where the assembly would tip if it
    /// stopped (m/s, [`AdvanceOptions::bridge_speed`]); 0 (the default): every advance must
    /// stand. The host sets its crossing speed.
    pub bridge_speed: f64,
}

impl CrossingOptions {
    /// The gate's options for a crossing of `required` m.
    pub fn advance_options(&self, required: f64) -> AdvanceOptions {
        AdvanceOptions {
            rigid_couplings: false,
            anchor_pitch_free: true,
            anchor_slides: true,
            knob_tilt_free: true,
            elastic: true,
            drive_accel: self.drive_accel,
            max_drop: self.max_drop,
            transfer: Some(self.transfer),
            settling: self.settling,
            bridge_speed: self.bridge_speed,
            horizon: required + 0.01,
        }
    }
}

impl Default for CrossingOptions {
    fn default() -> Self {
        CrossingOptions {
            // THESIS 5.2.4: 0–50° in steps of 10°.
            headings: (0..6).map(|k| f64::from(k * 10).to_radians()).collect(),
            start_y: 0.0,
            clearance: 0.005,
            step: 0.005,
            max_drop: 0.006,
            drive_accel: 0.0,
            transfer: LoadTransfer::default(),
            settling: Some(Settling::default()),
            bridge_speed: 0.0,
        }
    }
}

/// Where the pilots sit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PilotPlace {
    /// No pilots.
    None,
    /// At the front of the rows.
    Front,
    /// At the back of the rows.
    Back,
    /// Front and back of the rows, alternately.
    FrontBack,
}

/// One evaluated candidate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// Shape name (`line 4`, `mesh 2x2`).
    pub shape: String,
    /// Pilot places.
    pub pilots: PilotPlace,
    /// Pilot robot indices (row-major, front first).
    pub pilot_robots: Vec<usize>,
    /// Heading (degrees from the crossing direction).
    pub heading_deg: f64,
    /// Start of the front robot's centre (world, m): [`formed`] there at the heading gives
    /// the candidate's assembly.
    pub start: [f64; 2],
    /// Diagonal angle α of the shape (degrees).
    pub diagonal_deg: f64,
    /// Advance needed to put every robot on the far side (m).
    pub required: f64,
    /// The gate's answer.
    pub advance: Advance,
    /// `advance.distance − required` (m): ≥ 0 crosses.
    pub margin: f64,
    /// Smallest internal stability margin (SOCP (42)) along a crossing the gate proves
    /// (sampled every `step`); None when it does not cross or no connection is loaded.
    pub stability_margin: Option<f64>,
}

impl Candidate {
    /// The gate proves the whole crossing.
    pub fn crosses(&self) -> bool {
        self.margin >= 0.0
    }
}

/// Why no plan can be made.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// Bad arguments.
    #[error("{0}")]
    Input(String),
    /// The gate's adapter refused a candidate.
    #[error("{shape}: {cause}")]
    Adapter {
        /// Candidate shape.
        shape: String,
        /// Cause.
        cause: AdapterError,
    },
}

/// Rank every candidate for `robots` robots with `pilots` pilots crossing from the platform
/// under (x_start, `start_y`) along +x; best first (crossing, then largest margin).
pub fn plan(
    terrain: &Terrain,
    params: &FleetParams,
    robots: usize,
    pilots: usize,
    opt: &CrossingOptions,
) -> Result<Vec<Candidate>, PlanError> {
    if robots == 0 || pilots > robots {
        return Err(PlanError::Input(format!(
            "--robots must be ≥ 1 and --pilots ≤ --robots (got {robots} and {pilots})"
        )));
    }
    check_inputs(terrain, opt)?;
    let g = &params.non_pilot.geometry;
    let mut out = Vec::new();
    for shape in Shape::candidates(robots) {
        let links = formation::layout(shape, g).1;
        for (place, set) in pilot_sets(shape, pilots) {
            for &h in &opt.headings {
                let Some(c) = candidate(terrain, params, shape, place, &set, &links, h, opt)?
                else {
                    continue;
                };
                out.push(c);
            }
        }
    }
    ranked(out, opt)
}

/// Rank the headings of one formed assembly: `shape` with pilots `pilots` (row-major
/// indices) held by the couplings `links` (as [`formed_with`]); best first.
pub fn plan_formed(
    terrain: &Terrain,
    params: &FleetParams,
    shape: Shape,
    pilots: &[usize],
    links: &[(Link, usize, usize)],
    opt: &CrossingOptions,
) -> Result<Vec<Candidate>, PlanError> {
    let n = shape.count();
    if pilots
        .iter()
        .chain(links.iter().flat_map(|l| [&l.1, &l.2]))
        .any(|&k| k >= n)
    {
        return Err(PlanError::Input(format!(
            "{}: a pilot or coupling names a robot beyond its {n}",
            shape.name()
        )));
    }
    check_inputs(terrain, opt)?;
    let place = place_of(shape, pilots);
    let mut out = Vec::new();
    for &h in &opt.headings {
        if let Some(c) = candidate(terrain, params, shape, place, pilots, links, h, opt)? {
            out.push(c);
        }
    }
    ranked(out, opt)
}

/// The crossing of an assembly as it stands: its robots `a` (the layout's order of `shape`,
/// front first) with pilots `pilots` (indices into `a`), driven from where they are along
/// `heading` (rad from the crossing direction +x, the robots' own heading). The start
/// platform is the one under every robot's centre.
pub fn plan_placed(
    terrain: &Terrain,
    params: &FleetParams,
    shape: Shape,
    pilots: &[usize],
    a: &PuzzleAssembly,
    heading: f64,
    opt: &CrossingOptions,
) -> Result<Candidate, PlanError> {
    let n = shape.count();
    if a.robots.len() != n || pilots.iter().any(|&k| k >= n) {
        return Err(PlanError::Input(format!(
            "{}: {} robots given, pilots {pilots:?}",
            shape.name(),
            a.robots.len()
        )));
    }
    let one = CrossingOptions {
        headings: vec![heading],
        ..opt.clone()
    };
    check_inputs(terrain, &one)?;
    let under: Vec<Option<usize>> = a
        .robots
        .iter()
        .map(|r| platform_at(terrain, [r.x, r.y]))
        .collect();
    let Some(start) = under[0].filter(|&p| under.iter().all(|&u| u == Some(p))) else {
        let k = under
            .iter()
            .position(|u| u.is_none() || *u != under[0])
            .unwrap_or(0);
        let r = &a.robots[k];
        return Err(PlanError::Input(format!(
            "the assembly does not stand on one platform: robot {k} at ({:.3}, {:.3}) m",
            r.x, r.y
        )));
    };
    let place = Placed {
        shape,
        pilots: place_of(shape, pilots),
        pilot_robots: pilots,
        start,
        front: [a.robots[0].x, a.robots[0].y],
    };
    judge_placed(terrain, params, a, &place, heading, opt)?.ok_or_else(|| {
        PlanError::Input(format!(
            "driving on along {:.0}° does not put every robot on another platform",
            heading.to_degrees()
        ))
    })
}

/// Largest heading from the crossing direction the planner takes (rad, about 86°): nearer
/// to parallel with the edge, a straight path crosses it only after metres.
pub const MAX_HEADING: f64 = 1.5;

fn check_inputs(terrain: &Terrain, opt: &CrossingOptions) -> Result<(), PlanError> {
    terrain
        .validate_solid()
        .map_err(|e| PlanError::Input(format!("terrain: {e}")))?;
    if opt
        .headings
        .iter()
        .any(|h| !h.is_finite() || h.abs() >= MAX_HEADING)
    {
        return Err(PlanError::Input(format!(
            "headings: must be finite and within ±{:.0}°",
            MAX_HEADING.to_degrees()
        )));
    }
    Ok(())
}

/// Best first: crossing candidates that may stop anywhere before those with a stretch proven
/// only at speed ([`Advance::bridged`]), each by their smallest stability margin; the others
/// by how far short they stop.
fn ranked(mut out: Vec<Candidate>, opt: &CrossingOptions) -> Result<Vec<Candidate>, PlanError> {
    if out.is_empty() {
        return Err(PlanError::Input(format!(
            "no start: no platform under y = {} ahead of a gap along +x",
            opt.start_y
        )));
    }
    let key = |c: &Candidate| c.stability_margin.unwrap_or(f64::INFINITY);
    out.sort_by(|a, b| {
        let stands = |c: &Candidate| c.advance.bridged.is_empty();
        b.crosses().cmp(&a.crosses()).then(if a.crosses() {
            stands(b).cmp(&stands(a)).then(key(b).total_cmp(&key(a)))
        } else {
            b.margin.total_cmp(&a.margin)
        })
    });
    Ok(out)
}

/// Index of the platform under `p`.
/// The platform of `t` under point `p` (world, m), if any.
pub fn platform_at(t: &Terrain, p: [f64; 2]) -> Option<usize> {
    t.platforms.iter().position(|pl| pl.contains(p))
}

/// The least advance along `heading` (rad), to the millimetre and at most `limit` (m), after
/// which every robot of `robots` stands wholly off platform `start` ([`stands_across`]): the
/// planner's required advance, and the drive's extension from measured poses.
pub fn advance_across(
    robots: &[RobotPose],
    params: &FleetParams,
    terrain: &Terrain,
    start: usize,
    heading: f64,
    limit: f64,
) -> Option<f64> {
    let (s, c) = heading.sin_cos();
    let step = 0.001;
    (0..=(limit.max(0.0) / step).ceil() as usize)
        .map(|k| k as f64 * step)
        .find(|&d| {
            robots
                .iter()
                .all(|r| stands_across(&r.translated([c * d, s * d]), params, terrain, start))
        })
}

/// Robot `r` stands wholly off platform `start` of `terrain`: every underside corner over
/// another platform, and every wheel a radius clear of `start`, so that none still rests on
/// its edge. The end of a crossing, for the planner and for the drive that measures it.
pub fn stands_across(r: &RobotPose, params: &FleetParams, terrain: &Terrain, start: usize) -> bool {
    let off_start = |p: [f64; 2]| platform_at(terrain, p).is_some_and(|i| i != start);
    let (fs, fc) = r.yaw.sin_cos();
    let radius = f64::from(params.robot(r.kind).geometry.wheel_radius);
    body_corners(r.kind, params)
        .iter()
        .all(|&b| off_start(world(r, b)))
        && contact_points(r.kind, params)
            .iter()
            .filter(|(_, wheel)| *wheel)
            .all(|&(b, _)| {
                let q = world(r, b);
                platform_at(terrain, [q[0] - radius * fc, q[1] - radius * fs]) != Some(start)
            })
}

#[allow(clippy::too_many_arguments)]
fn candidate(
    terrain: &Terrain,
    params: &FleetParams,
    shape: Shape,
    place: PilotPlace,
    set: &[usize],
    links: &[(Link, usize, usize)],
    heading: f64,
    opt: &CrossingOptions,
) -> Result<Option<Candidate>, PlanError> {
    // The start platform: the one under the line y = start_y with the smallest far edge.
    let Some((start, edge)) = terrain
        .platforms
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let xs = p.polygon.iter().map(|v| v[0]);
            let (lo, hi) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
            p.contains([0.5 * (lo + hi), opt.start_y])
                .then_some((i, hi))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return Ok(None);
    };
    // Place the front robot so the foremost body corner is `clearance` behind the edge.
    let g = &params.non_pilot.geometry;
    let probe = formed_with(shape, set, links, params, [0.0, opt.start_y], heading);
    let (hl, hw) = (0.5 * f64::from(g.length), 0.5 * f64::from(g.width));
    let (s, c) = heading.sin_cos();
    let reach = probe
        .robots
        .iter()
        .flat_map(|r| {
            [[hl, hw], [hl, -hw], [-hl, hw], [-hl, -hw]].map(|[x, y]| r.x + c * x - s * y)
        })
        .fold(f64::MIN, f64::max);
    let front = [edge - opt.clearance - reach, opt.start_y];
    let a = formed_with(shape, set, links, params, front, heading);
    let place = Placed {
        shape,
        pilots: place,
        pilot_robots: set,
        start,
        front,
    };
    judge_placed(terrain, params, &a, &place, heading, opt)
}

/// The assembly as it stands: its shape, pilots and start platform.
struct Placed<'a> {
    shape: Shape,
    pilots: PilotPlace,
    pilot_robots: &'a [usize],
    /// Index of the start platform.
    start: usize,
    /// The front robot's centre (m).
    front: [f64; 2],
}

/// The gate's answer for assembly `a`, placed as `place` says, driven along `heading`.
fn judge_placed(
    terrain: &Terrain,
    params: &FleetParams,
    a: &PuzzleAssembly,
    place: &Placed,
    heading: f64,
    opt: &CrossingOptions,
) -> Result<Option<Candidate>, PlanError> {
    let (shape, start) = (place.shape, place.start);
    let g = &params.non_pilot.geometry;
    let limit = 4.0 * formation::footprint(shape, g)[0] + 1.0;
    let Some(required) = advance_across(&a.robots, params, terrain, start, heading, limit) else {
        return Ok(None); // nowhere to go along this heading
    };
    let advance = max_safe_advance_with(
        a,
        params,
        terrain,
        heading,
        opt.step,
        opt.advance_options(required),
    )
    .map_err(|cause| PlanError::Adapter {
        shape: shape.name(),
        cause,
    })?;
    let margin = match advance.limited_by {
        LimitedBy::Horizon => advance.distance - required,
        _ => advance.distance.min(required + 0.01) - required,
    };
    let stability_margin = if margin >= 0.0 {
        sampled_margin(a, params, terrain, heading, required, opt).map_err(|cause| {
            PlanError::Adapter {
                shape: shape.name(),
                cause,
            }
        })?
    } else {
        None
    };
    Ok(Some(Candidate {
        shape: shape.name(),
        pilots: place.pilots,
        pilot_robots: place.pilot_robots.to_vec(),
        heading_deg: heading.to_degrees(),
        start: place.front,
        diagonal_deg: formation::diagonal_angle(shape, g).to_degrees(),
        required,
        advance,
        margin,
        stability_margin,
    }))
}

/// Smallest internal stability margin at samples every `opt.step` along `distance` of
/// advance and just after every support event ([`support_events`]).
fn sampled_margin(
    a: &PuzzleAssembly,
    params: &FleetParams,
    terrain: &Terrain,
    heading: f64,
    distance: f64,
    opt: &CrossingOptions,
) -> Result<Option<f64>, AdapterError> {
    let step = opt.step;
    let model_opt = opt.advance_options(distance);
    let Some(level) = assembly_level(a, params, terrain) else {
        return Ok(None);
    };
    let (s, c) = heading.sin_cos();
    let n = (distance / step).ceil() as usize;
    // Every `step`, and just after every change of the support (where the loads jump).
    let mut at: Vec<f64> = (0..=n).map(|k| (k as f64 * step).min(distance)).collect();
    at.extend(
        support_events(a, params, terrain, heading, distance)
            .into_iter()
            .map(|e| e + EVENT_EPS)
            .filter(|&d| d < distance),
    );
    at.sort_by(f64::total_cmp);
    let mut worst: Option<f64> = None;
    for d in at {
        let m = build_model_with(a, params, terrain, level, [c * d, s * d], &model_opt)?;
        if let Some(margin) = evaluate(&m)?.margin {
            worst = Some(worst.map_or(margin, |w: f64| w.min(margin)));
        }
    }
    Ok(worst)
}

#[cfg(test)]
mod tests;
