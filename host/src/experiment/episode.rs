//! One randomized assembly episode, fully determined by its seed and impairment profile: the
//! fleet's size, the shape, the pilots, where the robots stand, the move and whether the
//! assembly is dissolved; and the simulator scenario (link loss, motion capture, per-robot
//! host-model mismatch) and assembly scenario that run it.

use std::path::{Path, PathBuf};

use anyhow::Context;
use puzzlebot_assembly::{Scenario as AsmScenario, Shape, SlotKind};
use puzzlebot_params::FleetParams;
use puzzlebot_sim::{Impairments, MocapConfig, PlantMismatch};
use rand::{Rng, SeedableRng};
use serde::Serialize;

use crate::assemble::scattered_fleet_in;

/// Where the custom shapes of the experiment live (`host/assembly/data/shapes`).
pub fn default_shapes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assembly/data/shapes")
}

/// How badly the world treats the fleet (the profiles of DESIGN.md §9).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Profile {
    /// No latency, no loss, nominal motion-capture noise, the plant exactly as believed.
    Ideal,
    /// A lab: 30 ± 20 ms controller latency, 2 % datagram loss, nominal noise, 1 % mocap
    /// dropouts, motor gain, dead-band and wheel radius up to ±10 % off per robot.
    Lab,
    /// A bad day: 80 ± 50 ms, 10 % loss, 3× noise, 3 % dropouts, ±20 % mismatch.
    Harsh,
}

impl Profile {
    /// Every profile, mildest first.
    pub const ALL: [Profile; 3] = [Profile::Ideal, Profile::Lab, Profile::Harsh];

    /// The profile's name as the command line spells it.
    pub fn name(self) -> &'static str {
        match self {
            Profile::Ideal => "ideal",
            Profile::Lab => "lab",
            Profile::Harsh => "harsh",
        }
    }

    /// The profile named `s`, or an error listing the names.
    pub fn parse(s: &str) -> anyhow::Result<Profile> {
        Profile::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .with_context(|| format!("unknown profile '{s}': use ideal, lab or harsh"))
    }

    /// The profile's numbers.
    pub fn impairment(self) -> Impairment {
        let nominal = MocapConfig::default();
        match self {
            Profile::Ideal => Impairment {
                latency_ms: 0.0,
                latency_jitter_ms: 0.0,
                loss: 0.0,
                mocap_noise_factor: 1.0,
                mocap_dropout: 0.0,
                mismatch: 0.0,
                nominal_mocap: nominal,
            },
            Profile::Lab => Impairment {
                latency_ms: 30.0,
                latency_jitter_ms: 20.0,
                loss: 0.02,
                mocap_noise_factor: 1.0,
                mocap_dropout: 0.01,
                mismatch: 0.10,
                nominal_mocap: nominal,
            },
            Profile::Harsh => Impairment {
                latency_ms: 80.0,
                latency_jitter_ms: 50.0,
                loss: 0.10,
                mocap_noise_factor: 3.0,
                mocap_dropout: 0.03,
                mismatch: 0.20,
                nominal_mocap: nominal,
            },
        }
    }
}

/// The numbers of a profile.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Impairment {
    /// Mean controller latency: a tick's commands act this long after it (ms).
    pub latency_ms: f64,
    /// The latency varies uniformly by ± this much per tick (ms).
    pub latency_jitter_ms: f64,
    /// Probability that a datagram is lost, each direction of each robot's link.
    pub loss: f64,
    /// Motion-capture noise as a multiple of the nominal ([`MocapConfig::default`]).
    pub mocap_noise_factor: f64,
    /// Probability that a body is lost in a motion-capture frame.
    pub mocap_dropout: f64,
    /// Each robot's motor gain, dead-band and wheel radius differ from what the host
    /// believes by a factor drawn uniformly from 1 ± this.
    pub mismatch: f64,
    /// The nominal motion capture the noise factor scales.
    nominal_mocap: MocapConfig,
}

impl Impairment {
    /// The motion capture of this profile.
    pub fn mocap(&self) -> MocapConfig {
        MocapConfig {
            position_noise_m: self.nominal_mocap.position_noise_m * self.mocap_noise_factor,
            yaw_noise_rad: self.nominal_mocap.yaw_noise_rad * self.mocap_noise_factor,
            dropout: self.mocap_dropout,
            ..self.nominal_mocap
        }
    }

