//! Battery voltage from ADC1 (curve-calibrated, 11 dB attenuation) behind the divider.

use esp_hal::analog::adc::{Adc, AdcCalCurve, AdcConfig, AdcPin, Attenuation};
use esp_hal::peripherals::{ADC1, GPIO2};
use esp_hal::Blocking;

use crate::pins::BATTERY_DIVIDER;

/// Longest wait for one conversion (µs); a conversion takes a few µs.
const MAX_WAIT_US: u64 = 200;

/// The battery sense input.
pub struct Battery {
    adc: Adc<'static, ADC1<'static>, Blocking>,
    pin: AdcPin<GPIO2<'static>, ADC1<'static>, AdcCalCurve<ADC1<'static>>>,
    last_mv: u16,
    timeouts: u32,
}

impl Battery {
    /// Configure ADC1 for the battery pin.
    pub fn new(adc: ADC1<'static>, pin: GPIO2<'static>) -> Self {
        let mut cfg = AdcConfig::new();
        let pin = cfg.enable_pin_with_cal::<_, AdcCalCurve<ADC1<'static>>>(pin, Attenuation::_11dB);
        Battery {
            adc: Adc::new(adc, cfg),
            pin,
            last_mv: 0,
            timeouts: 0,
        }
    }

    /// Battery voltage (mV) from one conversion (a few µs). A conversion that is not done
    /// within [`MAX_WAIT_US`] is abandoned and the previous reading returned, so the
    /// control tick never waits longer than that.
    pub fn read_mv(&mut self) -> u16 {
        let start = crate::encoders::now_us();
        let pin_mv = loop {
            match self.adc.read_oneshot(&mut self.pin) {
                Ok(v) => break u32::from(v),
                Err(nb::Error::WouldBlock) => {
                    if crate::encoders::now_us().saturating_sub(start) > MAX_WAIT_US {
                        self.timeouts = self.timeouts.wrapping_add(1);
                        if self.timeouts.is_power_of_two() {
                            log::warn!("battery ADC timed out {} times", self.timeouts);
                        }
                        return self.last_mv;
                    }
                }
                Err(nb::Error::Other(())) => break 0,
            }
        };
        self.last_mv = (pin_mv * BATTERY_DIVIDER).min(u32::from(u16::MAX)) as u16;
        self.last_mv
    }
}
