//! End to end over loopback, as a lab runs a fleet: `puzzlebot fleet init` and `fleet add`
//! write the config, `puzzlebot sim --fleet F` runs four robots in another process,
//! `puzzlebot fleet check` sees them, and `puzzlebot run SCENARIO --fleet F` passes the
//! pre-flight check, forms a 4-robot line and drives it; the run folder records it.

use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_puzzlebot");

/// Four non-pilots set down one behind the other, each a few millimetres and hundredths of a
/// radian off its place in the line.
const SIM: &str = r#"
seed = 3
[[robots]]
id = 1
kind = "NonPilot"
pose = [0.3, 0.0, 0.0]
[[robots]]
id = 2
kind = "NonPilot"
pose = [0.2, 0.01, 0.05]
[[robots]]
id = 3
kind = "NonPilot"
pose = [0.1, -0.005, -0.05]
[[robots]]
id = 4
kind = "NonPilot"
pose = [0.0, 0.008, 0.03]
"#;

/// Form the line of four, then drive it 0.1 m.
const STEPS: &str = r#"
name = "line4"
[[step]]
form = { shape = "line", heading_deg = 0 }
timeout_s = 40
[[step]]
move = { velocity = [0.05, 0.0], duration_s = 2 }
"#;

/// Kills the simulator when the test ends, passed or not.
struct Sim(Child);

impl Drop for Sim {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|s| s.local_addr())
        .expect("a free loopback port")
        .port()
}

fn puzzlebot(args: &[&str], dir: &Path) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .env("RUST_LOG", "warn")
        .output()
        .expect("puzzlebot runs")
}

