//! micropt on a Raspberry Pi Pico (RP2040, two Cortex-M0+ cores at 125 MHz,
//! no FPU) with a Pimoroni Pico Display Pack (ST7789, 1.14", 240×135),
//! rendering the Cornell box on both cores, progressively, tile by tile,
//! straight to the panel through `mipidsi`.
//!
//! Both cores run the core's shared executor
//! (`micropt::multicore::render_shared`): a preview of every tile (sample 0
//! of one pixel per 2×2 block), then every tile refined to its share of
//! [`BUDGET`] with adaptive allocation, each core taking the next tile from
//! one queue. The M0+ has no atomic read-modify-write, so the queue
//! (`queue.rs`) counts under the RP2040's hardware spinlock. Each core keeps
//! one 16×16 tile of sample accumulators (`TileAccum`, 5 KiB, static) and
//! draws its finished tiles itself, holding the panel for one window write.
//! The image does not depend on which core rendered which tile: with
//! `Budget::Spp(16)` it is the host's `micropt render scenes/cornell.scene
//! --size 240x135 --spp 16 --seed 0`, bit for bit.
//!
//! The M0+ has no FPU: every f32 add, subtract, multiply, divide, compare
//! and int-to-float conversion is micropt's correctly rounded routine
//! (`micropt::math::soft`, exported under the ARM EABI names by
//! `examples/board/softfloat.rs`; the HAL's `disable-intrinsics` feature
//! keeps it from installing the boot ROM's, which flush subnormals to zero
//! and so could change bits). A frame takes minutes (docs/boards.md).
//!
//! What it shows: the panel is cleared to black before the backlight comes
//! on, then the preview fills it in tile by tile, then the refined tiles
//! replace it. The pack's RGB LED: blue while rendering, green when the
//! frame is done, red blinking N times (then a pause, again) when init
//! step N failed ([`Step`]). Over a debug probe (`cargo run --release`:
//! `probe-rs run`), defmt prints each step, the preview's and each tenth
//! of the refinement's progress, and the frame time.
//!
//! Wiring: none, the Display Pack plugs onto the Pico's headers. It uses
//! (Pimoroni's pinout):
//!
//! | panel     | RP2040 |
//! | --------- | ------ |
//! | SCK       | GP18 (SPI0 SCK) |
//! | MOSI      | GP19 (SPI0 TX)  |
//! | CS        | GP17   |
//! | DC        | GP16   |
//! | backlight | GP20 (high after the panel is cleared) |
//! | RGB LED   | GP6 red, GP7 green, GP8 blue (active low) |
//! | reset     | not wired (the panel resets at power-on) |
//!
//! Build and flash: docs/boards.md.
#![no_std]
#![no_main]

// micropt's soft-float routines under the runtime's names (same bits as the
// host, about half the instructions of compiler-builtins' on Armv6-M)
#[path = "../../../board/softfloat.rs"]
mod softfloat;

#[path = "../../../board/locked_panel.rs"]
mod locked_panel;
#[path = "../../../board/pico.rs"]
mod pico;
#[path = "../../../board/progress.rs"]
mod progress;
mod queue;

use defmt_rtt as _;
use panic_probe as _;

use core::cell::{Cell, RefCell};
use core::sync::atomic::AtomicBool;
use critical_section::Mutex;
use defmt::{info, warn};
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::geometry::Size;
use embedded_graphics::pixelcolor::{Rgb565, RgbColor};
use embedded_hal::digital::OutputPin;
use embedded_hal_bus::spi::{ExclusiveDevice, NoDelay};
use hal::Clock as _;
use hal::fugit::RateExtU32;
use hal::gpio::bank0::{Gpio16, Gpio17, Gpio18, Gpio19};
use hal::gpio::{FunctionSioOutput, FunctionSpi, Pin, PinState, PullDown};
use hal::multicore::{Multicore, Stack};
use locked_panel::LockedPanel;
use micropt::Budget;
use micropt::film::tile_count;
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::{ColorInversion, Orientation, Rotation};
use mipidsi::{Builder, NoResetPin};
use pico::{BLUE, Led, Step, core0, core1, fail, report};
use progress::Progress;
use queue::LockedQueue;
use rp2040_hal as hal;

