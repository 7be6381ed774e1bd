//! Battery voltage from ADC1 (curve-calibrated, 11 dB attenuation) behind the divider.

use esp_hal::analog::adc::{Adc, AdcCalCurve, AdcConfig, AdcPin, Attenuation};
use esp_hal::peripherals::{ADC1, GPIO2};
use esp_hal::Blocking;

use crate::pins::BATTERY_DIVIDER;

/// The battery sense input.
pub struct Battery {
    adc: Adc<'static, ADC1<'static>, Blocking>,
    pin: AdcPin<GPIO2<'static>, ADC1<'static>, AdcCalCurve<ADC1<'static>>>,
}

impl Battery {
    /// Configure ADC1 for the battery pin.
    pub fn new(adc: ADC1<'static>, pin: GPIO2<'static>) -> Self {
        let mut cfg = AdcConfig::new();
        let pin = cfg.enable_pin_with_cal::<_, AdcCalCurve<ADC1<'static>>>(pin, Attenuation::_11dB);
        Battery {
            adc: Adc::new(adc, cfg),
            pin,
        }
    }

    /// Battery voltage (mV); one conversion (a few µs).
    pub fn read_mv(&mut self) -> u16 {
        let pin_mv = loop {
            match self.adc.read_oneshot(&mut self.pin) {
                Ok(v) => break u32::from(v),
                Err(nb::Error::WouldBlock) => continue,
                Err(nb::Error::Other(())) => break 0,
            }
        };
        (pin_mv * BATTERY_DIVIDER).min(u32::from(u16::MAX)) as u16
    }
}
