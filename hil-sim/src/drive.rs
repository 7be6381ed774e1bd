//! One robot's drive plant: two DC motors behind DRV8833 bridges, gearboxes with static,
//! Coulomb and viscous friction, wheels with traction limits, the body on the floor
//! (two wheels + casters, or four wheels), and the LiPo battery with sag.
//!
//! # Model
//!
//! Unknowns after one fixed step `dt` (1 ms by default): wheel speeds ω_l, ω_r (output
//! shaft, rad/s) and the body-frame velocities v (forward), Ω (yaw rate), v_y (sideways).
//!
//! * Motor s (armature R, L, k_t = k_e = k; gear ratio N, efficiency η): the bridge
//!   gives an average armature voltage; slow decay (one input held high) keeps the
//!   armature closed, `L di/dt = (d₁−d₂)·V − R i − k N ω`; fast decay (one input low)
//!   coasts during the off time, which scales drive and back-EMF damping by the duty D:
//!   `L di/dt = D·(±V − k N ω) − R i`. The current is integrated with backward Euler
//!   (L/R ≈ 55 µs ≪ dt, so it is L-stable and exact at steady state); wheel torque
//!   `η N k i`.
//! * Gearbox friction at the wheel shaft: a wheel at rest stays locked while the torque
//!   reaching it is below the static friction (the start-up dead-band M_min of THESIS 3.4);
//!   once turning, Coulomb plus viscous friction.
//! * Wheel–floor traction per side: `F = c·(r ω − v_contact)`, linear up to the slip speed
//!   and capped at μN (wheel spin / skid; this is the slip limit of the unicycle).
//! * Body (THESIS 2.1 / 5.1 unicycle, with forces): `m v̇ = F_l + F_r + casters`,
//!   `I Ω̇ = (F_r − F_l) L/2 + Σ x_j F_lat,j`, `m v̇_y = Σ F_lat,j`. Lateral tyre forces
//!   follow the slip angle α = |v_lat| / |v_long| up to saturation (μ_lat N at
//!   `slip_angle_saturation`): the wheels of a pilot sit at x = ±d, so yawing scrubs them
//!   sideways; at standstill that costs the full μ_lat N d per wheel (the motors stall),
//!   while rolling forward makes the slip angle small (the pilot "needs forward speed to
//!   turn", THESIS 3.5.1). A non-pilot's wheels sit on the centre line: it turns in place.
//!
//! All linear terms (motor damping, traction, secant lateral and caster friction) are
//! implicit, so the step is stable for every parameter set; the result is a 5 × 5 linear
//! system per robot per step, solved by eliminating the wheels (see [`step`]).

mod bridge;
mod model;

pub use bridge::Bridge;
pub use model::{BatteryModel, DriveModel, DriveState};

/// Gravity (m/s²).
pub const G: f64 = 9.81;

/// Speed below which a wheel counts as standing (rad/s).
const WHEEL_REST: f64 = 1e-3;
/// Regularisation speed of sliding friction (m/s).
const V_REG: f64 = 2e-3;
/// Rolling speed added under the slip angle so a standing wheel has a finite stiffness.
const V_ROLL_EPS: f64 = 5e-3;

