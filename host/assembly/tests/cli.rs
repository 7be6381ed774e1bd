//! `puzzlebot-shape info` prints THESIS 5.2.4's mesh diagonal angles.

use std::process::Command;

fn run(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_puzzlebot-shape"))
        .args(args)
        .output()
        .expect("binary runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn mesh_info_text_and_json() {
    let (ok, text, _) = run(&["info", "mesh", "--robots", "4"]);
    assert!(ok);
    assert!(text.contains("α = 38.7°"), "{text}");
    let (ok, json, _) = run(&["info", "mesh", "--robots", "8", "--json"]);
    assert!(ok);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let a = v["diagonal_angle_deg"].as_f64().unwrap();
    assert!((a - 24.0).abs() < 0.05, "{a}");
    assert_eq!(v["robots"], 8);
}

#[test]
fn bad_input_is_a_clear_error() {
    let (ok, _, err) = run(&["info", "mesh", "--robots", "1", "--rows", "2"]);
    assert!(!ok);
    assert!(
        err.contains("robots") && err.contains("at least 2"),
        "{err}"
    );
    let (ok, _, err) = run(&["info", "/nonexistent/shape.toml"]);
    assert!(!ok);
    assert!(err.contains("/nonexistent/shape.toml"), "{err}");
}
