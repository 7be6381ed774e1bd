//! 3-vector algebra in the world frame and the frames built from it.

use super::Vec3;

/// Rotation matrix (columns are the local axes in the world) from roll, pitch, yaw.
pub fn rot_rpy(rpy: Vec3) -> [Vec3; 3] {
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    // R = Rz Ry Rx; columns:
    [
        [cy * cp, sy * cp, -sp],
        [cy * sp * sr - sy * cr, sy * sp * sr + cy * cr, cp * sr],
        [cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr],
    ]
}

/// a · b
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
/// a × b
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// a − b
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
/// a + b
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
/// s·a
pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
/// ‖a‖
pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// A right-handed frame [x, y, z] (columns of ᴵR) with z along `z`; x from the hint.
pub fn frame_from_z(z: Vec3, x_hint: Option<Vec3>) -> Option<[Vec3; 3]> {
    let nz = norm(z);
    if nz.is_nan() || nz <= 1e-12 {
        return None;
    }
    let z = scale(z, 1.0 / nz);
    let candidates = [
        x_hint.unwrap_or([0.0, 0.0, 1.0]),
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    for h in candidates {
        let x = sub(h, scale(z, dot(h, z)));
        let nx = norm(x);
        if nx > 1e-6 * norm(h).max(1e-300) && nx > 1e-9 {
            let x = scale(x, 1.0 / nx);
            let y = cross(z, x);
            return Some([x, y, z]);
        }
    }
    None
}
