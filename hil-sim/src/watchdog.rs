//! The robot's fault path in the simulator: the core's [`Watchdog`] and [`SafeOutputs`]
//! traits implemented on a simulated robot, so the firmware's fault policy
//! (`puzzlebot_firmware_core::safety`) runs here as it does on the ESP32-C3.
//!
//! A robot's control task can be made to stall ([`crate::World::stall_control`]): its
//! firmware stops ticking while the PWM keeps its last duties (as LEDC does on the chip).
//! The [`Supervision`] of every robot feeds its [`SimWatchdog`] only through the core's
//! [`TickSupervisor`]; when the watchdog expires the robot resets: its pins are released
//! (the board's pull-downs give [`FAULT_OUTPUTS`]) and it boots again, announcing
//! [`ResetReason::Hang`].

use puzzlebot_firmware_core::safety::HwReset;
use puzzlebot_firmware_core::{
    reset_reason, FaultMark, MotorOutputs, SafeOutputs, TickSupervisor, Watchdog, FAULT_OUTPUTS,
    WATCHDOG_TIMEOUT_MS,
};
use puzzlebot_protocol::ResetReason;

/// A hardware-like watchdog in simulated time: armed by the first feed, it expires
/// `timeout_us` after the last one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SimWatchdog {
    timeout_us: u64,
    deadline_us: Option<u64>,
}

impl SimWatchdog {
    /// A watchdog with the firmware's timeout ([`WATCHDOG_TIMEOUT_MS`]).
    pub fn new() -> SimWatchdog {
        SimWatchdog::with_timeout_us(u64::from(WATCHDOG_TIMEOUT_MS) * 1000)
    }

    /// A watchdog with another timeout (µs).
    pub fn with_timeout_us(timeout_us: u64) -> SimWatchdog {
        SimWatchdog {
            timeout_us,
            deadline_us: None,
        }
    }

    /// The timeout (µs).
    pub fn timeout_us(&self) -> u64 {
        self.timeout_us
    }

    /// True when armed and not fed for the timeout at `now_us`.
    pub fn expired(&self, now_us: u64) -> bool {
        self.deadline_us.is_some_and(|d| now_us >= d)
    }
}

impl Default for SimWatchdog {
    fn default() -> Self {
        SimWatchdog::new()
    }
}

impl Watchdog for SimWatchdog {
    fn feed(&mut self, now_us: u64) {
        self.deadline_us = Some(now_us + self.timeout_us);
    }
}

/// A simulated robot's four bridge inputs, as the plant reads them.
#[derive(Debug)]
pub struct SimPins<'a>(pub &'a mut MotorOutputs);

impl SafeOutputs for SimPins<'_> {
    fn force(&mut self, outputs: &MotorOutputs) {
        *self.0 = *outputs;
    }
}

/// One robot's control-task health: the stall switch, the tick supervisor and the
/// watchdog it feeds.
#[derive(Debug, Clone)]
pub struct Supervision {
    stalled: bool,
    ticks: TickSupervisor,
    watchdog: SimWatchdog,
    resets: u32,
}

impl Supervision {
    /// Supervision of a freshly booted robot with a loop of `period_us`.
    pub fn new(period_us: u64) -> Supervision {
        Supervision {
            stalled: false,
            ticks: TickSupervisor::new(period_us),
            watchdog: SimWatchdog::new(),
            resets: 0,
        }
    }

    /// Make the control task stall (true) until the next reset.
    pub fn set_stalled(&mut self, stalled: bool) {
        self.stalled = stalled;
    }

    /// True while the control task is stalled.
    pub fn is_stalled(&self) -> bool {
        self.stalled
    }

    /// Watchdog resets so far.
    pub fn resets(&self) -> u32 {
        self.resets
    }

    /// The watchdog.
    pub fn watchdog(&self) -> &SimWatchdog {
        &self.watchdog
    }

    /// After a control tick at `now_us`: feed the watchdog if the tick was healthy.
    pub fn after_tick(&mut self, now_us: u64) -> bool {
        self.ticks.on_tick(now_us, &mut self.watchdog)
    }

    /// At `now_us`: if the watchdog expired, the chip resets: the pins are released to
    /// [`FAULT_OUTPUTS`] and the reason the next boot announces is returned. The caller
    /// boots the firmware again and calls [`Supervision::rebooted`].
    pub fn check(&mut self, now_us: u64, pins: &mut MotorOutputs) -> Option<ResetReason> {
        if !self.watchdog.expired(now_us) {
            return None;
        }
        SimPins(pins).force(&FAULT_OUTPUTS);
        self.resets += 1;
        // What the next boot reads: the main watchdog's reset cause, no mark.
        Some(reset_reason(Some(HwReset::MainWatchdog), FaultMark::NONE))
    }

    /// The firmware booted again (loop period `period_us`): the stall is over, the
    /// watchdog waits for the new loop's first tick.
    pub fn rebooted(&mut self, period_us: u64) {
        let resets = self.resets;
        *self = Supervision::new(period_us);
        self.resets = resets;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_watchdog_expires_only_after_the_timeout_without_a_feed() {
        let mut w = SimWatchdog::with_timeout_us(100);
        assert!(!w.expired(1_000_000), "unarmed until the first feed");
        w.feed(1_000);
        assert!(!w.expired(1_099));
        assert!(w.expired(1_100));
        w.feed(1_050);
        assert!(!w.expired(1_100));
    }

    #[test]
    fn a_stalled_loop_resets_to_the_fault_outputs_and_reports_a_hang() {
        let mut s = Supervision::new(20_000);
        let mut pins = MotorOutputs::BRAKE;
        for k in 0..5 {
            assert!(s.after_tick(k * 20_000));
            assert_eq!(s.check(k * 20_000, &mut pins), None);
        }
        s.set_stalled(true);
        let last = 4 * 20_000;
        let timeout = s.watchdog().timeout_us();
        assert_eq!(s.check(last + timeout - 1, &mut pins), None);
        assert_eq!(pins, MotorOutputs::BRAKE, "the pins hold until the reset");
        assert_eq!(s.check(last + timeout, &mut pins), Some(ResetReason::Hang));
        assert_eq!(pins, FAULT_OUTPUTS);
        s.rebooted(20_000);
        assert!(!s.is_stalled());
        assert_eq!(s.resets(), 1);
        assert_eq!(
            s.check(10 * last, &mut pins),
            None,
            "unarmed after a reboot"
        );
    }
}
