//! The four DRV8833 inputs on LEDC low-speed channels: 25 kHz (above hearing), 10-bit duty.

use esp_hal::gpio::{AnyPin, DriveMode};
use esp_hal::ledc::channel::{self, ChannelHW, ChannelIFace};
use esp_hal::ledc::timer::{self, TimerIFace};
use esp_hal::ledc::{Ledc, LowSpeed};
use esp_hal::time::Rate;
use puzzlebot_firmware_core::{HBridge, MotorOutputs, PWM_FULL_SCALE};
use static_cell::StaticCell;

use crate::pins::RIGHT_REVERSED;

/// PWM frequency (Hz): at least 20 kHz so the motors do not whine.
pub const PWM_HZ: u32 = 25_000;
const DUTY_BITS: u32 = 10;

static LEDC: StaticCell<Ledc<'static>> = StaticCell::new();
static TIMER: StaticCell<timer::Timer<'static, LowSpeed>> = StaticCell::new();

/// The four PWM channels: AIN1, AIN2, BIN1, BIN2.
pub struct Motors {
    ch: [channel::Channel<'static, LowSpeed>; 4],
}

/// Why the PWM could not start.
#[derive(Debug)]
pub enum MotorError {
    /// The LEDC timer rejected the frequency/resolution.
    Timer(timer::Error),
    /// A channel could not be configured.
    Channel(channel::Error),
}

impl core::fmt::Display for MotorError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            MotorError::Timer(e) => write!(f, "LEDC timer: {e:?}"),
            MotorError::Channel(e) => write!(f, "LEDC channel: {e:?}"),
        }
    }
}

impl Motors {
    /// Configure the LEDC timer and the four channels, all outputs low (coast).
    pub fn new(
        ledc: esp_hal::peripherals::LEDC<'static>,
        pins: [AnyPin<'static>; 4],
    ) -> Result<Self, MotorError> {
        let ledc = LEDC.init(Ledc::new(ledc));
        ledc.set_global_slow_clock(esp_hal::ledc::LSGlobalClkSource::APBClk);
        let t = TIMER.init(ledc.timer::<LowSpeed>(timer::Number::Timer0));
        t.configure(timer::config::Config {
            duty: timer::config::Duty::Duty10Bit,
            clock_source: timer::LSClockSource::APBClk,
            frequency: Rate::from_hz(PWM_HZ),
        })
        .map_err(MotorError::Timer)?;
        let t: &'static timer::Timer<'static, LowSpeed> = t;
        let mk = |n: channel::Number, pin: AnyPin<'static>| {
            let mut c = ledc.channel(n, pin);
            c.configure(channel::config::Config {
                timer: t,
                duty_pct: 0,
                drive_mode: DriveMode::PushPull,
            })
            .map(|()| c)
            .map_err(MotorError::Channel)
        };
        let [a1, a2, b1, b2] = pins;
        Ok(Motors {
            ch: [
                mk(channel::Number::Channel0, a1)?,
                mk(channel::Number::Channel1, a2)?,
                mk(channel::Number::Channel2, b1)?,
                mk(channel::Number::Channel3, b2)?,
            ],
        })
    }

    /// Apply the DRV8833 input duties from the control loop.
    pub fn apply(&self, out: &MotorOutputs) {
        let right = if RIGHT_REVERSED {
            HBridge {
                in1: out.right.in2,
                in2: out.right.in1,
            }
        } else {
            out.right
        };
        let duties = [out.left.in1, out.left.in2, right.in1, right.in2];
        for (c, d) in self.ch.iter().zip(duties) {
            c.set_duty_hw(to_hw(d));
        }
    }
}

/// Per-mille → LEDC duty counts (0…2^bits, full scale = always high).
fn to_hw(per_mille: u16) -> u32 {
    let d = u32::from(per_mille.min(PWM_FULL_SCALE));
    (d * (1 << DUTY_BITS) + u32::from(PWM_FULL_SCALE) / 2) / u32::from(PWM_FULL_SCALE)
}
