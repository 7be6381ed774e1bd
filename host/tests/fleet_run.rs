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

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("pb-fleet-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn a_separate_simulator_process_forms_and_drives_a_line_through_run_fleet() {
    let dir = scratch();
    let o = puzzlebot(&["fleet", "init", "."], &dir);
    assert!(o.status.success(), "{}", text(&o));
    // Free loopback ports instead of the defaults, so parallel tests do not collide.
    let cfg = dir.join("fleet.toml");
    let s = std::fs::read_to_string(&cfg).unwrap();
    let s = s
        .replace("127.0.0.1:47800", &format!("127.0.0.1:{}", free_port()))
        .replace("127.0.0.1:47810", &format!("127.0.0.1:{}", free_port()));
    std::fs::write(&cfg, s).unwrap();
    for id in ["1", "2", "3", "4"] {
        let o = puzzlebot(&["fleet", "add", "--id", id, "--kind", "non-pilot"], &dir);
        assert!(o.status.success(), "{}", text(&o));
    }
    std::fs::write(dir.join("sim.toml"), SIM).unwrap();
    std::fs::write(dir.join("line4.toml"), STEPS).unwrap();

    let _sim = Sim(Command::new(BIN)
        .args(["sim", "--fleet", "fleet.toml", "--scenario", "sim.toml"])
        .current_dir(&dir)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("puzzlebot sim starts"));

    let o = puzzlebot(&["fleet", "check", "--seconds", "15"], &dir);
    assert!(o.status.success(), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("ready"), "{}", text(&o));
    assert_eq!(out.matches("online").count(), 4, "{}", text(&o));

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
