//! Over-the-air update of simulated robots over loopback: `fleet_update::run` signs an
//! image with the fleet's update key and the robots install it, restart and announce the
//! new version; a corrupted, truncated, unsigned or replayed package is refused and the
//! robot keeps running and driving its old firmware.

use std::collections::BTreeSet;
use std::time::Duration;

use puzzlebot_host::fleet_update::{self, UpdateError};
use puzzlebot_host::link::{FleetLink, LinkConfig};
use puzzlebot_protocol::{FirmwareVersion, FleetKey, HostMsg, UpdateRefusal};
use puzzlebot_sim::{Pace, Scenario, SimFleet, SimOptions};

const OLD: FirmwareVersion = puzzlebot_sim::world::SIM_FIRMWARE_VERSION;
const NEW: FirmwareVersion = FirmwareVersion {
    major: 0,
    minor: 2,
    patch: 0,
};

/// A stand-in ESP-IDF app image of `len` bytes announcing `version` in its descriptor.
fn esp_image(len: usize, version: &str) -> Vec<u8> {
    let mut img: Vec<u8> = (0..len).map(|i| (i * 13 % 256) as u8).collect();
    img[0] = 0xE9;
    img[32..36].copy_from_slice(&0xABCD_5432u32.to_le_bytes());
    img[48..80].fill(0);
    img[48..48 + version.len()].copy_from_slice(version.as_bytes());
    img
}

fn version_of(link: &FleetLink, id: u16) -> Option<(u8, u8, u8)> {
    link.status(id).and_then(|s| s.firmware)
}

async fn drives(link: &FleetLink, sim: &SimFleet, id: u16) -> bool {
    link.command(
        id,
        HostMsg::WheelSpeed {
            left_rpm: 80.0,
            right_rpm: 80.0,
        },
    )
    .await;
    tokio::time::sleep(Duration::from_millis(600)).await;
    let v = sim.ground_truth().robot(id).map_or(0.0, |r| r.v);
    link.command(id, HostMsg::Stop).await;
    v > 0.05
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn robots_install_a_signed_image_and_refuse_bad_ones() {
    let dir = std::env::temp_dir().join(format!("puzzlebot-ota-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let fleet = dir.join("fleet.toml");
    std::fs::write(
        fleet_update::key_path(&fleet),
        fleet_update::fresh_key_hex(),
    )
    .unwrap();
    let signer = fleet_update::read_signing_key(&fleet).unwrap();

    let key = FleetKey([0x3c; 32]);
    let mut cfg = LinkConfig::new("127.0.0.1:0".parse().unwrap());
    cfg.allowed = Some(BTreeSet::from([1, 2]));
    let link = FleetLink::start(key.clone(), cfg).await.expect("link");
    let sim = SimFleet::start(
        Scenario::grid(2, 3),
        SimOptions {
            fleet_key: key,
            host_addr: link.local_addr().unwrap(),
            pose_addr: None,
            pace: Pace::RealTime,
        },
    )
    .expect("sim");
    sim.set_update_key(fleet_update::verifying_key(&fleet).unwrap());
    assert!(link.wait_for_robots(2, Duration::from_secs(5)).await);
    let old = Some((OLD.major, OLD.minor, OLD.patch));
    assert_eq!(version_of(&link, 1), old);

    let image = esp_image(3_000, "0.2.0");
    let good = fleet_update::package(&image, NEW, &signer);
    let patience = Duration::from_secs(5);
    let mut corrupted = good.clone();
    corrupted[2_000] ^= 0x40;
    let truncated = good[..good.len() - 100].to_vec();
    let mut unsigned = good.clone();
    unsigned[44..108].fill(0);
    let replayed = fleet_update::package(&image, OLD, &signer);
    let cases = [
        (corrupted, UpdateRefusal::Corrupted),
        (truncated, UpdateRefusal::BadPackage),
        (unsigned, UpdateRefusal::BadSignature),
        (replayed, UpdateRefusal::NotNewer),
    ];
    for (pkg, want) in cases {
        match fleet_update::send(&link, 1, &pkg, patience).await {
            Err(UpdateError::Refused { id: 1, why }) => assert_eq!(why, want),
            other => panic!("expected a refusal {want:?}, got {other:?}"),
        }
        assert_eq!(version_of(&link, 1), old, "still the old firmware");
    }
    assert!(drives(&link, &sim, 1).await, "drives after the refusals");

    let file = dir.join("fw.bin");
    std::fs::write(&file, &image).unwrap();
    let lines = fleet_update::run(&link, &fleet, &file, None, &[1, 2], patience)
        .await
        .expect("update");
    assert_eq!(lines, vec!["robot 1: runs 0.2.0", "robot 2: runs 0.2.0"]);
    for id in [1, 2] {
        assert_eq!(version_of(&link, id), Some((0, 2, 0)), "robot {id}");
    }
    assert!(drives(&link, &sim, 2).await, "drives on the new firmware");
    // The same package again is a replay now: refused.
    let again = fleet_update::run(&link, &fleet, &file, None, &[1], patience).await;
    let e = again.unwrap_err().to_string();
    assert!(e.contains("robot 1: refused the update (not newer"), "{e}");

    link.shutdown().await;
    sim.stop();
    let _ = std::fs::remove_dir_all(&dir);
}
