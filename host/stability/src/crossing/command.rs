//! Terrain files and the planner's command line: its arguments, its run and its table.

use super::{plan, Candidate, CrossingOptions, PlanError};
use crate::puzzlebot::{LimitedBy, LoadTransfer};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::FleetParams;

/// Read a terrain file (TOML, `[[platforms]]` tables as in `puzzlebot_params::terrain`) and
/// check it ([`Terrain::validate_solid`]); errors name the file, line and field.
pub fn load_terrain(path: &std::path::Path) -> Result<Terrain, PlanError> {
    let t: Terrain = puzzlebot_params::load::from_toml_file(path)
        .map_err(|e| PlanError::Input(e.to_string()))?;
    t.validate_solid().map_err(|e| {
        // Point at the `[[platforms]]` table of the platform the message names.
        let index = e
            .strip_prefix("platforms[")
            .and_then(|r| r.split(']').next())
            .and_then(|n| n.parse::<usize>().ok());
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let line = index.and_then(|i| {
            text.lines()
                .enumerate()
                .filter(|(_, l)| l.trim_start().starts_with("[[platforms]]"))
                .nth(i)
                .map(|(n, _)| n + 1)
        });
        match line {
            Some(n) => PlanError::Input(format!("{}:{n}: {e}", path.display())),
            None => PlanError::Input(format!("{}: {e}", path.display())),
        }
    })?;
    Ok(t)
}

/// The command-line arguments of the crossing planner (`puzzlebot plan crossing`,
/// `puzzlebot-gate crossing`).
#[derive(Debug, Clone, clap::Args)]
pub struct CrossingArgs {
    /// Terrain file (TOML `[[platforms]]`: polygon, height, friction).
    #[arg(long)]
    pub terrain: std::path::PathBuf,
    /// Number of robots.
    #[arg(long)]
    pub robots: usize,
    /// Number of pilots among them.
    #[arg(long, default_value_t = 0)]
    pub pilots: usize,
    /// y of the front robot's start (m).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub start_y: f64,
    /// Acceleration of the drive the proof covers, starting and braking (m/s²; default: the
    /// host's crossing drive in `puzzlebot plan crossing`, 0 (quasi-static) in
    /// `puzzlebot-gate crossing`).
    #[arg(long)]
    pub drive_accel: Option<f64>,
    /// Speed the drive holds through a stretch where the assembly would tip if it stopped
    /// (m/s; default: the host's crossing speed in `puzzlebot plan crossing`, 0 (every
    /// advance must stand) in `puzzlebot-gate crossing`).
    #[arg(long)]
    pub speed: Option<f64>,
    /// Damping ratio of the connectors' load response (1): how far they overshoot when a
    /// support rolls off an edge (default: the parameter set's
    /// `coupling.connector_damping_ratio`, printed TPU's 0.025; 0: the undamped bound, twice
    /// the change). Set it from a measurement of your couplings (the decay of one ringing
    /// coupling).
    #[arg(long)]
    pub connector_damping: Option<f64>,
    /// The robots' parameters (TOML, any fields of the parameter set; the rest default).
    #[arg(long)]
    pub params: Option<std::path::PathBuf>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

impl CrossingArgs {
    /// The robots' parameters: `--params`, checked, or the defaults.
    pub fn fleet_params(&self) -> Result<FleetParams, PlanError> {
        let Some(file) = &self.params else {
            return Ok(FleetParams::default());
        };
        FleetParams::from_file(file).map_err(|e| PlanError::Input(e.to_string()))
    }

    /// Run the planner: its table (or JSON) as text.
    pub fn run(&self) -> Result<String, PlanError> {
        let params = self.fleet_params()?;
        crossing_command(
            &self.terrain,
            self.robots,
            self.pilots,
            self.start_y,
            Drive {
                accel: self.drive_accel.unwrap_or(0.0),
                speed: self.speed.unwrap_or(0.0),
                connector_damping: self
                    .connector_damping
                    .unwrap_or_else(|| LoadTransfer::of(&params).damping_ratio),
            },
            &params,
            self.json,
        )
    }
}

/// The crossing drive a plan's proof covers, and how the couplings respond to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// Acceleration starting and braking (m/s², [`CrossingOptions::drive_accel`]).
    pub accel: f64,
    /// Speed held through stretches where stopping would tip the assembly (m/s,
    /// [`CrossingOptions::bridge_speed`]).
    pub speed: f64,
    /// Damping ratio of the connectors' load response (1,
    /// [`crate::transfer::LoadTransfer::damping_ratio`]).
    pub connector_damping: f64,
}

