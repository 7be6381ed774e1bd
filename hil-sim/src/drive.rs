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

use puzzlebot_params::{mass::Mass, plant::Plant, RobotKind};

/// Gravity (m/s²).
pub const G: f64 = 9.81;

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

/// Derived constants of one robot's drive (computed once).
#[derive(Debug, Clone, Copy)]
pub struct DriveModel {
    /// Wheel radius (m).
    pub r: f64,
    /// Wheel base (m).
    pub base: f64,
    /// Mass (kg).
    pub m: f64,
    /// Yaw inertia (kg·m²).
    pub iz: f64,
    /// Wheel-side inertia of one motor + gearbox + wheel (kg·m²).
    pub jw: f64,
    /// Motor constant (SI).
    pub k: f64,
    /// Armature resistance (Ω).
    pub res: f64,
    /// Armature inductance (H).
    pub ind: f64,
    /// Gear ratio.
    pub n: f64,
    /// Gear efficiency.
    pub eta: f64,
    /// Static friction torque at the wheel (N·m).
    pub t_static: f64,
    /// Coulomb friction torque at the wheel (N·m).
    pub t_coulomb: f64,
    /// Viscous friction (N·m·s/rad).
    pub b_visc: f64,
    /// Traction cap per side (N).
    pub traction_max: f64,
    /// Traction slope per side (N per m/s of slip).
    pub traction_c: f64,
    /// Lateral wheel contacts: (x in body frame, μ_lat·N).
    pub lateral: [(f64, f64); 4],
    /// Number of used entries of `lateral`.
    pub n_lateral: usize,
    /// Casters: (x, μ·N).
    pub casters: [(f64, f64); 2],
    /// Number of casters.
    pub n_casters: usize,
    /// Slip angle at which lateral tyre force saturates (rad).
    pub alpha_sat: f64,
    /// Battery.
    pub battery: BatteryModel,
}

/// Battery constants.
#[derive(Debug, Clone, Copy)]
pub struct BatteryModel {
    /// Open-circuit voltage at 50 % charge (V).
    pub nominal: f64,
    /// Open-circuit swing from empty to full (V).
    pub swing: f64,
    /// Internal resistance (Ω).
    pub resistance: f64,
    /// 1 / capacity (1/C).
    pub inv_capacity: f64,
    /// Current of the electronics (A).
    pub idle: f64,
}

/// Speed below which a wheel counts as standing (rad/s).
const WHEEL_REST: f64 = 1e-3;
/// Regularisation speed of sliding friction (m/s).
const V_REG: f64 = 2e-3;
/// Rolling speed added under the slip angle so a standing wheel has a finite stiffness.
const V_ROLL_EPS: f64 = 5e-3;

impl DriveModel {
    /// Constants for a robot of `kind` with the given parameters.
    pub fn new(
        kind: RobotKind,
        p: &Plant,
        mass: &Mass,
        geom: &puzzlebot_params::geometry::Geometry,
    ) -> Self {
        let m = f64::from(mass.mass);
        let w = m * G;
        let _ = kind;
        let four = p.four_wheels;
        let wheel_share = if four {
            1.0
        } else {
            f64::from(p.wheel_load_fraction).clamp(0.0, 1.0)
        };
        let n_side = w * wheel_share * 0.5;
        let mu = f64::from(p.wheel_friction);
        let mu_lat = f64::from(p.wheel_lateral_friction);
        let d = f64::from(p.wheel_axle_offset);
        let mut lateral = [(0.0, 0.0); 4];
        let n_lateral = if four {
            // Two wheels per side at x = ±d; each carries a quarter of the weight.
            lateral[0] = (d, mu_lat * w * 0.25 * 2.0);
            lateral[1] = (-d, mu_lat * w * 0.25 * 2.0);
            2
        } else {
            // One axle, `wheel_axle_offset` ahead of the centre (0 for the chapter-5 robot).
            lateral[0] = (d, mu_lat * n_side * 2.0);
            1
        };
        let mut casters = [(0.0, 0.0); 2];
        let n_casters = if four {
            0
        } else {
            let nc = w * (1.0 - wheel_share) * 0.5;
            let c = f64::from(p.caster_offset);
            casters[0] = (c, f64::from(p.caster_friction) * nc);
            casters[1] = (-c, f64::from(p.caster_friction) * nc);
            2
        };
        let n = f64::from(p.gear_ratio);
        DriveModel {
            r: f64::from(geom.wheel_radius),
            base: f64::from(geom.wheel_base),
            m,
            iz: f64::from(p.yaw_inertia),
            jw: f64::from(p.rotor_inertia) * n * n,
            k: f64::from(p.motor_k),
            res: f64::from(p.motor_resistance),
            ind: f64::from(p.motor_inductance),
            n,
            eta: f64::from(p.gear_efficiency),
            t_static: f64::from(p.friction_static),
            t_coulomb: f64::from(p.friction_coulomb),
            b_visc: f64::from(p.friction_viscous),
            traction_max: mu * n_side,
            traction_c: mu * n_side / f64::from(p.traction_slip_speed).max(1e-4),
            lateral,
            n_lateral,
            casters,
            n_casters,
            alpha_sat: f64::from(p.slip_angle_saturation).max(1e-3),
            battery: BatteryModel {
                nominal: f64::from(p.battery_voltage),
                swing: f64::from(p.battery_voltage_swing),
                resistance: f64::from(p.battery_resistance),
                inv_capacity: 1.0 / (f64::from(p.battery_capacity_mah) * 3.6).max(1e-9),
                idle: f64::from(p.idle_current),
            },
        }
    }
}

