//! Outgoing datagrams: announces, queued replies and telemetry.

use puzzlebot_protocol::{EncodeError, RobotMsg, Telemetry, MAX_DATAGRAM};

use super::{NonceSource, Robot};

impl<N: NonceSource> Robot<N> {
    /// The next datagram to send at `now_us` (announce, reply or telemetry), written to
    /// `out` (at least [`MAX_DATAGRAM`] bytes); call until it returns `None`.
    pub fn poll_transmit(&mut self, now_us: u64, out: &mut [u8]) -> Option<usize> {
        let link = self.link.as_mut()?;
        if out.len() < MAX_DATAGRAM {
            self.stats.tx_errors += 1;
            return None;
        }
        if !link.is_established() {
            if now_us < self.next_announce_us {
                return None;
            }
            self.next_announce_us =
                now_us + u64::from(self.params.announce_interval_ms).max(1) * 1000;
            return match link.announce(self.kind, self.version, out) {
                Ok(n) => Some(n),
                Err(e) => self.tx_failed(e),
            };
        }
        if let Some(slot) = self.replies.iter_mut().find(|r| r.is_some()) {
            let msg = slot.take()?;
            return match link.send(&msg, out) {
                Ok(n) => Some(n),
                Err(e) => self.tx_failed(e),
            };
        }
        if self.params.telemetry_hz == 0 || now_us < self.next_telemetry_us {
            return None;
        }
        let period = 1_000_000 / u64::from(self.params.telemetry_hz);
        self.next_telemetry_us = if now_us >= self.next_telemetry_us + period {
            now_us + period
        } else {
            self.next_telemetry_us + period
        };
        let t = self.telemetry(now_us);
        self.reported_errors = self.encoder_errors;
        match self
            .link
            .as_mut()
            .map(|l| l.send(&RobotMsg::Telemetry(t), out))
        {
            Some(Ok(n)) => Some(n),
            Some(Err(e)) => self.tx_failed(e),
            None => None,
        }
    }

    fn tx_failed(&mut self, e: EncodeError) -> Option<usize> {
        self.stats.tx_errors += 1;
        if e == EncodeError::CounterExhausted {
            let n = self.nonces.fresh_nonce();
            if let Some(l) = self.link.as_mut() {
                l.restart(n);
            }
        }
        None
    }

    /// The telemetry record as it would be sent at `now_us`.
    pub fn telemetry(&self, now_us: u64) -> Telemetry {
        Telemetry {
            uptime_ms: (now_us / 1000) as u32,
            measured_rpm: self.measured,
            target_rpm: [self.wheels[0].target(), self.wheels[1].target()],
            duty: self.duty,
            encoder_counts: self.positions,
            battery_mv: self.battery_mv,
            rssi_dbm: self.rssi_dbm,
            flags: self.flags(),
            last_command_counter: self.last_command_counter,
        }
    }
}
