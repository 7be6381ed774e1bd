//! Prints one closed-loop step response tick by tick (time, true speed, estimate, duty):
//! `cargo run --release -p puzzlebot-firmware-core --example trace -- 100 1.0`
//! (target RPM, motor gain factor).

use puzzlebot_firmware_core::model::{ClosedLoop, MotorModel};
use puzzlebot_params::firmware::Firmware;

fn main() {
    let mut args = std::env::args().skip(1);
    let target: f32 = args.next().and_then(|a| a.parse().ok()).unwrap_or(100.0);
    let factor: f32 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1.0);
    let motor = MotorModel {
        no_load_rpm: MotorModel::default().no_load_rpm * factor,
        ..MotorModel::default()
    };
    let lp = ClosedLoop::new(Firmware::default(), motor);
    let r = lp.step_response_traced(target, 0.5, &mut |t, true_rpm, est, reference, duty| {
        println!("{t:.3} true {true_rpm:7.2} est {est:7.2} ref {reference:7.2} duty {duty:7.1}");
    });
    println!("{r:?}");
}