/// The evolving state of one robot's drive.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DriveState {
    /// Wheel speeds left, right (rad/s, output shaft; positive drives forward).
    pub wheel: [f64; 2],
    /// Wheel angles (rad, output shaft, unwrapped).
    pub angle: [f64; 2],
    /// Armature currents (A).
    pub current: [f64; 2],
    /// Forward speed (m/s, body frame).
    pub v: f64,
    /// Sideways speed (m/s, body frame, left positive).
    pub vy: f64,
    /// Yaw rate (rad/s).
    pub omega: f64,
    /// Battery state of charge (0…1).
    pub soc: f64,
    /// Battery terminal voltage at the last step (V).
    pub battery_v: f64,
    /// Traction forces left, right at the last step (N).
    pub traction: [f64; 2],
}

impl DriveState {
    /// At rest with the battery at `soc`.
    pub fn at_rest(model: &DriveModel, soc: f64) -> DriveState {
        let soc = soc.clamp(0.0, 1.0);
        DriveState {
            soc,
            battery_v: model.battery.open_circuit(soc),
            ..DriveState::default()
        }
    }
}

impl BatteryModel {
    /// Open-circuit voltage at `soc` (linear around the nominal voltage).
    pub fn open_circuit(&self, soc: f64) -> f64 {
        self.nominal + (soc - 0.5) * self.swing
    }
}

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
mod tests {
    use super::*;
    use puzzlebot_params::RobotParams;

    /// Solve `a x = b` for the drive's 5 × 5 structure: rows/columns 0 and 1 are the wheels,
    /// which couple only to themselves and to the body (columns 2…4), never to each other. The
    /// wheels are eliminated (their diagonal is ≥ the wheel inertia, or 1 for a locked wheel),
    /// leaving a 3 × 3 body system (Gaussian elimination); then the wheels are back-substituted.
    #[allow(clippy::needless_range_loop)] // dense small-matrix elimination
    fn solve5(a: &[[f64; 5]; 5], b: &[f64; 5]) -> [f64; 5] {
        let inv_w = [1.0 / a[0][0], 1.0 / a[1][1]];
        let mut m = [[0.0; 3]; 3];
        let mut y = [0.0; 3];
        for r in 0..3 {
            y[r] = b[r + 2];
            m[r] = [a[r + 2][2], a[r + 2][3], a[r + 2][4]];
            for s in 0..2 {
                let f = a[r + 2][s] * inv_w[s];
                if f != 0.0 {
                    for c in 0..3 {
                        m[r][c] -= f * a[s][c + 2];
                    }
                    y[r] -= f * b[s];
                }
            }
        }
        // 3 × 3 Gaussian elimination with partial pivoting.
        let mut x = [0.0; 5];
        let mut inv_diag = [0.0; 3];
        for col in 0..3 {
            let mut piv = col;
            for r in col + 1..3 {
                if m[r][col].abs() > m[piv][col].abs() {
                    piv = r;
                }
            }
            m.swap(col, piv);
            y.swap(col, piv);
            let d = m[col][col];
            if d.abs() < 1e-300 {
                continue;
            }
            let inv = 1.0 / d;
            inv_diag[col] = inv;
            for r in col + 1..3 {
                let f = m[r][col] * inv;
                for c in col..3 {
                    m[r][c] -= f * m[col][c];
                }
                y[r] -= f * y[col];
            }
        }
        for r in (0..3).rev() {
            let mut v = y[r];
            for c in r + 1..3 {
                v -= m[r][c] * x[c + 2];
            }
            x[r + 2] = v * inv_diag[r]; // 0 for a singular pivot
        }
        for s in 0..2 {
            let mut v = b[s];
            for c in 2..5 {
                v -= a[s][c] * x[c];
            }
            x[s] = v * inv_w[s];
        }
        x
    }

