//! Tests of shape construction and shape files.

use super::*;

fn g() -> Geometry {
    Geometry::default()
}

#[test]
fn mesh_rows_are_offset_by_half_a_body() {
    let s = Shape::mesh(3, 2, &g()).unwrap();
    assert_eq!(s.len(), 3);
    let row1: Vec<_> = s.slots.iter().filter(|sl| sl.pose.y > 0.0).collect();
    let row0: Vec<_> = s.slots.iter().filter(|sl| sl.pose.y < 0.0).collect();
    assert_eq!(
        (row0.len(), row1.len()),
        (2, 1),
        "THESIS Fig 5.4D: two then one"
    );
    let dx = row1[0].pose.x - row0.iter().map(|r| r.pose.x).fold(f64::INFINITY, f64::min);
    assert!((dx - 0.025).abs() < 1e-9);
    assert!(Shape::mesh(1, 2, &g()).is_err());
    assert!(Shape::line(0, &g()).is_err());
}

#[test]
fn the_coordinators_meshes_are_the_crossing_planners_layouts() {
    // The cross step reads a formed mesh against `params::formation::layout`: every mesh
    // the coordinator forms, even or not, must be that layout up to where it stands.
    use puzzlebot_params::formation;
    let g = g();
    for (n, rows) in [(4, 2), (5, 2), (7, 2), (8, 2), (7, 3), (9, 3)] {
        let ours: Vec<[f64; 2]> = Shape::mesh(n, rows, &g)
            .unwrap()
            .slots
            .iter()
            .map(|s| [s.pose.x, s.pose.y])
            .collect();
        let planned = formation::Shape::mesh_of(rows, n).unwrap();
        let theirs = formation::layout(planned, &g).0;
        let centred = |v: &[[f64; 2]]| -> Vec<[f64; 2]> {
            let k = v.len() as f64;
            let c = v
                .iter()
                .fold([0.0, 0.0], |s, p| [s[0] + p[0] / k, s[1] + p[1] / k]);
            let mut out: Vec<[f64; 2]> = v.iter().map(|p| [p[0] - c[0], p[1] - c[1]]).collect();
            out.sort_by(|a, b| a[1].total_cmp(&b[1]).then(a[0].total_cmp(&b[0])));
            out
        };
        let (a, b) = (centred(&ours), centred(&theirs));
        assert_eq!(a.len(), b.len());
        for (p, q) in a.iter().zip(&b) {
            assert!(
                (p[0] - q[0]).hypot(p[1] - q[1]) < 1e-9,
                "{}: {p:?} vs {q:?}",
                planned.name()
            );
        }
    }
}

#[test]
fn pose_file_and_graph_file_give_the_same_shape() {
    let poses = "name = \"pair\"\n[[slot]]\nx = 0.0\ny = 0.0\n[[slot]]\nx = 0.05\ny = 0.0\nkind = \"pilot\"\n";
    let a = Shape::from_toml_str(Path::new("p.toml"), poses, &g()).unwrap();
    // Slot b's back (anchor) meets slot a's front (opening): b is in front.
    let graph = "[[slot]]\nname = \"a\"\n[[slot]]\nname = \"b\"\nkind = \"pilot\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"front\"\nto = \"b\"\nto_port = \"back\"\n";
    let b = Shape::from_toml_str(Path::new("g.toml"), graph, &g()).unwrap();
    for (x, y) in a.slots.iter().zip(&b.slots) {
        assert!(x.pose.distance(&y.pose) < 1e-9 && (x.pose.yaw - y.pose.yaw).abs() < 1e-9);
        assert_eq!(x.kind, y.kind);
    }
    assert_eq!(a.pairs(&g()).len(), 1);
}

