//! `replay.html` in headless Chromium: a short recorded run's page, opened at chosen times
//! (`replay.html#t=…`), shows as many robots as the run had, each where the recording has it
//! (within 1 mm), and exactly the couplings the simulator had then.
//!
//! Chromium is found as `chromium`, `chromium-browser` or `google-chrome` on the PATH (or
//! `$CHROMIUM`). Without one the test is skipped with a message, unless
//! `PUZZLEBOT_REQUIRE_CHROMIUM` is set (CI sets it): then it fails.

mod short_run;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use puzzlebot_host::record::foxglove::yaw_of;
use puzzlebot_host::record::Recording;
use serde_json::Value;

fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .flat_map(|name| std::env::split_paths(&path).map(move |d| d.join(name)))
        .find(|p| p.is_file())
}

/// The page's state JSON (`<pre id="state">`) and the number of coupling lines drawn, with
/// the page opened at `t`.
fn page_at(chrome: &Path, page: &Path, t: f64, profile: &Path) -> (Value, usize) {
    let url = format!("file://{}#t={t}", page.display());
    let out = Command::new(chrome)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-dev-shm-usage",
            "--no-first-run",
            "--virtual-time-budget=3000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg("--dump-dom")
        .arg(&url)
        .output()
        .expect("chromium runs");
    let dom = String::from_utf8_lossy(&out.stdout);
    let state = dom
        .split("<pre id=\"state\">")
        .nth(1)
        .and_then(|s| s.split("</pre>").next())
        .unwrap_or_else(|| {
            panic!(
                "no state in the page at t = {t}: {}\n{}",
                String::from_utf8_lossy(&out.stderr),
                &dom[..dom.len().min(2000)]
            )
        });
    let v: Value = serde_json::from_str(state).expect("the state is JSON");
    (v, dom.matches("class=\"coupling\"").count())
}

/// Robot `id`'s recorded true pose at `t`, linearly interpolated between the 10 Hz samples
/// (yaw along the shorter arc), as the page draws it.
fn recorded_pose(rec: &Recording, id: u16, t: f64) -> [f64; 3] {
    let topic = format!("/robot_{id}/pose/true");
    let poses: Vec<(f64, [f64; 3])> = rec
        .topic(&topic)
        .map(|m| {
            let p = &m.data["pose"];
            let xy = &p["position"];
            (
                m.t,
                [
                    xy["x"].as_f64().unwrap(),
                    xy["y"].as_f64().unwrap(),
                    yaw_of(p).unwrap(),
                ],
            )
        })
        .collect();
    let i = poses.partition_point(|p| p.0 <= t).saturating_sub(1);
    let (t0, a) = poses[i];
    let Some(&(t1, b)) = poses.get(i + 1) else {
        return a;
    };
    let f = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
    let d = (b[2] - a[2] + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
        - std::f64::consts::PI;
    [
        a[0] + (b[0] - a[0]) * f,
        a[1] + (b[1] - a[1]) * f,
        a[2] + d * f,
    ]
}

/// The couplings the simulator had at `t` (the last sample at or before it).
fn recorded_couplings(rec: &Recording, t: f64) -> BTreeSet<(String, u64, u64)> {
    let m = rec
        .topic("/couplings/true")
        .take_while(|m| m.t <= t + 1e-9)
        .last()
        .expect("a coupling sample");
    m.data["links"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|l| l["state"] == "Coupled")
        .map(|l| {
            (
                l["kind"].as_str().unwrap().to_lowercase(),
                l["a"].as_u64().unwrap(),
                l["b"].as_u64().unwrap(),
            )
        })
        .collect()
}

#[test]
fn the_replay_page_shows_the_recorded_robots_and_couplings_at_chosen_times() {
    let Some(chrome) = chromium() else {
        if std::env::var_os("PUZZLEBOT_REQUIRE_CHROMIUM").is_some() {
            panic!("PUZZLEBOT_REQUIRE_CHROMIUM is set but no chromium is on the PATH");
        }
        eprintln!(
            "SKIPPED the_replay_page_shows_…: no chromium on the PATH \
             (apt-get install chromium, or set CHROMIUM=/path/to/chrome)"
        );
        return;
    };
    let (report, mcap) = short_run::run("replay");
    let written = puzzlebot_host::replay::write(&report.folder).expect("replay.html");
    let page = std::fs::canonicalize(&written.page).expect("page path");
    let rec = Recording::read(&mcap).expect("recording");
    let end = written.timeline.end();
    let first_coupled = rec
        .topic("/couplings/true")
        .find(|m| !recorded_couplings(&rec, m.t).is_empty())
        .map(|m| m.t)
        .expect("the pair couples");
    // Before the coupling, between samples just after it, and during the drive.
    let times = [
        0.5,
        first_coupled + 0.05,
        (first_coupled + end) / 2.0 + 0.03,
    ];
    let results: Vec<(f64, (Value, usize))> = std::thread::scope(|s| {
        let handles: Vec<_> = times
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let (chrome, page) = (&chrome, &page);
                let profile = report.folder.join(format!("chromium-profile-{i}"));
                s.spawn(move || (t, page_at(chrome, page, t, &profile)))
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for (t, (state, lines)) in results {
        assert!(
            (state["t"].as_f64().unwrap() - t).abs() < 1e-3,
            "the page opened at {t}: {state}"
        );
        let robots = state["robots"].as_array().unwrap();
        assert_eq!(robots.len(), 2, "t = {t}: {state}");
        for r in robots {
            let id = r["id"].as_u64().unwrap() as u16;
            let want = recorded_pose(&rec, id, t);
            let (x, y) = (r["x"].as_f64().unwrap(), r["y"].as_f64().unwrap());
            let d = (x - want[0]).hypot(y - want[1]);
            assert!(
                d < 0.001,
                "t = {t}: robot {id} drawn at ({x:.4}, {y:.4}), recorded at ({:.4}, {:.4})",
                want[0],
                want[1]
            );
            let dyaw = (r["yaw"].as_f64().unwrap() - want[2]).sin().abs();
            assert!(dyaw < 0.01, "t = {t}: robot {id} heading");
        }
        let shown: BTreeSet<(String, u64, u64)> = state["couplings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| {
                (
                    c["kind"].as_str().unwrap().to_string(),
                    c["a"].as_u64().unwrap(),
                    c["b"].as_u64().unwrap(),
                )
            })
            .collect();
        assert_eq!(shown, recorded_couplings(&rec, t), "t = {t}");
        assert_eq!(lines, shown.len(), "t = {t}: coupling lines drawn");
    }
    // Before the coupling there is none; after it robot 2's anchor is in robot 1's opening.
    assert!(recorded_couplings(&rec, 0.5).is_empty());
    assert!(recorded_couplings(&rec, end).contains(&("anchor".into(), 2, 1)));
    let _ = std::fs::remove_dir_all(report.folder.parent().unwrap_or(&report.folder));
}