    /// Fixed part of the controller latency for the lockstep run (ms).
    pub fn delay_ms(&self) -> f64 {
        (self.latency_ms - self.latency_jitter_ms).max(0.0)
    }

    /// Random part: uniform in [0, this) on top of [`Impairment::delay_ms`] (ms).
    pub fn jitter_ms(&self) -> f64 {
        self.latency_ms + self.latency_jitter_ms - self.delay_ms()
    }
}

/// A robot's plant mismatch: motor gain, dead band and wheel radius each off by a factor
/// drawn uniformly from 1 ± `m` (none for `m` = 0).
pub fn draw_mismatch(rng: &mut impl Rng, m: f64) -> PlantMismatch {
    let mut f = || {
        if m > 0.0 {
            rng.random_range(1.0 - m..=1.0 + m)
        } else {
            1.0
        }
    };
    PlantMismatch {
        motor_gain: f(),
        dead_band: f(),
        wheel_radius: f(),
    }
}

/// The shape an episode forms.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum EpisodeShape {
    /// One row.
    Line,
    /// Rows side by side.
    Mesh {
        /// Number of rows.
        rows: usize,
    },
    /// A shape file.
    Custom {
        /// The shape's name.
        name: String,
        /// Its file.
        path: PathBuf,
    },
}

impl EpisodeShape {
    /// Bucket name: `line`, `mesh2`, `mesh3`, or the custom shape's name.
    pub fn bucket(&self) -> String {
        match self {
            EpisodeShape::Line => "line".into(),
            EpisodeShape::Mesh { rows } => format!("mesh{rows}"),
            EpisodeShape::Custom { name, .. } => name.clone(),
        }
    }

    /// Whether a formed assembly of this shape can turn while it drives: a line's anchors
    /// bend (±0.5 rad, THESIS 4.2.2); knob pairs are rigid, and a rigid body of unicycles
    /// at different places along the heading cannot turn without its wheels sliding sideways.
    pub fn can_turn(&self) -> bool {
        matches!(self, EpisodeShape::Line)
    }
}

/// A custom shape the experiment can draw.
#[derive(Debug, Clone)]
pub struct CustomShape {
    /// Name (file stem).
    pub name: String,
    /// File.
    pub path: PathBuf,
    /// Slots.
    pub slots: usize,
    /// Slots that ask for a pilot.
    pub pilot_slots: usize,
}

/// Every shape file (`*.toml`, `*.json`) in `dir`, sorted by name.
pub fn custom_shapes(dir: &Path) -> anyhow::Result<Vec<CustomShape>> {
    let g = FleetParams::default().non_pilot.geometry;
    let mut out = Vec::new();
    let entries =
        std::fs::read_dir(dir).with_context(|| format!("reading shapes in {}", dir.display()))?;
    for e in entries {
        let path = e?.path();
        if !matches!(
            path.extension().and_then(|x| x.to_str()),
            Some("toml" | "json")
        ) {
            continue;
        }
        let shape = Shape::from_file(&path, &g)?;
        out.push(CustomShape {
            name: shape.name.clone(),
            path,
            slots: shape.slots.len(),
            pilot_slots: shape
                .slots
                .iter()
                .filter(|s| s.kind == SlotKind::Pilot)
                .count(),
        });
    }
    out.sort_by(|a, b| a.name.cmp(&b.name));
    Ok(out)
}

/// The move after formation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EpisodeMove {
    /// Forward speed of the assembly (m/s).
    pub v: f64,
    /// Turn rate (rad/s; 0 for shapes that cannot turn).
    pub w: f64,
    /// Duration (s).
    pub duration_s: f64,
}

