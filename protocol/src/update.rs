//! Over-the-air update messages (protocol version 3).
//!
//! The host streams a signed update package (format: `puzzlebot_firmware_core::update`)
//! in [`UPDATE_CHUNK`]-byte pieces over the authenticated session: `UpdateBegin` names the
//! package (`transfer`) and its length, each `UpdateChunk` carries its byte offset, and the
//! robot answers with an [`UpdateStatus`] saying how many bytes it holds in order. A chunk
//! at any other offset is ignored and answered with the status, so the host resumes from
//! there (after loss, a relink or a host restart: the same package has the same
//! `transfer`).

use serde::{Deserialize, Serialize};

/// Package bytes per `UpdateChunk`: the largest that keeps the datagram within the 64-byte
/// command budget (DESIGN.md §9) with any 32-bit offset.
pub const UPDATE_CHUNK: usize = 32;

/// A robot's report on an update.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct UpdateStatus {
    /// The package the report is about (0: none yet).
    pub transfer: u32,
    /// Bytes of it received in order (the next offset the robot takes).
    pub received: u32,
    /// Where the update stands.
    pub state: UpdateState,
}

/// Where an update stands on the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum UpdateState {
    /// No update in progress.
    Idle,
    /// Receiving: send the chunk at `received`.
    Receiving,
    /// Verified and written; the robot restarts into it and announces its version.
    Installed,
    /// Refused; the robot keeps running its current image.
    Refused(UpdateRefusal),
}

/// Why a robot refused an update package.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum UpdateRefusal {
    /// The robot has no update key in its provisioning record.
    NoUpdateKey,
    /// Not a package (magic, format or header), or its length disagrees with `UpdateBegin`.
    BadPackage,
    /// Larger than the robot's update slot.
    TooLarge,
    /// The signature does not verify under the robot's update key.
    BadSignature,
    /// Not newer than the running firmware (a replayed or older package).
    NotNewer,
    /// The image does not match the signed digest (corrupted or truncated).
    Corrupted,
    /// Writing or reading the update slot failed.
    Flash,
}

impl UpdateRefusal {
    /// Short lower-case reason for logs and error messages.
    pub fn name(self) -> &'static str {
        match self {
            UpdateRefusal::NoUpdateKey => "the robot has no update key (re-provision it)",
            UpdateRefusal::BadPackage => "not an update package",
            UpdateRefusal::TooLarge => "larger than the update slot",
            UpdateRefusal::BadSignature => "signature does not verify",
            UpdateRefusal::NotNewer => "not newer than the running firmware",
            UpdateRefusal::Corrupted => "image does not match its signed digest",
            UpdateRefusal::Flash => "flash write failed",
        }
    }
}
