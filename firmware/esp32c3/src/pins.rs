//! The one pin map of the PuzzleBot board on a Seeed XIAO ESP32-C3 (THESIS 5.5.1).
//!
//! | XIAO pad | GPIO | function |
//! |---|---|---|
//! | D0 | GPIO2 | battery voltage through a 1:2 divider (ADC1 channel 2) |
//! | D1 | GPIO3 | DRV8833 AIN1 (left motor) |
//! | D2 | GPIO4 | DRV8833 AIN2 (left motor) |
//! | D3 | GPIO5 | DRV8833 BIN1 (right motor) |
//! | D4 | GPIO6 | DRV8833 BIN2 (right motor) |
//! | D5 | GPIO7 | left encoder A |
//! | D6 | GPIO21 | status LED (output; UART0 TX of the ROM, never an input) |
//! | D7 | GPIO20 | right encoder A |
//! | D8 | GPIO8 | left encoder B |
//! | D10 | GPIO10 | right encoder B |
//!
//! D6 (GPIO21) is UART0 TX, which the ROM and the bootloader drive at every boot, so it
//! only carries the LED. D8 (GPIO8) is a strapping pin read at reset only when GPIO9
//! selects download mode; D9 (GPIO9, BOOT button) stays free. The battery must be on ADC1
//! (GPIO0–4): ADC2 cannot be read while Wi-Fi is on. The right motor and encoder face the
//! other way; [`RIGHT_REVERSED`] makes "forward" mean the same for both wheels. Change
//! this file (only) to match another PCB.

/// The right motor and encoder are mounted mirrored: swap its bridge inputs and its
/// encoder channels so that positive speeds drive both wheels forward.
pub const RIGHT_REVERSED: bool = true;

/// Battery divider: battery voltage = ADC pin voltage × this ratio.
pub const BATTERY_DIVIDER: u32 = 2;

/// GPIO numbers of the DRV8833 inputs AIN1, AIN2, BIN1, BIN2 (for the fault path, which
/// drives them without the PWM driver).
pub const MOTOR_GPIOS: [u8; 4] = [3, 4, 5, 6];

/// The board's pins, taken out of the peripherals once at start-up.
pub struct Board {
    /// Battery sense (ADC1).
    pub battery: esp_hal::peripherals::GPIO2<'static>,
    /// DRV8833 AIN1, AIN2 (left), BIN1, BIN2 (right): the GPIOs of [`MOTOR_GPIOS`].
    pub motor: [esp_hal::gpio::AnyPin<'static>; 4],
    /// Encoder inputs: left A, left B, right A, right B.
    pub encoder: [esp_hal::gpio::AnyPin<'static>; 4],
    /// Status LED (active high).
    pub led: esp_hal::gpio::AnyPin<'static>,
}

/// Take the board pins out of `esp_hal::init`'s peripherals (by field, so the remaining
/// peripherals stay usable).
#[macro_export]
macro_rules! take_board {
    ($p:ident) => {
        $crate::pins::Board {
            battery: $p.GPIO2,
            motor: [
                $p.GPIO3.into(),
                $p.GPIO4.into(),
                $p.GPIO5.into(),
                $p.GPIO6.into(),
            ],
            encoder: [
                $p.GPIO7.into(),
                $p.GPIO8.into(),
                $p.GPIO20.into(),
                $p.GPIO10.into(),
            ],
            led: $p.GPIO21.into(),
        }
    };
}