/// One episode.
#[derive(Debug, Clone, Serialize)]
pub struct Episode {
    /// The seed everything is drawn from (and the simulator's seed).
    pub seed: u64,
    /// Impairment profile.
    pub profile: Profile,
    /// Robots.
    pub robots: usize,
    /// Pilots among them (the lowest ids).
    pub pilots: usize,
    /// Shape.
    pub shape: EpisodeShape,
    /// Grown around one robot (`form = { grow = true }`) rather than formed in parallel.
    pub grow: bool,
    /// Half the side of the square the robots start in (m).
    pub area_half_side: f64,
    /// The move.
    pub motion: EpisodeMove,
    /// Dissolved and dispersed after the move.
    pub dissolve: bool,
    /// Mean controller latency instead of the profile's (ms; the profile's jitter stays).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub latency_ms: Option<f64>,
}

/// Largest fleet of an episode.
pub const MAX_ROBOTS: usize = 12;
/// Speed of every episode's move (m/s): what the demo drives at.
const MOVE_SPEED: f64 = 0.05;
/// Distance of the move (m): at least, at most.
const MOVE_DISTANCE: (f64, f64) = (0.2, 0.5);
/// Turn of a line's move (rad): at least, at most, either way (the lines turn 0.6).
const MOVE_TURN: (f64, f64) = (0.3, 0.8);
/// Start area of fleets up to four robots (half side, m), as `scattered_fleet`; larger
/// fleets get the same area per robot.
const AREA_HALF_SIDE_4: f64 = 0.3;

impl Episode {
    /// The episode of `seed` under `profile`, drawing custom shapes from `shapes`; a share
    /// `parallel` (0…1) of the episodes without two pilots forms its shape in parallel
    /// (`grow = false`, THESIS Algorithm 3) instead of growing it (the default).
    pub fn draw(seed: u64, profile: Profile, shapes: &[CustomShape], parallel: f64) -> Episode {
        Episode::draw_up_to(seed, profile, shapes, parallel, MAX_ROBOTS)
    }

    /// [`Episode::draw`] with fleets of at most `max_robots` (≥ 6; custom shapes with more
    /// slots are left out): a quicker sample.
    pub fn draw_up_to(
        seed: u64,
        profile: Profile,
        shapes: &[CustomShape],
        parallel: f64,
        max_robots: usize,
    ) -> Episode {
        let max = max_robots.clamp(6, MAX_ROBOTS);
        let shapes: Vec<&CustomShape> = shapes.iter().filter(|c| c.slots <= max).collect();
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let pick = rng.random_range(0.0..1.0);
        let (shape, robots) = if pick < 0.12 && !shapes.is_empty() {
            let c = &shapes[rng.random_range(0..shapes.len())];
            (
                EpisodeShape::Custom {
                    name: c.name.clone(),
                    path: c.path.clone(),
                },
                c.slots,
            )
        } else if pick < 0.45 {
            (EpisodeShape::Line, rng.random_range(2..=max))
        } else if pick < 0.75 {
            (EpisodeShape::Mesh { rows: 2 }, rng.random_range(4..=max))
        } else {
            (EpisodeShape::Mesh { rows: 3 }, rng.random_range(6..=max))
        };
        let pilots = match &shape {
            EpisodeShape::Custom { .. } => shapes
                .iter()
                .find(|c| shape.bucket() == c.name)
                .map_or(0, |c| c.pilot_slots),
            // A second pilot stands in the first's lane, linked to it through one non-pilot
            // (`assign_around_lane`): lines of three or more and 2-row meshes of six or more
            // have the slots (a 2 x 2 mesh has no slot ahead of another on its axis).
            EpisodeShape::Line if robots >= 3 => rng.random_range(0..=2),
            EpisodeShape::Mesh { rows: 2 } if robots >= 6 => rng.random_range(0..=2),
            _ => rng.random_range(0..=1),
        };
        // Two pilots are only brought together by growing around the front one.
        let grow = pilots == 2 || rng.random_range(0.0..1.0) >= parallel;
        let distance = rng.random_range(MOVE_DISTANCE.0..MOVE_DISTANCE.1);
        let duration_s = distance / MOVE_SPEED;
        let w = if shape.can_turn() {
            let turn = rng.random_range(MOVE_TURN.0..MOVE_TURN.1);
            let sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            sign * turn / duration_s
        } else {
            0.0
        };
        let dissolve = rng.random_bool(0.5);
        Episode {
            seed,
            profile,
            robots,
            pilots,
            shape,
            grow,
            area_half_side: AREA_HALF_SIDE_4 * (robots.max(4) as f64 / 4.0).sqrt(),
            motion: EpisodeMove {
                v: MOVE_SPEED,
                w,
                duration_s,
            },
            dissolve,
            latency_ms: None,
        }
    }

