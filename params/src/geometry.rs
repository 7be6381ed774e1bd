//! Body and wheel geometry (THESIS 2.3.4, 4.2.1, 5.2.1, 5.5.6).

use serde::{Deserialize, Serialize};

/// Body footprint, wheels and connection points, in the body frame (x forward, y left).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Geometry {
    /// Body length along x (m). THESIS 5.2.1: 5 cm.
    pub length: f32,
    /// Body width along y (m). THESIS 5.2.1: 5 cm.
    pub width: f32,
    /// Body height (m). THESIS 5.2.1: 5.5 cm (v3).
    pub height: f32,
    /// Wheel radius R (m). THESIS 2.3.4: 17 mm.
    pub wheel_radius: f32,
    /// Distance between the wheels L (m). THESIS 2.3.4: 40 mm.
    pub wheel_base: f32,
    /// Anchor head point a in the body frame (m). THESIS 5.5.6: (−0.032, 0).
    pub anchor_head: [f32; 2],
    /// Centre of the anchor opening (front) in the body frame (m): the front face.
    pub anchor_opening: [f32; 2],
    /// Knob centre on the left side (m); the right side carries the hole at the mirror point.
    pub knob_left: [f32; 2],
    /// x offset (±) of the two connection points on each side (m); the left side carries the
    /// knobs, the right side the holes. THESIS Fig 5.12 (six connection points) and 5.2.2 (mesh
    /// rows offset by half a body put a knob onto a hole): L/4 = 12.5 mm.
    pub side_point_x: f32,
    /// How far a knob stands out of the side face (m); its tip is the augmented knob point of
    /// THESIS Fig 5.14. Not given as a number in THESIS; 3 mm estimated from Fig 2.3.
    pub knob_length: f32,
    /// Height of the centre of mass above the ground (m), used by the stability gate.
    pub com_height: f32,
    /// Convex polygon (counter-clockwise, in the body frame of the robot with the opening)
    /// that a coupled partner's projected anchor head must stay in (m). THESIS 4.3.4 / (4.11):
    /// pip(C_i | R_j, C_j^r, C_j^l), the triangle of the body centre and the two front corners.
    pub anchor_polygon: [[f32; 2]; 3],
}

impl Default for Geometry {
    fn default() -> Self {
        Geometry {
            length: 0.050,
            width: 0.050,
            height: 0.055,
            wheel_radius: 0.017,
            wheel_base: 0.040,
            anchor_head: [-0.032, 0.0],
            anchor_opening: [0.025, 0.0],
            knob_left: [0.0, 0.025],
            side_point_x: 0.0125,
            knob_length: 0.003,
            // Not given in THESIS; battery and motors sit low: about 40 % of the height.
            com_height: 0.022,
            // THESIS 4.3.4: body centre R_j, front-right corner C_j^r, front-left corner C_j^l.
            anchor_polygon: [[0.0, 0.0], [0.025, -0.025], [0.025, 0.025]],
        }
    }
}

impl Geometry {
    /// Half extents of the body rectangle (m).
    pub fn half_extents(&self) -> [f32; 2] {
        [self.length * 0.5, self.width * 0.5]
    }
}