    /// The previous implementation: the full 5 × 5 system assembled and solved generically.
    #[allow(clippy::needless_range_loop)] // index-parallel arrays of the 5 × 5 system
    fn reference_step(model: &DriveModel, st: &mut DriveState, cmd: [Bridge; 2], dt: f64) {
        let md = model;
        let vbat = st.battery_v;
        let half = md.base * 0.5;
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
        let roll = (0.5 * (long[0].abs() + long[1].abs())).max(0.0);
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
        // Secant lateral stiffnesses (wheel scrub with slip angle, caster sliding).
        let mut lat_k = [0.0; 4];
        for (j, lk) in lat_k.iter_mut().enumerate().take(md.n_lateral) {
            let (x, mu_n) = md.lateral[j];
            let vl = (st.vy + st.omega * x).abs();
            // min(1/(α_sat·rolling), 1/|v_lat|): linear in the slip angle, capped at μN.
            *lk = mu_n / (md.alpha_sat * (roll + V_ROLL_EPS)).max(vl.max(V_REG));
        }
        let mut cas_k = [0.0; 2];
        for (j, ck) in cas_k.iter_mut().enumerate().take(md.n_casters) {
            let (x, mu_n) = md.casters[j];
            let lat = st.vy + st.omega * x;
            let sp = (st.v * st.v + lat * lat).sqrt();
            *ck = mu_n / sp.max(V_REG);
        }
        let mut sat: [Option<f64>; 2] = [None, None];
        let mut x = [0.0; 5];
        for _pass in 0..4 {
            // Rows: 0,1 wheels; 2 v; 3 Ω; 4 v_y. Columns: ω_l, ω_r, v, Ω, v_y.
            let mut a = [[0.0; 5]; 5];
            let mut b = [0.0; 5];
            // Traction coefficients F_s = c·(r ω_s − v ± Ω·half) or a constant.
            // left contact speed = v − Ω half; right = v + Ω half.
            let sign_om = [half, -half];
            for s in 0..2 {
                if locked[s] {
                    a[s][s] = 1.0;
                    b[s] = 0.0;
                } else {
                    a[s][s] = md.jw + dt * b_m[s];
                    b[s] = md.jw * st.wheel[s] + dt * (a_m[s] + t_fric[s]);
                }
                match sat[s] {
                    Some(f) => {
                        if !locked[s] {
                            b[s] -= dt * md.r * f;
                        }
                        b[2] += dt * f;
                        // Torque (F_r − F_l)·half: left −half, right +half.
                        b[3] += dt * f * if s == 0 { -half } else { half };
                    }
                    None => {
                        let c = md.traction_c;
                        // Wheel row: + dt·r·F.
                        if !locked[s] {
                            a[s][s] += dt * md.r * c * md.r;
                            a[s][2] += -dt * md.r * c;
                            a[s][3] += dt * md.r * c * sign_om[s];
                        }
                        // v row: − dt·F.
                        a[2][s] -= dt * c * md.r;
                        a[2][2] += dt * c;
                        a[2][3] -= dt * c * sign_om[s];
                        // Ω row: − dt·(±half)·F.
                        let arm = if s == 0 { -half } else { half };
                        a[3][s] -= dt * arm * c * md.r;
                        a[3][2] += dt * arm * c;
                        a[3][3] -= dt * arm * c * sign_om[s];
                    }
                }
            }
            a[2][2] += md.m;
            b[2] += md.m * st.v;
            a[3][3] += md.iz;
            b[3] += md.iz * st.omega;
            a[4][4] += md.m;
            b[4] += md.m * st.vy;
            // Lateral wheel forces F = −k (v_y + Ω x).
            for j in 0..md.n_lateral {
                let (xj, _) = md.lateral[j];
                let k = lat_k[j];
                a[4][4] += dt * k;
                a[4][3] += dt * k * xj;
                a[3][4] += dt * k * xj;
                a[3][3] += dt * k * xj * xj;
            }
            for j in 0..md.n_casters {
                let (xj, _) = md.casters[j];
                let k = cas_k[j];
                a[2][2] += dt * k;
                a[4][4] += dt * k;
                a[4][3] += dt * k * xj;
                a[3][4] += dt * k * xj;
                a[3][3] += dt * k * xj * xj;
            }
            x = solve5(&a, &b);
            // Traction limits and friction sign changes.
            let mut again = false;
            for s in 0..2 {
                if sat[s].is_none() {
                    let contact = x[2] - sign_om[s] * x[3];
                    let f = md.traction_c * (md.r * x[s] - contact);
                    if f.abs() > md.traction_max {
                        sat[s] = Some(md.traction_max * f.signum());
                        again = true;
                    }
                }
                if !locked[s] && st.wheel[s].abs() >= WHEEL_REST && st.wheel[s] * x[s] < 0.0 {
                    locked[s] = true;
                    again = true;
                }
            }
            if !again {
                break;
            }
        }
        for s in 0..2 {
            let contact = x[2] - [half, -half][s] * x[3];
            st.traction[s] = match sat[s] {
                Some(f) => f,
                None => md.traction_c * (md.r * x[s] - contact),
            };
            st.current[s] = cur_c0[s] - cur_c1[s] * x[s];
            st.wheel[s] = x[s];
            st.angle[s] += x[s] * dt;
        }
        st.v = x[2];
        st.omega = x[3];
        st.vy = x[4];
        // Battery: motors draw |i| from the pack (regeneration is not stored).
        let i_total = md.battery.idle + st.current[0].abs() + st.current[1].abs();
        st.soc = (st.soc - i_total * dt * md.battery.inv_capacity).max(0.0);
        st.battery_v = (md.battery.open_circuit(st.soc) - i_total * md.battery.resistance).max(0.0);
    }

