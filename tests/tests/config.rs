//! A malformed fleet config gives an error naming the file, the line and the field.

use puzzlebot_host::config::{write_new_key, Fleet};

#[test]
fn malformed_fleet_config_names_file_line_and_field() {
    let dir = puzzlebot_e2e::scratch("config");
    write_new_key(&dir.join("fleet.key")).expect("key");
    let path = dir.join("fleet.toml");
    let cases = [
        // (text, line, words the message must contain)
        ("key_file = \"fleet.key\"\n\n[[robots]]\nid = 1\nkind = \"NonPilot\"\n[[robots]]\nid = \"two\"\nkind = \"Pilot\"\n", 7, vec!["two"]),
        ("key_file = \"fleet.key\"\n[params.rates]\ncommand_hz = 30.0\noffline_afer_ms = 300\n", 4, vec!["offline_afer_ms"]),
        ("key_file = \"fleet.key\"\n[link]\nbind = \"localhost\"\n", 3, vec![]),
        ("key_file = \"fleet.key\"\n[pose]\nsource = \"vicon\"\n", 3, vec!["vicon"]),
    ];
    for (text, line, words) in cases {
        std::fs::write(&path, text).expect("write");
        let msg = Fleet::load(&path).expect_err("malformed").to_string();
        println!("{msg}");
        let prefix = format!("{}:{line}:", path.display());
        assert!(
            msg.starts_with(&prefix),
            "{msg:?} should start with {prefix:?}"
        );
        for w in words {
            assert!(msg.contains(w), "{msg:?} should name {w:?}");
        }
    }
    // Duplicate ids and a bad key file are named too.
    std::fs::write(&path, "key_file = \"fleet.key\"\n[[robots]]\nid = 1\nkind = \"NonPilot\"\n[[robots]]\nid = 1\nkind = \"Pilot\"\n").expect("write");
    let msg = Fleet::load(&path).expect_err("duplicate").to_string();
    assert!(
        msg.contains("fleet.toml") && msg.contains("robots[1].id"),
        "{msg}"
    );
    std::fs::write(dir.join("short.key"), "abcd\n").expect("write");
    std::fs::write(&path, "key_file = \"short.key\"\n").expect("write");
    let msg = Fleet::load(&path).expect_err("bad key").to_string();
    assert!(msg.contains("short.key") && !msg.contains("abcd"), "{msg}");
}
