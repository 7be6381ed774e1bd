//! The robot: command session, failsafe, speed loops, motor outputs and telemetry.
//!
//! One [`Robot`] is the whole firmware behaviour of a PuzzleBot; the ESP32-C3 image and
//! every simulated robot drive it the same way:
//! [`Robot::on_datagram`] for each received UDP payload, [`Robot::tick`] at the loop rate
//! (50 Hz) with the sensor readings, and [`Robot::poll_transmit`] until it returns `None`
//! to collect datagrams to send. Time is always passed in (µs since boot); nothing here
//! reads a clock.
//!
//! Safety rules implemented here:
//! - an unprovisioned robot (no key) never drives: its outputs are always coast;
//! - only authenticated, fresh frames of the current session are acted on
//!   ([`puzzlebot_protocol::RobotSession`]); drive commands older than the newest applied
//!   one are ignored (latest wins; a late command is worse than a lost one);
//! - no wheel-speed or raw-duty command for `failsafe_timeout_ms` → brake (failsafe), except
//!   while a `WheelSpeedHold` runs (at most `max_hold_ms`: a stretch of a crossing where
//!   stopping would tip the assembly); stop and emergency stop end a hold at once;
//! - an emergency stop latches until `ClearEmergencyStop`; after the clear the robot
//!   stays stopped until the next drive command; the latch survives session restarts;
//! - no valid frame for `relink_after_ms` → drop the session and announce again with a
//!   fresh nonce, so a restarted host can take over.

mod config;
mod receive;
mod transmit;

pub use config::{check_config, ConfigError};

use puzzlebot_params::firmware::Firmware;
use puzzlebot_protocol::{
    flags, FirmwareVersion, Nonce, Rejection, ResetReason, RobotId, RobotKey, RobotKind, RobotMsg,
    RobotSession,
};

use crate::drv8833::{Decay, HBridge, MotorCommand, MotorOutputs};
use crate::encoder::EncoderSnapshot;
use crate::estimator::SpeedEstimator;
use crate::pi::WheelController;
use crate::update::UpdateRequest;

/// Source of fresh, unpredictable handshake nonces (the ESP32-C3 uses its hardware RNG;
/// the simulator a seeded generator).
pub trait NonceSource {
    /// A fresh nonce, never repeated.
    fn fresh_nonce(&mut self) -> Nonce;
}

impl<F: FnMut() -> Nonce> NonceSource for F {
    fn fresh_nonce(&mut self) -> Nonce {
        self()
    }
}

/// Readings handed to [`Robot::tick`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sensors {
    /// Battery voltage (mV).
    pub battery_mv: u16,
    /// Wi-Fi RSSI (dBm); 0 when unknown.
    pub rssi_dbm: i8,
    /// Encoder snapshots, left and right, taken at the tick time.
    pub encoders: [EncoderSnapshot; 2],
}

/// What the motors are doing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DriveMode {
    /// Not yet commanded (boot) or unprovisioned: both motors coast.
    Idle,
    /// Stopped by command, failsafe, e-stop or session change: both motors brake.
    Stopped,
    /// Closed-loop wheel speeds (targets in the controllers).
    Speed,
    /// Open-loop duties (per-mille), for calibration.
    RawDuty([i16; 2]),
}

/// Counters of the link, for telemetry-side diagnostics and tests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinkStats {
    /// Rejected datagrams per [`Rejection`] reason (indexed by `reason as usize`).
    pub rejected: [u32; Rejection::ALL.len()],
    /// Authenticated frames accepted.
    pub accepted: u32,
    /// Drive commands ignored because a newer one was already applied.
    pub stale_commands: u32,
    /// Drive commands ignored because the emergency stop is latched.
    pub blocked_by_estop: u32,
    /// Sessions opened (welcomes accepted).
    pub sessions: u32,
    /// Sessions dropped after link silence.
    pub relinks: u32,
    /// Datagrams that could not be sealed (buffer too small, counter exhausted).
    pub tx_errors: u32,
    /// Replies dropped because the reply queue was full.
    pub replies_dropped: u32,
}

impl LinkStats {
    /// Total rejected datagrams.
    pub fn rejected_total(&self) -> u32 {
        self.rejected.iter().sum()
    }
}

