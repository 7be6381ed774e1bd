//! PuzzleBot firmware image for the Seeed XIAO ESP32-C3: glue between the hardware and
//! `puzzlebot-firmware-core` (DESIGN.md §5). Everything the robot *does* lives in the core;
//! this crate wires pins ([`pins`]), the encoder interrupts ([`encoders`]), the PWM
//! ([`motors`]), the battery ADC ([`battery`]), Wi-Fi and UDP to it, and runs the fault
//! path ([`fault`]: safe pins, panic hooks, watchdogs, reset reason) and the status LED
//! ([`led`]).
#![no_std]
#![no_main]

mod battery;
mod encoders;
mod fault;
mod led;
mod motors;
mod ota;
mod pins;
mod provision;

use core::net::SocketAddrV4;
use core::sync::atomic::{AtomicI32, Ordering};

use embassy_executor::Spawner;
use embassy_futures::poll_once;
use embassy_futures::select::{select, Either};
use embassy_net::udp::{PacketMetadata, UdpSocket};
use embassy_net::{IpEndpoint, Runner, Stack, StackResources};
use embassy_time::{Duration, Ticker, Timer};
use esp_backtrace as _;
use esp_bootloader_esp_idf::partitions::FlashStorage;
use esp_hal::gpio::{Io, Output};
use esp_hal::rng::Rng;
use esp_hal::timer::timg::TimerGroup;
use esp_radio::wifi::sta::StationConfig;
use esp_radio::wifi::{
    AuthenticationMethodConfig, Config, ControllerConfig, Interface, PowerSaveMode, WifiController,
};
use fault::FaultPins;
use led::BlinkCode;
use puzzlebot_firmware_core::{
    NonceSource, Provision, Robot, SafeOutputs, Sensors, TickSupervisor,
};
use puzzlebot_params::firmware::Firmware;
use puzzlebot_protocol::{FirmwareVersion, Nonce, RobotKind, DEFAULT_ROBOT_PORT, MAX_DATAGRAM};
use static_cell::StaticCell;

esp_bootloader_esp_idf::esp_app_desc!();

/// Firmware version announced to the host (from this crate's version).
const VERSION: FirmwareVersion = FirmwareVersion {
    major: parse_u8(env!("CARGO_PKG_VERSION_MAJOR")),
    minor: parse_u8(env!("CARGO_PKG_VERSION_MINOR")),
    patch: parse_u8(env!("CARGO_PKG_VERSION_PATCH")),
};

const fn parse_u8(s: &str) -> u8 {
    let b = s.as_bytes();
    let mut i = 0;
    let mut v: u8 = 0;
    while i < b.len() {
        v = v.wrapping_mul(10).wrapping_add(b[i].wrapping_sub(b'0'));
        i += 1;
    }
    v
}

/// Latest Wi-Fi RSSI (dBm), written by the Wi-Fi task, read by the control loop.
static RSSI_DBM: AtomicI32 = AtomicI32::new(0);

/// Handshake nonces from the hardware RNG (entropy from the radio while Wi-Fi runs).
struct HwNonces(Rng);

impl NonceSource for HwNonces {
    fn fresh_nonce(&mut self) -> Nonce {
        let mut n = [0u8; 16];
        self.0.read(&mut n);
        n
    }
}

/// The network side of a provisioned robot.
struct Net {
    stack: Stack<'static>,
    host: IpEndpoint,
}

