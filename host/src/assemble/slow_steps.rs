//! Scenario checks against the robots' drive: velocity steps too slow to drive steadily.

use puzzlebot_assembly::{Behaviour, Scenario as AsmScenario};
use puzzlebot_params::{FleetParams, RobotKind};

use crate::drive::DriveMap;

/// The slowest speed (m/s) every kind of robot drives steadily: both wheels at the start-up
/// dead-band M_min (THESIS 3.4), through the drive map the host commands with.
pub fn slowest_steady_speed(params: &FleetParams) -> f64 {
    [RobotKind::NonPilot, RobotKind::Pilot]
        .into_iter()
        .map(|k| {
            let map = DriveMap::from_params_or_geometric(params.robot(k));
            map.k_v * map.m_min
        })
        .fold(0.0, f64::max)
}

/// Warnings for velocity steps of `scenario` whose speed is not zero but below
/// [`slowest_steady_speed`]: each wheel can only be stopped or at M_min, so the robots
/// stick-slip, which jerks a train at its anchors (measured: a 4-robot line at 0.03 m/s
/// surged between 0 and 0.08 m/s).
pub fn slow_step_warnings(scenario: &AsmScenario, params: &FleetParams) -> Vec<String> {
    let slowest = slowest_steady_speed(params);
    scenario
        .steps
        .iter()
        .enumerate()
        .filter_map(|(i, step)| match step.behaviour {
            Behaviour::Velocity { v, .. } if v != 0.0 && v.abs() < slowest => Some(format!(
                "step {} '{}' (line {}): velocity {v} m/s is below the slowest steady speed \
                 {slowest:.3} m/s (drive.min_rpm); the robots will stick-slip and jerk \
                 their anchors",
                i + 1,
                step.label,
                step.line
            )),
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::assemble::parse_scenario;

    #[test]
    fn a_velocity_step_below_the_wheels_dead_band_is_warned_about_by_step_and_line() {
        let p = FleetParams::default();
        let slowest = slowest_steady_speed(&p);
        // 20 RPM on 17-19 mm wheels: a few centimetres per second.
        assert!((0.02..0.06).contains(&slowest), "slowest {slowest}");
        let s = parse_scenario(
            "s.toml",
            &format!(
                "[[step]]\nmove = {{ velocity = [{}, 0.0], duration_s = 2 }}\n\
             [[step]]\nlabel = \"creep\"\nmove = {{ velocity = [{}, 0.1], duration_s = 2 }}\n\
             [[step]]\nmove = {{ velocity = [0.0, 0.5], duration_s = 2 }}\n\
             [[step]]\nmove = {{ velocity = [{}, 0.0], duration_s = 2 }}\n",
                slowest * 1.2,
                -slowest * 0.8,
                slowest * 0.5
            ),
        )
        .expect("scenario");
        let w = slow_step_warnings(&s, &p);
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w[0].starts_with("step 2 'creep' (line 3)"), "{}", w[0]);
        assert!(w[1].starts_with("step 4 "), "{}", w[1]);
        assert!(w[0].contains(&format!("{slowest:.3} m/s")), "{}", w[0]);
    }
}