#[test]
fn graph_file_builds_a_tee_with_a_side_coupling() {
    // A line of two and a third robot knob-coupled on the left of the first.
    let text = r#"
[[slot]]
name = "a"
[[slot]]
name = "b"
[[slot]]
name = "c"
[[link]]
from = "a"
from_port = "front"
to = "b"
to_port = "back"
[[link]]
from = "a"
from_port = "left_front"
to = "c"
to_port = "right_back"
"#;
    let s = Shape::from_toml_str(Path::new("tee.toml"), text, &g()).unwrap();
    let p = s.pairs(&g());
    assert_eq!(p.len(), 2);
    assert_eq!(p.iter().filter(|x| x.kind == PairType::KnobHole).count(), 1);
    let json = r#"{"slot":[{"name":"a"},{"name":"b"}],"link":[{"from":"a","from_port":"front","to":"b","to_port":"back"}]}"#;
    let dir = std::env::temp_dir().join(format!("pb-asm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("two.json");
    std::fs::write(&f, json).unwrap();
    let two = Shape::from_file(&f, &g()).unwrap();
    assert_eq!(two.name, "two");
    assert_eq!(two.len(), 2);
    std::fs::write(&f, "{\"slot\": [\n  {\"nam\": 1}\n]}").unwrap();
    let e = Shape::from_file(&f, &g()).unwrap_err().to_string();
    assert!(e.contains("two.json:2:"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_shape_files_name_the_field() {
    let e = |t: &str| {
        Shape::from_toml_str(Path::new("s.toml"), t, &g())
            .unwrap_err()
            .to_string()
    };
    let msg = e("[[slot]]\nname = \"a\"\n[[slot]]\nname = \"b\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"front\"\nto = \"b\"\nto_port = \"front\"\n");
    assert!(
        msg.contains("link[0].to_port") && msg.contains("cannot couple"),
        "{msg}"
    );
    let msg = e("[[slot]]\nname = \"a\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"front\"\nto = \"x\"\nto_port = \"back\"\n");
    assert!(
        msg.contains("link[0].to") && msg.contains("unknown slot 'x'"),
        "{msg}"
    );
    let msg = e("[[slot]]\nx = 0.0\ny = 0.0\n[[slot]]\nx = 0.01\ny = 0.0\n");
    assert!(msg.contains("slot[1]") && msg.contains("overlaps"), "{msg}");
    let msg = e("[[slot]]\nx = 0.0\ny = 0.0\n[[slot]]\nx = 0.2\ny = 0.0\n");
    assert!(msg.contains("one coupled assembly"), "{msg}");
    let msg = e("[[slot]]\nx = 0.0\nyy = 0.0\n");
    assert!(msg.starts_with("s.toml:3:") && msg.contains("yy"), "{msg}");
    let msg = e("[[slot]]\nx = 0.0\n");
    assert!(
        msg.contains("slot[0]") && msg.contains("needs x and y"),
        "{msg}"
    );
    let msg = e("[[slot]]\nx = 0.0\ny = 0.0\nyaw = 0.0\nyaw_deg = 0.0\n");
    assert!(msg.contains("slot[0].yaw_deg"), "{msg}");
    // Side by side without offset: knob meets knob? No: left (knobs) meets right (holes),
    // so this is a valid knob–hole pair at both side points.
    let ok = Shape::from_toml_str(
        Path::new("s.toml"),
        "[[slot]]\nx = 0.0\ny = 0.0\n[[slot]]\nx = 0.0\ny = 0.05\n",
        &g(),
    )
    .unwrap();
    assert_eq!(ok.pairs(&g())[0].kind, PairType::KnobHole);
    // Loop closed inconsistently.
    let msg = e("[[slot]]\nname = \"a\"\n[[slot]]\nname = \"b\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"front\"\nto = \"b\"\nto_port = \"back\"\n[[link]]\nfrom = \"a\"\nfrom_port = \"left_front\"\nto = \"b\"\nto_port = \"right_back\"\n");
    assert!(msg.contains("link[1]") && msg.contains("loop"), "{msg}");
}