#[esp_rtos::main]
async fn main(spawner: Spawner) -> ! {
    // The very first thing after reset: motor pins to the fault state (coast), before
    // clocks, heap or logging; the board's pull-downs held them there until now.
    FaultPins.make_safe();
    esp_println::logger::init_logger(log::LevelFilter::Info);
    let config = esp_hal::Config::default().with_cpu_clock(esp_hal::clock::CpuClock::max());
    let peripherals = esp_hal::init(config);
    // `init` disables every watchdog: the RTC one guards the rest of the boot.
    let mut watchdogs = fault::Watchdogs::start_boot(peripherals.RTC_TIMER);
    let reset_reason = fault::boot_reset_reason();
    // Wi-Fi's heap, as esp-radio's examples size it: the reclaimed bootloader RAM (64 KiB)
    // plus 36 KiB.
    esp_alloc::heap_allocator!(#[esp_hal::ram(reclaimed)] size: 64 * 1024);
    esp_alloc::heap_allocator!(size: 36 * 1024);

    let timg0 = TimerGroup::new(peripherals.TIMG0);
    esp_rtos::start(timg0.timer0, peripherals.FROM_CPU_INTR0);

    let board = take_board!(peripherals);
    let mut led = Some(led::new(board.led));
    let mut io = Io::new(peripherals.IO_MUX);
    encoders::start(&mut io, board.encoder);
    let motors = match motors::Motors::new(peripherals.LEDC, board.motor) {
        Ok(m) => m,
        Err(e) => {
            log::error!("PWM set-up failed: {e}; halted, motors coasting");
            halt(&mut watchdogs, led.as_mut()).await
        }
    };
    let battery = battery::Battery::new(peripherals.ADC1, board.battery);
    let rng = Rng::new();
    let mut flash = FlashStorage::new(peripherals.FLASH);

    // `black_box`: keep the Wi-Fi path in unprovisioned (CI) builds too, so CI links and
    // measures the same image a provisioned robot runs.
    let prov = core::hint::black_box(provision::load(&mut flash));
    let update_key = prov.as_ref().ok().and_then(|p| p.update_key);
    let (id, kind, key, net) = match prov {
        Err(why) => {
            let code = if why.is_bad() {
                BlinkCode::BadProvisioning
            } else {
                BlinkCode::Unprovisioned
            };
            log::warn!("not provisioned ({why}): the robot will never drive");
            blink(&spawner, &mut led, code);
            (provision::UNPROVISIONED_ID, RobotKind::NonPilot, None, None)
        }
        Ok(p) => match start_wifi(&spawner, peripherals.WIFI, &p, rng) {
            Ok(net) => (p.id, p.kind, Some(p.key), Some(net)),
            Err(code) => {
                // The reason is logged where it happened; the robot stays silent, coasting.
                blink(&spawner, &mut led, code);
                (p.id, p.kind, Some(p.key), None)
            }
        },
    };
    let mut robot = match Robot::new(id, kind, key, Firmware::default(), VERSION, HwNonces(rng)) {
        Ok(r) => r,
        Err(e) => {
            log::error!("invalid firmware parameters: {e}; halted, motors coasting");
            halt(&mut watchdogs, led.as_mut()).await
        }
    };
    robot.set_reset_reason(reset_reason);
    if reset_reason.is_fault() {
        log::warn!("reset after a fault: {}", reset_reason.name());
    }
    log::info!(
        "PuzzleBot {id} ({kind:?}) firmware {VERSION:?} running (reset: {})",
        reset_reason.name()
    );
    let ota = ota::EspOta::new(flash, update_key, VERSION, encoders::now_us());
    if ota.is_none() {
        log::warn!("no OTA partitions: over-the-air updates are refused");
    }
    watchdogs.start_main(peripherals.TIMG1);
    control_loop(robot, motors, battery, net, watchdogs, ota).await
}

/// A permanent halt: motors at the fault state, watchdogs off (resetting would not help),
/// the LED flashing [`BlinkCode::Halted`].
async fn halt(watchdogs: &mut fault::Watchdogs, led: Option<&mut Output<'static>>) -> ! {
    FaultPins.make_safe();
    watchdogs.stop();
    match led {
        Some(l) => led::blink_forever(l, BlinkCode::Halted).await,
        None => loop {
            Timer::after(Duration::from_secs(3600)).await;
        },
    }
}

/// Hand the LED to a task flashing `code`.
fn blink(spawner: &Spawner, led: &mut Option<Output<'static>>, code: BlinkCode) {
    if let Some(l) = led.take() {
        match led::blink_task(l, code) {
            Ok(t) => spawner.spawn(t),
            Err(e) => log::error!("LED task: {e:?}"),
        }
    }
}

/// Start Wi-Fi (station, power save off, reconnecting forever) and the IP stack; on
/// failure the reason is logged and its blink code returned.
fn start_wifi(
    spawner: &Spawner,
    wifi: esp_hal::peripherals::WIFI<'static>,
    p: &Provision,
    rng: Rng,
) -> Result<Net, BlinkCode> {
    let auth = if p.password().is_empty() {
        AuthenticationMethodConfig::Open
    } else {
        let pw = p.password().try_into().map_err(|_| {
            log::error!(
                "Wi-Fi not started: password of {} bytes is too long",
                p.password().len()
            );
            BlinkCode::WifiCredentials
        })?;
        AuthenticationMethodConfig::WpaWpa2Personal(pw)
    };
    let ssid = p.ssid().try_into().map_err(|_| {
        log::error!(
            "Wi-Fi not started: SSID of {} bytes is too long",
            p.ssid().len()
        );
        BlinkCode::WifiCredentials
    })?;
    let station = StationConfig::default()
        .with_ssid(ssid)
        .with_authentication(auth);
    let mut controller = WifiController::new(
        wifi,
        ControllerConfig::default().with_initial_config(Config::Station(station)),
    )
    .map_err(|e| {
        log::error!("Wi-Fi not started: driver error {e:?}");
        BlinkCode::WifiStart
    })?;
    // Modem sleep adds hundreds of ms of latency (DESIGN.md §5).
    if let Err(e) = controller.set_power_saving(PowerSaveMode::None) {
        log::warn!("could not disable Wi-Fi power save: {e:?}");
    }
    static RESOURCES: StaticCell<StackResources<3>> = StaticCell::new();
    let seed = (u64::from(rng.random()) << 32) | u64::from(rng.random());
    let (stack, runner) = embassy_net::new(
        Interface::station(),
        embassy_net::Config::dhcpv4(Default::default()),
        RESOURCES.init(StackResources::new()),
        seed,
    );
    let spawn_failed = |what: &str, e: embassy_executor::SpawnError| {
        log::error!("Wi-Fi not started: {what} task: {e:?}");
        BlinkCode::NetTask
    };
    spawner.spawn(wifi_task(controller).map_err(|e| spawn_failed("Wi-Fi", e))?);
    spawner.spawn(net_task(runner).map_err(|e| spawn_failed("network", e))?);
    Ok(Net {
        stack,
        host: endpoint(p.host),
    })
}

fn endpoint(a: SocketAddrV4) -> IpEndpoint {
    IpEndpoint::new(embassy_net::IpAddress::Ipv4(*a.ip()), a.port())
}

/// Keep the station connected: reconnect forever, publish the RSSI once a second.
#[embassy_executor::task]
async fn wifi_task(mut controller: WifiController<'static>) {
    loop {
        match controller.connect_async().await {
            Ok(_) => {
                log::info!("Wi-Fi connected");
                loop {
                    let lost = select(
                        controller.wait_for_disconnect_async(),
                        Timer::after(Duration::from_secs(1)),
                    )
                    .await;
                    match lost {
                        Either::First(_) => break,
                        Either::Second(()) => {
                            if let Ok(r) = controller.rssi() {
                                RSSI_DBM.store(r, Ordering::Relaxed);
                            }
                        }
                    }
                }
                log::warn!("Wi-Fi lost; reconnecting");
            }
            Err(e) => log::warn!("Wi-Fi connect failed: {e:?}"),
        }
        Timer::after(Duration::from_millis(500)).await;
    }
}

#[embassy_executor::task]
async fn net_task(mut runner: Runner<'static, Interface>) {
    runner.run().await
}

/// Wait for a datagram, or forever without a socket.
async fn receive(socket: Option<&mut UdpSocket<'_>>, buf: &mut [u8]) -> Option<usize> {
    match socket {
        Some(s) => s.recv_from(buf).await.ok().map(|(n, _)| n),
        None => core::future::pending().await,
    }
}

/// The newest datagram the socket could not take yet. Latest wins: a newer datagram
/// replaces it, so nothing stale is ever sent after something fresher, and nothing waits.
struct Outbox {
    buf: [u8; MAX_DATAGRAM],
    len: usize,
    replaced: u32,
}

impl Outbox {
    /// Hand `frame` to the socket now if it has room, else keep it (replacing an older one).
    fn send(&mut self, s: &mut UdpSocket<'_>, host: IpEndpoint, frame: &[u8]) {
        self.flush(s, host);
        if self.len != 0 {
            self.replaced = self.replaced.wrapping_add(1);
            self.keep(frame);
        } else if !try_send(s, host, frame) {
            self.keep(frame);
        }
    }

    /// Send the kept datagram if the socket has room now.
    fn flush(&mut self, s: &mut UdpSocket<'_>, host: IpEndpoint) {
        if self.len != 0 && try_send(s, host, &self.buf[..self.len]) {
            self.len = 0;
        }
    }

    fn keep(&mut self, frame: &[u8]) {
        let n = frame.len().min(MAX_DATAGRAM);
        self.buf[..n].copy_from_slice(&frame[..n]);
        self.len = n;
    }
}

/// Queue `frame` without waiting: true when the socket took it (or refused it for good,
/// e.g. no route yet), false when its buffer is full.
fn try_send(s: &mut UdpSocket<'_>, host: IpEndpoint, frame: &[u8]) -> bool {
    if !s.may_send() {
        return false;
    }
    poll_once(s.send_to(frame, host)).is_ready()
}

/// The 50 Hz loop: tick the core with encoder snapshots, battery and RSSI, drive the PWM,
/// feed the watchdogs after a healthy tick; feed received datagrams to the core; send
/// what the core wants to send (latest wins). No step waits: the ADC read is bounded, the
/// socket is only polled.
async fn control_loop<N: NonceSource>(
    mut robot: Robot<N>,
    motors: motors::Motors,
    mut battery: battery::Battery,
    net: Option<Net>,
    mut watchdogs: fault::Watchdogs,
    mut ota: Option<ota::EspOta>,
) -> ! {
    let mut rx_meta = [PacketMetadata::EMPTY; 4];
    let mut tx_meta = [PacketMetadata::EMPTY; 4];
    let mut rx_store = [0u8; 4 * MAX_DATAGRAM];
    let mut tx_store = [0u8; 4 * MAX_DATAGRAM];
    let mut socket = net.as_ref().map(|n| {
        UdpSocket::new(
            n.stack,
            &mut rx_meta,
            &mut rx_store,
            &mut tx_meta,
            &mut tx_store,
        )
    });
    if let Some(s) = socket.as_mut() {
        if let Err(e) = s.bind(DEFAULT_ROBOT_PORT) {
            log::error!("UDP bind failed: {e:?}");
        }
    }
    let host = net.as_ref().map(|n| n.host);
    let mut supervisor = TickSupervisor::new(robot.period_us());
    let mut ticker = Ticker::every(Duration::from_micros(robot.period_us()));
    let mut rx = [0u8; MAX_DATAGRAM + 1];
    let mut tx = [0u8; MAX_DATAGRAM];
    let mut outbox = Outbox {
        buf: [0; MAX_DATAGRAM],
        len: 0,
        replaced: 0,
    };
    loop {
        match select(ticker.next(), receive(socket.as_mut(), &mut rx)).await {
            Either::First(()) => {
                let sensors = Sensors {
                    battery_mv: battery.read_mv(),
                    rssi_dbm: RSSI_DBM.load(Ordering::Relaxed).clamp(-128, 127) as i8,
                    encoders: encoders::snapshot(),
                };
                let now = encoders::now_us();
                let out = robot.tick(now, &sensors);
                motors.apply(&out);
                supervisor.on_tick(now, &mut watchdogs);
                if ota
                    .as_mut()
                    .is_some_and(|o| o.after_tick(now, robot.is_established()))
                {
                    log::info!("restarting into the other firmware slot");
                    FaultPins.make_safe();
                    esp_hal::system::software_reset();
                }
            }
            Either::Second(Some(n)) => {
                // Oversized datagrams arrive truncated to MAX_DATAGRAM + 1 and are rejected.
                let _ = robot.on_datagram(&rx[..n], encoders::now_us());
                if let Some(req) = robot.take_update_request() {
                    if let Some(report) = ota.as_mut().and_then(|o| o.handle(req)) {
                        robot.report_update(report);
                    }
                }
            }
            Either::Second(None) => {}
        }
        let (Some(s), Some(h)) = (socket.as_mut(), host) else {
            continue;
        };
        outbox.flush(s, h);
        while let Some(n) = robot.poll_transmit(encoders::now_us(), &mut tx) {
            outbox.send(s, h, &tx[..n]);
        }
    }
}
