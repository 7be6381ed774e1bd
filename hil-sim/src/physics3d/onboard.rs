//! What runs on a robot of the 3-D world: the unchanged `firmware/core` [`Robot`] (session,
//! failsafe, speed estimation from encoder edges, gain-scheduled PI, DRV8833 mapping), fed by
//! simulated quadrature encoders on the wheel joints, and an in-process host session that
//! streams wheel-speed commands to it over the real authenticated protocol (no radio
//! impairments: the crossing is about mechanics).

use crate::encoder::QuadEncoder;
use crate::rng::Rng;
use crate::world::{SimNonces, SIM_FIRMWARE_VERSION};
use puzzlebot_firmware_core::{Encoder, MotorOutputs, Robot, Sensors};
use puzzlebot_params::RobotParams;
use puzzlebot_protocol::session::HostReceived;
use puzzlebot_protocol::{FleetKey, HostMsg, HostSession, RobotId, RobotKind, MAX_DATAGRAM};

/// Host command period (µs): 30 Hz (THESIS 4.4.3).
pub const COMMAND_PERIOD_US: u64 = 33_333;

/// Firmware, encoders and the host's end of the link of one robot.
#[derive(Debug)]
pub struct Onboard {
    fw: Box<Robot<SimNonces>>,
    host: HostSession,
    quad: [QuadEncoder; 2],
    enc: [Encoder; 2],
    host_nonce: u64,
    next_tick_us: u64,
    next_cmd_us: u64,
    /// Wheel-speed command streamed to the robot (RPM, left and right); `None`: nothing
    /// reaches it (the firmware's failsafe stops it).
    pub command: Option<[f32; 2]>,
    /// How long the robot is to keep the command through link silence (ms; 0: the plain
    /// failsafe), sent as [`HostMsg::WheelSpeedHold`].
    pub hold_ms: u16,
    /// Bridge outputs of the last tick.
    pub outputs: MotorOutputs,
}

impl Onboard {
    /// Boot robot `id` of `kind` with fleet key `key`; nonces from `seed`.
    pub fn boot(
        id: RobotId,
        kind: RobotKind,
        p: &RobotParams,
        key: &FleetKey,
        seed: u64,
    ) -> Result<Onboard, String> {
        let nonces = SimNonces(Rng::new(seed, u64::from(id) << 8 | 0x3D));
        let fw = Robot::new(
            id,
            kind,
            Some(key.robot_key(id)),
            p.firmware,
            SIM_FIRMWARE_VERSION,
            nonces,
        )
        .map_err(|e| format!("robot {id}: firmware parameters: {e}"))?;
        let edges = p.firmware.encoder_edges_per_rev;
        let quad = [QuadEncoder::new(edges, 0.0), QuadEncoder::new(edges, 0.0)];
        let mut enc = [Encoder::new(), Encoder::new()];
        for s in 0..2 {
            let (a, b) = quad[s].levels();
            enc[s].init_levels(a, b);
        }
        let period = fw.period_us();
        Ok(Onboard {
            fw: Box::new(fw),
            host: HostSession::new(id, key.robot_key(id)),
            quad,
            enc,
            host_nonce: seed ^ (u64::from(id) << 32),
            next_tick_us: period,
            next_cmd_us: 0,
            command: None,
            hold_ms: 0,
            outputs: MotorOutputs::COAST,
        })
    }

    /// True once the host's session with the robot is proven.
    pub fn linked(&self) -> bool {
        self.host.is_established()
    }

    /// The wheels turned from `a0` to `a1` (rad, left and right) between `t0` and `t1` (µs).
    pub fn encoders(&mut self, a0: [f64; 2], a1: [f64; 2], t0: u64, t1: u64) {
        for s in 0..2 {
            let enc = &mut self.enc[s];
            self.quad[s].advance(a0[s], a1[s], t0, t1, |e| {
                enc.on_edge(e.a, e.b, e.t_us);
            });
        }
    }

    /// Commands due at `now` (µs) into the firmware, its tick when due, its datagrams back to
    /// the host; returns the bridge outputs to apply.
    pub fn step(&mut self, now: u64, battery_v: f64) -> MotorOutputs {
        let mut buf = [0u8; MAX_DATAGRAM];
        if now >= self.next_cmd_us {
            self.next_cmd_us = now + COMMAND_PERIOD_US;
            if let (Some([l, r]), true) = (self.command, self.host.is_established()) {
                let msg = if self.hold_ms > 0 {
                    HostMsg::WheelSpeedHold {
                        left_rpm: l,
                        right_rpm: r,
                        hold_ms: self.hold_ms,
                    }
                } else {
                    HostMsg::WheelSpeed {
                        left_rpm: l,
                        right_rpm: r,
                    }
                };
                if let Ok(n) = self.host.send(&msg, &mut buf) {
                    // Rejections are counted by the firmware itself.
                    let _ = self.fw.on_datagram(&buf[..n], now);
                }
            }
        }
        if now >= self.next_tick_us {
            self.next_tick_us = now + self.fw.period_us();
            let sensors = Sensors {
                battery_mv: (battery_v * 1000.0).clamp(0.0, 65_535.0) as u16,
                rssi_dbm: -45,
                encoders: [self.enc[0].snapshot(), self.enc[1].snapshot()],
            };
            self.outputs = self.fw.tick(now, &sensors);
            let mut replies: Vec<Vec<u8>> = Vec::new();
            while let Some(n) = self.fw.poll_transmit(now, &mut buf) {
                self.host_nonce = self.host_nonce.wrapping_add(1);
                let hn = self.host_nonce;
                let mut out = [0u8; MAX_DATAGRAM];
                let fresh = || {
                    let mut b = [0u8; 16];
                    b[..8].copy_from_slice(&hn.to_le_bytes());
                    b
                };
                if let Ok(HostReceived::Announce { welcome_len, .. }) =
                    self.host.receive(&buf[..n], fresh, &mut out)
                {
                    replies.push(out[..welcome_len].to_vec());
                }
            }
            for r in replies {
                let _ = self.fw.on_datagram(&r, now);
            }
        }
        self.outputs
    }
}
