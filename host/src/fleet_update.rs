//! `puzzlebot fleet update --image F`: sign a firmware image with the fleet's update key and
//! stream it to robots over their authenticated sessions (format and robot side:
//! `puzzlebot_firmware_core::update`; messages: `puzzlebot_protocol::update`).
//!
//! The update key is an Ed25519 signing key (`update.key`, 64 hex characters, owner-only)
//! beside the fleet config, made by `puzzlebot fleet init` (or `puzzlebot fleet
//! update-key` for a fleet set up without one); its public half goes into every robot's
//! provisioning record. The host streams [`UPDATE_CHUNK`]-byte chunks in windows of
//! [`ACK_EVERY`], resumes from the robot's report after loss, and succeeds once the robot
//! has installed the image and announces the new version.

use std::path::{Path, PathBuf};
use std::time::Duration;

use ed25519_dalek::{Signer, SigningKey};
use puzzlebot_firmware_core::update::{Manifest, ACK_EVERY};
use puzzlebot_protocol::{
    FirmwareVersion, HostMsg, RobotId, UpdateRefusal, UpdateState, UPDATE_CHUNK,
};
use sha2::{Digest, Sha256};

use crate::link::FleetLink;

/// Name of the update signing key file, beside the fleet config.
pub const SIGN_FILE: &str = "update.key";

/// An update could not be made or sent.
#[derive(Debug, thiserror::Error)]
pub enum UpdateError {
    /// The fleet has no update key.
    #[error("{0}: no update signing key; make one with `puzzlebot fleet update-key` and re-provision the robots")]
    NoSigningKey(PathBuf),
    /// A key or image file is unusable.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The robot refused the package; it keeps running its current image.
    #[error("robot {id}: refused the update ({}); it keeps running its current firmware", .why.name())]
    Refused {
        /// The robot.
        id: RobotId,
        /// Its reason.
        why: UpdateRefusal,
    },
    /// The robot stopped answering.
    #[error("robot {id}: no answer for {seconds} s while {what}")]
    Timeout {
        /// The robot.
        id: RobotId,
        /// Seconds waited.
        seconds: u64,
        /// The step.
        what: &'static str,
    },
}

/// Where the update key of the fleet config `fleet` lives.
pub fn key_path(fleet: &Path) -> PathBuf {
    fleet.with_file_name(SIGN_FILE)
}

/// Read the update signing key of the fleet config `fleet`.
pub fn read_signing_key(fleet: &Path) -> Result<SigningKey, UpdateError> {
    let path = key_path(fleet);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(UpdateError::NoSigningKey(path))
        }
        Err(e) => {
            return Err(UpdateError::File {
                path,
                message: format!("cannot read update key: {e}"),
            })
        }
    };
    let seed = puzzlebot_protocol::RobotKey::from_hex(&text).ok_or_else(|| UpdateError::File {
        path: path.clone(),
        message: "update key must be exactly 64 hexadecimal characters".into(),
    })?;
    Ok(SigningKey::from_bytes(&seed.0))
}

/// The public update key robots are provisioned with; `None` when the fleet has none.
pub fn verifying_key(fleet: &Path) -> Result<Option<[u8; 32]>, UpdateError> {
    match read_signing_key(fleet) {
        Ok(k) => Ok(Some(k.verifying_key().to_bytes())),
        Err(UpdateError::NoSigningKey(_)) => Ok(None),
        Err(e) => Err(e),
    }
}

/// 64 hex characters of a fresh update signing key (for a new `update.key`).
pub fn fresh_key_hex() -> String {
    let mut seed = [0u8; 32];
    rand::fill(&mut seed);
    seed.iter().map(|b| format!("{b:02x}")).collect()
}

/// The version in an ESP-IDF app image's descriptor (`esp_app_desc!`: magic 0xABCD5432 at
/// byte 32, version string at byte 48), e.g. "0.2.0".
pub fn image_version(image: &[u8]) -> Option<FirmwareVersion> {
    let magic = image.get(32..36)?;
    if image.first() != Some(&0xE9) || magic != 0xABCD_5432u32.to_le_bytes() {
        return None;
    }
    let raw = image.get(48..80)?;
    let end = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
    parse_version(std::str::from_utf8(&raw[..end]).ok()?)
}

