//! `run.mcap`: a short recorded lockstep run read back with the `mcap` crate has messages on
//! every channel host/README.md documents (and on no other), with the documented schemas,
//! and its poses and couplings agree with the run's report.

mod short_run;

use std::collections::{BTreeMap, BTreeSet};

use serde_json::Value;

/// (topic pattern, schema) of every row of host/README.md's recording table.
fn documented_channels() -> Vec<(String, String)> {
    let readme = include_str!("../README.md");
    let section = readme
        .split("\n## Recording\n")
        .nth(1)
        .expect("host/README.md has a Recording section");
    let section = section.split("\n## ").next().unwrap_or(section);
    let rows: Vec<(String, String)> = section
        .lines()
        .filter(|l| l.starts_with("| `/"))
        .map(|l| {
            let cells: Vec<&str> = l.split('|').map(|c| c.trim().trim_matches('`')).collect();
            (cells[1].to_string(), cells[2].to_string())
        })
        .collect();
    assert!(
        rows.len() >= 8,
        "the recording table has {} rows",
        rows.len()
    );
    rows
}

/// A channel read back: schema name, schema encoding, message encoding, (time, message).
type Channel = (String, String, String, Vec<(f64, Value)>);

#[test]
fn a_recorded_run_has_messages_on_every_documented_channel() {
    let (report, path) = short_run::run("recording");
    let bytes = std::fs::read(&path).expect("run.mcap");
    let mut channels: BTreeMap<String, Channel> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let m = m.expect("a readable message");
        let schema = m
            .channel
            .schema
            .as_ref()
            .expect("every channel has a schema");
        let entry = channels.entry(m.channel.topic.clone()).or_insert_with(|| {
            (
                schema.name.clone(),
                schema.encoding.clone(),
                m.channel.message_encoding.clone(),
                Vec::new(),
            )
        });
        let v: Value = serde_json::from_slice(&m.data).expect("JSON messages");
        entry.3.push((m.log_time as f64 * 1e-9, v));
    }
    let robots: Vec<u16> = report.final_poses.keys().copied().collect();
    assert_eq!(robots, [1, 2]);
    let mut expected = BTreeSet::new();
    for (pattern, schema) in documented_channels() {
        let topics: Vec<String> = if pattern.contains("robot_N") {
            robots
                .iter()
                .map(|id| pattern.replace("robot_N", &format!("robot_{id}")))
                .collect()
        } else {
            vec![pattern.clone()]
        };
        for topic in topics {
            let (name, schema_enc, msg_enc, msgs) = channels
                .get(&topic)
                .unwrap_or_else(|| panic!("no messages on the documented channel {topic}"));
            assert_eq!(name, &schema, "{topic}: schema");
            assert_eq!(
                (schema_enc.as_str(), msg_enc.as_str()),
                ("jsonschema", "json"),
                "{topic}"
            );
            assert!(!msgs.is_empty(), "{topic}: no messages");
            expected.insert(topic);
        }
    }
    let undocumented: Vec<&String> = channels.keys().filter(|t| !expected.contains(*t)).collect();
    assert!(
        undocumented.is_empty(),
        "channels not in host/README.md: {undocumented:?}"
    );

    // 10 Hz over the whole run (≈ 3.5 s: forming, then a 2 s drive).
    let truth = &channels["/robot_2/pose/true"].3;
    let span = truth.last().map_or(0.0, |m| m.0) - truth[0].0;
    assert!(
        (truth.len() as f64 - span * 10.0).abs() <= 2.0 && span > 2.0,
        "{} true poses over {span:.1} s",
        truth.len()
    );
    // The last true pose is where the report says the robot ended.
    for id in &robots {
        let (_, last) = channels[&format!("/robot_{id}/pose/true")]
            .3
            .last()
            .unwrap();
        let p = &last["pose"]["position"];
        let end = report.final_poses[id];
        let d = (p["x"].as_f64().unwrap() - end[0]).hypot(p["y"].as_f64().unwrap() - end[1]);
        assert!(
            d < 0.005,
            "robot {id}: last recorded pose {d:.4} m from its final pose"
        );
        assert_eq!(last["frame_id"], "world");
    }
    // Commands at the 30 Hz command rate, and the robots were driven.
    let cmds = &channels["/robot_2/command"].3;
    assert!(cmds.len() as f64 > span * 25.0, "{} commands", cmds.len());
    assert!(cmds
        .iter()
        .any(|(_, c)| c["left_rpm"].as_f64().unwrap().abs() > 1.0));
    // No coupling at the start; robot 2's anchor in robot 1's opening at the end, as in the
    // simulator's ground truth, and drawn in the scene.
    let couplings = &channels["/couplings/true"].3;
    let coupled = |v: &Value| -> Vec<(u64, u64, String)> {
        v["links"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|l| l["state"] == "Coupled")
            .map(|l| {
                let id = |k: &str| l[k].as_u64().unwrap();
                (id("a"), id("b"), l["kind"].as_str().unwrap().to_string())
            })
            .collect()
    };
    assert!(coupled(&couplings[0].1).is_empty(), "{:?}", couplings[0].1);
    assert_eq!(
        coupled(&couplings.last().unwrap().1),
        [(2, 1, "Anchor".to_string())]
    );
    assert!(report.coupled_truth.contains(&(2, 1)));
    let scene = &channels["/scene/couplings"].3.last().unwrap().1;
    assert_eq!(scene["entities"].as_array().unwrap().len(), 1, "{scene}");
    let bodies = &channels["/scene/robots"].3.last().unwrap().1;
    assert_eq!(bodies["entities"].as_array().unwrap().len(), 2);
    // The host's pair went through its statuses to connected.
    let statuses: Vec<&str> = channels["/pairs/status"]
        .3
        .iter()
        .map(|(_, m)| m["to"].as_str().unwrap())
        .collect();
    assert_eq!(statuses.last(), Some(&"connected"), "{statuses:?}");
    // The recording names its robots, parameters and terrain.
    let rec = puzzlebot_host::record::Recording::read(&path).expect("read back");
    assert_eq!(rec.info.robots.len(), 2);
    assert_eq!(rec.info.params, puzzlebot_params::FleetParams::default());
    let events = &channels["/events"].3;
    assert!(events.iter().any(|(_, e)| e["message"]
        .as_str()
        .unwrap()
        .contains("formation_complete")));
}
