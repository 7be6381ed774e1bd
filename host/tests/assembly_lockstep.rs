//! Assembly behaviours (issue 7) in the simulator's lockstep world: the host's assembly
//! controller (coordinator → distributed MPC → drive mapping → stabiliser → sealed frames)
//! against the real firmware logic and the coupling mechanics, deterministic and faster than
//! real time. Couplings are judged by the simulator's ground truth.

use std::path::Path;

use puzzlebot_assembly::{EventKind, RunState, Scenario as AsmScenario};
use puzzlebot_host::assemble::{AssemblyController, GateConfig};
use puzzlebot_host::lockstep::{Lockstep, LockstepRun};
use puzzlebot_protocol::messages::RobotId;
use puzzlebot_sim::{EventKind as SimEventKind, GroundTruth, Scenario};

fn fleet(poses: &[(RobotId, &str, [f64; 3])]) -> Scenario {
    let mut s = String::from("seed = 3\n");
    for (id, kind, p) in poses {
        s.push_str(&format!(
            "[[robots]]\nid = {id}\nkind = \"{kind}\"\npose = [{}, {}, {}]\n",
            p[0], p[1], p[2]
        ));
    }
    Scenario::from_toml(Path::new("fleet.toml"), &s).expect("simulator scenario")
}

struct Outcome {
    ctl: AssemblyController,
    run: LockstepRun,
    truth: GroundTruth,
}

fn run(fleet: &Scenario, scenario: &str, limit: f64) -> Outcome {
    let asm = AsmScenario::from_toml_str(
        Path::new("scenario.toml"),
        scenario,
        &fleet.params.non_pilot.geometry,
    )
    .expect("assembly scenario");
    let gate = GateConfig {
        terrain: fleet.terrain.clone(),
        ..GateConfig::default()
    };
    let mut ctl = AssemblyController::new(asm, fleet.params.clone(), gate).expect("controller");
    let mut ls = Lockstep::new(fleet).expect("lockstep world");
    let run = ls.run(&mut ctl, limit, |_, _| {});
    for e in &ctl.events {
        println!("  {}", serde_json::to_string(e).unwrap_or_default());
    }
    for e in &run.sim_events {
        println!("  sim {:.2} s {:?}", e.t_us as f64 * 1e-6, e.kind);
    }
    let truth = ls.world.ground_truth();
    Outcome { ctl, run, truth }
}

fn finished(o: &Outcome) -> bool {
    matches!(o.ctl.state(), RunState::Finished)
}

#[test]
fn four_robots_form_a_line_and_hold_it_while_it_drives_and_turns() {
    let f = fleet(&[
        (1, "NonPilot", [0.0, 0.0, 0.0]),
        (2, "NonPilot", [-0.085, 0.01, 0.1]),
        (3, "NonPilot", [-0.17, -0.01, -0.1]),
        (4, "NonPilot", [-0.255, 0.0, 0.05]),
    ]);
    let o = run(
        &f,
        r#"
name = "line"
[[step]]
form = { shape = "line", heading_deg = 0 }
timeout_s = 40
[[step]]
move = { velocity = [0.03, 0.0], duration_s = 3.0 }
[[step]]
move = { velocity = [0.03, 0.1], duration_s = 9.0 }
"#,
        60.0,
    );
    assert!(finished(&o), "state {:?}", o.ctl.state());
    let formed = o
        .ctl
        .events
        .iter()
        .find(|e| matches!(e.kind, EventKind::FormationComplete))
        .expect("formation complete");
    assert!(formed.t < 40.0);
    for (a, b) in [(1, 2), (2, 3), (3, 4)] {
        assert!(
            o.truth.are_coupled(a, b),
            "pair {a}-{b} coupled after driving and turning"
        );
    }
    let pose = |id| o.truth.robot(id).expect("robot").pose;
    let yaws: Vec<f64> = (1..=4).map(|i| pose(i).yaw).collect();
    println!("final yaws {yaws:?}, robot 1 at {:?}", pose(1));
    // The line drives like a train (a rigid line cannot turn: its rear would have to move
    // sideways): the head turned most of the commanded 0.9 rad, and every robot follows its
    // predecessor round the curve, lagging it by less than the anchor's yaw range.
    assert!(yaws[0] > 0.6, "the head turned: {yaws:?}");
    for k in 1..4 {
        let lag = yaws[k - 1] - yaws[k];
        assert!(
            (-0.05..0.5).contains(&lag),
            "robot {} lags by {lag}: {yaws:?}",
            k + 1
        );
    }
    assert!(pose(1).x > 0.15, "the line drove forward: {:?}", pose(1));
    // Nothing came apart on the way: no decoupling in the ground truth.
    assert!(!o
        .run
        .sim_events
        .iter()
        .any(|e| matches!(e.kind, SimEventKind::Decoupled { .. })));
}

#[test]
#[ignore = "known failing (measured): both anchor rows couple, the knob pair between them \
            never aligns: rows cannot move sideways and the 1 s MPC horizon finds no \
            parallel-parking manoeuvre (lateral gap stays 9-15 mm)"]
fn four_robots_form_a_two_by_two_mesh() {
    // Slots of the 2-row mesh (mm): (-37.5,-25) (12.5,-25) (-12.5,25) (37.5,25), spread 30 mm.
    let f = fleet(&[
        (1, "NonPilot", [0.045, -0.03, 0.0]),
        (2, "NonPilot", [-0.045, -0.03, 0.05]),
        (3, "NonPilot", [0.075, 0.035, -0.05]),
        (4, "NonPilot", [-0.02, 0.035, 0.0]),
    ]);
    let o = run(
        &f,
        r#"
name = "mesh"
[[step]]
form = { shape = "mesh", rows = 2, heading_deg = 0 }
timeout_s = 50
"#,
        55.0,
    );
    assert!(finished(&o), "state {:?}", o.ctl.state());
    // Two anchor rows and a knob between them (THESIS 5.2.2).
    let n = o.truth.coupled.len();
    assert!(n >= 3, "couplings {:?}", o.truth.coupled);
}
