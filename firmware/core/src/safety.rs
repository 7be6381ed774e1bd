//! What the robot does when its own software fails: the fault → safe-output policy, the
//! watchdog feeding rule and the reset-reason flow. The ESP32-C3 image implements the two
//! traits on its hardware (GPIO, timer-group and RTC watchdogs, RTC memory); the simulator
//! implements them on its plant, so the same policy is tested on the PC.
//!
//! The flow:
//! 1. every control tick asks a [`TickSupervisor`] whether it is healthy (on time); only
//!    then is the [`Watchdog`] fed;
//! 2. a panic (also a CPU exception, a stack overflow or an out-of-memory, which all end in
//!    the panic handler) calls [`on_fault`]: the motor pins go to [`FAULT_OUTPUTS`] first,
//!    then a [`FaultMark`] for the reset is returned to be kept in memory that survives
//!    the reset, then the caller resets;
//! 3. a hang stops the feeding: the watchdog resets the chip after
//!    [`WATCHDOG_TIMEOUT_MS`]; a reset releases the pins, which the board's pull-downs hold
//!    at [`FAULT_OUTPUTS`] (coast) until the firmware drives them there itself;
//! 4. at boot [`reset_reason`] combines what the hardware says ([`HwReset`]) with the mark
//!    into the [`ResetReason`] that every announce carries.

use puzzlebot_protocol::ResetReason;

use crate::drv8833::{HBridge, MotorOutputs, PWM_FULL_SCALE};

/// The motor state of every fault, chosen here only: coast (all four DRV8833 inputs low).
///
/// Coast, not brake, because it is the state a reset produces by itself: a reset releases
/// the pins and the pull-downs on the bridge inputs hold them low, so the motors do the
/// same before, during and after the reset.
pub const FAULT_OUTPUTS: MotorOutputs = MotorOutputs::COAST;

/// Main-watchdog timeout (ms): this long without a healthy tick resets the chip (five
/// 50 Hz periods).
pub const WATCHDOG_TIMEOUT_MS: u32 = 100;

/// Boot-watchdog timeout (ms): start-up must reach the control loop within this long.
pub const BOOT_WATCHDOG_TIMEOUT_MS: u32 = 4_000;

/// A tick later than this many loop periods after the previous one is not healthy.
pub const MAX_TICK_GAP_PERIODS: u64 = 3;

/// The motor pins, driven directly (no PWM peripheral, no allocation): callable from a
/// panic handler.
pub trait SafeOutputs {
    /// Drive the four bridge inputs to `outputs` (only full-off or full-on levels).
    fn force(&mut self, outputs: &MotorOutputs);

    /// Drive the pins to [`FAULT_OUTPUTS`].
    fn make_safe(&mut self) {
        self.force(&FAULT_OUTPUTS);
    }
}

/// A watchdog that resets the chip unless fed in time.
pub trait Watchdog {
    /// Restart the watchdog's countdown (`now_us`: µs since boot, for software watchdogs).
    fn feed(&mut self, now_us: u64);
}

/// The static pin levels (in1, in2) of each bridge of `o`, when it has only full-off or
/// full-on inputs (what a pin without PWM can do).
pub fn static_levels(o: &MotorOutputs) -> Option<[[bool; 2]; 2]> {
    let level = |d: u16| match d {
        0 => Some(false),
        d if d >= PWM_FULL_SCALE => Some(true),
        _ => None,
    };
    let bridge = |h: HBridge| Some([level(h.in1)?, level(h.in2)?]);
    Some([bridge(o.left)?, bridge(o.right)?])
}

const fn is_static(d: u16) -> bool {
    d == 0 || d >= PWM_FULL_SCALE
}

const _: () = assert!(
    is_static(FAULT_OUTPUTS.left.in1)
        && is_static(FAULT_OUTPUTS.left.in2)
        && is_static(FAULT_OUTPUTS.right.in1)
        && is_static(FAULT_OUTPUTS.right.in2),
    "fault outputs must be static pin levels"
);

