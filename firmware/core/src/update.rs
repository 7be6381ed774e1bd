//! Over-the-air update on the robot: receive a signed package into the spare image slot,
//! verify it, and hand it over for activation; then run the new image on trial and roll
//! back if it does not reach the host in time ([`Trial`]).
//!
//! Package (what the host streams; `puzzlebot fleet update` makes it):
//!
//! ```text
//! offset size field
//! 0      4    magic "PBUP"
//! 4      1    format (PACKAGE_FORMAT = 1)
//! 5      3    firmware version major, minor, patch
//! 8      4    image length u32 LE
//! 12     32   SHA-256 of the image
//! 44     64   Ed25519 signature of bytes 0..44 under the fleet's update key
//! 108    n    the image (what the spare slot receives)
//! ```
//!
//! [`Updater`] takes the header into RAM and the image into an [`UpdateSlot`] chunk by
//! chunk. It refuses a package as soon as the header is in when the signature does not
//! verify, the version is not newer than the running one (a replayed or older package),
//! the lengths disagree or the image would not fit; and after the last byte when the
//! SHA-256 of the image *read back from the slot* differs from the signed one. Nothing is
//! activated before all of that passed, so a refused package leaves the robot running
//! (and driving) its current image. The simulator's slot is memory (`hil-sim/src/ota.rs`),
//! where all of this is exercised end to end; the ESP32-C3's is its `ota_1` partition.

use ed25519_dalek::{Signature, VerifyingKey};
use puzzlebot_protocol::{FirmwareVersion, UpdateRefusal, UpdateState, UpdateStatus, UPDATE_CHUNK};
use sha2::{Digest, Sha256};

/// First four bytes of every package.
pub const PACKAGE_MAGIC: [u8; 4] = *b"PBUP";
/// Package format this firmware reads.
pub const PACKAGE_FORMAT: u8 = 1;
/// Bytes of the package header (before the image).
pub const HEADER_LEN: usize = 108;
/// Bytes of the header the signature covers.
pub const SIGNED_LEN: usize = 44;
/// A newly installed image must open a session with the host within this time of its
/// first boot, or the robot rolls back to the previous image (ms).
pub const TRIAL_TIMEOUT_MS: u32 = 30_000;

/// Writing or reading the update slot failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlotError;

/// The spare image slot an update is written to.
pub trait UpdateSlot {
    /// Largest image the slot holds (bytes).
    fn capacity(&self) -> u32;
    /// Write `data` at `offset`; writes arrive in order from offset 0 and the slot erases
    /// what it needs before writing.
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError>;
    /// Read `buf.len()` bytes at `offset`.
    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), SlotError>;
}

/// The signed header of a package.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Manifest {
    /// Version of the image.
    pub version: FirmwareVersion,
    /// Image length (bytes).
    pub image_len: u32,
    /// SHA-256 of the image.
    pub digest: [u8; 32],
}

impl Manifest {
    /// The signed bytes of the header (0..[`SIGNED_LEN`]).
    pub fn signed_bytes(&self) -> [u8; SIGNED_LEN] {
        let mut b = [0u8; SIGNED_LEN];
        b[..4].copy_from_slice(&PACKAGE_MAGIC);
        b[4] = PACKAGE_FORMAT;
        b[5..8].copy_from_slice(&[self.version.major, self.version.minor, self.version.patch]);
        b[8..12].copy_from_slice(&self.image_len.to_le_bytes());
        b[12..44].copy_from_slice(&self.digest);
        b
    }

    /// Parse and check a header against `key`; `BadPackage` or `BadSignature` otherwise.
    pub fn verify(header: &[u8; HEADER_LEN], key: &[u8; 32]) -> Result<Manifest, UpdateRefusal> {
        if header[..4] != PACKAGE_MAGIC || header[4] != PACKAGE_FORMAT {
            return Err(UpdateRefusal::BadPackage);
        }
        let key = VerifyingKey::from_bytes(key).map_err(|_| UpdateRefusal::BadSignature)?;
        let mut sig = [0u8; 64];
        sig.copy_from_slice(&header[SIGNED_LEN..HEADER_LEN]);
        key.verify_strict(&header[..SIGNED_LEN], &Signature::from_bytes(&sig))
            .map_err(|_| UpdateRefusal::BadSignature)?;
        let mut digest = [0u8; 32];
        digest.copy_from_slice(&header[12..44]);
        Ok(Manifest {
            version: FirmwareVersion {
                major: header[5],
                minor: header[6],
                patch: header[7],
            },
            image_len: u32::from_le_bytes([header[8], header[9], header[10], header[11]]),
            digest,
        })
    }
}