/// A snapshot of the robot's control state (for the simulator, tests and logging).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Status {
    /// The robot has a key.
    pub provisioned: bool,
    /// A session with the host is open.
    pub established: bool,
    /// Current drive mode.
    pub mode: DriveMode,
    /// Telemetry [`flags`] as they would be reported now.
    pub flags: u16,
    /// Wheel speed targets (RPM).
    pub target_rpm: [f32; 2],
    /// Estimated wheel speeds of the last tick (RPM).
    pub measured_rpm: [f32; 2],
    /// Signed duties applied at the last tick (per-mille).
    pub duty: [i16; 2],
}

const REPLY_QUEUE: usize = 4;

/// The PuzzleBot firmware behaviour (see the module documentation).
#[derive(Debug, Clone)]
pub struct Robot<N: NonceSource> {
    id: RobotId,
    kind: RobotKind,
    version: FirmwareVersion,
    params: Firmware,
    nonces: N,
    link: Option<RobotSession>,
    wheels: [WheelController; 2],
    estimators: [SpeedEstimator; 2],
    mode: DriveMode,
    estop: bool,
    failsafe: bool,
    last_rx_us: u64,
    last_drive_us: u64,
    /// Until when (µs) a [`HostMsg::WheelSpeedHold`] keeps the wheels driving without a
    /// further command; 0: no hold.
    hold_until_us: u64,
    last_drive_counter: Option<u64>,
    last_estop_counter: Option<u64>,
    last_command_counter: u64,
    last_tick_us: Option<u64>,
    next_announce_us: u64,
    next_telemetry_us: u64,
    replies: [Option<RobotMsg>; REPLY_QUEUE],
    measured: [f32; 2],
    duty: [i16; 2],
    positions: [i32; 2],
    encoder_errors: [u32; 2],
    reported_errors: [u32; 2],
    battery_mv: u16,
    rssi_dbm: i8,
    stats: LinkStats,
    update_rx: Option<UpdateRequest>,
}

impl<N: NonceSource> Robot<N> {
    /// A freshly booted robot. `key = None` makes an unprovisioned robot that never drives
    /// and never transmits. The parameter set is checked first.
    pub fn new(
        id: RobotId,
        kind: RobotKind,
        key: Option<RobotKey>,
        params: Firmware,
        version: FirmwareVersion,
        mut nonces: N,
    ) -> Result<Self, ConfigError> {
        check_config(&params)?;
        let link = key.map(|k| RobotSession::new(id, k, nonces.fresh_nonce()));
        let period_us = (1.0e6 / params.loop_hz) as u64;
        let standstill_us = u64::from(params.standstill_after_ms) * 1000;
        let est = SpeedEstimator::new(params.encoder_edges_per_rev, period_us, standstill_us);
        Ok(Robot {
            id,
            kind,
            version,
            params,
            nonces,
            link,
            wheels: [WheelController::new(&params), WheelController::new(&params)],
            estimators: [est.clone(), est],
            mode: DriveMode::Idle,
            estop: false,
            failsafe: false,
            last_rx_us: 0,
            last_drive_us: 0,
            hold_until_us: 0,
            last_drive_counter: None,
            last_estop_counter: None,
            last_command_counter: 0,
            last_tick_us: None,
            next_announce_us: 0,
            next_telemetry_us: 0,
            replies: [const { None }; REPLY_QUEUE],
            measured: [0.0; 2],
            duty: [0; 2],
            positions: [0; 2],
            encoder_errors: [0; 2],
            reported_errors: [0; 2],
            battery_mv: 0,
            rssi_dbm: 0,
            stats: LinkStats::default(),
            update_rx: None,
        })
    }

    /// Set why the processor last reset ([`crate::safety::reset_reason`]); every announce
    /// of this boot carries it. Call once, right after [`Robot::new`].
    pub fn set_reset_reason(&mut self, reason: ResetReason) {
        if let Some(l) = self.link.as_mut() {
            l.set_reset_reason(reason);
        }
    }

    /// This robot's id.
    pub fn id(&self) -> RobotId {
        self.id
    }

    /// Parameters in force (after any accepted `SetParams`).
    pub fn params(&self) -> &Firmware {
        &self.params
    }

    /// Link counters.
    pub fn stats(&self) -> &LinkStats {
        &self.stats
    }

    /// The loop period (µs) at which [`Robot::tick`] should be called.
    pub fn period_us(&self) -> u64 {
        (1.0e6 / self.params.loop_hz) as u64
    }

    /// Control state now.
    pub fn status(&self) -> Status {
        Status {
            provisioned: self.link.is_some(),
            established: self.is_established(),
            mode: self.mode,
            flags: self.flags(),
            target_rpm: [self.wheels[0].target(), self.wheels[1].target()],
            measured_rpm: self.measured,
            duty: self.duty,
        }
    }

