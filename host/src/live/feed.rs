//! What the live page is sent: one sample every [`LIVE_PERIOD`] of run time, in the replay
//! page's compact form (`page::data`): every robot's pose, the couplings the host counts as
//! connected, the plan's pair status changes and step changes since the last sample, and the
//! progress line.

use std::collections::BTreeMap;

use puzzlebot_assembly::{PairStatus, PairType};
use puzzlebot_protocol::RobotId;
use serde_json::{json, Value};

use crate::replay::Progress;

/// Run time between two samples (s): the replay page's 10 Hz.
pub const LIVE_PERIOD: f64 = 0.1;

/// Round to 0.1 mm (positions in m) or 1 mrad, as the replay page.
fn r4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

/// Index of a pair status in the page's list (decoupled, head aligned, head inserted,
/// connected).
fn status_index(s: PairStatus) -> u8 {
    match s {
        PairStatus::Decoupled => 0,
        PairStatus::HeadAligned => 1,
        PairStatus::HeadInserted => 2,
        PairStatus::Connected => 3,
    }
}

/// The page's coupling kind: 0 anchor, 1 knob.
fn kind_index(k: PairType) -> u8 {
    u8::from(k == PairType::KnobHole)
}

/// Turns a run's ticks into the live page's samples.
#[derive(Debug, Default)]
pub struct Feed {
    /// Run time of the next sample (s).
    next_t: f64,
    /// Status of every pair as last sent, by pair index.
    sent: Vec<Option<PairStatus>>,
    /// Scenario step last sent.
    step: Option<usize>,
}

impl Feed {
    /// A feed whose first sample is taken at the first tick.
    pub fn new() -> Feed {
        Feed::default()
    }

    /// Whether a tick at run time `t` (s) is due a sample.
    pub fn due(&self, t: f64) -> bool {
        t + 1e-9 >= self.next_t
    }

    /// The sample at run time `t` (s) of robot poses `poses` ([x, y, yaw]: m, m, rad) and
    /// the run's `progress` (none: a behaviour without a plan), or `None` when it is not due.
    pub fn sample(
        &mut self,
        t: f64,
        poses: &BTreeMap<RobotId, [f64; 3]>,
        progress: Option<&Progress>,
    ) -> Option<Value> {
        if !self.due(t) {
            return None;
        }
        self.next_t = t + LIVE_PERIOD;
        let t = r4(t);
        let poses: serde_json::Map<String, Value> = poses
            .iter()
            .map(|(id, p)| (id.to_string(), json!([r4(p[0]), r4(p[1]), r4(p[2])])))
            .collect();
        let mut links = Vec::new();
        let mut pairs = Vec::new();
        let mut events = Vec::new();
        let mut line = format!("{t:.1} s");
        if let Some(p) = progress {
            line = p.line(t);
            self.sent.resize(self.sent.len().max(p.plan.len()), None);
            for (i, q) in p.plan.iter().enumerate() {
                if q.status == PairStatus::Connected {
                    links.push(json!([kind_index(q.kind), q.a, q.b, 1]));
                }
                if self.sent[i] != Some(q.status) {
                    self.sent[i] = Some(q.status);
                    pairs.push(json!([
                        t,
                        i,
                        q.a,
                        q.b,
                        kind_index(q.kind),
                        status_index(q.status)
                    ]));
                }
            }
            if self.step != Some(p.step) {
                self.step = Some(p.step);
                let text = if p.step >= p.steps {
                    "scenario finished".to_string()
                } else {
                    format!("step {}: {}", p.step, p.label)
                };
                events.push(json!([t, "coordinator", text]));
            }
        }
        Some(json!({
            "t": t,
            "poses": poses,
            "links": links,
            "pairs": pairs,
            "events": events,
            "progress": line,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::replay::PlanPair;

    fn progress(step: usize, status: PairStatus) -> Progress {
        Progress {
            step,
            steps: 2,
            label: "form a line".into(),
            connected: usize::from(status == PairStatus::Connected),
            pairs: 1,
            plan: vec![PlanPair {
                a: 2,
                b: 1,
                kind: PairType::AnchorOpening,
                status,
            }],
        }
    }

    #[test]
    fn samples_come_at_ten_hertz_with_pair_changes_and_steps_once() {
        let mut f = Feed::new();
        let poses = BTreeMap::from([(1, [0.123_456, 0.0, 0.5]), (2, [0.2, 0.0, 0.0])]);
        let first = f
            .sample(0.0, &poses, Some(&progress(0, PairStatus::Decoupled)))
            .expect("the first tick is sampled");
        assert_eq!(first["poses"]["1"], json!([0.1235, 0.0, 0.5]));
        assert_eq!(first["pairs"], json!([[0.0, 0, 2, 1, 0, 0]]));
        assert_eq!(
            first["events"],
            json!([[0.0, "coordinator", "step 0: form a line"]])
        );
        assert_eq!(first["links"], json!([]));
        assert!(first["progress"].as_str().unwrap().starts_with("step 1/2"));
        // Ticks within the period are skipped.
        assert!(f.sample(0.05, &poses, None).is_none());
        let same = f
            .sample(0.1, &poses, Some(&progress(0, PairStatus::Decoupled)))
            .expect("due");
        assert_eq!(
            same["pairs"],
            json!([]),
            "unchanged pairs are not sent again"
        );
        assert_eq!(same["events"], json!([]));
        let joined = f
            .sample(0.2, &poses, Some(&progress(1, PairStatus::Connected)))
            .expect("due");
        assert_eq!(joined["pairs"], json!([[0.2, 0, 2, 1, 0, 3]]));
        assert_eq!(joined["links"], json!([[0, 2, 1, 1]]));
        assert_eq!(joined["events"][0][2], "step 1: form a line");
    }
}
