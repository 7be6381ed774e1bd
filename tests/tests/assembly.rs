//! Assemblies end to end: the host's assembly controller
//! (coordinator → distributed MPC → drive mapping) drives a simulated fleet over loopback UDP
//! in real time; couplings are judged by the simulator's ground truth (anchor/knob mechanics).

use puzzlebot_host::assemble::assembly::EventKind;
use puzzlebot_host::assemble::{parse_scenario, run_scenario, AssemblyReport, RunHook};
use puzzlebot_protocol::messages::RobotId;
use puzzlebot_sim::Scenario;

fn sim(text: &str) -> Scenario {
    Scenario::from_toml(std::path::Path::new("fleet.toml"), text).expect("simulator scenario")
}

fn coupled(r: &AssemblyReport, a: RobotId, b: RobotId) -> bool {
    r.coupled_truth.contains(&(a, b)) || r.coupled_truth.contains(&(b, a))
}

fn finished(r: &AssemblyReport) -> bool {
    matches!(
        r.state,
        puzzlebot_host::assemble::assembly::RunState::Finished
    )
}

/// The runs are real time and share two cores with their simulated fleets: one at a time,
/// so a test measures the controller, not the scheduler.
static REAL_TIME: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

async fn run(
    name: &str,
    scenario: &str,
    fleet: Scenario,
    limit: f64,
    hook: Option<RunHook>,
) -> AssemblyReport {
    let _one_at_a_time = REAL_TIME.lock().await;
    let runs = puzzlebot_e2e::scratch(name);
    let s = parse_scenario(name, scenario).expect("assembly scenario");
    let r = run_scenario(s, fleet, &runs, limit, hook)
        .await
        .expect("run");
    print!("{}", puzzlebot_host::assemble::describe(&r));
    let replay = puzzlebot_host::replay::write(&r.folder).expect("the run folder replays");
    assert!(replay.page.is_file() && replay.picture.is_file());
    assert!(r.folder.join("assembly_events.jsonl").is_file());
    r
}

/// Robot `id`'s ground-truth pose at the first tick at or after `t` (s), from the run
/// folder's `telemetry.jsonl`.
fn truth_at(r: &AssemblyReport, id: RobotId, t: f64) -> [f64; 3] {
    let text = std::fs::read_to_string(r.folder.join("telemetry.jsonl")).expect("telemetry");
    text.lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).expect("telemetry line"))
        .filter(|v| v["robot"] == id && v["t"].as_f64().is_some_and(|s| s >= t))
        .find_map(|v| serde_json::from_value::<[f64; 3]>(v["truth"].clone()).ok())
        .expect("a ground-truth pose after t")
}