fn text(o: &Output) -> String {
    format!(
        "status {:?}\nstdout:\n{}\nstderr:\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A fresh folder for the test `tag` (tests run in parallel in one process).
fn scratch(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pb-fleet-run-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `puzzlebot fleet init` in `dir` on free loopback ports (parallel tests do not collide),
/// `fleet add` of `robots` (id, kind), `puzzlebot sim` of `sim` in another process, and
/// `fleet check` once every robot is online.
fn start_fleet(dir: &Path, robots: &[(&str, &str)], sim: &str) -> Sim {
    let o = puzzlebot(&["fleet", "init", "."], dir);
    assert!(o.status.success(), "{}", text(&o));
    let cfg = dir.join("fleet.toml");
    let s = std::fs::read_to_string(&cfg).unwrap();
    let s = s
        .replace("127.0.0.1:47800", &format!("127.0.0.1:{}", free_port()))
        .replace("127.0.0.1:47810", &format!("127.0.0.1:{}", free_port()));
    std::fs::write(&cfg, s).unwrap();
    for (id, kind) in robots {
        let o = puzzlebot(&["fleet", "add", "--id", id, "--kind", kind], dir);
        assert!(o.status.success(), "{}", text(&o));
    }
    std::fs::write(dir.join("sim.toml"), sim).unwrap();
    let child = Sim(Command::new(BIN)
        .args(["sim", "--fleet", "fleet.toml", "--scenario", "sim.toml"])
        .current_dir(dir)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("puzzlebot sim starts"));
    let o = puzzlebot(&["fleet", "check", "--seconds", "15"], dir);
    assert!(o.status.success(), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("ready"), "{}", text(&o));
    assert_eq!(out.matches("online").count(), robots.len(), "{}", text(&o));
    child
}

#[test]
fn a_separate_simulator_process_forms_and_drives_a_line_through_run_fleet() {
    let dir = scratch("line");
    let robots = ["1", "2", "3", "4"].map(|id| (id, "non-pilot"));
    let _sim = start_fleet(&dir, &robots, SIM);
    std::fs::write(dir.join("line4.toml"), STEPS).unwrap();

    let o = puzzlebot(
        &[
            "--runs-dir",
            "runs",
            "run",
            "line4.toml",
            "--fleet",
            "fleet.toml",
            "--limit",
            "60",
            "--json",
        ],
        &dir,
    );
    assert!(o.status.success(), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("motion capture:"),
        "pre-flight table: {}",
        text(&o)
    );

    // The run folder: the pre-flight table, the line's couplings, the drive.
    let runs: Vec<PathBuf> = std::fs::read_dir(dir.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(runs.len(), 1, "{runs:?}");
    let run = &runs[0];
    let pre = std::fs::read_to_string(run.join("preflight.txt")).unwrap();
    assert!(!pre.contains("forced past"), "{pre}");
    let events = std::fs::read_to_string(run.join("assembly_events.jsonl")).unwrap();
    let connected = events
        .lines()
        .filter(|l| l.contains("\"pair_status\"") && l.contains("\"to\":\"connected\""))
        .count();
    assert!(
        connected >= 3,
        "three pairs connect a line of four:\n{events}"
    );
    assert!(events.contains("\"formation_complete\""), "{events}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("assembly_report.json")).unwrap())
            .unwrap();
    assert_eq!(report["state"], "finished", "{report}");
    assert!(
        events.contains(r#""event":"step_finished","index":1"#),
        "the line drove:\n{events}"
    );
    // It ends as a line: each robot one coupled length behind the one ahead, on the x axis.
    let pose = |id: u16| -> [f64; 2] {
        let p = &report["final_poses"][id.to_string()];
        [p[0].as_f64().unwrap(), p[1].as_f64().unwrap()]
    };
    for id in 1..4u16 {
        let (a, b) = (pose(id), pose(id + 1));
        let gap = (a[0] - b[0]).hypot(a[1] - b[1]);
        assert!(
            (0.03..0.07).contains(&gap),
            "robots {id}, {}: {gap} m apart",
            id + 1
        );
        assert!(a[0] > b[0], "robot {id} ahead of {}", id + 1);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A pilot and a non-pilot set down one behind the other, 20° to a 10 mm gap whose near edge
/// is at x = 0.30 m ([`GAP10`]).
const SIM_AT_GAP: &str = r#"
seed = 4
[[robots]]
id = 1
kind = "Pilot"
pose = [0.0, 0.0, 0.349]
[[robots]]
id = 2
kind = "NonPilot"
pose = [-0.113, -0.03, 0.4]
"#;

/// Two platforms of equal height 10 mm apart: a lone robot tips in, the line of two with
/// its pilot in front crosses at 20° (`puzzlebot plan crossing --robots 2 --pilots 1`).
const GAP10: &str = r#"
[[platforms]]
name = "near"
polygon = [[-1.0, -1.0], [0.30, -1.0], [0.30, 1.0], [-1.0, 1.0]]
[[platforms]]
name = "far"
polygon = [[0.31, -1.0], [1.6, -1.0], [1.6, 1.0], [0.31, 1.0]]
"#;

/// The cross step over the real link: the host plans the formed line from the poses motion
/// capture gives it and drives it with the crossing controller through the UDP link. The
/// simulator process is the flat 2-D plant (no gap), so this checks the host's side: the
/// plan from measured poses, the drive at the crossing speed to the advance the plan needs.
#[test]
fn a_cross_step_runs_over_the_link_through_run_fleet() {
    let dir = scratch("cross");
    let _sim = start_fleet(&dir, &[("1", "pilot"), ("2", "non-pilot")], SIM_AT_GAP);
    std::fs::write(dir.join("gap10.toml"), GAP10).unwrap();
    std::fs::write(
        dir.join("cross.toml"),
        "name = \"cross2\"\n[[step]]\nform = { shape = \"line\" }\ntimeout_s = 40\n\
         [[step]]\ncross = { terrain = \"gap10.toml\" }\ntimeout_s = 90\n",
    )
    .unwrap();
    let o = puzzlebot(
        &[
            "--runs-dir",
            "runs",
            "run",
            "cross.toml",
            "--fleet",
            "fleet.toml",
            "--limit",
            "120",
            "--json",
        ],
        &dir,
    );
    let run = std::fs::read_dir(dir.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .next()
        .expect("a run folder");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("assembly_report.json")).unwrap())
            .unwrap();
    // The host drove the line at the crossing speed through the link (a member outside a
    // turn of the whole body up to `max_speed_up` faster), the pilot straight (THESIS
    // 5.4.1), and stopped it at the end.
    let settings = puzzlebot_host::crossing::drive3d::CrossSettings::default();
    let (speed, fastest) = (
        settings.speed,
        settings.speed * (1.0 + settings.max_speed_up),
    );
    let ticks: Vec<serde_json::Value> = std::fs::read_to_string(run.join("telemetry.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let driving = |id: u64| {
        ticks
            .iter()
            .filter(|r| r["robot"] == id)
            .filter(|r| {
                let v = r["desired"]["v"].as_f64().unwrap_or(0.0);
                v >= speed - 1e-9 && v <= fastest + 1e-9
            })
            .collect::<Vec<_>>()
    };
    let (pilot, other) = (driving(1), driving(2));
    assert!(
        pilot.len() > 50 && other.len() > 50,
        "{} and {} ticks",
        pilot.len(),
        other.len()
    );
    assert!(pilot.iter().all(|r| r["desired"]["omega"] == 0.0));
    for id in [1, 2] {
        let last = ticks.iter().rev().find(|r| r["robot"] == id).unwrap();
        assert_eq!(last["desired"]["v"].as_f64(), Some(0.0), "{last}");
    }
    // Across, or stopped by the host (the flat 2-D plant's line turns under the pilot as no
    // gap's far platform would let it); never refused, since the plan proves the crossing.
    if o.status.success() {
        assert_eq!(report["state"], "finished", "{report}");
        for id in ["1", "2"] {
            assert!(
                report["final_poses"][id][0].as_f64().unwrap() > 0.31,
                "{report}"
            );
        }
    } else {
        let why = report["state"]["failed"]["reason"]
            .as_str()
            .unwrap_or_default();
        assert!(why.contains("stopped") && !why.contains("refused"), "{why}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