/// Feeds the watchdog only from healthy control ticks.
#[derive(Debug, Clone)]
pub struct TickSupervisor {
    max_gap_us: u64,
    last_tick_us: Option<u64>,
    late_ticks: u32,
}

impl TickSupervisor {
    /// A supervisor for a loop of `period_us`.
    pub fn new(period_us: u64) -> Self {
        TickSupervisor {
            max_gap_us: period_us.max(1) * MAX_TICK_GAP_PERIODS,
            last_tick_us: None,
            late_ticks: 0,
        }
    }

    /// Call once per control tick at `now_us`, after the outputs were applied. Feeds `wd`
    /// and returns true when the tick came on time; a late tick is counted and not fed, so
    /// a loop that keeps running late is reset like a stopped one.
    pub fn on_tick(&mut self, now_us: u64, wd: &mut impl Watchdog) -> bool {
        let healthy = match self.last_tick_us {
            None => true,
            Some(t) => now_us >= t && now_us - t <= self.max_gap_us,
        };
        self.last_tick_us = Some(now_us);
        if healthy {
            wd.feed(now_us);
        } else {
            self.late_ticks = self.late_ticks.saturating_add(1);
        }
        healthy
    }

    /// Ticks that came too late since start.
    pub fn late_ticks(&self) -> u32 {
        self.late_ticks
    }
}

/// A fault the firmware noticed itself before resetting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Panic, CPU exception, stack overflow or out-of-memory.
    Panic,
    /// The watchdog's early stage fired (the loop stopped feeding it).
    Hang,
}

/// The word kept across a reset (RTC memory) saying which [`Fault`] caused it. Memory that
/// survives resets holds garbage after power-on, so a mark is a magic value plus the fault;
/// anything else reads as no mark.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FaultMark(pub u32);

const MARK_MAGIC: u32 = 0x5AFE_0000;

impl FaultMark {
    /// No fault recorded.
    pub const NONE: FaultMark = FaultMark(0);

    /// The mark for `fault`.
    pub fn of(fault: Fault) -> FaultMark {
        FaultMark(
            MARK_MAGIC
                | match fault {
                    Fault::Panic => 0x00A1,
                    Fault::Hang => 0x00B2,
                },
        )
    }

    /// The fault this word records, if it is a mark at all.
    pub fn fault(self) -> Option<Fault> {
        match self.0 {
            w if w == FaultMark::of(Fault::Panic).0 => Some(Fault::Panic),
            w if w == FaultMark::of(Fault::Hang).0 => Some(Fault::Hang),
            _ => None,
        }
    }
}

/// The fault policy: motor pins to [`FAULT_OUTPUTS`] first, then the mark to keep for
/// the reset that the caller performs next.
pub fn on_fault(fault: Fault, outputs: &mut impl SafeOutputs) -> FaultMark {
    outputs.make_safe();
    FaultMark::of(fault)
}

/// What the hardware reports about the last reset (the ESP32-C3 glue maps its reset cause
/// register onto this).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HwReset {
    /// Power-on (battery or USB).
    PowerOn,
    /// A software reset (the panic handler's, or a deliberate one).
    Software,
    /// The timer-group (main) watchdog.
    MainWatchdog,
    /// The RTC watchdog.
    RtcWatchdog,
    /// Brown-out detector.
    BrownOut,
    /// Anything else (reset pin, USB/JTAG, debugger, glitch detectors).
    Other,
}