    /// Size bucket: 2–4, 5–8 or 9–12 robots.
    pub fn size_bucket(&self) -> &'static str {
        match self.robots {
            0..=4 => "2-4",
            5..=8 => "5-8",
            _ => "9-12",
        }
    }

    /// The profile's impairment with this episode's latency.
    pub fn impairment(&self) -> Impairment {
        let mut imp = self.profile.impairment();
        if let Some(ms) = self.latency_ms {
            imp.latency_ms = ms;
        }
        imp
    }

    /// Time limit of the formation step (s) ([`form_timeout_s`]).
    pub fn form_timeout_s(&self) -> f64 {
        form_timeout_s(self.robots)
    }

    /// Time limit of the whole run (s): every step's limit plus the holds.
    pub fn run_limit_s(&self) -> f64 {
        let dissolve = if self.dissolve {
            self.dissolve_timeout_s() + 10.0 + 60.0 + 2.0
        } else {
            0.0
        };
        self.form_timeout_s() + 2.0 + self.motion.duration_s + 60.0 + dissolve + 5.0
    }

    fn dissolve_timeout_s(&self) -> f64 {
        30.0 + 10.0 * self.robots as f64
    }

    /// The simulated fleet: robots scattered over the area (pilots in one lane), the
    /// profile's link loss and motion capture, each robot's plant mismatch.
    pub fn sim_scenario(&self) -> anyhow::Result<puzzlebot_sim::Scenario> {
        let imp = self.impairment();
        let mut s = scattered_fleet_in(self.robots, self.pilots, self.seed, self.area_half_side)?;
        s.impairments = Impairments {
            loss: imp.loss,
            ..Impairments::NONE
        };
        s.mocap = imp.mocap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(self.seed ^ MISMATCH_SEED);
        for r in &mut s.robots {
            r.mismatch = draw_mismatch(&mut rng, imp.mismatch);
        }
        Ok(s)
    }

    /// The assembly scenario as a file would say it.
    pub fn scenario_text(&self) -> String {
        let shape = match &self.shape {
            EpisodeShape::Line => "shape = \"line\"".to_string(),
            EpisodeShape::Mesh { rows } => format!("shape = \"mesh\", rows = {rows}"),
            EpisodeShape::Custom { path, .. } => {
                format!("shape = {:?}", path.display().to_string())
            }
        };
        let grow = if self.grow {
            ", grow = true"
        } else {
            ", grow = false"
        };
        let mut t = format!(
            "name = \"episode-{seed}\"\n\n[[step]]\nlabel = \"form\"\nform = {{ {shape}{grow} }}\ntimeout_s = {ft}\n\n[[step]]\nhold = {{ duration_s = 1.0 }}\n\n[[step]]\nlabel = \"move\"\nmove = {{ velocity = [{v}, {w}], duration_s = {d} }}\ntimeout_s = {mt}\n\n[[step]]\nhold = {{ duration_s = 1.0 }}\n",
            seed = self.seed,
            ft = self.form_timeout_s(),
            v = self.motion.v,
            w = self.motion.w,
            d = self.motion.duration_s,
            mt = self.motion.duration_s + 60.0,
        );
        if self.dissolve {
            let goals: Vec<String> = (1..=self.robots)
                .map(|id| format!("{{ robot = {id}, away = 0.1 }}"))
                .collect();
            t.push_str(&format!(
                "\n[[step]]\nlabel = \"dissolve\"\ndecouple = {{ v_bias = 0.01, w_max = 1.5, period_s = 2.0 }}\ntimeout_s = {dt}\n\n[[step]]\nlabel = \"spread out\"\nanti_rendezvous = {{ gain = 0.5, until_distance = 0.1, duration_s = 10 }}\n\n[[step]]\nlabel = \"disperse\"\ndisperse = {{ tolerance = 0.02, goal = [ {goals} ] }}\ntimeout_s = 60\n",
                dt = self.dissolve_timeout_s(),
                goals = goals.join(", "),
            ));
        }
        t
    }

    /// The assembly scenario, parsed as a file would be.
    pub fn asm_scenario(&self, params: &FleetParams) -> anyhow::Result<AsmScenario> {
        let name = PathBuf::from(format!("episode-{}.toml", self.seed));
        Ok(AsmScenario::from_toml_str(
            &name,
            &self.scenario_text(),
            &params.non_pilot.geometry,
        )?)
    }

    /// One line for logs.
    pub fn describe(&self) -> String {
        format!(
            "seed {} [{}{}]: {} robots, {} pilot(s), {}{}, move {:.2} m turning {:+.2} rad{}",
            self.seed,
            self.profile.name(),
            self.latency_ms
                .map_or(String::new(), |ms| format!(", {ms} ms latency")),
            self.robots,
            self.pilots,
            self.shape.bucket(),
            if self.grow { " grown" } else { "" },
            self.motion.v * self.motion.duration_s,
            self.motion.w * self.motion.duration_s,
            if self.dissolve {
                ", dissolved and dispersed"
            } else {
                ""
            }
        )
    }
}

