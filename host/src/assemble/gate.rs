//! The stability gate (SOCP paper §4, DESIGN.md §7): every coupled assembly that is
//! commanded to move has its advance along its heading bounded by
//! [`puzzlebot_stability::max_safe_advance`]; the host never commands it past the safe
//! distance, it stops the assembly and records why.

use std::collections::{BTreeMap, BTreeSet};

use puzzlebot_assembly::{MaintainPair, PairType, RobotState};
use puzzlebot_params::terrain::Terrain;
use puzzlebot_params::FleetParams;
use puzzlebot_protocol::messages::RobotId;
use puzzlebot_stability::puzzlebot::{Pair, PairKind, PuzzleAssembly, RobotPose};
use puzzlebot_stability::{max_safe_advance, LimitedBy};
use serde::Serialize;

use crate::drive::Twist;

/// One stop (or limit) decided by the stability gate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GateStop {
    /// Controller time (s since start).
    pub t: f64,
    /// Robots of the assembly.
    pub robots: Vec<RobotId>,
    /// Heading of the requested advance (rad).
    pub heading: f64,
    /// Safe advance left along it (m).
    pub safe_advance: f64,
    /// What limits it.
    pub limited_by: LimitedBy,
    /// Centre of the assembly when it was stopped (m).
    pub centre: [f64; 2],
}

/// Gate settings.
#[derive(Debug, Clone, PartialEq)]
pub struct GateConfig {
    /// Terrain the assembly moves over (no platforms: endless floor, gate idle).
    pub terrain: Terrain,
    /// Scan step of the contact-state search (m).
    pub step: f64,
    /// Distance kept back from the safe limit (m): covers latency (about two control
    /// periods at cruise speed) and pose noise.
    pub margin: f64,
    /// Outside a cross step, keep robots from driving towards a drop at all
    /// ([`super::edge_guard`]); off, assemblies drive up to the gate's limit.
    pub edge_guard: bool,
}

impl Default for GateConfig {
    fn default() -> Self {
        GateConfig {
            terrain: Terrain::flat(),
            step: 0.005,
            margin: 0.004,
            edge_guard: true,
        }
    }
}

/// The gate's state over a run: its settings, the fleet it checks and which assemblies it
/// holds stopped.
#[derive(Debug, Clone)]
pub struct Gate {
    config: GateConfig,
    params: FleetParams,
    /// Assemblies stopped now (one stop recorded per change of their stop state).
    gated: BTreeSet<Vec<RobotId>>,
}

impl Gate {
    /// A gate with `config` over a fleet of `params`.
    pub fn new(config: GateConfig, params: FleetParams) -> Self {
        Gate {
            config,
            params,
            gated: BTreeSet::new(),
        }
    }

    /// For every coupled assembly (`segments`) that is commanded (`out`) to move over the
    /// next control period `dt` (s), limit its advance along its heading to the proven-safe
    /// distance; stop it there. Returns the stops newly decided.
    pub fn apply(
        &mut self,
        t: f64,
        dt: f64,
        states: &[RobotState],
        maintain: &[MaintainPair],
        segments: &BTreeMap<usize, Vec<RobotId>>,
        out: &mut BTreeMap<RobotId, Twist>,
    ) -> Vec<GateStop> {
        let mut stops = Vec::new();
        if self.config.terrain.platforms.is_empty() {
            return stops;
        }
        let geometry = self.params.non_pilot.geometry;
        for members in segments.values() {
            let idx: BTreeMap<RobotId, usize> =
                members.iter().enumerate().map(|(i, id)| (*id, i)).collect();
            let robots: Vec<RobotPose> = members
                .iter()
                .filter_map(|id| states.iter().find(|s| s.id == *id))
                .map(|s| RobotPose {
                    kind: s.kind,
                    x: s.pose.x,
                    y: s.pose.y,
                    yaw: s.pose.yaw,
                })
                .collect();
            if robots.len() != members.len() {
                continue;
            }
            let pairs: Vec<Pair> = maintain
                .iter()
                .filter_map(|m| {
                    let (a, b) = (*idx.get(&m.a)?, *idx.get(&m.b)?);
                    Some(match m.kind {
                        PairType::AnchorOpening => Pair {
                            a,
                            b,
                            kind: PairKind::Anchor,
                            point: None,
                        },
                        PairType::KnobHole => Pair {
                            a,
                            b,
                            kind: PairKind::Knob,
                            point: Some(m.point_a.position(&geometry)),
                        },
                    })
                })
                .collect();
            // Requested motion of the assembly: mean commanded speed along the mean heading.
            let n = robots.len() as f64;
            let (mut vx, mut vy) = (0.0, 0.0);
            for (r, id) in robots.iter().zip(members) {
                if let Some(tw) = out.get(id) {
                    vx += tw.v * r.yaw.cos() / n;
                    vy += tw.v * r.yaw.sin() / n;
                }
            }
            let speed = vx.hypot(vy);
            let key = members.clone();
            if speed < 1e-4 {
                continue;
            }
            let heading = vy.atan2(vx);
            let asm = PuzzleAssembly {
                robots: robots.clone(),
                pairs,
            };
            let centre = [
                robots.iter().map(|r| r.x).sum::<f64>() / n,
                robots.iter().map(|r| r.y).sum::<f64>() / n,
            ];
            let (safe, why) = match max_safe_advance(
                &asm,
                &self.params,
                &self.config.terrain,
                heading,
                self.config.step,
            ) {
                Ok(a) => (a.distance, a.limited_by),
                Err(e) => (
                    0.0,
                    LimitedBy::NotProven {
                        reason: e.to_string(),
                    },
                ),
            };
            let room = safe - self.config.margin;
            // Never command past the limit: the advance over the next two control periods
            // (latency) must stay inside the room left.
            if room <= speed * 2.0 * dt {
                for id in members {
                    out.insert(*id, Twist::new(0.0, 0.0));
                }
                if self.gated.insert(key) {
                    tracing::warn!(
                        "stability gate: assembly {members:?} stopped, safe advance {safe:.4} m ({why:?})"
                    );
                    stops.push(GateStop {
                        t,
                        robots: members.clone(),
                        heading,
                        safe_advance: safe,
                        limited_by: why,
                        centre,
                    });
                }
            } else {
                self.gated.remove(&key);
            }
        }
        stops
    }
}