/// The second-stage bootloader for the Pico's W25Q080 flash.
#[unsafe(link_section = ".boot2")]
#[used]
pub static BOOT2: [u8; 256] = rp2040_boot2::BOOT_LOADER_W25Q080;

/// The Pico's crystal.
const XTAL_HZ: u32 = 12_000_000;
/// Panel size (landscape).
const WIDTH: u32 = 240;
/// Panel size (landscape).
const HEIGHT: u32 = 135;
/// The render budget: 16 samples per pixel on average. A sample budget
/// (`Spp` or `Paths`): the two-core executor refuses a deadline.
const BUDGET: Budget = Budget::Spp(16);
/// Render seed.
const SEED: u64 = 0;

type Spi0 = hal::spi::Spi<
    hal::spi::Enabled,
    hal::pac::SPI0,
    (
        Pin<Gpio19, FunctionSpi, PullDown>,
        Pin<Gpio18, FunctionSpi, PullDown>,
    ),
    8,
>;
type Cs = Pin<Gpio17, FunctionSioOutput, PullDown>;
type Dc = Pin<Gpio16, FunctionSioOutput, PullDown>;
type Panel = mipidsi::Display<
    SpiInterface<'static, ExclusiveDevice<Spi0, Cs, NoDelay>, Dc>,
    ST7789,
    NoResetPin,
>;

/// The panel, drawn to by both cores, one tile at a time.
static PANEL: Mutex<RefCell<Option<Progress<Panel>>>> = Mutex::new(RefCell::new(None));
/// The two cores' tile queue.
static QUEUE: LockedQueue = LockedQueue::new(2);
/// The queue when core 1 did not start.
static QUEUE_ALONE: LockedQueue = LockedQueue::new(1);
/// Core 1's stack: 16 KiB, its tile accumulators static (the render's
/// stack depth measured in QEMU: docs/boards.md).
static CORE1_STACK: Stack<4096> = Stack::new();
/// Set by core 1 if it could not draw to the panel.
static CORE1_FAILED: AtomicBool = AtomicBool::new(false);
/// The 1 MHz timer, for log timestamps (set once the clocks run).
static TIMER: Mutex<Cell<Option<hal::Timer>>> = Mutex::new(Cell::new(None));

/// Microseconds since the timer started (0 before).
fn now_us() -> u64 {
    critical_section::with(|cs| TIMER.borrow(cs).get()).map_or(0, |t| t.get_counter().ticks())
}

defmt::timestamp!("{=u64:us}", now_us());