/// True when `a` is a newer version than `b`.
pub fn is_newer(a: FirmwareVersion, b: FirmwareVersion) -> bool {
    (a.major, a.minor, a.patch) > (b.major, b.minor, b.patch)
}

/// An update message taken from the link ([`crate::Robot::take_update_request`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UpdateRequest {
    /// `UpdateBegin`.
    Begin {
        /// Package name.
        transfer: u32,
        /// Package length (bytes).
        total_len: u32,
    },
    /// `UpdateChunk`.
    Chunk {
        /// Byte offset in the package.
        offset: u32,
        /// The bytes.
        data: [u8; UPDATE_CHUNK],
    },
}

/// Chunks between two progress reports while receiving in order (the host's window).
pub const ACK_EVERY: u32 = 16;

/// The receive / verify state machine of one robot (see the module documentation).
#[derive(Debug, Clone)]
pub struct Updater {
    key: Option<[u8; 32]>,
    running: FirmwareVersion,
    transfer: u32,
    total: u32,
    received: u32,
    header: [u8; HEADER_LEN],
    manifest: Option<Manifest>,
    state: UpdateState,
}

impl Updater {
    /// An idle updater of a robot running `running` that trusts packages signed with
    /// `key` (`None`: every package is refused).
    pub fn new(key: Option<[u8; 32]>, running: FirmwareVersion) -> Updater {
        Updater {
            key,
            running,
            transfer: 0,
            total: 0,
            received: 0,
            header: [0; HEADER_LEN],
            manifest: None,
            state: UpdateState::Idle,
        }
    }

    /// The current report.
    pub fn status(&self) -> UpdateStatus {
        UpdateStatus {
            transfer: self.transfer,
            received: self.received,
            state: self.state,
        }
    }

    /// The verified manifest once the state is `Installed`: activate that image.
    pub fn installed(&self) -> Option<Manifest> {
        match self.state {
            UpdateState::Installed => self.manifest,
            _ => None,
        }
    }

    /// Handle one request; returns the report to send, if one is due: after every begin,
    /// a chunk out of order, a change of state, and every [`ACK_EVERY`] chunks.
    pub fn handle(
        &mut self,
        req: UpdateRequest,
        slot: &mut impl UpdateSlot,
    ) -> Option<UpdateStatus> {
        match req {
            UpdateRequest::Begin {
                transfer,
                total_len,
            } => Some(self.on_begin(transfer, total_len, slot)),
            UpdateRequest::Chunk { offset, data } => {
                let before = (self.state, self.received);
                let s = self.on_chunk(offset, &data, slot);
                let window = ACK_EVERY * UPDATE_CHUNK as u32;
                let due = s.state != before.0
                    || s.received == before.1
                    || s.received.is_multiple_of(window);
                due.then_some(s)
            }
        }
    }

    /// `UpdateBegin`: start package `transfer` of `total_len` bytes, or resume it when it
    /// is the one in progress (or already decided: the decision is repeated).
    pub fn on_begin(
        &mut self,
        transfer: u32,
        total_len: u32,
        slot: &impl UpdateSlot,
    ) -> UpdateStatus {
        if transfer == self.transfer && total_len == self.total && self.state != UpdateState::Idle {
            return self.status();
        }
        *self = Updater::new(self.key, self.running);
        self.transfer = transfer;
        self.total = total_len;
        self.state = if self.key.is_none() {
            UpdateState::Refused(UpdateRefusal::NoUpdateKey)
        } else if (total_len as usize) < HEADER_LEN {
            UpdateState::Refused(UpdateRefusal::BadPackage)
        } else if total_len - HEADER_LEN as u32 > slot.capacity() {
            UpdateState::Refused(UpdateRefusal::TooLarge)
        } else {
            UpdateState::Receiving
        };
        self.status()
    }

