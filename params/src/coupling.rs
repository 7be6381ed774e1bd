//! Anchor and knob mechanics (THESIS 4.2.2, 4.4.1, 5.5.3, 5.5.6; DESIGN.md §8).

use serde::{Deserialize, Serialize};

/// Limits and tolerances of the passive couplings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Coupling {
    /// Anchor head must be within this distance of the opening to go in (m). THESIS: 3.5 mm.
    pub anchor_align_tolerance: f32,
    /// Force to push the anchor in (N). THESIS 4.4.1: < 0.2 N.
    pub anchor_push_force: f32,
    /// Force to pull a coupled anchor straight out (N): above a robot's push. THESIS 4.4.1.
    pub anchor_pull_force: f32,
    /// Load a locked anchor holds (N). THESIS 4.4.1: 500 g ≈ 4.9 N.
    pub anchor_hold_force: f32,
    /// Yaw freedom of a coupled anchor (rad). THESIS 4.2.2: ±0.5.
    pub anchor_yaw_range: f32,
    /// Travel of a coupled anchor (m). THESIS 4.2.2: 5 mm.
    pub anchor_travel: f32,
    /// Knob alignment needed to couple (m). THESIS 5.2.3: < 1 mm.
    pub knob_align_tolerance: f32,
    /// Force one knob holds (N). THESIS 5.5.3: ≥ 3.2 N (sensor limit).
    pub knob_hold_force: f32,
    /// Push force of one robot at top speed (N). THESIS 4.4.1, 5.5.2: 0.5–0.72.
    pub robot_push_force: f32,
}

impl Default for Coupling {
    fn default() -> Self {
        Coupling {
            anchor_align_tolerance: 0.0035,
            anchor_push_force: 0.2,
            anchor_pull_force: 0.6,
            anchor_hold_force: 0.5 * 9.81,
            anchor_yaw_range: 0.5,
            anchor_travel: 0.005,
            knob_align_tolerance: 0.001,
            knob_hold_force: 3.2,
            robot_push_force: 0.5,
        }
    }
}