#[hal::entry]
fn main() -> ! {
    info!(
        "micropt on Raspberry Pi Pico + Pico Display Pack: cornell {=u32}x{=u32}",
        WIDTH, HEIGHT
    );
    let Some(mut pac) = hal::pac::Peripherals::take() else {
        // taken once, here: cannot fail
        loop {
            cortex_m::asm::wfi();
        }
    };
    let mut sio = hal::Sio::new(pac.SIO);
    let pins = hal::gpio::Pins::new(
        pac.IO_BANK0,
        pac.PADS_BANK0,
        sio.gpio_bank0,
        &mut pac.RESETS,
    );
    // LED off, backlight off until the panel is cleared
    let mut led = Led([
        pins.gpio6
            .into_push_pull_output_in_state(PinState::High)
            .into_dyn_pin(),
        pins.gpio7
            .into_push_pull_output_in_state(PinState::High)
            .into_dyn_pin(),
        pins.gpio8
            .into_push_pull_output_in_state(PinState::High)
            .into_dyn_pin(),
    ]);
    let mut backlight = pins.gpio20.into_push_pull_output_in_state(PinState::Low);

    let mut watchdog = hal::Watchdog::new(pac.WATCHDOG);
    // 125 MHz system clock from the 12 MHz crystal
    let Ok(clocks) = hal::clocks::init_clocks_and_plls(
        XTAL_HZ,
        pac.XOSC,
        pac.CLOCKS,
        pac.PLL_SYS,
        pac.PLL_USB,
        &mut pac.RESETS,
        &mut watchdog,
    ) else {
        fail(&mut led, Step::Clocks)
    };
    let mut timer = hal::Timer::new(pac.TIMER, &mut pac.RESETS, &clocks);
    critical_section::with(|cs| TIMER.borrow(cs).set(Some(timer)));
    info!("clocks: {=u32} Hz", clocks.system_clock.freq().to_Hz());

    let mosi = pins.gpio19.into_function::<FunctionSpi>();
    let sck = pins.gpio18.into_function::<FunctionSpi>();
    // 62.5 MHz: half the 125 MHz peripheral clock, the SPI's maximum
    let spi: Spi0 = hal::spi::Spi::<_, _, _, 8>::new(pac.SPI0, (mosi, sck)).init(
        &mut pac.RESETS,
        clocks.peripheral_clock.freq(),
        62_500_000u32.Hz(),
        embedded_hal::spi::MODE_0,
    );
    let cs: Cs = pins.gpio17.into_push_pull_output();
    let dc: Dc = pins.gpio16.into_push_pull_output();
    let Ok(device) = ExclusiveDevice::new_no_delay(spi, cs);
    let Some(buffer) = cortex_m::singleton!(: [u8; 512] = [0; 512]) else {
        fail(&mut led, Step::Memory)
    };
    let di = SpiInterface::new(device, dc, buffer);
    // a 135×240 window of the controller's 240×320 memory, turned a quarter
    // for 240×135
    let Ok(mut panel) = Builder::new(ST7789, di)
        .display_size(HEIGHT as u16, WIDTH as u16)
        .display_offset(52, 40)
        .orientation(Orientation::new().rotate(Rotation::Deg90))
        .invert_colors(ColorInversion::Inverted)
        .init(&mut timer)
    else {
        fail(&mut led, Step::Panel)
    };
    if panel.clear(Rgb565::BLACK).is_err() {
        fail(&mut led, Step::Clear)
    }
    let _ = backlight.set_high();
    info!("panel ready (cleared, backlight on)");
    let tiles = tile_count(WIDTH, HEIGHT) as u32;
    critical_section::with(|cs| {
        PANEL
            .borrow_ref_mut(cs)
            .replace(Progress::new(panel, tiles, report))
    });

    let (renderer, acc0, acc1) = pico::setup(&mut led, WIDTH, HEIGHT, SEED);
    let size = Size::new(WIDTH, HEIGHT);

    led.set(BLUE);
    info!(
        "rendering {=u32} tiles on two cores: preview, then refinement",
        tiles
    );
    let start = now_us();
    let mut mc = Multicore::new(&mut pac.PSM, &mut pac.PPB, &mut sio.fifo);
    let cores = mc.cores();
    let spawned = match CORE1_STACK.take() {
        Some(stack) => cores[1]
            .spawn(stack, move || {
                let target = LockedPanel {
                    panel: &PANEL,
                    size,
                };
                core1(&renderer, BUDGET, acc1, &QUEUE, target, &CORE1_FAILED)
            })
            .is_ok(),
        None => false,
    };
    let queue = if spawned {
        &QUEUE
    } else {
        warn!("core 1 did not start: core 0 renders alone");
        &QUEUE_ALONE
    };
    let target = LockedPanel {
        panel: &PANEL,
        size,
    };
    core0(
        &renderer,
        BUDGET,
        acc0,
        queue,
        target,
        &CORE1_FAILED,
        &mut led,
        (start, now_us),
    )
}
