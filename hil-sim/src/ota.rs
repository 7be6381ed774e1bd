//! Over-the-air updates of a simulated robot: the firmware core's [`Updater`] writes into
//! an in-memory slot the size of the ESP32-C3's OTA partition; an installed image is
//! "booted" by restarting the robot's firmware with the package's version, on trial
//! ([`Trial`]): without a session with the host within [`TRIAL_TIMEOUT_MS`] the robot
//! restarts into the version it came from. The image bytes are not executed: a simulated
//! robot always runs this repository's firmware core, only its announced version changes.

use puzzlebot_firmware_core::update::{
    SlotError, Trial, TrialAction, UpdateRequest, UpdateSlot, Updater, TRIAL_TIMEOUT_MS,
};
use puzzlebot_protocol::{FirmwareVersion, ResetReason, UpdateStatus};

/// Capacity of the simulated update slot (bytes): the `ota_1` partition of
/// `firmware/esp32c3/partitions.csv`.
pub const SLOT_CAPACITY: u32 = 0x1E_0000;

/// An in-memory update slot.
#[derive(Debug, Clone, Default)]
pub struct MemSlot(Vec<u8>);

impl UpdateSlot for MemSlot {
    fn capacity(&self) -> u32 {
        SLOT_CAPACITY
    }

    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError> {
        let end = offset as usize + data.len();
        if end > SLOT_CAPACITY as usize {
            return Err(SlotError);
        }
        if self.0.len() < end {
            self.0.resize(end, 0xff);
        }
        self.0[offset as usize..end].copy_from_slice(data);
        Ok(())
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), SlotError> {
        let src = self
            .0
            .get(offset as usize..offset as usize + buf.len())
            .ok_or(SlotError)?;
        buf.copy_from_slice(src);
        Ok(())
    }
}

/// The update side of one simulated robot (survives its reboots, as flash does).
#[derive(Debug, Clone)]
pub struct SimOta {
    key: Option<[u8; 32]>,
    running: FirmwareVersion,
    /// The image a rollback returns to while the running one is unconfirmed.
    previous: Option<FirmwareVersion>,
    updater: Updater,
    slot: MemSlot,
    trial: Trial,
}

impl SimOta {
    /// A robot running `version` that trusts no update key yet.
    pub fn new(version: FirmwareVersion) -> SimOta {
        SimOta {
            key: None,
            running: version,
            previous: None,
            updater: Updater::new(None, version),
            slot: MemSlot::default(),
            trial: Trial::new(false, 0, TRIAL_TIMEOUT_MS),
        }
    }

    /// Trust packages signed with `key` (the provisioning record's update key).
    pub fn set_key(&mut self, key: Option<[u8; 32]>) {
        self.key = key;
        self.updater = Updater::new(key, self.running);
    }

    /// The version the robot runs (and announces).
    pub fn version(&self) -> FirmwareVersion {
        self.running
    }

    /// True while a newly installed image is unconfirmed.
    pub fn on_trial(&self) -> bool {
        self.trial.pending()
    }

    /// The firmware (re)booted at `now_us`: RAM state is gone; an unconfirmed image
    /// starts (or restarts) its trial.
    pub fn on_boot(&mut self, now_us: u64) {
        self.updater = Updater::new(self.key, self.running);
        self.trial = Trial::new(self.previous.is_some(), now_us, TRIAL_TIMEOUT_MS);
    }

    /// An update message from the link; the report to send, if one is due.
    pub fn on_request(&mut self, req: UpdateRequest) -> Option<UpdateStatus> {
        self.updater.handle(req, &mut self.slot)
    }

    /// After a control tick at `now_us`: `Some(reason)` when the robot must restart now
    /// (into an installed image, or back to the previous one).
    pub fn after_tick(&mut self, now_us: u64, established: bool) -> Option<ResetReason> {
        if let Some(m) = self.updater.installed() {
            self.previous = Some(self.running);
            self.running = m.version;
            return Some(ResetReason::Software);
        }
        match self.trial.on_tick(now_us, established) {
            TrialAction::Wait => None,
            TrialAction::Confirm => {
                self.previous = None;
                None
            }
            TrialAction::RollBack => {
                self.running = self.previous.take().unwrap_or(self.running);
                Some(ResetReason::Software)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ed25519_dalek::{Signer, SigningKey};
    use puzzlebot_firmware_core::update::Manifest;
    use puzzlebot_protocol::UPDATE_CHUNK;
    use sha2::{Digest, Sha256};

    const NEW: FirmwareVersion = FirmwareVersion {
        major: 0,
        minor: 9,
        patch: 0,
    };

    /// A robot running `old` with `NEW` installed through the update messages.
    fn installed(old: FirmwareVersion) -> SimOta {
        let signer = SigningKey::from_bytes(&[8; 32]);
        let image = [0x5a; 500];
        let m = Manifest {
            version: NEW,
            image_len: image.len() as u32,
            digest: Sha256::digest(image).into(),
        };
        let mut pkg = m.signed_bytes().to_vec();
        pkg.extend_from_slice(&signer.sign(&m.signed_bytes()).to_bytes());
        pkg.extend_from_slice(&image);
        let mut ota = SimOta::new(old);
        ota.set_key(Some(signer.verifying_key().to_bytes()));
        ota.on_request(UpdateRequest::Begin {
            transfer: 1,
            total_len: pkg.len() as u32,
        });
        for (i, c) in pkg.chunks(UPDATE_CHUNK).enumerate() {
            let mut data = [0; UPDATE_CHUNK];
            data[..c.len()].copy_from_slice(c);
            let offset = (i * UPDATE_CHUNK) as u32;
            ota.on_request(UpdateRequest::Chunk { offset, data });
        }
        ota
    }

    #[test]
    fn an_installed_image_boots_on_trial_and_rolls_back_without_the_host() {
        let old = crate::world::SIM_FIRMWARE_VERSION;
        let mut ota = installed(old);
        assert_eq!(ota.after_tick(1_000, true), Some(ResetReason::Software));
        assert_eq!(ota.version(), NEW);
        ota.on_boot(2_000);
        assert!(ota.on_trial());
        let timeout_us = u64::from(TRIAL_TIMEOUT_MS) * 1000;
        assert_eq!(
            ota.after_tick(1_000 + timeout_us, false),
            None,
            "still waiting"
        );
        assert_eq!(
            ota.after_tick(2_000 + timeout_us, false),
            Some(ResetReason::Software),
            "no host within the timeout: back to the old image"
        );
        assert_eq!(ota.version(), old);
        ota.on_boot(3_000 + timeout_us);
        assert!(!ota.on_trial(), "the old image is not on trial");
    }

    #[test]
    fn a_session_confirms_the_new_image_for_good() {
        let mut ota = installed(crate::world::SIM_FIRMWARE_VERSION);
        ota.after_tick(0, true);
        ota.on_boot(0);
        assert_eq!(ota.after_tick(20_000, true), None);
        assert!(!ota.on_trial());
        ota.on_boot(40_000);
        let later = 40_000 + 2 * u64::from(TRIAL_TIMEOUT_MS) * 1000;
        assert_eq!(ota.after_tick(later, false), None, "confirmed: no rollback");
        assert_eq!(ota.version(), NEW);
    }
}