/// Mixed into the episode's seed for the draw of its robots' plant mismatch.
const MISMATCH_SEED: u64 = 0xbb67_ae85_84ca_a73b;

/// Time limit of the formation step of a fleet of `robots` (s): the order is sequential
/// where it grows, so it scales with the fleet. The experiments that form a fleet share it.
pub fn form_timeout_s(robots: usize) -> f64 {
    60.0 + 30.0 * robots as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_episode_is_fully_determined_by_its_seed_and_profile() {
        let shapes = custom_shapes(&default_shapes_dir()).expect("shapes");
        for seed in 1..40 {
            let a = Episode::draw(seed, Profile::Lab, &shapes, 0.5);
            let b = Episode::draw(seed, Profile::Lab, &shapes, 0.5);
            assert_eq!(a.scenario_text(), b.scenario_text());
            assert_eq!(
                a.sim_scenario().expect("fits"),
                b.sim_scenario().expect("fits")
            );
            assert!((2..=12).contains(&a.robots), "{}", a.describe());
            assert!(a.pilots <= 2 && a.pilots < a.robots, "{}", a.describe());
            a.asm_scenario(&FleetParams::default())
                .unwrap_or_else(|e| panic!("{}: {e}", a.describe()));
        }
    }

    #[test]
    fn lab_robots_differ_from_the_host_model_within_ten_percent_and_ideal_ones_not() {
        let shapes = custom_shapes(&default_shapes_dir()).expect("shapes");
        let lab = Episode::draw(7, Profile::Lab, &shapes, 0.0)
            .sim_scenario()
            .expect("fits");
        let mut off = 0;
        for r in &lab.robots {
            for f in [
                r.mismatch.motor_gain,
                r.mismatch.dead_band,
                r.mismatch.wheel_radius,
            ] {
                assert!((0.9..=1.1).contains(&f), "{f}");
                off += usize::from((f - 1.0).abs() > 1e-3);
            }
        }
        assert!(off > 0, "no lab robot differs from the model");
        let ideal = Episode::draw(7, Profile::Ideal, &shapes, 0.0)
            .sim_scenario()
            .expect("fits");
        assert!(ideal
            .robots
            .iter()
            .all(|r| r.mismatch == PlantMismatch::NONE));
        assert_eq!(lab.impairments.loss, 0.02);
    }

    #[test]
    fn a_latency_override_replaces_the_profiles_mean_and_keeps_the_rest() {
        let shapes = custom_shapes(&default_shapes_dir()).expect("shapes");
        let mut ep = Episode::draw(7, Profile::Lab, &shapes, 0.0);
        let lab = ep.impairment();
        assert_eq!(lab, Profile::Lab.impairment());
        ep.latency_ms = Some(60.0);
        let imp = ep.impairment();
        assert_eq!(imp.latency_ms, 60.0);
        assert_eq!(
            Impairment {
                latency_ms: lab.latency_ms,
                ..imp
            },
            lab
        );
        assert!(ep.describe().contains("60 ms latency"), "{}", ep.describe());
    }
}
