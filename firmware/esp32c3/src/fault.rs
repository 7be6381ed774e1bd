//! The fault path on the chip (policy in `puzzlebot_firmware_core::safety`): the motor
//! pins driven without the PWM driver, esp-backtrace's panic hooks, the two watchdogs and
//! the reset reason read at boot.
//!
//! - Panic, CPU exception, stack overflow, out-of-memory: esp-hal turns each into a panic;
//!   `custom_pre_backtrace` drives the motor pins to `FAULT_OUTPUTS` and keeps a mark in
//!   RTC memory before anything is printed, `custom_halt` resets after the report.
//! - Hang: only a healthy control tick feeds the timer-group watchdog (100 ms) and the RTC
//!   watchdog; either resets the chip, which releases the pins to the board's pull-downs.
//! - Stuck boot: the RTC watchdog (4 s) runs from right after `esp_hal::init` until the
//!   control loop feeds it.

use core::sync::atomic::Ordering;

use portable_atomic::AtomicU32;

use esp_hal::gpio::{AnyPin, Level, Output, OutputConfig};
use esp_hal::peripherals::TIMG1;
use esp_hal::rtc_cntl::{Rtc, RwdtStage, SocResetReason};
use esp_hal::time::Duration;
use esp_hal::timer::timg::{MwdtStage, Wdt};
use puzzlebot_firmware_core::safety::{static_levels, BOOT_WATCHDOG_TIMEOUT_MS};
use puzzlebot_firmware_core::{
    on_fault, reset_reason, Fault, FaultMark, HwReset, MotorOutputs, SafeOutputs, Watchdog,
    WATCHDOG_TIMEOUT_MS,
};
use puzzlebot_protocol::ResetReason;

use crate::pins::{MOTOR_GPIOS, RIGHT_REVERSED};

/// The fault mark, in RTC fast memory that keeps its contents across every reset but
/// power-on (where [`FaultMark`] rejects the garbage).
#[esp_hal::ram(unstable(rtc_fast, persistent))]
static FAULT_MARK: AtomicU32 = AtomicU32::new(0);

/// The DRV8833 inputs as plain GPIO outputs: no PWM driver, no allocation, no lock, so it
/// works at reset, in the panic handler and with interrupts off.
pub struct FaultPins;

impl SafeOutputs for FaultPins {
    fn force(&mut self, outputs: &MotorOutputs) {
        // Anything but static levels (it cannot happen for FAULT_OUTPUTS) means all low.
        let [l, r] = static_levels(outputs).unwrap_or([[false; 2]; 2]);
        let r = if RIGHT_REVERSED { [r[1], r[0]] } else { r };
        let levels = [l[0], l[1], r[0], r[1]];
        for (gpio, high) in MOTOR_GPIOS.into_iter().zip(levels) {
            // SAFETY: the fault path takes the pins away from whatever drives them (the
            // PWM, or nothing yet at reset); nothing else runs concurrently on this
            // single core when it is called (boot, panic with interrupts off).
            let pin = unsafe { AnyPin::steal(gpio) };
            // `Output` has no `Drop`: the pin keeps driving after the driver object is gone.
            let _ = Output::new(pin, Level::from(high), OutputConfig::default());
        }
    }
}

/// esp-backtrace's hook before it prints a panic: motor pins safe first, then the mark.
#[unsafe(no_mangle)]
pub extern "Rust" fn custom_pre_backtrace() {
    let mark = on_fault(Fault::Panic, &mut FaultPins);
    FAULT_MARK.store(mark.0, Ordering::SeqCst);
}

/// esp-backtrace's end of a panic: reset (the next boot announces `Panic`).
#[unsafe(no_mangle)]
pub extern "Rust" fn custom_halt() -> ! {
    esp_hal::system::software_reset()
}

/// Why this boot happened; clears the mark so the next reset is judged on its own.
pub fn boot_reset_reason() -> ResetReason {
    let hw = esp_hal::system::reset_reason().map(|r| match r {
        SocResetReason::ChipPowerOn => HwReset::PowerOn,
        SocResetReason::CoreSw | SocResetReason::Cpu0Sw => HwReset::Software,
        SocResetReason::CoreMwdt0
        | SocResetReason::CoreMwdt1
        | SocResetReason::Cpu0Mwdt0
        | SocResetReason::Cpu0Mwdt1 => HwReset::MainWatchdog,
        SocResetReason::CoreRtcWdt
        | SocResetReason::Cpu0RtcWdt
        | SocResetReason::SysRtcWdt
        | SocResetReason::SysSuperWdt => HwReset::RtcWatchdog,
        SocResetReason::SysBrownOut => HwReset::BrownOut,
        _ => HwReset::Other,
    });
    let mark = FaultMark(FAULT_MARK.load(Ordering::SeqCst));
    FAULT_MARK.store(0, Ordering::SeqCst);
    reset_reason(hw, mark)
}

/// The timer-group watchdog (control tick) and the RTC watchdog (boot, and backstop).
pub struct Watchdogs {
    rtc: Rtc<'static>,
    main: Option<Wdt<TIMG1<'static>>>,
}

impl Watchdogs {
    /// Start the RTC watchdog for the boot ([`BOOT_WATCHDOG_TIMEOUT_MS`]); call right
    /// after `esp_hal::init`, which disables every watchdog.
    pub fn start_boot(rtc: esp_hal::peripherals::RTC_TIMER<'static>) -> Self {
        let mut rtc = Rtc::new(rtc);
        let boot = Duration::from_millis(u64::from(BOOT_WATCHDOG_TIMEOUT_MS));
        rtc.rwdt.set_timeout(RwdtStage::Stage0, boot);
        rtc.rwdt.enable();
        Watchdogs { rtc, main: None }
    }

    /// The control loop is about to run: start the main watchdog ([`WATCHDOG_TIMEOUT_MS`],
    /// reset on expiry) on timer group 1 (group 0's timer runs the scheduler).
    pub fn start_main(&mut self, timg1: TIMG1<'static>) {
        let tg = esp_hal::timer::timg::TimerGroup::new(timg1);
        let mut wdt = tg.wdt;
        let t = Duration::from_millis(u64::from(WATCHDOG_TIMEOUT_MS));
        wdt.set_timeout(MwdtStage::Stage0, t);
        wdt.enable();
        wdt.feed();
        self.main = Some(wdt);
    }

    /// A permanent halt on purpose (bad parameters, no PWM): no more resets.
    pub fn stop(&mut self) {
        self.rtc.rwdt.disable();
        if let Some(w) = self.main.as_mut() {
            w.disable();
        }
    }
}

impl Watchdog for Watchdogs {
    fn feed(&mut self, _now_us: u64) {
        self.rtc.rwdt.feed();
        if let Some(w) = self.main.as_mut() {
            w.feed();
        }
    }
}