/// "X.Y.Z" (each 0..=255; anything after a '-' or '+' is ignored).
pub fn parse_version(s: &str) -> Option<FirmwareVersion> {
    let core = s.trim().split(['-', '+']).next()?;
    let mut it = core.split('.').map(|p| p.parse::<u8>().ok());
    let v = FirmwareVersion {
        major: it.next()??,
        minor: it.next()??,
        patch: it.next()??,
    };
    it.next().is_none().then_some(v)
}

/// The signed package of `image` at `version` (header, signature, image).
pub fn package(image: &[u8], version: FirmwareVersion, key: &SigningKey) -> Vec<u8> {
    let m = Manifest {
        version,
        image_len: image.len() as u32,
        digest: Sha256::digest(image).into(),
    };
    let signed = m.signed_bytes();
    let mut p = signed.to_vec();
    p.extend_from_slice(&key.sign(&signed).to_bytes());
    p.extend_from_slice(image);
    p
}

/// Stream `package` to robot `id` until it reports the image installed; an error when it
/// refuses or stops answering for `patience`.
pub async fn send(
    link: &FleetLink,
    id: RobotId,
    package: &[u8],
    patience: Duration,
) -> Result<(), UpdateError> {
    let digest = Sha256::digest(package);
    let transfer = u32::from_le_bytes([digest[0], digest[1], digest[2], digest[3]]);
    let total = package.len() as u32;
    let window = ACK_EVERY * UPDATE_CHUNK as u32;
    let begin = HostMsg::UpdateBegin {
        transfer,
        total_len: total,
    };
    let _ = link.take_update_status(id);
    let mut last_heard = tokio::time::Instant::now();
    let mut next: Option<u32> = None;
    loop {
        match next {
            None => {
                link.send_once(id, &begin).await;
            }
            Some(from) => {
                let end = total.min((from / window + 1) * window);
                let mut off = from;
                while off < end {
                    let mut data = [0u8; UPDATE_CHUNK];
                    let n = (end - off).min(UPDATE_CHUNK as u32) as usize;
                    data[..n].copy_from_slice(&package[off as usize..off as usize + n]);
                    link.send_once(id, &HostMsg::UpdateChunk { offset: off, data })
                        .await;
                    off += UPDATE_CHUNK as u32;
                }
            }
        }
        let report = wait_report(link, id, transfer, Duration::from_millis(300)).await;
        match report {
            Some(s) => {
                last_heard = tokio::time::Instant::now();
                match s.state {
                    UpdateState::Installed => return Ok(()),
                    UpdateState::Refused(why) => return Err(UpdateError::Refused { id, why }),
                    UpdateState::Receiving => next = Some(s.received),
                    UpdateState::Idle => next = None,
                }
            }
            // Lost window or report: ask where the robot stands.
            None => next = None,
        }
        if last_heard.elapsed() > patience {
            return Err(UpdateError::Timeout {
                id,
                seconds: patience.as_secs(),
                what: "sending the image",
            });
        }
    }
}

