//! Reading fuzz input: the byte cursor, the edit program applied to genuine frames, and
//! re-tagging under the real key.

use puzzlebot_protocol::{Nonce, SessionKey, HEADER_LEN, TAG_LEN};

/// A cursor over fuzz input; every read returns `None` once the input is used up.
pub struct Input<'a> {
    data: &'a [u8],
}

impl<'a> Input<'a> {
    /// Wrap `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Input { data }
    }
    /// Next byte.
    pub fn byte(&mut self) -> Option<u8> {
        let (&b, rest) = self.data.split_first()?;
        self.data = rest;
        Some(b)
    }
    /// Up to `n` next bytes.
    pub fn take(&mut self, n: usize) -> &'a [u8] {
        let n = n.min(self.data.len());
        let (a, b) = self.data.split_at(n);
        self.data = b;
        a
    }
    /// A nonce (zero-padded when input runs out).
    pub fn nonce(&mut self) -> Nonce {
        let mut n = [0u8; 16];
        let t = self.take(16);
        n[..t.len()].copy_from_slice(t);
        n
    }
}

/// Apply a short edit program from `inp` to `frame`; returns true when the program asked
/// for the tag to be recomputed (then `retag` must be applied by the caller).
pub(super) fn mutate(inp: &mut Input<'_>, frame: &mut Vec<u8>) -> bool {
    let ops = inp.byte().unwrap_or(1) % 4 + 1;
    let mut retag = false;
    for _ in 0..ops {
        let Some(op) = inp.byte() else { break };
        let pos = inp.byte().unwrap_or(0) as usize;
        let val = inp.byte().unwrap_or(0);
        let len = frame.len();
        match op % 9 {
            0 if len > 0 => frame[pos % len] ^= 1 << (val % 8),
            1 if len > 0 => frame[pos % len] = val,
            2 => frame.insert(pos % (len + 1), val),
            3 if len > 0 => {
                frame.remove(pos % len);
            }
            4 => frame.truncate(pos % (len + 1)),
            5 => frame.extend(std::iter::repeat_n(val, pos % 8 + 1)),
            6 if len >= HEADER_LEN => {
                // Rewrite the 48-bit counter (little-endian) with a small or large value.
                let c: u64 = if val & 1 == 0 {
                    (pos as u64) >> 1
                } else {
                    (1u64 << 48) - 1 - pos as u64
                };
                frame[4..10].copy_from_slice(&c.to_le_bytes()[..6]);
            }
            7 => retag = true,
            // Swap the direction / stream flag bits.
            8 if len > 1 => frame[1] ^= val & 3,
            _ => {}
        }
    }
    retag
}

/// A fresh host nonce per call (unique within one execution).
pub(super) fn next_host_nonce(seq: &mut u32) -> Nonce {
    *seq += 1;
    let mut n = [0xC3; 16];
    n[..4].copy_from_slice(&seq.to_le_bytes());
    n
}

/// Replace the last `TAG_LEN` bytes of `frame` with a valid tag under `key`
/// (frames shorter than a header plus one payload byte are left alone).
pub(super) fn retag(key: &SessionKey, frame: &mut [u8]) {
    if frame.len() < HEADER_LEN + TAG_LEN + 1 {
        return;
    }
    let body = frame.len() - TAG_LEN;
    let t = key.tag(&frame[..body]);
    frame[body..].copy_from_slice(&t);
}