    fn model(kind: RobotKind) -> (DriveModel, DriveState) {
        let p = RobotParams::for_kind(kind);
        let m = DriveModel::new(kind, &p.plant, &p.mass, &p.geometry);
        let s = DriveState::at_rest(&m, f64::from(p.plant.battery_initial_soc));
        (m, s)
    }

    fn run(kind: RobotKind, duty: [i16; 2], secs: f64) -> (DriveModel, DriveState) {
        let (m, mut s) = model(kind);
        let b = |d: i16| {
            if d >= 0 {
                Bridge {
                    in1: 1000,
                    in2: 1000 - d as u16,
                }
            } else {
                Bridge {
                    in1: 1000 - (-d) as u16,
                    in2: 1000,
                }
            }
        };
        for _ in 0..(secs * 1000.0) as usize {
            step(&m, &mut s, [b(duty[0]), b(duty[1])], 1e-3);
        }
        (m, s)
    }

    #[test]
    fn structured_solver_matches_the_system() {
        let mut a = [[0.0; 5]; 5];
        let vals = [0.3, -0.7, 1.1, 0.2, -0.4, 0.9, 0.5, -0.2, 0.8];
        a[0][0] = 2.0;
        a[1][1] = 3.0;
        for r in 0..2 {
            for c in 2..5 {
                a[r][c] = vals[r * 3 + c - 2];
                a[c][r] = vals[(r * 3 + c) % 9] * 0.5;
            }
        }
        for r in 2..5 {
            for c in 2..5 {
                a[r][c] = if r == c { 5.0 } else { vals[r + c - 4] };
            }
        }
        let b = [1.0, -2.0, 0.5, 3.0, -1.0];
        let x = solve5(&a, &b);
        for r in 0..5 {
            let lhs: f64 = (0..5).map(|c| a[r][c] * x[c]).sum();
            assert!((lhs - b[r]).abs() < 1e-12, "row {r}: {lhs} vs {}", b[r]);
        }
    }

