//! Scenario file parsing: the TOML layout and its checks, with errors that name line, column and field.

use super::{
    Behaviour, Finite, Goal, Grow, NonNeg, Scenario, ScenarioError, Step, DEFAULT_TOLERANCE,
};
use crate::behaviour::{Trajectory, Wiggle};
use crate::geom::Pose;
use crate::shape::{Shape, ShapeSpec};
use puzzlebot_params::geometry::Geometry;
use puzzlebot_protocol::messages::RobotId;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::Path;
use toml::Spanned;

/// `form = { shape = "line" | "mesh" | "path/to/shape.toml", rows = 2, heading_deg = 0 }`, or
/// grown around one robot: `form = { shape = "mesh", rows = 2, grow = true, seed = 3 }`.
/// Growing is the default; `grow = false` or a `heading_deg` forms the shape in parallel.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct FormFile {
    shape: Spanned<String>,
    #[serde(default)]
    rows: Option<usize>,
    #[serde(default)]
    heading_deg: Option<Finite>,
    #[serde(default)]
    grow: Option<bool>,
    #[serde(default)]
    seed: Option<RobotId>,
}

/// `hold = { duration_s = 2 }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct HoldFile {
    duration_s: NonNeg,
}

/// `cross = { terrain = "gap40.toml" }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct CrossFile {
    terrain: String,
}

/// `move = { velocity = [v, w], duration_s }` | `{ go_to = [x, y] or [x, y, yaw_deg], tolerance }`
/// | `{ trajectory = [[t, x, y], …] or [[t, x, y, yaw_deg], …] }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct MoveFile {
    #[serde(default)]
    velocity: Option<[Finite; 2]>,
    #[serde(default)]
    duration_s: Option<NonNeg>,
    #[serde(default)]
    go_to: Option<Spanned<Vec<Finite>>>,
    #[serde(default)]
    tolerance: Option<NonNeg>,
    #[serde(default)]
    trajectory: Option<Spanned<Vec<Vec<Finite>>>>,
}

/// `rendezvous = { robots = [1, 2], gain = 0.5, duration_s = 10, until_distance = 0.05 }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RendezvousFile {
    #[serde(default)]
    robots: Option<Vec<RobotId>>,
    #[serde(default)]
    gain: Option<NonNeg>,
    #[serde(default)]
    duration_s: Option<NonNeg>,
    #[serde(default)]
    until_distance: Option<NonNeg>,
}

/// `decouple = { robots = [3], v_bias = 0.01, w_max = 1.5, period_s = 0.5, square = true }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct DecoupleFile {
    #[serde(default)]
    robots: Option<Vec<RobotId>>,
    #[serde(default)]
    v_bias: Option<Finite>,
    #[serde(default)]
    w_max: Option<NonNeg>,
    #[serde(default)]
    period_s: Option<NonNeg>,
    #[serde(default)]
    square: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct GoalFile {
    robot: RobotId,
    #[serde(default)]
    x: Option<Finite>,
    #[serde(default)]
    y: Option<Finite>,
    #[serde(default)]
    ahead: Option<Finite>,
    #[serde(default)]
    away: Option<Finite>,
}

