//! PuzzleBot firmware image for the Seeed XIAO ESP32-C3 (minimal bring-up).
#![no_std]
#![no_main]

use embassy_executor::Spawner;
use embassy_time::{Duration, Timer};
use esp_backtrace as _;
use esp_hal::timer::timg::TimerGroup;

esp_bootloader_esp_idf::esp_app_desc!();

/// Heartbeat: proves the executor and the time driver run.
#[embassy_executor::task]
async fn heartbeat() {
    let mut n: u32 = 0;
    loop {
        log::info!("alive {n} (protocol v{})", puzzlebot_protocol::PROTOCOL_VERSION);
        n = n.wrapping_add(1);
        Timer::after(Duration::from_secs(5)).await;
    }
}

#[esp_rtos::main]
async fn main(spawner: Spawner) -> ! {
    esp_println::logger::init_logger(log::LevelFilter::Info);
    let peripherals = esp_hal::init(esp_hal::Config::default());
    let timg0 = TimerGroup::new(peripherals.TIMG0);
    esp_rtos::start(timg0.timer0, peripherals.FROM_CPU_INTR0);
    spawner.spawn(heartbeat().expect("heartbeat task spawned once"));
    loop {
        Timer::after(Duration::from_secs(60)).await;
    }
}
