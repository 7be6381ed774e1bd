//! Received datagrams: the session handshake and the host's commands (drive, stop,
//! emergency stop, parameters, ping, firmware update).

use puzzlebot_protocol::{HostMsg, Rejection, RobotMsg, UpdateStatus};

use super::{DriveMode, NonceSource, Robot};
use crate::update::UpdateRequest;

impl<N: NonceSource> Robot<N> {
    /// Handle one received datagram at `now_us`. Returns why it was refused, if it was;
    /// a refused datagram never changes what the motors do.
    pub fn on_datagram(&mut self, frame: &[u8], now_us: u64) -> Result<(), Rejection> {
        let Some(link) = self.link.as_mut() else {
            self.stats.rejected[Rejection::NoSession as usize] += 1;
            return Err(Rejection::NoSession);
        };
        let (header, msg) = match link.receive(frame) {
            Ok(x) => x,
            Err(r) => {
                self.stats.rejected[r as usize] += 1;
                return Err(r);
            }
        };
        self.stats.accepted += 1;
        self.last_rx_us = now_us;
        if let HostMsg::Welcome { .. } = msg {
            self.on_welcome(now_us);
        } else {
            self.last_command_counter = header.counter;
            self.apply(header.counter, msg, now_us);
        }
        Ok(())
    }

    fn on_welcome(&mut self, now_us: u64) {
        self.stats.sessions += 1;
        // Counters restart with the session; commands of the old session are void.
        self.last_drive_counter = None;
        self.last_estop_counter = None;
        self.last_command_counter = 0;
        self.reported_errors = self.encoder_errors;
        if self.driving(now_us) {
            self.stop();
        }
        // Telemetry right away: the first session frame proves the session to the host.
        self.next_telemetry_us = now_us;
    }

    /// True if a drive command with `counter` is the newest seen (and records it).
    fn fresh_drive(&mut self, counter: u64) -> bool {
        if self.last_drive_counter.is_some_and(|c| counter <= c) {
            self.stats.stale_commands += 1;
            return false;
        }
        self.last_drive_counter = Some(counter);
        true
    }

    /// Drive the wheels at `rpm` (left, right), kept `hold_ms` without a further command.
    fn drive_speed(&mut self, counter: u64, rpm: [f32; 2], hold_ms: u16, now_us: u64) {
        if self.estop {
            self.stats.blocked_by_estop += 1;
        } else if self.fresh_drive(counter) {
            if self.mode != DriveMode::Speed {
                for w in &mut self.wheels {
                    w.reset();
                }
            }
            self.wheels[0].set_target(rpm[0]);
            self.wheels[1].set_target(rpm[1]);
            self.mode = DriveMode::Speed;
            self.failsafe = false;
            self.last_drive_us = now_us;
            self.hold_until_us = if hold_ms > 0 {
                now_us + u64::from(hold_ms) * 1000
            } else {
                0
            };
        }
    }

    fn apply(&mut self, counter: u64, msg: HostMsg, now_us: u64) {
        match msg {
            HostMsg::WheelSpeed {
                left_rpm,
                right_rpm,
            } => self.drive_speed(counter, [left_rpm, right_rpm], 0, now_us),
            HostMsg::WheelSpeedHold {
                left_rpm,
                right_rpm,
                hold_ms,
            } => {
                let ms = hold_ms.min(self.params.max_hold_ms);
                self.drive_speed(counter, [left_rpm, right_rpm], ms, now_us);
            }
            HostMsg::RawDuty { left, right } => {
                if self.estop {
                    self.stats.blocked_by_estop += 1;
                } else if self.fresh_drive(counter) {
                    for w in &mut self.wheels {
                        w.reset();
                    }
                    self.hold_until_us = 0;
                    self.mode = DriveMode::RawDuty([left, right]);
                    self.failsafe = false;
                    self.last_drive_us = now_us;
                }
            }
            HostMsg::Stop => {
                // Stopping is always safe, even when reordered; it still orders later commands.
                self.last_drive_counter =
                    Some(self.last_drive_counter.map_or(counter, |c| c.max(counter)));
                self.stop();
            }
            HostMsg::EmergencyStop => {
                self.estop = true;
                self.last_estop_counter =
                    Some(self.last_estop_counter.map_or(counter, |c| c.max(counter)));
                self.last_drive_counter =
                    Some(self.last_drive_counter.map_or(counter, |c| c.max(counter)));
                self.stop();
            }
            HostMsg::ClearEmergencyStop => {
                // A clear older than the newest e-stop does not release it.
                if self.last_estop_counter.is_none_or(|c| counter > c) {
                    self.estop = false;
                    self.last_drive_counter =
                        Some(self.last_drive_counter.map_or(counter, |c| c.max(counter)));
                    if self.mode != DriveMode::Idle {
                        self.stop();
                    }
                }
            }
            HostMsg::SetParams(set) => {
                let rejected = set.check().err();
                if rejected.is_none() {
                    self.params.pi = set.pi;
                    self.params.failsafe_timeout_ms = set.failsafe_timeout_ms;
                    self.params.telemetry_hz = set.telemetry_hz;
                    for w in &mut self.wheels {
                        w.set_gains(set.pi);
                    }
                    self.next_telemetry_us = now_us;
                }
                self.queue_reply(RobotMsg::ParamsReply { rejected });
            }
            HostMsg::Ping { seq, host_time_us } => {
                self.queue_reply(RobotMsg::Pong { seq, host_time_us });
            }
            HostMsg::UpdateBegin {
                transfer,
                total_len,
            } => {
                self.update_rx = Some(UpdateRequest::Begin {
                    transfer,
                    total_len,
                })
            }
            HostMsg::UpdateChunk { offset, data } => {
                self.update_rx = Some(UpdateRequest::Chunk { offset, data })
            }
            // Welcomes arrive on the hello stream and are handled in `on_datagram`.
            HostMsg::Welcome { .. } => {}
        }
    }

    /// The update message of the last datagram, if it carried one: hand it to the
    /// [`crate::update::Updater`] (which owns the flash slot) right after
    /// [`Robot::on_datagram`], and its report to [`Robot::report_update`].
    pub fn take_update_request(&mut self) -> Option<UpdateRequest> {
        self.update_rx.take()
    }

    /// Send an update report to the host (with the next transmission).
    pub fn report_update(&mut self, status: UpdateStatus) {
        self.queue_reply(RobotMsg::UpdateStatus(status));
    }

    fn queue_reply(&mut self, msg: RobotMsg) {
        match self.replies.iter_mut().find(|r| r.is_none()) {
            Some(slot) => *slot = Some(msg),
            None => self.stats.replies_dropped += 1,
        }
    }
}