/// Advance the drive by `dt` seconds with the bridge commands `cmd` (left, right).
///
/// The implicit step is the 5 × 5 linear system of the module documentation (wheels,
/// v, Ω, v_y). Each wheel couples only to itself and to the body, so it is eliminated
/// first: its traction becomes `F_s = g_s − e_s·u_s` in the contact speed
/// `u_s = v ∓ Ω·L/2` (a locked wheel: `e = c`, `g = 0`; a saturated one: `e = 0`,
/// `g = ±μN`). What is left is a symmetric positive-definite tridiagonal 3 × 3 system in
/// (v, Ω, v_y), solved in closed form (adjugate / determinant); the wheels follow by
/// back-substitution. Up to four passes re-solve when a wheel saturates or its friction
/// would reverse it.
///
/// Returns the new body velocities (v, Ω, v_y), the same values as `st.v`, `st.omega`,
/// `st.vy` (handed back in registers so a caller integrating the pose does not reload
/// them from memory right after they were stored).
pub fn step(model: &DriveModel, st: &mut DriveState, cmd: [Bridge; 2], dt: f64) -> [f64; 3] {
    let md = model;
    let vbat = st.battery_v;
    let half = md.base * 0.5;
    // Contact-speed arms: left contact = v − Ω·half, right = v + Ω·half, i.e. v − σ_s·Ω.
    let sigma = [half, -half];
    // Motor terms: wheel torque = A_s − B_s·ω_s' (after eliminating the current).
    let l_dt = md.ind / dt;
    let inv_r = 1.0 / (md.res + l_dt);
    let torque_k = md.eta * md.n * md.k;
    let mut a_m = [0.0; 2];
    let mut b_m = [0.0; 2];
    let mut cur_c0 = [0.0; 2];
    let mut cur_c1 = [0.0; 2];
    for s in 0..2 {
        let (av, g) = cmd[s].drive();
        let c0 = (l_dt * st.current[s] + av * vbat) * inv_r;
        let c1 = g * md.k * md.n * inv_r;
        cur_c0[s] = c0;
        cur_c1[s] = c1;
        a_m[s] = torque_k * c0;
        b_m[s] = torque_k * c1 + md.b_visc;
    }
    // Contact speeds at the start of the step (for the secant stiffnesses).
    let long = [st.v - st.omega * half, st.v + st.omega * half];
    let roll = 0.5 * (long[0].abs() + long[1].abs());
    // Friction decisions per wheel: locked (static) or Coulomb with a sign.
    let mut locked = [false; 2];
    let mut t_fric = [0.0; 2];
    for s in 0..2 {
        let w = st.wheel[s];
        if w.abs() < WHEEL_REST {
            let slip = md.r * w - long[s];
            let f_now = (md.traction_c * slip).clamp(-md.traction_max, md.traction_max);
            let t_net = a_m[s] - md.r * f_now;
            if t_net.abs() <= md.t_static {
                locked[s] = true;
            } else {
                t_fric[s] = -md.t_coulomb * t_net.signum();
            }
        } else {
            t_fric[s] = -md.t_coulomb * w.signum();
        }
    }
    // Secant lateral stiffnesses (wheel scrub with slip angle, caster sliding), summed
    // into the body rows: Σk (v_y and Ω coupling), Σk·x, Σk·x², and the casters' Σk on v.
    let (mut k_sum, mut kx_sum, mut kxx_sum, mut k_cast) = (0.0, 0.0, 0.0, 0.0);
    for &(x, mu_n) in &md.lateral[..md.n_lateral] {
        let vl = (st.vy + st.omega * x).abs();
        // min(1/(α_sat·rolling), 1/|v_lat|): linear in the slip angle, capped at μN.
        let k = mu_n / (md.alpha_sat * (roll + V_ROLL_EPS)).max(vl.max(V_REG));
        k_sum += k;
        kx_sum += k * x;
        kxx_sum += k * x * x;
    }
    for &(x, mu_n) in &md.casters[..md.n_casters] {
        let lat = st.vy + st.omega * x;
        let sp = (st.v * st.v + lat * lat).sqrt();
        let k = mu_n / sp.max(V_REG);
        k_cast += k;
        k_sum += k;
        kx_sum += k * x;
        kxx_sum += k * x * x;
    }
    let c = md.traction_c;
    let dtr = dt * md.r;
    // Wheel rows without traction: diagonal J + dt·B_s and right-hand side.
    let jb = [md.jw + dt * b_m[0], md.jw + dt * b_m[1]];
    let bw = [
        md.jw * st.wheel[0] + dt * (a_m[0] + t_fric[0]),
        md.jw * st.wheel[1] + dt * (a_m[1] + t_fric[1]),
    ];
    // Terms of the body system that do not change between passes.
    let a33 = md.m + dt * k_sum;
    let a23 = dt * kx_sum;
    let a22_base = md.iz + dt * kxx_sum;
    let a11_base = md.m + dt * k_cast;
    let (b1_base, b2_base, b3) = (md.m * st.v, md.iz * st.omega, md.m * st.vy);
    let mut sat: [Option<f64>; 2] = [None, None];
    let (mut v, mut om, mut vy) = (0.0, 0.0, 0.0);
    let mut wheel = [0.0; 2];
    for _pass in 0..4 {
        // Traction of each wheel as F_s = g_s − e_s·u_s (wheel eliminated).
        let mut e = [0.0; 2];
        let mut g = [0.0; 2];
        let mut inv_d = [0.0; 2];
        for s in 0..2 {
            match (sat[s], locked[s]) {
                (Some(f), _) => g[s] = f,
                (None, true) => e[s] = c,
                (None, false) => {
                    let inv = 1.0 / (jb[s] + dtr * md.r * c);
                    inv_d[s] = inv;
                    e[s] = c * jb[s] * inv;
                    g[s] = c * md.r * bw[s] * inv;
                }
            }
        }
        // Body rows (v, Ω, v_y): symmetric tridiagonal.
        let a11 = a11_base + dt * (e[0] + e[1]);
        let a12 = -dt * (sigma[0] * e[0] + sigma[1] * e[1]);
        let a22 = a22_base + dt * half * half * (e[0] + e[1]);
        let b1 = b1_base + dt * (g[0] + g[1]);
        let b2 = b2_base - dt * (sigma[0] * g[0] + sigma[1] * g[1]);
        let c11 = a22 * a33 - a23 * a23;
        let det = a11 * c11 - a12 * a12 * a33;
        if det > 0.0 {
            let inv_det = 1.0 / det;
            v = (c11 * b1 - a12 * a33 * b2 + a12 * a23 * b3) * inv_det;
            om = (-a12 * a33 * b1 + a11 * a33 * b2 - a11 * a23 * b3) * inv_det;
            vy = (a12 * a23 * b1 - a11 * a23 * b2 + (a11 * a22 - a12 * a12) * b3) * inv_det;
        } else {
            // Only for degenerate parameters (zero mass or inertia): the body stays put.
            (v, om, vy) = (0.0, 0.0, 0.0);
        }
        // Wheels by back-substitution; traction limits and friction sign changes.
        let mut again = false;
        for s in 0..2 {
            let u = v - sigma[s] * om;
            wheel[s] = match (sat[s], locked[s]) {
                (_, true) => 0.0,
                (Some(f), false) => (bw[s] - dtr * f) / jb[s],
                (None, false) => (bw[s] + dtr * c * u) * inv_d[s],
            };
            if sat[s].is_none() {
                let f = c * (md.r * wheel[s] - u);
                if f.abs() > md.traction_max {
                    sat[s] = Some(md.traction_max * f.signum());
                    again = true;
                }
            }
            if !locked[s] && st.wheel[s].abs() >= WHEEL_REST && st.wheel[s] * wheel[s] < 0.0 {
                locked[s] = true;
                again = true;
            }
        }
        if !again {
            break;
        }
    }
    for s in 0..2 {
        let u = v - sigma[s] * om;
        st.traction[s] = match sat[s] {
            Some(f) => f,
            None => c * (md.r * wheel[s] - u),
        };
        st.current[s] = cur_c0[s] - cur_c1[s] * wheel[s];
        st.wheel[s] = wheel[s];
        st.angle[s] += wheel[s] * dt;
    }
    st.v = v;
    st.omega = om;
    st.vy = vy;
    // Battery: motors draw |i| from the pack (regeneration is not stored).
    let i_total = md.battery.idle + st.current[0].abs() + st.current[1].abs();
    st.soc = (st.soc - i_total * dt * md.battery.inv_capacity).max(0.0);
    st.battery_v = (md.battery.open_circuit(st.soc) - i_total * md.battery.resistance).max(0.0);
    [v, om, vy]
}

#[cfg(test)]
mod tests;