/// `crossing --terrain FILE --robots N --pilots P`: the ranking as text or JSON for robots
/// `params`, the gate's proof covering `drive`.
pub fn crossing_command(
    terrain: &std::path::Path,
    robots: usize,
    pilots: usize,
    start_y: f64,
    drive: Drive,
    params: &FleetParams,
    json: bool,
) -> Result<String, PlanError> {
    for (name, v) in [
        ("--drive-accel", drive.accel),
        ("--speed", drive.speed),
        ("--connector-damping", drive.connector_damping),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(PlanError::Input(format!("{name}: must be ≥ 0, got {v}")));
        }
    }
    let t = load_terrain(terrain)?;
    let defaults = CrossingOptions::default();
    let opt = CrossingOptions {
        start_y,
        drive_accel: drive.accel,
        bridge_speed: drive.speed,
        transfer: LoadTransfer {
            damping_ratio: drive.connector_damping,
            ..LoadTransfer::of(params)
        },
        ..defaults
    };
    let c = plan(&t, params, robots, pilots, &opt)?;
    Ok(if json {
        serde_json::to_string_pretty(&c).map_err(|e| PlanError::Input(e.to_string()))?
    } else {
        let best = &c[0];
        let verdict = if best.crosses() {
            format!(
                "best: {} with pilots {:?} at {:.0}° (smallest stability margin {})\n",
                best.shape,
                best.pilot_robots,
                best.heading_deg,
                best.stability_margin
                    .map_or("-".to_string(), |m| format!("{m:.3}"))
            )
        } else {
            "no candidate is proven to cross: the host refuses this crossing\n".to_string()
        };
        render(&c) + &verdict
    })
}

/// `crosses`, with the stretches where the drive must keep its speed, or `refused`.
fn verdict_of(c: &Candidate) -> String {
    if !c.crosses() {
        return "refused".into();
    }
    if c.advance.bridged.is_empty() {
        return "crosses".into();
    }
    let at: Vec<String> = c
        .advance
        .bridged
        .iter()
        .map(|b| format!("{:.0}-{:.0}", b[0] * 1e3, b[1] * 1e3))
        .collect();
    format!("crosses; no stop at {} mm", at.join(", "))
}

/// The ranking as a table (best first): shape, pilots, heading, α, required advance, the
/// gate's advance and what limits it, margin, verdict.
pub fn render(cands: &[Candidate]) -> String {
    let mut s = String::from(
        "shape      pilots      heading  alpha  needed_mm  proven_mm  limited_by       margin_mm  stability  verdict\n",
    );
    for c in cands {
        let why = match &c.advance.limited_by {
            LimitedBy::Horizon => "-".to_string(),
            LimitedBy::Tips => "tips".to_string(),
            LimitedBy::Connection { pairs } => format!("pairs {pairs:?}"),
            LimitedBy::StepUp { robot } => format!("step up r{robot}"),
            LimitedBy::Stalls => "stalls".to_string(),
            LimitedBy::NotProven { .. } => "not proven".to_string(),
        };
        s.push_str(&format!(
            "{:<10} {:<11} {:>6.0}°  {:>4.1}°  {:>9.1}  {:>9.1}  {:<15}  {:>9.1}  {:>9}  {}\n",
            c.shape,
            format!("{:?}{:?}", c.pilots, c.pilot_robots),
            c.heading_deg,
            c.diagonal_deg,
            c.required * 1e3,
            c.advance.distance * 1e3,
            why,
            c.margin * 1e3,
            c.stability_margin
                .map_or("-".to_string(), |m| format!("{m:.3}")),
            verdict_of(c)
        ));
    }
    s
}
