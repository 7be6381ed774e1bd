//! Tests of `scenario`.

use super::*;
use puzzlebot_params::geometry::Geometry;
use std::path::Path;

const GOOD: &str = r#"
name = "demo"

[[step]]
form = { shape = "mesh", rows = 2 }
timeout_s = 120

[[step]]
hold = { duration_s = 1.0 }

[[step]]
move = { velocity = [0.02, 0.0], duration_s = 2 }

[[step]]
move = { go_to = [0.5, 0.0, 90], tolerance = 0.01 }

[[step]]
label = "wiggle out"
decouple = { v_bias = 0.02 }

[[step]]
anti_rendezvous = { until_distance = 0.1, gain = 0.3 }

[[step]]
move = { trajectory = [[0, 0, 0], [10, 0.5, 0]] }

[[step]]
disperse = { goal = [{ robot = 1, x = 0.2, y = 0.4 }, { robot = 2, ahead = 0.3 }] }
"#;

fn parse(text: &str) -> Result<Scenario, ScenarioError> {
    Scenario::from_toml_str(Path::new("run.toml"), text, &Geometry::default())
}

#[test]
fn good_scenario_parses() {
    let s = parse(GOOD).unwrap();
    assert_eq!(s.name, "demo");
    assert_eq!(s.steps.len(), 8);
    assert_eq!(
        s.steps[0].behaviour,
        Behaviour::Form {
            spec: ShapeSpec::Mesh { rows: 2 },
            heading: None,
            grow: Some(Grow { seed: None }),
        }
    );
    // In parallel when asked, or for a given heading (a grown shape takes its seed's).
    for form in ["grow = false", "heading_deg = 30"] {
        let text = GOOD.replace("rows = 2 }", &format!("rows = 2, {form} }}"));
        let p = parse(&text).unwrap();
        assert!(
            matches!(p.steps[0].behaviour, Behaviour::Form { grow: None, .. }),
            "{form}: {:?}",
            p.steps[0].behaviour
        );
    }
    assert_eq!(s.steps[0].timeout_s, Some(120.0));
    assert_eq!(s.steps[0].line, 4);
    assert!(
        matches!(s.steps[3].behaviour, Behaviour::GoTo { goal, tolerance } if (goal.yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12 && tolerance == 0.01)
    );
    assert_eq!(s.steps[4].label, "wiggle out");
    match &s.steps[4].behaviour {
        Behaviour::Decouple { wiggle, robots } => {
            assert_eq!(wiggle.v_bias, 0.02);
            assert!(robots.is_none());
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        s.steps[5].behaviour,
        Behaviour::Rendezvous { anti: true, .. }
    ));
    match &s.steps[7].behaviour {
        Behaviour::Disperse { goals, .. } => {
            assert_eq!(goals[&1], Goal::At { x: 0.2, y: 0.4 });
            assert_eq!(goals[&2], Goal::Ahead(0.3));
            // Ahead: along the robot's heading where the step starts.
            let g = goals[&2].resolve(
                &Pose::new(1.0, 2.0, std::f64::consts::FRAC_PI_2),
                [0.0, 0.0],
                false,
            );
            assert!(
                (g.x - 1.0).abs() < 1e-12 && (g.y - 2.3).abs() < 1e-12,
                "{g:?}"
            );
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn away_goals_lead_out_from_the_group_and_a_pilot_keeps_to_its_axis() {
    let text = "[[step]]\ndisperse = { goal = [{ robot = 1, away = 0.1 }, \
                { robot = 2, away = 0.1 }, { robot = 3, away = 0.1 }] }\n";
    let s = parse(text).unwrap();
    let Behaviour::Disperse { goals, .. } = &s.steps[0].behaviour else {
        panic!("{:?}", s.steps[0].behaviour);
    };
    assert_eq!(goals[&3], Goal::Away(0.1));
    // Two robots facing each other either side of the centre (goals `ahead` would swap
    // them head-on): each goes 0.1 m further out, whatever its heading.
    let (pi, c) = (std::f64::consts::PI, [0.0, 0.0]);
    let g1 = goals[&1].resolve(&Pose::new(-0.03, 0.0, 0.0), c, false);
    let g2 = goals[&2].resolve(&Pose::new(0.03, 0.0, pi), c, false);
    assert!((g1.x + 0.13).abs() < 1e-12 && g1.y.abs() < 1e-12, "{g1:?}");
    assert!((g2.x - 0.13).abs() < 1e-12 && g2.y.abs() < 1e-12, "{g2:?}");
    // A pilot cannot turn: it backs out along its axis when the centre is ahead of it.
    let g = goals[&1].resolve(&Pose::new(0.0, -0.05, pi / 2.0), c, true);
    assert!(g.x.abs() < 1e-12 && (g.y + 0.15).abs() < 1e-12, "{g:?}");
    // Resolved when the step starts, around the centre of the step's robots.
    let mut r = ScenarioRunner::new(
        s,
        Coordinator::from_params(&puzzlebot_params::FleetParams::default()),
    );
    let at = |id, x: f64, y: f64, kind| RobotState {
        id,
        kind,
        pose: Pose::new(x, y, 0.0),
    };
    let robots = vec![
        at(1, 1.0, 0.0, RobotKind::Pilot),
        at(2, 1.2, 0.0, RobotKind::NonPilot),
        at(3, 1.1, 0.3, RobotKind::NonPilot),
    ];
    r.tick(0.0, &robots);
    let Mode::Disperse { goals, .. } = r.coordinator().mode() else {
        panic!("{:?}", r.coordinator().mode());
    };
    assert!(
        (goals[&1].x - 0.9).abs() < 1e-12,
        "the pilot backs out: {goals:?}"
    );
    assert!(
        (goals[&2].x - 1.2).abs() > 0.05 && goals[&2].y < 0.0,
        "{goals:?}"
    );
    assert!((goals[&3].y - 0.4).abs() < 1e-12, "{goals:?}");
}

fn err(text: &str) -> String {
    parse(text).expect_err("must fail").to_string()
}

#[test]
fn bad_scenarios_name_file_line_and_field() {
    // Unknown field inside a behaviour: reported by the TOML parser with its line.
    let e = err("[[step]]\nhold = { duration_s = 1 }\n\n[[step]]\nhold = { durations = 2 }\n");
    assert!(
        e.starts_with("run.toml:5:") && e.contains("durations"),
        "{e}"
    );
    // Negative duration: the value's line.
    let e = err("[[step]]\nhold = { duration_s = -1 }\n");
    assert!(e.starts_with("run.toml:2:") && e.contains("≥ 0"), "{e}");
    // Two behaviours in one step.
    let e = err(
        "[[step]]\nhold = { duration_s = 1 }\n[[step]]\nhold = { duration_s = 1 }\ndecouple = {}\n",
    );
    assert!(
        e.starts_with("run.toml:3:") || e.starts_with("run.toml:4:"),
        "{e}"
    );
    assert!(e.contains("step[1]") && e.contains("hold, decouple"), "{e}");
    // Move with two modes.
    let e = err("[[step]]\nmove = { velocity = [0.1, 0], go_to = [1, 1], duration_s = 1 }\n");
    assert!(
        e.starts_with("run.toml:2:") && e.contains("step[0].move"),
        "{e}"
    );
    // Velocity without duration.
    let e = err("[[step]]\nmove = { velocity = [0.1, 0] }\n");
    assert!(e.contains("step[0].move.duration_s"), "{e}");
    // Bad go_to arity.
    let e = err("[[step]]\n\nmove = { go_to = [1] }\n");
    assert!(
        e.starts_with("run.toml:3:") && e.contains("move.go_to"),
        "{e}"
    );
    // A grown shape takes its seed's heading.
    let e = err("[[step]]\nform = { shape = \"mesh\", grow = true, heading_deg = 0 }\n");
    assert!(
        e.starts_with("run.toml:2:") && e.contains("form.heading_deg"),
        "{e}"
    );
    // A seed implies growing.
    let s = parse("[[step]]\nform = { shape = \"line\", seed = 3 }\n").unwrap();
    assert!(matches!(
        s.steps[0].behaviour,
        Behaviour::Form {
            grow: Some(Grow { seed: Some(3) }),
            ..
        }
    ));
    // Missing shape file.
    let e = err("[[step]]\nform = { shape = \"nope.toml\" }\n");
    assert!(
        e.starts_with("run.toml:2:") && e.contains("form.shape"),
        "{e}"
    );
    // A goal is a point or a distance ahead, not both.
    let e = err("[[step]]\ndisperse = { goal = [{ robot = 1, x = 0.2, y = 0.1, ahead = 0.2 }] }\n");
    assert!(
        e.starts_with("run.toml:1:") && e.contains("disperse.goal[0]") && e.contains("ahead"),
        "{e}"
    );
    // Unknown behaviour key.
    let e = err("[[step]]\nfly = {}\n");
    assert!(e.starts_with("run.toml:2:") && e.contains("fly"), "{e}");
    // Trajectory times must increase.
    let e = err("[[step]]\nmove = { trajectory = [[0, 0, 0], [0, 1, 0]] }\n");
    assert!(
        e.contains("move.trajectory[1]") && e.contains("increase"),
        "{e}"
    );
    // No steps.
    let e = err("name = \"x\"\n");
    assert!(e.contains("step"), "{e}");
}

#[test]
fn runner_forms_holds_and_finishes() {
    let text = "[[step]]\nform = { shape = \"line\" }\ntimeout_s = 5\n[[step]]\nhold = { duration_s = 0.5 }\n";
    let s = parse(text).unwrap();
    let mut r = ScenarioRunner::new(
        s,
        Coordinator::from_params(&puzzlebot_params::FleetParams::default()),
    );
    // Two robots already coupled in a line (1 in front, 2 behind).
    let robots = vec![
        RobotState {
            id: 1,
            kind: RobotKind::NonPilot,
            pose: Pose::new(0.05, 0.0, 0.0),
        },
        RobotState {
            id: 2,
            kind: RobotKind::NonPilot,
            pose: Pose::new(0.0, 0.0, 0.0),
        },
    ];
    let mut t = 0.0;
    while !matches!(r.state(), RunState::Finished | RunState::Failed { .. }) && t < 3.0 {
        r.tick(t, &robots);
        t += 0.1;
    }
    assert_eq!(r.state(), &RunState::Finished);
    let ev = r.coordinator().events();
    assert!(ev.iter().any(|e| e.kind == EventKind::FormationComplete));
    assert_eq!(
        ev.iter()
            .filter(|e| matches!(e.kind, EventKind::StepFinished { .. }))
            .count(),
        2
    );
}

#[test]
fn a_disperse_goal_for_a_robot_not_in_the_fleet_fails_its_step_by_name() {
    let text = "[[step]]\nlabel = \"go home\"\n\
                disperse = { goal = [{ robot = 1, ahead = 0.1 }, { robot = 9, x = 0.0, y = 0.0 }] }\n";
    let mut r = ScenarioRunner::new(
        parse(text).unwrap(),
        Coordinator::from_params(&puzzlebot_params::FleetParams::default()),
    );
    let robots = vec![RobotState {
        id: 1,
        kind: RobotKind::NonPilot,
        pose: Pose::new(0.0, 0.0, 0.0),
    }];
    r.tick(0.0, &robots);
    match r.state() {
        RunState::Failed { index: 0, reason } => assert!(
            reason.contains("go home") && reason.contains("robot 9"),
            "{reason}"
        ),
        other => panic!("{other:?}"),
    }
}

/// Two robots coupled in a line (robot 1's anchor in robot 2's opening at x1 − x2 = 5 cm),
/// then a 5 s move labelled "drive"; ticked until the move runs.
fn line_then_drive() -> (ScenarioRunner, f64) {
    let text = "[[step]]\nform = { shape = \"line\" }\ntimeout_s = 5\n\
                [[step]]\nlabel = \"drive\"\nmove = { velocity = [0.02, 0.0], duration_s = 5 }\n";
    let mut r = ScenarioRunner::new(
        parse(text).unwrap(),
        Coordinator::from_params(&puzzlebot_params::FleetParams::default()),
    );
    let mut t = 0.0;
    while t < 2.0 {
        r.tick(t, &two_at(0.05, 0.0));
        t += 0.1;
    }
    assert_eq!(r.state(), &RunState::Running { index: 1 });
    (r, t)
}

fn two_at(x1: f64, x2: f64) -> Vec<RobotState> {
    [(1, x1), (2, x2)]
        .map(|(id, x)| RobotState {
            id,
            kind: RobotKind::NonPilot,
            pose: Pose::new(x, 0.0, 0.0),
        })
        .to_vec()
}

fn has(r: &ScenarioRunner, f: impl Fn(&EventKind) -> bool) -> Option<f64> {
    r.coordinator()
        .events()
        .iter()
        .find(|e| f(&e.kind))
        .map(|e| e.t)
}

#[test]
fn a_move_whose_pair_comes_apart_stops_couples_it_again_and_goes_on_for_what_was_left() {
    let (mut r, mut t) = line_then_drive();
    let started = has(&r, |k| matches!(k, EventKind::StepStarted { index: 1, .. })).unwrap();
    // 1 s into the move the front robot is 3 cm ahead of where its anchor could reach.
    while t < started + 1.0 {
        r.tick(t, &two_at(0.05, 0.0));
        t += 0.1;
    }
    let tick = r.tick(t, &two_at(0.08, 0.0));
    let apart = t;
    assert!(
        tick.tasks.iter().all(|k| k.role == Role::Hold),
        "the assembly stops: {:?}",
        tick.tasks
    );
    assert_eq!(r.state(), &RunState::Running { index: 1 });
    assert_eq!(
        r.coordinator().mode(),
        &Mode::Form,
        "the pair is coupled again"
    );
    assert!(has(&r, |k| matches!(
        k,
        EventKind::Recoupling {
            a: 1,
            b: 2,
            index: 1
        }
    ))
    .is_some());
    // Back in its seat: once the formation is complete again the move goes on, for the
    // 4 s that were left of it.
    t += 0.1;
    while has(&r, |k| matches!(k, EventKind::Recoupled { .. })).is_none() && t < apart + 10.0 {
        r.tick(t, &two_at(0.05, 0.0));
        t += 0.1;
    }
    let again =
        has(&r, |k| matches!(k, EventKind::Recoupled { a: 1, b: 2 })).expect("coupled again");
    assert!(matches!(r.coordinator().mode(), Mode::Velocity { .. }));
    while r.state() == &(RunState::Running { index: 1 }) && t < again + 10.0 {
        r.tick(t, &two_at(0.05, 0.0));
        t += 0.1;
    }
    let finished = has(&r, |k| matches!(k, EventKind::StepFinished { index: 1 })).unwrap();
    let left = 5.0 - (apart - started);
    assert!(
        (finished - again - left).abs() < 0.25,
        "the move ran {:.1} s after coupling again, {left:.1} s were left",
        finished - again
    );
    assert_eq!(r.state(), &RunState::Finished);
}

#[test]
fn a_move_fails_when_a_pair_that_came_apart_is_not_coupled_again_or_keeps_coming_apart() {
    // Not coupled again within the time allowed: the step fails and everyone holds.
    let (mut r, mut t) = line_then_drive();
    let apart = t;
    while t < apart + RECOUPLE_TIMEOUT_S + 1.0 && r.state() == &(RunState::Running { index: 1 }) {
        r.tick(t, &two_at(0.08, 0.0));
        t += 0.1;
    }
    match r.state() {
        RunState::Failed { index: 1, reason } => assert!(
            reason.contains("came apart")
                && reason.contains("drive")
                && reason.contains("not coupled again"),
            "{reason}"
        ),
        other => panic!("{other:?}"),
    }
    assert_eq!(r.coordinator().mode(), &Mode::Hold);
    // Coming apart again after every re-coupling: the third time the step fails.
    let (mut r, mut t) = line_then_drive();
    for _ in 0..=MAX_RECOUPLES {
        r.tick(t, &two_at(0.08, 0.0));
        t += 0.1;
        let since = t;
        while r.coordinator().mode() == &Mode::Form && t < since + 10.0 {
            r.tick(t, &two_at(0.05, 0.0));
            t += 0.1;
        }
    }
    match r.state() {
        RunState::Failed { index: 1, reason } => {
            assert!(
                reason.contains("came apart") && reason.contains("3 times"),
                "{reason}"
            )
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn runner_fails_a_step_on_timeout() {
    let text = "[[step]]\nform = { shape = \"line\" }\ntimeout_s = 0.5\n";
    let s = parse(text).unwrap();
    let mut r = ScenarioRunner::new(
        s,
        Coordinator::from_params(&puzzlebot_params::FleetParams::default()),
    );
    let robots = vec![
        RobotState {
            id: 1,
            kind: RobotKind::NonPilot,
            pose: Pose::new(0.5, 0.0, 0.0),
        },
        RobotState {
            id: 2,
            kind: RobotKind::NonPilot,
            pose: Pose::new(0.0, 0.0, 0.0),
        },
    ];
    for k in 0..10 {
        r.tick(f64::from(k) * 0.1, &robots);
    }
    assert!(matches!(r.state(), RunState::Failed { index: 0, .. }));
}

#[test]
fn a_cross_step_waits_for_the_hosts_result_and_finishes_or_fails_by_it() {
    let text =
        "[[step]]\ncross = { terrain = \"gap.toml\" }\n[[step]]\nhold = { duration_s = 0.2 }\n";
    let s = parse(text).unwrap();
    // The terrain file is resolved against the scenario's folder.
    assert_eq!(
        s.steps[0].behaviour,
        Behaviour::Cross {
            terrain: Path::new("gap.toml").to_path_buf()
        }
    );
    let e = err("[[step]]\ncross = { terrain = \"gap.toml\", speed = 1 }\n");
    assert!(e.contains("speed"), "{e}");
    let robots = two_at(0.05, 0.0);
    for result in [
        Ok(()),
        Err("the gate proves 12 mm of the 86 mm".to_string()),
    ] {
        let mut r = ScenarioRunner::new(
            s.clone(),
            Coordinator::from_params(&puzzlebot_params::FleetParams::default()),
        );
        // Before the step starts nothing is due; once it runs the coordinator holds until
        // the host reports.
        assert_eq!(r.crossing_due(), None);
        let mut t = 0.0;
        for _ in 0..20 {
            r.tick(t, &robots);
            t += 0.1;
        }
        assert_eq!(r.state(), &RunState::Running { index: 0 });
        assert_eq!(r.crossing_due(), Some(Path::new("gap.toml")));
        assert_eq!(r.coordinator().mode(), &Mode::Hold);
        r.finish_crossing(result.clone());
        assert_eq!(r.crossing_due(), None);
        for _ in 0..10 {
            r.tick(t, &robots);
            t += 0.1;
        }
        match result {
            Ok(()) => assert_eq!(r.state(), &RunState::Finished),
            Err(why) => match r.state() {
                RunState::Failed { index: 0, reason } => assert!(reason.contains(&why)),
                other => panic!("{other:?}"),
            },
        }
    }
}
