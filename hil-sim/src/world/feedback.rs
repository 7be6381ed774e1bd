//! The contact and coupling projection fed back into the robots' velocities, without ever
//! adding kinetic energy.
//!
//! Position-based dynamics turns a projection's displacement `dx` into a velocity change
//! `dx/dt`. That is right for the part of `dx` that undoes this step's motion into a
//! constraint (an inelastic push, a towed partner), but not for the part that repairs an error
//! the bodies already had (a penetration at rest, an anchor guided sideways into its opening, a
//! loop of rigid knobs that Gauss–Seidel does not close in a few iterations): fed back, that
//! part launches robots that were standing still. Momentum-exchanging, inelastic projections
//! lower the kinetic energy of the bodies they touch; repairs raise it. So each island of
//! bodies that can touch (joined by a link or a broad-phase pair) gets the largest share
//! `s ∈ [0, 1]` of its velocity changes that keeps its kinetic energy at most what the plants
//! left it: with `E(s) = A + 2sB + s²C`, `s = min(1, −2B/C)` (and 0 when `B ≥ 0`).

use super::*;

impl World {
    /// Take the projected bodies' poses and feed the projection back into velocities.
    pub(super) fn feed_back_projection(&mut self, dt: f64) {
        let n = self.robots.len();
        let mut dv = std::mem::take(&mut self.feedback);
        dv.clear();
        dv.resize(n, [0.0; 3]);
        let mut any = false;
        for ((r, body), d) in self
            .robots
            .iter_mut()
            .zip(self.bodies.iter())
            .zip(dv.iter_mut())
        {
            if r.fallen {
                continue;
            }
            let dx = body.pose.x - r.pose.x;
            let dy = body.pose.y - r.pose.y;
            let dyaw = crate::math::wrap(body.pose.yaw - r.pose.yaw);
            if dx == 0.0 && dy == 0.0 && dyaw == 0.0 {
                continue;
            }
            any = true;
            let [s, c] = body.trig;
            let lim = |x: f64, m: f64| x.clamp(-m, m);
            *d = [
                lim((c * dx + s * dy) / dt, MAX_FEEDBACK_SPEED),
                lim((-s * dx + c * dy) / dt, MAX_FEEDBACK_SPEED),
                lim(dyaw / dt, MAX_FEEDBACK_TURN),
            ];
            r.pose = body.pose;
            if dyaw != 0.0 {
                r.trig = body.trig;
                r.trig_age = 0;
            }
        }
        if any {
            let island = self.mech.islands(n);
            // Per island: B = Σ m·v·Δv + I·Ω·ΔΩ, C = Σ m·|Δv|² + I·ΔΩ².
            let mut bc = std::mem::take(&mut self.feedback_energy);
            bc.clear();
            bc.resize(n, [0.0; 2]);
            for ((r, d), &k) in self.robots.iter().zip(dv.iter()).zip(island.iter()) {
                let (m, iz) = (r.model.m, r.model.iz);
                let st = &r.drive;
                bc[k][0] += m * (st.v * d[0] + st.vy * d[1]) + iz * st.omega * d[2];
                bc[k][1] += m * (d[0] * d[0] + d[1] * d[1]) + iz * d[2] * d[2];
            }
            for ((r, d), &k) in self.robots.iter_mut().zip(dv.iter()).zip(island.iter()) {
                let [b, c] = bc[k];
                if c <= 0.0 {
                    continue;
                }
                let share = (-2.0 * b / c).clamp(0.0, 1.0);
                r.drive.v += share * d[0];
                r.drive.vy += share * d[1];
                r.drive.omega += share * d[2];
            }
            self.feedback_energy = bc;
        }
        self.feedback = dv;
    }
}
