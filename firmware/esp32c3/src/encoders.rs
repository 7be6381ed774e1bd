//! Encoder inputs: GPIO any-edge interrupts, timestamped by the SYSTIMER (1 µs), decoded
//! by `puzzlebot_firmware_core::Encoder` (the ESP32-C3 has no pulse counter).

use core::cell::RefCell;

use critical_section::Mutex;
use esp_hal::gpio::{AnyPin, Event, Input, InputConfig, Io, Pull};
use esp_hal::{handler, ram};
use puzzlebot_firmware_core::{Encoder, EncoderSnapshot};

use crate::pins::RIGHT_REVERSED;

/// Inputs: left A, left B, right A, right B.
static INPUTS: Mutex<RefCell<Option<[Input<'static>; 4]>>> = Mutex::new(RefCell::new(None));
/// Decoders: left, right.
static ENCODERS: Mutex<RefCell<[Encoder; 2]>> =
    Mutex::new(RefCell::new([Encoder::new(), Encoder::new()]));

/// Microseconds since boot from the SYSTIMER (the robot's one clock).
pub fn now_us() -> u64 {
    esp_hal::time::Instant::now()
        .duration_since_epoch()
        .as_micros()
}

fn levels(inputs: &[Input<'static>; 4], wheel: usize) -> (bool, bool) {
    let a = inputs[2 * wheel].is_high();
    let b = inputs[2 * wheel + 1].is_high();
    if wheel == 1 && RIGHT_REVERSED {
        (b, a)
    } else {
        (a, b)
    }
}

/// Configure the four inputs with pull-ups, read the initial levels and listen to every
/// edge.
pub fn start(io: &mut Io<'_>, pins: [AnyPin<'static>; 4]) {
    let cfg = InputConfig::default().with_pull(Pull::Up);
    let mut inputs = pins.map(|p| Input::new(p, cfg));
    io.set_interrupt_handler(on_edge);
    critical_section::with(|cs| {
        let mut enc = ENCODERS.borrow_ref_mut(cs);
        for (w, e) in enc.iter_mut().enumerate() {
            let (a, b) = levels(&inputs, w);
            e.init_levels(a, b);
        }
        for i in &mut inputs {
            i.listen(Event::AnyEdge);
        }
        INPUTS.borrow_ref_mut(cs).replace(inputs);
    });
}

#[handler]
#[ram]
fn on_edge() {
    let t = now_us();
    critical_section::with(|cs| {
        let mut inputs = INPUTS.borrow_ref_mut(cs);
        let Some(inputs) = inputs.as_mut() else {
            return;
        };
        let mut fired = [false; 2];
        for (i, input) in inputs.iter_mut().enumerate() {
            if input.is_interrupt_set() {
                input.clear_interrupt();
                fired[i / 2] = true;
            }
        }
        let mut enc = ENCODERS.borrow_ref_mut(cs);
        for (w, e) in enc.iter_mut().enumerate() {
            if fired[w] {
                let (a, b) = levels(inputs, w);
                e.on_edge(a, b, t);
            }
        }
    });
}

/// Snapshots of both encoders for the control tick.
pub fn snapshot() -> [EncoderSnapshot; 2] {
    critical_section::with(|cs| {
        let enc = ENCODERS.borrow_ref(cs);
        [enc[0].snapshot(), enc[1].snapshot()]
    })
}
