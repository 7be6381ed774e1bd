//! A fixed-seed sample of randomized assembly episodes (`puzzlebot experiment assemblies`):
//! fleets of 2–6 robots, every shape, 0–2 pilots, half dissolved, under the ideal and the
//! lab profile (latency, loss, mocap dropouts, ±10 % model mismatch). The benchmark runs 500
//! episodes of up to 12 robots with seeds from the clock; this sample guards against
//! regressions in CI.

use puzzlebot_host::experiment::assemblies::{describe, run, Options};
use puzzlebot_host::experiment::episode::Profile;

/// Share of the sample that must succeed (the lab target of DESIGN §9; the randomized
/// figures over fresh seeds and larger fleets are in BENCHMARKS.md).
const FLOOR: f64 = 0.95;

#[test]
fn a_fixed_sample_of_random_episodes_forms_moves_and_dissolves() {
    let mut passed = 0;
    let mut total = 0;
    let mut report = String::new();
    for profile in [Profile::Ideal, Profile::Lab] {
        let mut opts = Options::new(20, profile, 424_242);
        opts.max_robots = 6;
        let s = run(&opts, &|_| {}).expect("the sample runs");
        passed += s.overall.passed;
        total += s.overall.total;
        report.push_str(&describe(&s));
    }
    println!("{report}");
    assert_eq!(total, 40);
    assert!(
        passed as f64 >= FLOOR * total as f64,
        "{passed} of {total} episodes succeeded (floor {FLOOR}):\n{report}"
    );
}
