//! File format: the shipped examples load and solve; bad files name file, line and field.

use puzzlebot_stability::io::{gate_command, parse_assembly, GateError};
use puzzlebot_stability::Verdict;
use std::path::{Path, PathBuf};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples")
        .join(name)
}

#[test]
fn shipped_examples_solve_and_draw() {
    let dir = std::env::temp_dir().join(format!("gate-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["cantilever.toml", "bridge.json"] {
        let svg = dir.join(format!("{name}.svg"));
        let text = gate_command(&example(name), false, Some(&svg)).unwrap();
        assert!(text.contains("verdict: stable"), "{name}: {text}");
        let pic = std::fs::read_to_string(&svg).unwrap();
        assert!(pic.contains("<svg"), "{name}");
        let json = gate_command(&example(name), true, None).unwrap();
        let v: serde_json::Value = serde_json::from_str(&json).unwrap();
        assert_eq!(v["verdict"]["kind"], "stable");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn cantilever_example_matches_statics() {
    let a = puzzlebot_stability::load_assembly(&example("cantilever.toml")).unwrap();
    let r = puzzlebot_stability::evaluate(&a).unwrap();
    assert_eq!(r.verdict, Verdict::Stable);
    // Root couple: 0.1·9.81·(0.025 + 0.075 + 0.125) + 0.5·0.145.
    let expect = 0.981 * 0.225 + 0.5 * 0.145;
    let w = r.connections[0].wrench;
    let m = (w[3] * w[3] + w[4] * w[4] + w[5] * w[5]).sqrt();
    assert!((m - expect).abs() < 1e-9, "{m} vs {expect}");
}

#[test]
fn json_errors_name_line_and_field() {
    let text = "{\n  \"modules\": [\n    { \"id\": \"a\", \"mass\": \"heavy\", \"position\": [0, 0, 0] }\n  ]\n}";
    match parse_assembly(text, false, Path::new("x.json")) {
        Err(GateError::Parse { line, field, .. }) => {
            assert_eq!(line, 3);
            assert_eq!(field, "modules[0].mass");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn toml_errors_name_line_and_field() {
    let text = "[[modules]]\nid = \"a\"\nmass = 1.0\nposition = [0.0, 0.0]\n";
    match parse_assembly(text, true, Path::new("x.toml")) {
        Err(GateError::Parse { line, field, .. }) => {
            assert_eq!(line, 4, "{field}");
            assert!(field.starts_with("modules[0].position"), "{field}");
        }
        other => panic!("{other:?}"),
    }
    let text = "[[modules]]\nid = \"a\"\nmass = 1.0\nposition = [0.0, 0.0, 0.0]\ncolour = 3\n";
    let e = parse_assembly(text, true, Path::new("x.toml")).unwrap_err();
    assert!(e.to_string().contains("colour"), "{e}");
}

#[test]
fn inconsistent_files_name_the_field() {
    let dir = std::env::temp_dir().join(format!("gate-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("bad.json");
    std::fs::write(
        &p,
        r#"{"modules": [{"id": "a", "mass": 1, "position": [0,0,0]}],
            "contacts": [{"module": "b", "point": [0,0,0], "mu": [0.5, 0.5]}]}"#,
    )
    .unwrap();
    let e = gate_command(&p, false, None).unwrap_err();
    assert!(e.to_string().contains("contacts[0].module"), "{e}");
    let e = gate_command(&dir.join("missing.toml"), false, None).unwrap_err();
    assert!(matches!(e, GateError::Io { .. }));
    let _ = std::fs::remove_dir_all(&dir);
}