/// `disperse = { goal = [{ robot = 1, x = 0.2, y = 0.4 }, { robot = 2, ahead = 0.2 },
/// { robot = 3, away = 0.1 }, …], tolerance = 0.02 }`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct DisperseFile {
    goal: Vec<GoalFile>,
    #[serde(default)]
    tolerance: Option<NonNeg>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct StepFile {
    #[serde(default)]
    label: Option<String>,
    #[serde(default)]
    timeout_s: Option<NonNeg>,
    #[serde(default)]
    form: Option<FormFile>,
    #[serde(default)]
    hold: Option<HoldFile>,
    #[serde(default, rename = "move")]
    move_: Option<Spanned<MoveFile>>,
    #[serde(default)]
    rendezvous: Option<RendezvousFile>,
    #[serde(default)]
    anti_rendezvous: Option<RendezvousFile>,
    #[serde(default)]
    decouple: Option<DecoupleFile>,
    #[serde(default)]
    disperse: Option<DisperseFile>,
    #[serde(default)]
    cross: Option<CrossFile>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioFile {
    #[serde(default)]
    name: Option<String>,
    #[serde(default)]
    step: Vec<Spanned<StepFile>>,
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

impl Scenario {
    /// Load a scenario file; shape files named in `form` are resolved relative to it.
    pub fn from_file(path: &Path, g: &Geometry) -> Result<Scenario, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|cause| {
            ScenarioError::Load(puzzlebot_params::load::LoadError::Io {
                path: path.to_path_buf(),
                cause,
            })
        })?;
        Scenario::from_toml_str(path, &text, g)
    }

    /// Parse scenario text; `path` names it in errors and anchors relative shape paths.
    pub fn from_toml_str(path: &Path, text: &str, g: &Geometry) -> Result<Scenario, ScenarioError> {
        let file: ScenarioFile = puzzlebot_params::load::from_toml_str(path, text)?;
        let invalid = |span: std::ops::Range<usize>, field: String, message: String| {
            let (line, column) = line_col(text, span.start);
            ScenarioError::Invalid {
                path: path.to_path_buf(),
                line,
                column,
                field,
                message,
            }
        };
        if file.step.is_empty() {
            return Err(invalid(
                0..0,
                "step".into(),
                "a scenario needs at least one [[step]]".into(),
            ));
        }
        let base = path.parent().unwrap_or(Path::new("."));
        let mut steps = Vec::with_capacity(file.step.len());
        for (k, spanned) in file.step.iter().enumerate() {
            let span = spanned.span();
            let s = spanned.get_ref();
            let field = |f: &str| format!("step[{k}].{f}");
            let mut given = Vec::new();
            if s.form.is_some() {
                given.push("form");
            }
            if s.hold.is_some() {
                given.push("hold");
            }
            if s.move_.is_some() {
                given.push("move");
            }
            if s.rendezvous.is_some() {
                given.push("rendezvous");
            }
            if s.anti_rendezvous.is_some() {
                given.push("anti_rendezvous");
            }
            if s.decouple.is_some() {
                given.push("decouple");
            }
            if s.disperse.is_some() {
                given.push("disperse");
            }
            if s.cross.is_some() {
                given.push("cross");
            }
            if given.len() != 1 {
                return Err(invalid(
                    span,
                    format!("step[{k}]"),
                    format!(
                        "exactly one behaviour expected (form, hold, move, rendezvous, anti_rendezvous, decouple, disperse, cross), found {}",
                        if given.is_empty() { "none".to_string() } else { given.join(", ") }
                    ),
                ));
            }
            let behaviour = if let Some(f) = &s.form {
                let spec = match f.shape.get_ref().as_str() {
                    "line" => {
                        if f.rows.is_some() {
                            return Err(invalid(
                                f.shape.span(),
                                field("form.rows"),
                                "rows applies to a mesh only".into(),
                            ));
                        }
                        ShapeSpec::Line
                    }
                    "mesh" => {
                        let rows = f.rows.unwrap_or(2);
                        if rows == 0 {
                            return Err(invalid(
                                f.shape.span(),
                                field("form.rows"),
                                "a mesh needs at least one row".into(),
                            ));
                        }
                        ShapeSpec::Mesh { rows }
                    }
                    file_name => {
                        let p = base.join(file_name);
                        let shape = Shape::from_file(&p, g).map_err(|e| {
                            invalid(
                                f.shape.span(),
                                field("form.shape"),
                                format!("shape file: {e}"),
                            )
                        })?;
                        ShapeSpec::Fixed(shape)
                    }
                };
                // Grown unless asked otherwise: one docking operation at a time, each robot
                // routed round the others to a free approach (the parallel order of THESIS
                // Algorithm 3 lets approaches cross; it is kept for a given heading).
                let grown = match (f.grow, f.seed, f.heading_deg) {
                    (Some(g), None, _) => g,
                    (_, Some(_), _) => true,
                    (None, None, heading) => heading.is_none(),
                };
                if f.grow == Some(false) && f.seed.is_some() {
                    return Err(invalid(
                        f.shape.span(),
                        field("form.seed"),
                        "a seed robot is what a shape grows around; drop seed or grow = false"
                            .into(),
                    ));
                }
                let grow = grown.then_some(Grow { seed: f.seed });
                if f.grow == Some(true) && f.heading_deg.is_some() {
                    return Err(invalid(
                        f.shape.span(),
                        field("form.heading_deg"),
                        "a grown shape takes its seed robot's heading; drop heading_deg or grow"
                            .into(),
                    ));
                }
                Behaviour::Form {
                    spec,
                    heading: f.heading_deg.map(|d| d.0.to_radians()),
                    grow,
                }
            } else if let Some(h) = &s.hold {
                Behaviour::Hold {
                    duration_s: h.duration_s.0,
                }
            } else if let Some(m) = &s.move_ {
                let mspan = m.span();
                let m = m.get_ref();
                let modes = [
                    m.velocity.is_some(),
                    m.go_to.is_some(),
                    m.trajectory.is_some(),
                ]
                .iter()
                .filter(|&&x| x)
                .count();
                if modes != 1 {
                    return Err(invalid(
                        mspan,
                        field("move"),
                        "give exactly one of velocity, go_to, trajectory".into(),
                    ));
                }
                if let Some([v, w]) = m.velocity {
                    let Some(d) = m.duration_s else {
                        return Err(invalid(
                            mspan,
                            field("move.duration_s"),
                            "velocity needs duration_s".into(),
                        ));
                    };
                    Behaviour::Velocity {
                        v: v.0,
                        w: w.0,
                        duration_s: d.0,
                    }
                } else if let Some(goal) = &m.go_to {
                    let v = goal.get_ref();
                    let pose = match v.as_slice() {
                        [x, y] => Pose::new(x.0, y.0, f64::NAN),
                        [x, y, yaw] => Pose::new(x.0, y.0, yaw.0.to_radians()),
                        _ => {
                            return Err(invalid(
                                goal.span(),
                                field("move.go_to"),
                                format!(
                                    "expected [x, y] or [x, y, yaw_deg], got {} numbers",
                                    v.len()
                                ),
                            ))
                        }
                    };
                    Behaviour::GoTo {
                        goal: pose,
                        tolerance: m.tolerance.map_or(DEFAULT_TOLERANCE, |t| t.0),
                    }
                } else {
                    let tr = m.trajectory.as_ref().expect("one mode given");
                    let mut waypoints = Vec::new();
                    for (i, row) in tr.get_ref().iter().enumerate() {
                        let (t, pose) = match row.as_slice() {
                            [t, x, y] => (t.0, Pose::new(x.0, y.0, 0.0)),
                            [t, x, y, yaw] => (t.0, Pose::new(x.0, y.0, yaw.0.to_radians())),
                            _ => {
                                return Err(invalid(
                                    tr.span(),
                                    field(&format!("move.trajectory[{i}]")),
                                    "expected [t, x, y] or [t, x, y, yaw_deg]".into(),
                                ))
                            }
                        };
                        if waypoints
                            .last()
                            .is_some_and(|&(tp, _): &(f64, Pose)| t <= tp)
                        {
                            return Err(invalid(
                                tr.span(),
                                field(&format!("move.trajectory[{i}]")),
                                "times must increase strictly".into(),
                            ));
                        }
                        waypoints.push((t, pose));
                    }
                    if waypoints.len() < 2 {
                        return Err(invalid(
                            tr.span(),
                            field("move.trajectory"),
                            "needs at least two waypoints".into(),
                        ));
                    }
                    // A trajectory without headings points along its path.
                    if tr.get_ref().iter().all(|r| r.len() == 3) {
                        for i in 0..waypoints.len() {
                            let (a, b) = if i + 1 < waypoints.len() {
                                (i, i + 1)
                            } else {
                                (i - 1, i)
                            };
                            let (pa, pb) = (waypoints[a].1, waypoints[b].1);
                            waypoints[i].1.yaw = (pb.y - pa.y).atan2(pb.x - pa.x);
                        }
                    }
                    Behaviour::Trajectory {
                        trajectory: Trajectory { waypoints },
                    }
                }
            } else if let Some(r) = s.rendezvous.as_ref().or(s.anti_rendezvous.as_ref()) {
                let anti = s.anti_rendezvous.is_some();
                if r.duration_s.is_none() && r.until_distance.is_none() {
                    return Err(invalid(
                        span,
                        field(if anti {
                            "anti_rendezvous"
                        } else {
                            "rendezvous"
                        }),
                        "give duration_s or until_distance (or both)".into(),
                    ));
                }
                Behaviour::Rendezvous {
                    robots: r.robots.clone(),
                    gain: r.gain.map_or(0.5, |g| g.0),
                    anti,
                    duration_s: r.duration_s.map(|d| d.0),
                    until_distance: r.until_distance.map(|d| d.0),
                }
            } else if let Some(d) = &s.decouple {
                let def = Wiggle::default();
                Behaviour::Decouple {
                    robots: d.robots.clone(),
                    wiggle: Wiggle {
                        v_bias: d.v_bias.map_or(def.v_bias, |v| v.0),
                        w_max: d.w_max.map_or(def.w_max, |v| v.0),
                        period_s: d.period_s.map_or(def.period_s, |v| v.0),
                        square: d.square.unwrap_or(def.square),
                    },
                }
            } else if let Some(c) = &s.cross {
                Behaviour::Cross {
                    terrain: base.join(&c.terrain),
                }
            } else {
                let d = s.disperse.as_ref().expect("one behaviour given");
                let mut goals = BTreeMap::new();
                for (i, gl) in d.goal.iter().enumerate() {
                    let goal = match (gl.x, gl.y, gl.ahead, gl.away) {
                        (Some(x), Some(y), None, None) => Goal::At { x: x.0, y: y.0 },
                        (None, None, Some(d), None) => Goal::Ahead(d.0),
                        (None, None, None, Some(d)) => Goal::Away(d.0),
                        _ => {
                            return Err(invalid(
                                span.clone(),
                                field(&format!("disperse.goal[{i}]")),
                                "give either x and y, or ahead, or away".into(),
                            ))
                        }
                    };
                    if goals.insert(gl.robot, goal).is_some() {
                        return Err(invalid(
                            span.clone(),
                            field(&format!("disperse.goal[{i}].robot")),
                            format!("robot {} has two goals", gl.robot),
                        ));
                    }
                }
                if goals.is_empty() {
                    return Err(invalid(span, field("disperse.goal"), "no goals".into()));
                }
                Behaviour::Disperse {
                    goals,
                    tolerance: d.tolerance.map_or(DEFAULT_TOLERANCE, |t| t.0),
                }
            };
            let (line, _) = line_col(text, span.start);
            steps.push(Step {
                label: s.label.clone().unwrap_or_else(|| given[0].to_string()),
                timeout_s: s.timeout_s.map(|t| t.0),
                behaviour,
                line,
            });
        }
        let name = file.name.unwrap_or_else(|| {
            path.file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("scenario")
                .to_string()
        });
        Ok(Scenario { name, steps })
    }
}
