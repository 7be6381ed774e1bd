//! The update state machine: a signed package is received, verified and installed; a
//! corrupted, truncated, unsigned, replayed or oversized one is refused before anything is
//! activated; a lost chunk is resumed from the robot's report; a new image on trial rolls
//! back when it does not reach the host.

use ed25519_dalek::{Signer, SigningKey};
use puzzlebot_firmware_core::update::{
    Manifest, SlotError, Trial, TrialAction, UpdateRequest, UpdateSlot, Updater, HEADER_LEN,
};
use puzzlebot_protocol::{FirmwareVersion, UpdateRefusal, UpdateState, UPDATE_CHUNK};
use sha2::{Digest, Sha256};

struct MemSlot(Vec<u8>, u32);

impl UpdateSlot for MemSlot {
    fn capacity(&self) -> u32 {
        self.1
    }
    fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError> {
        let end = offset as usize + data.len();
        if end > self.1 as usize {
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

const RUNNING: FirmwareVersion = FirmwareVersion {
    major: 0,
    minor: 1,
    patch: 0,
};
const NEW: FirmwareVersion = FirmwareVersion {
    major: 0,
    minor: 2,
    patch: 0,
};

fn signer() -> SigningKey {
    SigningKey::from_bytes(&[3; 32])
}

fn package(image: &[u8], version: FirmwareVersion, key: &SigningKey) -> Vec<u8> {
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

fn image(n: usize) -> Vec<u8> {
    (0..n).map(|i| (i * 7 % 251) as u8).collect()
}

/// Stream `pkg` in order (declaring `total` bytes); the final state.
fn send(u: &mut Updater, slot: &mut MemSlot, pkg: &[u8], total: u32) -> UpdateState {
    u.handle(
        UpdateRequest::Begin {
            transfer: 1,
            total_len: total,
        },
        slot,
    );
    for (i, c) in pkg.chunks(UPDATE_CHUNK).enumerate() {
        let mut data = [0u8; UPDATE_CHUNK];
        data[..c.len()].copy_from_slice(c);
        let offset = (i * UPDATE_CHUNK) as u32;
        u.handle(UpdateRequest::Chunk { offset, data }, slot);
    }
    u.status().state
}

fn updater() -> Updater {
    Updater::new(Some(signer().verifying_key().to_bytes()), RUNNING)
}

#[test]
fn a_signed_newer_package_is_installed_and_the_slot_holds_the_image() {
    let img = image(5_000);
    let pkg = package(&img, NEW, &signer());
    let (mut u, mut slot) = (updater(), MemSlot(Vec::new(), 64 * 1024));
    assert_eq!(
        send(&mut u, &mut slot, &pkg, pkg.len() as u32),
        UpdateState::Installed
    );
    assert_eq!(u.installed().map(|m| m.version), Some(NEW));
    assert_eq!(&slot.0[..img.len()], &img[..]);
}

#[test]
fn bad_packages_are_refused_before_activation() {
    let img = image(3_000);
    let good = package(&img, NEW, &signer());
    let refused = |pkg: &[u8], total: u32| {
        let (mut u, mut slot) = (updater(), MemSlot(Vec::new(), 64 * 1024));
        let state = send(&mut u, &mut slot, pkg, total);
        assert!(u.installed().is_none());
        state
    };
    let mut corrupted = good.clone();
    corrupted[HEADER_LEN + 1234] ^= 0x10;
    assert_eq!(
        refused(&corrupted, good.len() as u32),
        UpdateState::Refused(UpdateRefusal::Corrupted)
    );
    let truncated = &good[..good.len() - 100];
    assert_eq!(
        refused(truncated, truncated.len() as u32),
        UpdateState::Refused(UpdateRefusal::BadPackage)
    );
    // Declared whole but cut short: it never completes, so it is never installed.
    assert_eq!(
        refused(truncated, good.len() as u32),
        UpdateState::Receiving
    );
    let mut unsigned = good.clone();
    unsigned[44..HEADER_LEN].fill(0);
    assert_eq!(
        refused(&unsigned, good.len() as u32),
        UpdateState::Refused(UpdateRefusal::BadSignature)
    );
    let foreign = package(&img, NEW, &SigningKey::from_bytes(&[4; 32]));
    assert_eq!(
        refused(&foreign, good.len() as u32),
        UpdateState::Refused(UpdateRefusal::BadSignature)
    );
    let replayed = package(&img, RUNNING, &signer());
    assert_eq!(
        refused(&replayed, replayed.len() as u32),
        UpdateState::Refused(UpdateRefusal::NotNewer)
    );
    let mut not_a_package = good.clone();
    not_a_package[0] = b'X';
    assert_eq!(
        refused(&not_a_package, good.len() as u32),
        UpdateState::Refused(UpdateRefusal::BadPackage)
    );
    let (mut u, mut slot) = (updater(), MemSlot(Vec::new(), 1_000));
    assert_eq!(
        send(&mut u, &mut slot, &good, good.len() as u32),
        UpdateState::Refused(UpdateRefusal::TooLarge)
    );
    let mut keyless = Updater::new(None, RUNNING);
    let mut slot = MemSlot(Vec::new(), 64 * 1024);
    assert_eq!(
        send(&mut keyless, &mut slot, &good, good.len() as u32),
        UpdateState::Refused(UpdateRefusal::NoUpdateKey)
    );
}

#[test]
fn a_lost_chunk_is_reported_and_the_transfer_resumes_after_a_new_begin() {
    let img = image(2_000);
    let pkg = package(&img, NEW, &signer());
    let total = pkg.len() as u32;
    let (mut u, mut slot) = (updater(), MemSlot(Vec::new(), 64 * 1024));
    let chunk = |i: usize| {
        let c = &pkg[i * UPDATE_CHUNK..((i + 1) * UPDATE_CHUNK).min(pkg.len())];
        let mut data = [0u8; UPDATE_CHUNK];
        data[..c.len()].copy_from_slice(c);
        UpdateRequest::Chunk {
            offset: (i * UPDATE_CHUNK) as u32,
            data,
        }
    };
    let begin = UpdateRequest::Begin {
        transfer: 9,
        total_len: total,
    };
    u.handle(begin, &mut slot);
    for i in 0..10 {
        u.handle(chunk(i), &mut slot);
    }
    // Chunk 10 is lost: chunk 11 is ignored and answered with where to resume.
    let report = u.handle(chunk(11), &mut slot).expect("a gap is reported");
    assert_eq!(report.received, 10 * UPDATE_CHUNK as u32);
    // The host restarts: the same begin resumes instead of starting over.
    assert_eq!(
        u.handle(begin, &mut slot).map(|s| s.received),
        Some(report.received)
    );
    let n = pkg.len().div_ceil(UPDATE_CHUNK);
    for i in 10..n {
        u.handle(chunk(i), &mut slot);
    }
    assert_eq!(u.status().state, UpdateState::Installed);
    // Replaying the whole transfer changes nothing: the decision is repeated.
    assert_eq!(
        u.handle(begin, &mut slot).map(|s| s.state),
        Some(UpdateState::Installed)
    );
}

#[test]
fn a_new_image_is_confirmed_by_a_session_or_rolled_back_after_the_timeout() {
    let mut t = Trial::new(true, 0, 30_000);
    assert_eq!(t.on_tick(1_000_000, false), TrialAction::Wait);
    assert_eq!(t.on_tick(2_000_000, true), TrialAction::Confirm);
    assert_eq!(
        t.on_tick(99_000_000, false),
        TrialAction::Wait,
        "confirmed once"
    );
    let mut t = Trial::new(true, 0, 30_000);
    assert_eq!(t.on_tick(29_999_999, false), TrialAction::Wait);
    assert_eq!(t.on_tick(30_000_000, false), TrialAction::RollBack);
    assert!(!t.pending());
    let mut t = Trial::new(false, 0, 30_000);
    assert_eq!(
        t.on_tick(99_000_000, false),
        TrialAction::Wait,
        "not on trial"
    );
}
