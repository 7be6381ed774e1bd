//! Tests of `crossing`.

use super::*;
use puzzlebot_params::terrain::Platform;

fn gap(w: f64) -> Terrain {
    Terrain {
        platforms: vec![
            Platform::rect("near", [-1.0, -0.5], [0.0, 0.5], 0.0),
            Platform::rect("far", [w, -0.5], [w + 1.0, 0.5], 0.0),
        ],
    }
}

#[test]
fn pilot_places_are_distinct_sets() {
    let mesh = Shape::Mesh {
        rows: 2,
        per_row: 2,
    };
    let sets = pilot_sets(mesh, 1);
    assert_eq!(
        sets,
        vec![(PilotPlace::Front, vec![0]), (PilotPlace::Back, vec![1])]
    );
    assert_eq!(
        pilot_sets(Shape::Line(3), 0),
        vec![(PilotPlace::None, vec![])]
    );
    // A line has one front and one back: two pilots sit there whichever way.
    assert_eq!(pilot_sets(Shape::Line(3), 2).len(), 1);
    assert_eq!(pilot_sets(mesh, 2).len(), 3);
}

#[test]
fn a_single_robot_cannot_cross_what_a_mesh_can() {
    let p = FleetParams::default();
    let opt = CrossingOptions {
        headings: vec![0.0, 0.7],
        ..CrossingOptions::default()
    };
    // 40 mm on equal heights: one robot tips into it, a 2 x 2 mesh is carried across.
    let lone = plan(&gap(0.04), &p, 1, 0, &opt).unwrap();
    assert!(lone.iter().all(|c| !c.crosses()), "{}", render(&lone));
    let four = plan(&gap(0.04), &p, 4, 1, &opt).unwrap();
    assert!(four[0].crosses(), "{}", render(&four));
    assert!(four.iter().any(|c| c.shape == "mesh 2x2" && c.crosses()));
    // A bad terrain file is refused naming file, line and field.
    let dir = std::env::temp_dir().join(format!("crossing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("t.toml");
    std::fs::write(
        &f,
        "[[platforms]]\npolygon = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]\n\n\
         [[platforms]]\npolygon = [[0.5, 0.0], [2.0, 0.0], [2.0, 1.0], [0.5, 1.0]]\n",
    )
    .unwrap();
    let e = load_terrain(&f).unwrap_err().to_string();
    assert!(
        e.ends_with(":4: platforms[1].polygon: overlaps platforms[0] (\"\" and \"\")"),
        "{e}"
    );
    std::fs::write(
        &f,
        "[[platforms]]\npolygon = [[0.0, 0.0]]\nheight = \"x\"\n",
    )
    .unwrap();
    let e = load_terrain(&f).unwrap_err().to_string();
    assert!(e.contains("t.toml:3:"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
    // Bad input is refused with the reason.
    let e = plan(&gap(0.04), &p, 2, 3, &opt).unwrap_err().to_string();
    assert!(e.contains("--pilots"), "{e}");
}

#[test]
fn a_bad_parameter_file_is_refused_by_name_before_planning() {
    let dir = std::env::temp_dir().join(format!("puzzlebot-plan-params-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("robots.toml");
    std::fs::write(&file, "[pilot.coupling]\nknob_hold_force = -1.0\n").unwrap();
    let args = CrossingArgs {
        terrain: dir.join("no-terrain.toml"),
        robots: 4,
        pilots: 1,
        start_y: 0.0,
        drive_accel: None,
        speed: None,
        connector_damping: None,
        params: Some(file.clone()),
        json: false,
    };
    let e = args.run().unwrap_err().to_string();
    assert!(
        e.contains("robots.toml") && e.contains("pilot.coupling.knob_hold_force"),
        "{e}"
    );
    std::fs::write(&file, "[pilot.coupling]\nconnector_damping_ratio = 0.01\n").unwrap();
    let p = args.fleet_params().unwrap();
    assert_eq!(LoadTransfer::of(&p).damping_ratio, 0.01f32 as f64);
    assert!(p.pilot.plant.four_wheels);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_assembly_is_planned_from_where_it_stands() {
    let p = FleetParams::default();
    let opt = CrossingOptions {
        headings: vec![0.0, 0.35, 0.7],
        ..CrossingOptions::default()
    };
    let mesh = Shape::Mesh {
        rows: 2,
        per_row: 2,
    };
    let links = formation::layout(mesh, &p.non_pilot.geometry).1;
    let all = plan(&gap(0.04), &p, 4, 1, &opt).unwrap();
    let planned = all
        .iter()
        .find(|c| c.shape == "mesh 2x2" && c.crosses())
        .unwrap_or_else(|| panic!("{}", render(&all)));
    let pilots = planned.pilot_robots.clone();
    let h = planned.heading_deg.to_radians();
    let at = |start: [f64; 2]| formed_with(mesh, &pilots, &links, &p, start, h);
    let here = plan_placed(&gap(0.04), &p, mesh, &pilots, &at(planned.start), h, &opt).unwrap();
    assert!((here.required - planned.required).abs() < 1e-9);
    assert_eq!(here.advance, planned.advance);
    // 10 cm further back along its heading: 10 cm more to drive, and still proven.
    let back = [
        planned.start[0] - 0.1 * h.cos(),
        planned.start[1] - 0.1 * h.sin(),
    ];
    let far = plan_placed(&gap(0.04), &p, mesh, &pilots, &at(back), h, &opt).unwrap();
    assert!(
        (far.required - planned.required - 0.1).abs() < 0.0015,
        "{}",
        far.required
    );
    assert!(far.crosses());
    // A lone robot at the edge is refused; an assembly astride the gap is an error.
    let lone = formed_with(Shape::Line(1), &[], &[], &p, planned.start, 0.0);
    let c = plan_placed(&gap(0.04), &p, Shape::Line(1), &[], &lone, 0.0, &opt).unwrap();
    assert!(!c.crosses());
    let astride = at([0.05, 0.0]);
    let e = plan_placed(&gap(0.04), &p, mesh, &pilots, &astride, h, &opt).unwrap_err();
    assert!(e.to_string().contains("one platform"), "{e}");
}
