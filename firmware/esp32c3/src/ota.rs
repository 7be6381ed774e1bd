//! Over-the-air update glue: the core's [`Updater`] writes into the spare OTA app partition
//! (`ota_0` / `ota_1` of `partitions.csv`), an installed image is selected in `otadata`
//! and booted, and a new image runs on [`Trial`]: confirmed (`Valid`) at its first session,
//! else marked `Invalid` and the previous slot selected again.
//!
//! Thin and exercised only in simulation: the state machine it drives is tested in
//! `firmware/core` and in the simulator (`hil-sim/src/ota.rs`, `host/tests/ota.rs`); this
//! file compiles in CI but has not run on a board. Erasing a 4 KiB sector stalls the
//! control loop for tens of milliseconds while an update is received.

use esp_bootloader_esp_idf::ota::OtaImageState;
use esp_bootloader_esp_idf::ota_updater::OtaUpdater;
use esp_bootloader_esp_idf::partitions::{
    self, FlashStorage, PartitionType, PARTITION_TABLE_MAX_LEN,
};
use puzzlebot_firmware_core::update::{
    SlotError, Trial, TrialAction, UpdateRequest, UpdateSlot, Updater, TRIAL_TIMEOUT_MS,
};
use puzzlebot_protocol::{FirmwareVersion, UpdateStatus};

const SECTOR: u32 = FlashStorage::SECTOR_SIZE;
const WORD: usize = FlashStorage::WORD_SIZE as usize;

/// The spare OTA app partition as an [`UpdateSlot`] (absolute flash offsets).
struct FlashSlot {
    flash: FlashStorage<'static>,
    offset: u32,
    len: u32,
    /// Bytes from the slot start already erased.
    erased_to: u32,
}

impl UpdateSlot for FlashSlot {
    fn capacity(&self) -> u32 {
        self.len
    }

    /// Writes come in order at word-aligned offsets (the package header is 108 bytes and
    /// chunks 32); the last one is padded with 0xFF, which leaves erased flash as it is.
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError> {
        let end = offset + data.len() as u32;
        if !(offset as usize).is_multiple_of(WORD) || end > self.len {
            return Err(SlotError);
        }
        if offset == 0 {
            self.erased_to = 0;
        }
        while self.erased_to < end {
            let at = self.offset + self.erased_to;
            self.flash.erase(at, at + SECTOR).map_err(|_| SlotError)?;
            self.erased_to += SECTOR;
        }
        let mut buf = [0xffu8; 64];
        let padded = data.len().div_ceil(WORD) * WORD;
        let buf = buf.get_mut(..padded).ok_or(SlotError)?;
        buf[..data.len()].copy_from_slice(data);
        self.flash
            .write_nor(self.offset + offset, buf)
            .map_err(|_| SlotError)
    }

    fn read(&mut self, offset: u32, buf: &mut [u8]) -> Result<(), SlotError> {
        self.flash
            .read(self.offset + offset, buf)
            .map_err(|_| SlotError)
    }
}

/// Update and trial state of this robot.
pub struct EspOta {
    slot: FlashSlot,
    updater: Updater,
    trial: Trial,
    key: Option<[u8; 32]>,
    running: FirmwareVersion,
}

impl EspOta {
    /// Find the spare slot and whether this image is on trial; `None` (updates refused)
    /// when the partition table has no OTA slots.
    pub fn new(
        mut flash: FlashStorage<'static>,
        key: Option<[u8; 32]>,
        running: FirmwareVersion,
        now_us: u64,
    ) -> Option<EspOta> {
        let mut table = [0u8; PARTITION_TABLE_MAX_LEN];
        let (spare, on_trial) = {
            let mut ota = OtaUpdater::new(&mut flash, &mut table).ok()?;
            let on_trial = matches!(
                ota.current_ota_state(),
                Ok(OtaImageState::New | OtaImageState::PendingVerify)
            );
            let (_, spare) = ota.next_partition().ok()?;
            (spare, on_trial)
        };
        let pt = partitions::read_partition_table(&mut flash, &mut table).ok()?;
        let entry = pt.find_partition(PartitionType::App(spare)).ok()??;
        let (offset, len) = (entry.offset(), entry.len());
        Some(EspOta {
            slot: FlashSlot {
                flash,
                offset,
                len,
                erased_to: 0,
            },
            updater: Updater::new(key, running),
            trial: Trial::new(on_trial, now_us, TRIAL_TIMEOUT_MS),
            key,
            running,
        })
    }

    /// An update message from the link; the report to send, if one is due.
    pub fn handle(&mut self, req: UpdateRequest) -> Option<UpdateStatus> {
        self.updater.handle(req, &mut self.slot)
    }

    /// After a control tick: select an installed image, confirm or roll back a new one.
    /// True when the robot must restart now (into the installed image, or back).
    pub fn after_tick(&mut self, now_us: u64, established: bool) -> bool {
        if self.updater.installed().is_some() {
            return match self.select_next(OtaImageState::New) {
                Ok(()) => true,
                Err(e) => {
                    log::error!("update installed but not selected: {e:?}");
                    self.updater = Updater::new(self.key, self.running);
                    false
                }
            };
        }
        match self.trial.on_tick(now_us, established) {
            TrialAction::Wait => false,
            TrialAction::Confirm => {
                if let Err(e) = self.set_state(OtaImageState::Valid) {
                    log::warn!("could not confirm the new image: {e:?}");
                }
                false
            }
            TrialAction::RollBack => {
                log::warn!("new image never reached the host: rolling back");
                let _ = self.set_state(OtaImageState::Invalid);
                self.select_next(OtaImageState::Valid).is_ok()
            }
        }
    }

    /// Select the other slot for the next boot, with `state`.
    fn select_next(&mut self, state: OtaImageState) -> Result<(), partitions::Error> {
        let mut table = [0u8; PARTITION_TABLE_MAX_LEN];
        let mut ota = OtaUpdater::new(&mut self.slot.flash, &mut table)?;
        ota.activate_next_partition()?;
        ota.set_current_ota_state(state)
    }

    fn set_state(&mut self, state: OtaImageState) -> Result<(), partitions::Error> {
        let mut table = [0u8; PARTITION_TABLE_MAX_LEN];
        OtaUpdater::new(&mut self.slot.flash, &mut table)?.set_current_ota_state(state)
    }
}