    #[test]
    fn step_solves_the_full_five_by_five_system() {
        // The structured step against the generic 5 × 5 assembly and elimination, from
        // random states and commands (rest, rolling, spinning, skidding, both kinds,
        // slow and fast decay, coast).
        let mut rng = crate::rng::Rng::new(7, 7);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
        let mut checked = 0;
        for kind in [RobotKind::NonPilot, RobotKind::Pilot] {
            for trial in 0..400 {
                let (m, mut s) = model(kind);
                if trial % 4 != 0 {
                    s.wheel = [u(-50.0, 50.0), u(-50.0, 50.0)];
                    s.v = u(-0.8, 0.8);
                    s.omega = u(-12.0, 12.0);
                    s.vy = u(-0.1, 0.1);
                    s.current = [u(-0.7, 0.7), u(-0.7, 0.7)];
                }
                let br = |x: f64, y: f64| Bridge {
                    in1: if x < 0.2 { 0 } else { (x * 1000.0) as u16 },
                    in2: if y < 0.2 { 0 } else { (y * 1000.0) as u16 },
                };
                let cmd = [br(u(0.0, 1.0), u(0.0, 1.0)), br(u(0.0, 1.0), u(0.0, 1.0))];
                let mut r = s;
                for _ in 0..5 {
                    step(&m, &mut s, cmd, 1e-3);
                    reference_step(&m, &mut r, cmd, 1e-3);
                    let pairs = [
                        (s.wheel[0], r.wheel[0], 100.0),
                        (s.wheel[1], r.wheel[1], 100.0),
                        (s.v, r.v, 1.0),
                        (s.omega, r.omega, 10.0),
                        (s.vy, r.vy, 1.0),
                        (s.traction[0], r.traction[0], 1.0),
                        (s.traction[1], r.traction[1], 1.0),
                    ];
                    for (a, b, scale) in pairs {
                        assert!(
                            (a - b).abs() <= 1e-9 * scale,
                            "{kind:?} trial {trial}: {a} vs {b}\n{s:?}\n{r:?}"
                        );
                    }
                    checked += 1;
                    // Continue from the same state so rounding does not accumulate.
                    r = s;
                }
            }
        }
        assert_eq!(checked, 4000);
    }

    #[test]
    fn full_duty_reaches_the_450_rpm_range() {
        let (_, s) = run(RobotKind::NonPilot, [1000, 1000], 1.0);
        let rpm = s.wheel[0] * 60.0 / (2.0 * core::f64::consts::PI);
        assert!((455.0..560.0).contains(&rpm), "top speed {rpm} RPM");
        assert!(s.v > 0.7, "{}", s.v);
    }

    #[test]
    fn small_duty_is_inside_the_dead_band() {
        let (m, _) = model(RobotKind::NonPilot);
        let (_, s) = run(RobotKind::NonPilot, [60, 60], 0.5);
        assert_eq!(s.wheel, [0.0, 0.0], "6 % duty must not start the wheels");
        let (_, s) = run(RobotKind::NonPilot, [200, 200], 0.5);
        assert!(s.wheel[0] > 1.0);
        assert!(m.t_static > m.t_coulomb);
    }

    #[test]
    fn non_pilot_turns_in_place_pilot_does_not() {
        let (_, np) = run(RobotKind::NonPilot, [-600, 600], 1.0);
        let (_, pi) = run(RobotKind::Pilot, [-600, 600], 1.0);
        assert!(np.omega > 5.0, "non-pilot spins at {}", np.omega);
        assert!(
            pi.omega.abs() < 0.3 * np.omega,
            "pilot spins at {}",
            pi.omega
        );
        // The pilot turns once it rolls forward.
        let (_, pf) = run(RobotKind::Pilot, [400, 900], 1.5);
        assert!(
            pf.omega > 2.0 * pi.omega.abs(),
            "{} vs {}",
            pf.omega,
            pi.omega
        );
    }
}