fn row(poses: &[(RobotId, &str, [f64; 3])]) -> String {
    let mut s = String::from("seed = 3\n");
    for (id, kind, p) in poses {
        s.push_str(&format!(
            "[[robots]]\nid = {id}\nkind = \"{kind}\"\npose = [{}, {}, {}]\n",
            p[0], p[1], p[2]
        ));
    }
    s
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
// Real time over loopback: two 2-robot trains form and then join, and the line drives and
// turns as a train. The host predicts every pose over the latency it measures (its own
// update time plus the link's half round trip); the lockstep version
// (`host/tests/assembly_lockstep.rs`) covers many seeds and latencies deterministically.
async fn four_robots_form_a_line_and_hold_it_while_it_drives_and_turns() {
    let fleet = sim(&row(&[
        (1, "NonPilot", [0.0, 0.0, 0.0]),
        (2, "NonPilot", [-0.085, 0.01, 0.1]),
        (3, "NonPilot", [-0.17, -0.01, -0.1]),
        (4, "NonPilot", [-0.255, 0.0, 0.05]),
    ]));
    let scenario = r#"
name = "line"
[[step]]
form = { shape = "line", heading_deg = 0 }
timeout_s = 40
[[step]]
move = { velocity = [0.05, 0.0], duration_s = 3.0 }
[[step]]
move = { velocity = [0.05, 0.1667], duration_s = 5.4 }
"#;
    let r = run("assembly-line", scenario, fleet, 60.0, None).await;
    assert!(finished(&r), "state {:?}", r.state);
    let formed = r
        .events
        .iter()
        .find(|e| matches!(e.kind, EventKind::FormationComplete))
        .expect("formation complete");
    assert!(formed.t < 40.0);
    for (a, b) in [(1, 2), (2, 3), (3, 4)] {
        assert!(
            coupled(&r, a, b),
            "pair {a}-{b} coupled after driving and turning"
        );
    }
    // The line drives like a train round the curve (a rigid line cannot turn: its rear
    // would have to move sideways): from where the line formed, the head turned most of the
    // commanded 0.73 rad (0.1667 rad/s for 5.4 s, ω ramped up over the first 2 s), every
    // robot lags its predecessor by less than the anchor's yaw range.
    let at_form = truth_at(&r, 1, formed.t);
    let yaw: Vec<f64> = (1..=4).map(|i| r.final_poses[&i][2]).collect();
    let turned = puzzlebot_host::drive::wrap_angle(yaw[0] - at_form[2]);
    assert!(
        turned > 0.5,
        "the head turned {turned:.2} rad from {at_form:?}: {yaw:?}"
    );
    for k in 1..4 {
        let lag = yaw[k - 1] - yaw[k];
        assert!(
            (-0.1..0.5).contains(&lag),
            "robot {} lags by {lag}: {yaw:?}",
            k + 1
        );
    }
    let end = r.final_poses[&1];
    let (sin, cos) = at_form[2].sin_cos();
    let ahead = (end[0] - at_form[0]) * cos + (end[1] - at_form[1]) * sin;
    assert!(
        ahead > 0.15,
        "the line drove forward {ahead:.3} m from {at_form:?} to {end:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
// Real time over loopback. A head is counted seated when it is seen so in two of the last
// three pose updates: over a network the two robots' poses can be from different instants,
// and the pair must not count connected while the simulator has it apart.
async fn four_robots_form_a_two_by_two_mesh() {
    // Slots of the 2-row mesh (mm): (-37.5,-25) (12.5,-25) (-12.5,25) (37.5,25), spread 30 mm.
    let fleet = sim(&row(&[
        (1, "NonPilot", [0.045, -0.03, 0.0]),
        (2, "NonPilot", [-0.045, -0.03, 0.05]),
        (3, "NonPilot", [0.075, 0.035, -0.05]),
        (4, "NonPilot", [-0.02, 0.035, 0.0]),
    ]));
    let scenario = r#"
name = "mesh"
[[step]]
form = { shape = "mesh", rows = 2, heading_deg = 0 }
timeout_s = 50
"#;
    let r = run("assembly-mesh", scenario, fleet, 55.0, None).await;
    assert!(finished(&r), "state {:?}", r.state);
    // Two anchor rows and one knob between them (THESIS 5.2.2).
    assert!(
        r.coupled_truth.len() >= 6,
        "couplings {:?}; in the simulator over time: {:?}",
        r.coupled_truth,
        r.coupling_truth
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_coupled_pair_decouples_and_both_reach_separate_goals() {
    let mut fleet = sim(&row(&[
        (1, "NonPilot", [0.0, 0.0, 0.0]),
        (2, "NonPilot", [0.05, 0.0, 0.0]),
    ]));
    fleet.couplings = vec![puzzlebot_sim::CouplingSpec {
        kind: puzzlebot_sim::LinkKind::Anchor,
        a: 2,
        b: 1,
    }];
    let scenario = r#"
name = "release"
[[step]]
form = { shape = "line", heading_deg = 0 }
timeout_s = 10
[[step]]
decouple = { v_bias = 0.08, w_max = 6.0, period_s = 1.0 }
timeout_s = 25
[[step]]
disperse = { tolerance = 0.02, goal = [ { robot = 1, x = -0.15, y = 0.15 }, { robot = 2, x = 0.25, y = -0.1 } ] }
timeout_s = 25
"#;
    let r = run("assembly-release", scenario, fleet, 58.0, None).await;
    assert!(finished(&r), "state {:?}", r.state);
    assert!(!coupled(&r, 1, 2), "released");
    // The report records the release from the simulator's ground truth, after the pair
    // had been connected on the host.
    assert!(
        r.coupling_truth
            .iter()
            .any(|c| !c.coupled && (c.a, c.b) == (2, 1)),
        "the simulator's release is in the report: {:?}",
        r.coupling_truth
    );
    for (id, goal) in [(1, [-0.15, 0.15]), (2, [0.25, -0.1])] {
        let p = r.final_poses[&id];
        let d = (p[0] - goal[0]).hypot(p[1] - goal[1]);
        assert!(d < 0.03, "robot {id} {d:.3} m from its goal");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
// Real time over loopback: robot 4 is switched off a second in; the host declares it lost
// and forms the line of the other three, coupled in the simulator's ground truth.
async fn a_robot_lost_mid_formation_is_replanned_without() {
    let fleet = sim(&row(&[
        (1, "NonPilot", [0.0, 0.0, 0.0]),
        (2, "NonPilot", [-0.085, 0.01, 0.1]),
        (3, "NonPilot", [-0.17, -0.01, -0.1]),
        (4, "NonPilot", [-0.40, 0.1, 0.6]),
    ]));
    let scenario = r#"
name = "lost"
[[step]]
form = { shape = "line", heading_deg = 0 }
timeout_s = 45
"#;
    let mut off = false;
    let hook: RunHook = Box::new(move |h, t| {
        if !off && t > 1.0 {
            off = true;
            h.fleet.set_online(4, false);
        }
    });
    let r = run("assembly-lost", scenario, fleet, 55.0, Some(hook)).await;
    assert!(
        r.events
            .iter()
            .any(|e| matches!(e.kind, EventKind::RobotLost { robot: 4 })),
        "robot 4 declared lost"
    );
    assert!(
        r.events.iter().any(|e| matches!(&e.kind,
            EventKind::Replanned { robots } if !robots.contains(&4) && robots.len() == 3)),
        "plan recomputed without robot 4"
    );
    assert!(finished(&r), "state {:?}", r.state);
    assert!(
        coupled(&r, 1, 2) && coupled(&r, 2, 3),
        "{:?}",
        r.coupled_truth
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_line_driven_at_a_gap_outside_a_cross_step_stops_short_of_its_edge() {
    // hil-sim/scenarios/gap_crossing.toml with a 120 mm gap: the line is told to drive on
    // to x = 0.5 m, across it. Crossing is a cross step's work, proven from its start; a
    // plain move stops the line within the edge guard's band of the edge (x = 0), where a
    // turn or the capture's noise cannot yet put a wheel over it.
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../hil-sim/scenarios/gap_crossing.toml"
    ))
    .expect("gap scenario")
    .replace(
        "[[0.04, -0.5], [1.0, -0.5], [1.0, 0.5], [0.04, 0.5]]",
        "[[0.12, -0.5], [1.0, -0.5], [1.0, 0.5], [0.12, 0.5]]",
    );
    assert!(text.contains("[0.12, 0.5]"), "far platform moved");
    // The line 0.15 m further back: its front robot (the pilot, 3) at x = -0.25 m.
    let text = text
        .replace("[-0.20, 0.0, 0.0]", "[-0.35, 0.0, 0.0]")
        .replace("[-0.15, 0.0, 0.0]", "[-0.30, 0.0, 0.0]")
        .replace("[-0.10, 0.0, 0.0]", "[-0.25, 0.0, 0.0]");
    assert!(text.contains("[-0.25, 0.0, 0.0]"), "line moved back");
    let fleet = sim(&text);
    let scenario = r#"
name = "gap"
[[step]]
form = { shape = "line", heading_deg = 0 }
timeout_s = 10
[[step]]
move = { go_to = [0.5, 0.0], tolerance = 0.02 }
timeout_s = 10
"#;
    let r = run("assembly-gap", scenario, fleet, 12.0, None).await;
    assert!(r.fallen.is_empty(), "fell: {:?}", r.fallen);
    // The front robot stops more than its body's reach from the edge, after driving most
    // of the way towards it.
    let front = r.final_poses[&3][0];
    assert!(
        (-0.15..-0.035).contains(&front),
        "the line's front stopped at x = {front:.4} m"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_mesh_is_dissolved_by_hand_and_wiggling_over_loopback() {
    // A 2×2 mesh (THESIS 5.2.2: rows offset by half a body, knobs where the rows meet): the
    // host asks for the knob pairs to be lifted, the simulated fleet's hand does it over its
    // command channel, and the anchors are wiggled open.
    let mut fleet = sim(&row(&[
        (1, "NonPilot", [0.0, 0.0, 0.0]),
        (2, "NonPilot", [0.057, 0.0, 0.0]),
        (3, "NonPilot", [0.0285, 0.05, 0.0]),
        (4, "NonPilot", [0.0855, 0.05, 0.0]),
    ]));
    let link = |kind, a, b| puzzlebot_sim::CouplingSpec { kind, a, b };
    use puzzlebot_sim::LinkKind::{Anchor, Knob};
    fleet.couplings = vec![
        link(Anchor, 2, 1),
        link(Anchor, 4, 3),
        link(Knob, 1, 3),
        link(Knob, 2, 3),
        link(Knob, 2, 4),
    ];
    let scenario = r#"
name = "dissolve"
[[step]]
form = { shape = "mesh", rows = 2, heading_deg = 0 }
timeout_s = 10
[[step]]
decouple = { v_bias = 0.01, w_max = 1.5, period_s = 2.0 }
timeout_s = 30
"#;
    let r = run("assembly-dissolve", scenario, fleet, 45.0, None).await;
    assert!(finished(&r), "state {:?}", r.state);
    assert!(
        r.events
            .iter()
            .any(|e| matches!(e.kind, EventKind::LiftKnobs { .. })),
        "the knob pairs were lifted"
    );
    assert!(
        r.coupled_truth.is_empty(),
        "still coupled: {:?}",
        r.coupled_truth
    );
}