async fn wait_report(
    link: &FleetLink,
    id: RobotId,
    transfer: u32,
    wait: Duration,
) -> Option<puzzlebot_protocol::UpdateStatus> {
    let end = tokio::time::Instant::now() + wait;
    while tokio::time::Instant::now() < end {
        if let Some(s) = link
            .take_update_status(id)
            .filter(|s| s.transfer == transfer)
        {
            return Some(s);
        }
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
    None
}

/// Wait until robot `id` announces `version` with a session (after its restart).
pub async fn wait_for_version(
    link: &FleetLink,
    id: RobotId,
    version: FirmwareVersion,
    patience: Duration,
) -> Result<(), UpdateError> {
    let want = (version.major, version.minor, version.patch);
    let end = tokio::time::Instant::now() + patience;
    while tokio::time::Instant::now() < end {
        if link
            .status(id)
            .is_some_and(|s| s.online && s.established && s.firmware == Some(want))
        {
            return Ok(());
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    Err(UpdateError::Timeout {
        id,
        seconds: patience.as_secs(),
        what: "waiting for it to restart with the new version",
    })
}

/// `puzzlebot fleet update`: sign `image` with the update key of the fleet config `fleet`
/// and update robots `ids` one after the other (each must be online). One line per
/// updated robot; an error naming every robot that was not updated.
pub async fn run(
    link: &FleetLink,
    fleet: &Path,
    image: &Path,
    version: Option<&str>,
    ids: &[RobotId],
    patience: Duration,
) -> anyhow::Result<Vec<String>> {
    let key = read_signing_key(fleet)?;
    let (bytes, version) = read_image(image, version)?;
    let pkg = package(&bytes, version, &key);
    let v = format!("{}.{}.{}", version.major, version.minor, version.patch);
    let mut lines = Vec::new();
    let mut failed = Vec::new();
    for &id in ids {
        let end = tokio::time::Instant::now() + patience;
        while !link.status(id).is_some_and(|s| s.online && s.established)
            && tokio::time::Instant::now() < end
        {
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let sent = match link.status(id).is_some_and(|s| s.online && s.established) {
            false => Err(UpdateError::Timeout {
                id,
                seconds: patience.as_secs(),
                what: "waiting for it to come online",
            }),
            true => match send(link, id, &pkg, patience).await {
                Ok(()) => wait_for_version(link, id, version, patience).await,
                Err(e) => Err(e),
            },
        };
        match sent {
            Ok(()) => lines.push(format!("robot {id}: runs {v}")),
            Err(e) => failed.push(e.to_string()),
        }
    }
    if !failed.is_empty() {
        anyhow::bail!("{}", failed.join("; "));
    }
    Ok(lines)
}

/// Read an image file and its version (from `version`, else its ESP-IDF app descriptor).
pub fn read_image(
    path: &Path,
    version: Option<&str>,
) -> Result<(Vec<u8>, FirmwareVersion), UpdateError> {
    let bad = |message: String| UpdateError::File {
        path: path.to_path_buf(),
        message,
    };
    let image = std::fs::read(path).map_err(|e| bad(format!("cannot read image: {e}")))?;
    if image.is_empty() {
        return Err(bad("image is empty".into()));
    }
    let v = match version {
        Some(s) => parse_version(s).ok_or_else(|| UpdateError::File {
            path: PathBuf::from("--version"),
            message: format!("'{s}' is not X.Y.Z"),
        })?,
        None => image_version(&image).ok_or_else(|| {
            bad("no ESP-IDF app descriptor with a version; give --version X.Y.Z".into())
        })?,
    };
    Ok((image, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_come_from_the_app_descriptor_or_the_command_line() {
        let mut img = vec![0u8; 256];
        img[0] = 0xE9;
        img[32..36].copy_from_slice(&0xABCD_5432u32.to_le_bytes());
        img[48..53].copy_from_slice(b"0.3.1");
        let v = image_version(&img).expect("descriptor");
        assert_eq!((v.major, v.minor, v.patch), (0, 3, 1));
        img[0] = 0;
        assert_eq!(image_version(&img), None, "not an ESP image");
        assert!(parse_version("1.2").is_none());
        assert!(parse_version("1.2.300").is_none());
        assert!(parse_version("1.2.3-rc1").is_some());
    }

    #[test]
    fn key_and_image_errors_are_one_line_and_name_the_file() {
        let d = std::env::temp_dir().join(format!("puzzlebot-update-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let fleet = d.join("fleet.toml");
        let e = read_signing_key(&fleet).unwrap_err().to_string();
        assert!(
            e.contains("update.key: no update signing key") && !e.contains('\n'),
            "{e}"
        );
        assert_eq!(verifying_key(&fleet).unwrap(), None, "a fleet without one");
        std::fs::write(key_path(&fleet), "zz\n").unwrap();
        let e = read_signing_key(&fleet).unwrap_err().to_string();
        assert!(
            e.contains("update.key: update key must be exactly 64"),
            "{e}"
        );
        std::fs::write(key_path(&fleet), fresh_key_hex()).unwrap();
        assert!(verifying_key(&fleet).unwrap().is_some());
        let img = d.join("fw.bin");
        std::fs::write(&img, b"").unwrap();
        assert!(read_image(&img, Some("1.0.0"))
            .unwrap_err()
            .to_string()
            .ends_with("fw.bin: image is empty"));
        std::fs::write(&img, b"abc").unwrap();
        let e = read_image(&img, None).unwrap_err().to_string();
        assert!(e.contains("give --version"), "{e}");
        let e = read_image(&img, Some("one")).unwrap_err().to_string();
        assert_eq!(e, "--version: 'one' is not X.Y.Z");
        assert!(read_image(&d.join("missing.bin"), None).is_err());
        let _ = std::fs::remove_dir_all(&d);
    }
}