    /// True when a session with the host is open.
    pub fn is_established(&self) -> bool {
        self.link.as_ref().is_some_and(RobotSession::is_established)
    }

    fn flags(&self) -> u16 {
        let mut f = 0;
        if self.failsafe {
            f |= flags::FAILSAFE;
        }
        if self.estop {
            f |= flags::ESTOP;
        }
        if self.link.is_none() {
            f |= flags::UNPROVISIONED;
        }
        if self.encoder_errors != self.reported_errors {
            f |= flags::ENCODER_ERROR;
        }
        if self.battery_mv != 0 && self.battery_mv < self.params.low_battery_mv {
            f |= flags::LOW_BATTERY;
        }
        if matches!(self.mode, DriveMode::RawDuty(_)) {
            f |= flags::RAW_DUTY;
        }
        if self.mode == DriveMode::Speed && self.wheels.iter().any(WheelController::saturated) {
            f |= flags::SATURATED;
        }
        f
    }

    /// Driving under a command that link silence may stop: any drive mode outside a hold.
    fn driving(&self, now_us: u64) -> bool {
        matches!(self.mode, DriveMode::Speed | DriveMode::RawDuty(_))
            && now_us >= self.hold_until_us
    }

    fn stop(&mut self) {
        self.mode = DriveMode::Stopped;
        self.hold_until_us = 0;
        for w in &mut self.wheels {
            w.reset();
        }
    }

    /// One control period at `now_us`: link supervision, failsafe, speed estimation, PI,
    /// and the DRV8833 input duties to apply now.
    pub fn tick(&mut self, now_us: u64, sensors: &Sensors) -> MotorOutputs {
        let period_s = 1.0 / self.params.loop_hz;
        let dt_s = match self.last_tick_us {
            Some(t) if now_us > t => ((now_us - t) as f32 * 1e-6).min(5.0 * period_s),
            _ => period_s,
        };
        self.last_tick_us = Some(now_us);
        for i in 0..2 {
            let snap = &sensors.encoders[i];
            self.measured[i] = self.estimators[i].update(now_us, snap);
            self.positions[i] = snap.position;
            self.encoder_errors[i] = snap.errors;
        }
        self.battery_mv = sensors.battery_mv;
        self.rssi_dbm = sensors.rssi_dbm;

        let Some(link) = self.link.as_mut() else {
            self.mode = DriveMode::Idle;
            self.duty = [0; 2];
            return MotorOutputs::COAST;
        };

        // Link silence: drop the session, announce again with a fresh nonce.
        let relink_us = u64::from(self.params.relink_after_ms) * 1000;
        if link.is_established() && now_us.saturating_sub(self.last_rx_us) >= relink_us {
            link.restart(self.nonces.fresh_nonce());
            self.stats.relinks += 1;
            self.next_announce_us = now_us;
            if self.driving(now_us) {
                self.failsafe = true;
                self.stop();
            }
        }

        // Failsafe: no drive command within the timeout (nor a hold still running).
        let timeout_us = u64::from(self.params.failsafe_timeout_ms) * 1000;
        if self.driving(now_us) && now_us.saturating_sub(self.last_drive_us) >= timeout_us {
            self.failsafe = true;
            self.stop();
        }
        if self.estop && self.mode != DriveMode::Stopped {
            self.stop();
        }

        let cmds = match self.mode {
            DriveMode::Idle => [MotorCommand::Coast; 2],
            DriveMode::Stopped => [MotorCommand::Brake; 2],
            DriveMode::Speed => {
                let mut c = [MotorCommand::Brake; 2];
                for (i, slot) in c.iter_mut().enumerate() {
                    let m = self.estimators[i].reliable().then_some(self.measured[i]);
                    let d = self.wheels[i].update(m, dt_s);
                    *slot = MotorCommand::Duty(round_duty(d));
                }
                c
            }
            DriveMode::RawDuty(d) => [MotorCommand::Duty(d[0]), MotorCommand::Duty(d[1])],
        };
        for (i, c) in cmds.iter().enumerate() {
            self.duty[i] = match c {
                MotorCommand::Duty(d) => *d,
                _ => 0,
            };
        }
        MotorOutputs {
            left: HBridge::drive(cmds[0], Decay::Slow),
            right: HBridge::drive(cmds[1], Decay::Slow),
        }
    }
}

fn round_duty(d: f32) -> i16 {
    let d = d.clamp(-1000.0, 1000.0);
    (if d >= 0.0 { d + 0.5 } else { d - 0.5 }) as i16
}
