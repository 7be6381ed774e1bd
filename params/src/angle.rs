//! Angles: the one wrap into (−π, π] that the simulator, the MPC, the host's drive mapping
//! and the assembly geometry share (`no_std`: comparisons and `%` only).

use core::f64::consts::PI;

/// Wrap an angle into (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    if a > -PI && a <= PI {
        return a;
    }
    if a > PI && a <= 3.0 * PI {
        return a - 2.0 * PI;
    }
    if a > -3.0 * PI && a <= -PI {
        return a + 2.0 * PI;
    }
    let mut a = a % (2.0 * PI);
    if a > PI {
        a -= 2.0 * PI;
    } else if a <= -PI {
        a += 2.0 * PI;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_into_the_half_open_interval() {
        assert_eq!(wrap_angle(PI), PI);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((wrap_angle(-7.0 * PI / 2.0) - PI / 2.0).abs() < 1e-12);
        assert!((wrap_angle(1e3) - (1e3 - 159.0 * 2.0 * PI)).abs() < 1e-9);
        for k in -40..40 {
            let a = f64::from(k) * 0.37;
            let w = wrap_angle(a);
            assert!(w > -PI && w <= PI, "{a} → {w}");
            assert!(
                ((a - w) / (2.0 * PI)).fract().abs() < 1e-9
                    || ((a - w) / (2.0 * PI)).fract().abs() > 1.0 - 1e-9
            );
        }
    }
}