/// Why the robot booted, from the hardware's reset cause and the mark kept across the
/// reset. After power-on and brown-out the mark is ignored (the memory holds garbage, or
/// the supply, not the software, failed); after a software or watchdog reset a mark wins
/// (a panic whose report outlasted the watchdog is still a panic).
pub fn reset_reason(hw: Option<HwReset>, mark: FaultMark) -> ResetReason {
    let marked = |f| match f {
        Fault::Panic => ResetReason::Panic,
        Fault::Hang => ResetReason::Hang,
    };
    match (hw, mark.fault()) {
        (Some(HwReset::PowerOn), _) => ResetReason::PowerOn,
        (Some(HwReset::BrownOut), _) => ResetReason::BrownOut,
        (Some(HwReset::Other), _) => ResetReason::Other,
        (
            Some(HwReset::Software | HwReset::MainWatchdog | HwReset::RtcWatchdog) | None,
            Some(f),
        ) => marked(f),
        (Some(HwReset::MainWatchdog), None) => ResetReason::Hang,
        (Some(HwReset::RtcWatchdog), None) => ResetReason::BootHang,
        (Some(HwReset::Software), None) => ResetReason::Software,
        (None, None) => ResetReason::Unknown,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Default)]
    struct Pins(Vec<MotorOutputs>);
    impl SafeOutputs for Pins {
        fn force(&mut self, o: &MotorOutputs) {
            self.0.push(*o);
        }
    }

    #[derive(Default)]
    struct Wd(Vec<u64>);
    impl Watchdog for Wd {
        fn feed(&mut self, now_us: u64) {
            self.0.push(now_us);
        }
    }

    #[test]
    fn a_fault_drives_the_pins_safe_before_returning_its_mark() {
        let mut pins = Pins::default();
        let mark = on_fault(Fault::Panic, &mut pins);
        assert_eq!(pins.0, vec![FAULT_OUTPUTS]);
        assert_eq!(mark.fault(), Some(Fault::Panic));
        assert_eq!(
            static_levels(&FAULT_OUTPUTS),
            Some([[false, false], [false, false]])
        );
    }

    #[test]
    fn only_timely_ticks_feed_the_watchdog() {
        let mut s = TickSupervisor::new(20_000);
        let mut wd = Wd::default();
        assert!(s.on_tick(0, &mut wd));
        assert!(s.on_tick(20_000, &mut wd));
        assert!(s.on_tick(80_000, &mut wd), "three periods is still on time");
        assert!(
            !s.on_tick(140_001, &mut wd),
            "a stalled loop's next tick is late"
        );
        assert!(
            !s.on_tick(100_000, &mut wd),
            "time going backwards is not healthy"
        );
        assert_eq!(wd.0, vec![0, 20_000, 80_000]);
        assert_eq!(s.late_ticks(), 2);
    }

    #[test]
    fn marks_survive_only_as_themselves() {
        for f in [Fault::Panic, Fault::Hang] {
            assert_eq!(FaultMark::of(f).fault(), Some(f));
        }
        for garbage in [0, u32::MAX, MARK_MAGIC, 0xDEAD_BEEF, MARK_MAGIC | 0x00A2] {
            assert_eq!(FaultMark(garbage).fault(), None, "{garbage:#x}");
        }
    }

    #[test]
    fn reset_reasons_combine_hardware_cause_and_mark() {
        let panic = FaultMark::of(Fault::Panic);
        let hang = FaultMark::of(Fault::Hang);
        let none = FaultMark::NONE;
        use HwReset as H;
        use ResetReason as R;
        let cases = [
            (Some(H::PowerOn), panic, R::PowerOn),
            (Some(H::PowerOn), none, R::PowerOn),
            (Some(H::Software), panic, R::Panic),
            (Some(H::Software), hang, R::Hang),
            (Some(H::Software), none, R::Software),
            (Some(H::MainWatchdog), none, R::Hang),
            (Some(H::RtcWatchdog), none, R::BootHang),
            (Some(H::RtcWatchdog), panic, R::Panic),
            (Some(H::MainWatchdog), panic, R::Panic),
            (Some(H::MainWatchdog), hang, R::Hang),
            (Some(H::BrownOut), panic, R::BrownOut),
            (Some(H::Other), none, R::Other),
            (None, panic, R::Panic),
            (None, none, R::Unknown),
        ];
        for (hw, mark, want) in cases {
            assert_eq!(reset_reason(hw, mark), want, "{hw:?} {mark:?}");
        }
    }
}