    /// `UpdateChunk`: take the bytes at `offset` if it is the next expected one (else
    /// ignore them); check the header once it is complete and the image after the last byte.
    pub fn on_chunk(
        &mut self,
        offset: u32,
        data: &[u8; UPDATE_CHUNK],
        slot: &mut impl UpdateSlot,
    ) -> UpdateStatus {
        if self.state != UpdateState::Receiving || offset != self.received {
            return self.status();
        }
        let n = (self.total - self.received).min(UPDATE_CHUNK as u32) as usize;
        let mut pos = self.received as usize;
        let mut bytes = &data[..n];
        if pos < HEADER_LEN {
            let k = (HEADER_LEN - pos).min(bytes.len());
            self.header[pos..pos + k].copy_from_slice(&bytes[..k]);
            bytes = &bytes[k..];
            pos += k;
            if pos == HEADER_LEN {
                if let Err(why) = self.check_header() {
                    self.state = UpdateState::Refused(why);
                    return self.status();
                }
            }
        }
        if !bytes.is_empty() && slot.write((pos - HEADER_LEN) as u32, bytes).is_err() {
            self.state = UpdateState::Refused(UpdateRefusal::Flash);
            return self.status();
        }
        self.received += n as u32;
        if self.received == self.total {
            self.state = match self.check_image(slot) {
                Ok(()) => UpdateState::Installed,
                Err(why) => UpdateState::Refused(why),
            };
        }
        self.status()
    }

    fn check_header(&mut self) -> Result<(), UpdateRefusal> {
        let key = self.key.ok_or(UpdateRefusal::NoUpdateKey)?;
        let m = Manifest::verify(&self.header, &key)?;
        if m.image_len != self.total - HEADER_LEN as u32 {
            return Err(UpdateRefusal::BadPackage);
        }
        if !is_newer(m.version, self.running) {
            return Err(UpdateRefusal::NotNewer);
        }
        self.manifest = Some(m);
        Ok(())
    }

    /// Hash the image as it is in the slot (not as it was received).
    fn check_image(&self, slot: &mut impl UpdateSlot) -> Result<(), UpdateRefusal> {
        let m = self.manifest.ok_or(UpdateRefusal::BadPackage)?;
        let mut hash = Sha256::new();
        let mut buf = [0u8; 256];
        let mut at = 0u32;
        while at < m.image_len {
            let n = (m.image_len - at).min(buf.len() as u32) as usize;
            slot.read(at, &mut buf[..n])
                .map_err(|_| UpdateRefusal::Flash)?;
            hash.update(&buf[..n]);
            at += n as u32;
        }
        if hash.finalize().as_slice() != m.digest {
            return Err(UpdateRefusal::Corrupted);
        }
        Ok(())
    }
}

/// What a robot on trial must do now ([`Trial::on_tick`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrialAction {
    /// Keep running.
    Wait,
    /// The new image reached the host: mark it valid (once).
    Confirm,
    /// The new image did not reach the host in time: restart into the previous one.
    RollBack,
}

/// The first boot of a freshly installed image: it must open a session with the host
/// within the timeout, or the robot rolls back to the image it came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Trial {
    deadline_us: Option<u64>,
}

impl Trial {
    /// A trial ending at `now_us + timeout_ms` when `on_trial` (the boot loader or the
    /// simulator says this image is new and unconfirmed), else none.
    pub fn new(on_trial: bool, now_us: u64, timeout_ms: u32) -> Trial {
        Trial {
            deadline_us: on_trial.then(|| now_us + u64::from(timeout_ms) * 1000),
        }
    }

    /// True while the image is unconfirmed.
    pub fn pending(&self) -> bool {
        self.deadline_us.is_some()
    }

    /// Call every control period with whether the robot has a session with the host.
    pub fn on_tick(&mut self, now_us: u64, established: bool) -> TrialAction {
        match self.deadline_us {
            None => TrialAction::Wait,
            Some(_) if established => {
                self.deadline_us = None;
                TrialAction::Confirm
            }
            Some(d) if now_us >= d => {
                self.deadline_us = None;
                TrialAction::RollBack
            }
            Some(_) => TrialAction::Wait,
        }
    }
}
