//! The status LED (D6): dark while all is well, a blink code when the robot cannot drive.
//!
//! A code is N short flashes (200 ms on, 200 ms off) then 1.5 s dark, repeated forever.

use embassy_time::{Duration, Timer};
use esp_hal::gpio::{AnyPin, Level, Output, OutputConfig};

/// Why the robot will not drive, as the number of flashes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlinkCode {
    /// 1: no provisioning record (erased `robot` partition, no build variables).
    Unprovisioned = 1,
    /// 2: a provisioning record or build variable is there but unusable (corrupted,
    /// truncated, unknown format, invalid field).
    BadProvisioning = 2,
    /// 3: SSID or password too long for the Wi-Fi driver.
    WifiCredentials = 3,
    /// 4: the Wi-Fi driver did not start.
    WifiStart = 4,
    /// 5: a network task could not be started.
    NetTask = 5,
    /// 6: the PWM did not start, or the firmware parameters are invalid (halted).
    Halted = 6,
}

/// The LED output, off.
pub fn new(pin: AnyPin<'static>) -> Output<'static> {
    Output::new(pin, Level::Low, OutputConfig::default())
}

/// Flash `code` forever.
pub async fn blink_forever(led: &mut Output<'static>, code: BlinkCode) -> ! {
    loop {
        for _ in 0..code as u8 {
            led.set_high();
            Timer::after(Duration::from_millis(200)).await;
            led.set_low();
            Timer::after(Duration::from_millis(200)).await;
        }
        Timer::after(Duration::from_millis(1500)).await;
    }
}

/// The LED task: flashes `code` forever (the control loop keeps running meanwhile).
#[embassy_executor::task]
pub async fn blink_task(mut led: Output<'static>, code: BlinkCode) {
    blink_forever(&mut led, code).await
}
