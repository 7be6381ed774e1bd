//! Tests of the drive plant: the structured step, motor speed and dead band, turning.

use super::*;
use puzzlebot_params::{RobotKind, RobotParams};

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
