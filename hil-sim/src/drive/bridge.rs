//! H-bridge commands and the average armature drive they give.

/// Commands of one H-bridge: per-mille duties of xIN1 and xIN2 (0…1000), as the DRV8833
/// sees them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Bridge {
    /// xIN1 duty, per-mille.
    pub in1: u16,
    /// xIN2 duty, per-mille.
    pub in2: u16,
}

impl Bridge {
    /// Average armature drive: (voltage factor a/V, damping factor g) such that the
    /// armature sees `a·V − g·e` with back-EMF e.
    pub fn drive(self) -> (f64, f64) {
        let d1 = f64::from(self.in1.min(1000)) * 1e-3;
        let d2 = f64::from(self.in2.min(1000)) * 1e-3;
        if d1 == 0.0 && d2 == 0.0 {
            (0.0, 0.0) // coast: open armature
        } else if d1 == 0.0 || d2 == 0.0 {
            // Fast decay: driven during the on time, coasting otherwise.
            let d = d1 - d2;
            (d, d.abs())
        } else {
            // Slow decay (or brake): the armature is always closed.
            (d1 - d2, 1.0)
        }
    }
}
