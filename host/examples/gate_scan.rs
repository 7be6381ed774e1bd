//! Scratch: the gate's elastic use of each connection along a crossing for several support
//! compliances, gaps kept.
use puzzlebot_host::crossing::drive3d;
use puzzlebot_host::experiment::crossing::{configs, predict, settings, Obstacle};
use puzzlebot_params::FleetParams;
use puzzlebot_stability::crossing::formed;
use puzzlebot_stability::elastic;
use puzzlebot_stability::puzzlebot::{assembly_level, build_model_with};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let num = |i: usize, d: f64| a.get(i).and_then(|s| s.parse().ok()).unwrap_or(d);
    let obstacle = Obstacle {
        width: num(3, 60.0) * 1e-3,
        drop: num(4, 0.0) * 1e-3,
    };
    let heading = num(5, 0.0);
    let (from, to) = (num(6, 60.0) * 1e-3, num(7, 90.0) * 1e-3);
    let ks: Vec<f64> = a
        .get(8)
        .map(|s| s.split(',').map(|v| v.parse().unwrap()).collect())
        .unwrap_or(vec![0.0, 1.0, 10.0, 1000.0]);
    let params = FleetParams::default();
    let cfgs = configs(&[2, 4, 6, 8, 9], &params);
    let cfg = cfgs
        .iter()
        .find(|c| c.shape == a[1] && c.pilots == a[2])
        .expect("cfg");
    let (cand, _) = predict(cfg, obstacle, heading, &params).expect("predict");
    println!(
        "gate {:.1} {:?}",
        cand.advance.distance * 1e3,
        cand.advance.limited_by
    );
    let shape = formation_shape(cfg);
    let h = heading.to_radians();
    let planned = formed(shape, &cfg.pilot_places, &params, cand.start, h);
    let terrain = obstacle.terrain();
    let level = assembly_level(&planned, &params, &terrain).unwrap();
    let aopt = drive3d::crossing_options(&settings(), &params).advance_options(cand.required);
    let c = &params.non_pilot.coupling;
    let mut d = from;
    while d <= to {
        let m = build_model_with(
            &planned,
            &params,
            &terrain,
            level,
            [h.cos() * d, h.sin() * d],
            &aopt,
        )
        .unwrap();
        let r = m.resolve().unwrap();
        let gaps: Vec<f64> = m.contacts.iter().map(|k| k.gap.max(0.0)).collect();
        let mut line = format!("d {:6.1}", d * 1e3);
        for &k in &ks {
            let comp = elastic::Compliance {
                force: 1.0 / f64::from(c.connector_stiffness),
                couple: 1.0 / f64::from(c.connector_angular_stiffness),
                support: k / f64::from(c.connector_stiffness),
            };
            let cs: f64 = std::env::var("CASTER")
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(1.0);
            let scale: Vec<f64> = m
                .contacts
                .iter()
                .map(|k| if k.mu[0] > 0.0 { 1.0 } else { cs })
                .collect();
            match elastic::distribution_with_supports(&r, comp, &gaps, &scale) {
                Ok(Some(w)) => {
                    let u: Vec<String> = elastic::use_of_limits(&r, &w)
                        .iter()
                        .map(|u| format!("{:3.0}", 100.0 * u.unwrap_or(0.0)))
                        .collect();
                    line += &format!(" | k{k}: {}", u.join(" "));
                }
                Ok(None) => line += " | tips",
                Err(e) => line += &format!(" | {e}"),
            }
        }
        println!("{line}");
        d += 0.002;
    }
}

fn formation_shape(
    cfg: &puzzlebot_host::experiment::crossing::Config,
) -> puzzlebot_params::formation::Shape {
    use puzzlebot_params::formation::Shape;
    let n = cfg.robots;
    if cfg.mesh {
        let rows = if n % 2 == 0 { 2 } else { 3 };
        Shape::Mesh {
            rows,
            per_row: n / rows,
        }
    } else {
        Shape::Line(n)
    }
}
