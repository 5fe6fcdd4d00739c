//! micropt on a Raspberry Pi Pico 2 (RP2350, two Cortex-M33 cores with
//! FPUs at 150 MHz) with a Pimoroni Pico Display Pack 2.0 (ST7789, 2.0",
//! 320×240), rendering the Cornell box on both cores, progressively, tile
//! by tile, straight to the panel through `mipidsi`.
//!
//! Both cores run the core's shared executor
//! (`micropt::multicore::render_shared`): a preview of every tile (sample 0
//! of one pixel per 2×2 block), then every tile refined to its share of
//! [`BUDGET`] with adaptive allocation, each core taking the next tile from
//! one queue of atomic counters (`micropt::multicore::AtomicQueue`). Each
//! core keeps one 16×16 tile of sample accumulators (`TileAccum`, 5 KiB,
//! static) and draws its finished tiles itself, holding the panel for one
//! window write. The image does not depend on which core rendered which tile:
//! with `Budget::Spp(16)` it is the host's `micropt render
//! scenes/cornell.scene --size 320x240 --spp 16 --seed 0`, bit for bit. There
//! is no framebuffer (one would fit in the RP2350's 520 KiB, but the render
//! does not need it). The FPUs do the f32 arithmetic (no float routine is
//! linked for it).
//!
//! What it shows: the panel is cleared to black before the backlight comes
//! on, then the preview fills it in tile by tile, then the refined tiles
//! replace it. The pack's RGB LED: blue while rendering, green when the
//! frame is done, red blinking N times (then a pause, again) when init
//! step N failed ([`Step`]). Over a debug probe (`cargo run --release`:
//! `probe-rs run`), defmt prints each step, the preview's and each tenth
//! of the refinement's progress, and the frame time.
//!
//! Wiring: none, the Display Pack 2.0 plugs onto the Pico 2's headers. It uses
//! (Pimoroni's pinout):
//!
//! | panel     | RP2350 |
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

#[path = "../../../board/locked_panel.rs"]
mod locked_panel;
#[path = "../../../board/pico.rs"]
mod pico;
#[path = "../../../board/progress.rs"]
mod progress;

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
use micropt::multicore::AtomicQueue;
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::{ColorInversion, Orientation, Rotation};
use mipidsi::{Builder, NoResetPin};
use pico::{BLUE, Led, Step, core0, core1, fail, report};
use progress::Progress;
use rp235x_hal as hal;

/// Tells the boot ROM that this is an Arm executable (in the first 4 KiB
/// of flash: memory.x).
#[unsafe(link_section = ".start_block")]
#[used]
pub static IMAGE_DEF: hal::block::ImageDef = hal::block::ImageDef::secure_exe();

/// The Pico 2's crystal.
const XTAL_HZ: u32 = 12_000_000;
/// Panel size (landscape).
const WIDTH: u32 = 320;
/// Panel size (landscape).
const HEIGHT: u32 = 240;
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
static QUEUE: AtomicQueue = AtomicQueue::new(2);
/// The queue when core 1 did not start.
static QUEUE_ALONE: AtomicQueue = AtomicQueue::new(1);
/// Core 1's stack: 16 KiB, its tile accumulators static (the render's
/// stack depth measured in QEMU: docs/boards.md).
static CORE1_STACK: Stack<4096> = Stack::new();
/// Set by core 1 if it could not draw to the panel.
static CORE1_FAILED: AtomicBool = AtomicBool::new(false);
/// The 1 MHz timer, for log timestamps (set once the clocks run).
static TIMER: Mutex<Cell<Option<Timer0>>> = Mutex::new(Cell::new(None));

type Timer0 = hal::Timer<hal::timer::CopyableTimer0>;

/// Microseconds since the timer started (0 before).
fn now_us() -> u64 {
    critical_section::with(|cs| TIMER.borrow(cs).get()).map_or(0, |t| t.get_counter().ticks())
}

defmt::timestamp!("{=u64:us}", now_us());

#[hal::entry]
fn main() -> ! {
    info!(
        "micropt on Raspberry Pi Pico 2 + Pico Display Pack 2.0: cornell {=u32}x{=u32}",
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
    // 150 MHz system clock from the 12 MHz crystal
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
    let mut timer = hal::Timer::new_timer0(pac.TIMER0, &mut pac.RESETS, &clocks);
    critical_section::with(|cs| TIMER.borrow(cs).set(Some(timer)));
    info!("clocks: {=u32} Hz", clocks.system_clock.freq().to_Hz());

    let mosi = pins.gpio19.into_function::<FunctionSpi>();
    let sck = pins.gpio18.into_function::<FunctionSpi>();
    // at most 62.5 MHz, the ST7789's write clock: the divider of the 150 MHz
    // peripheral clock gives 37.5 MHz (150 / 4; the next step is 75 MHz)
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
    // the panel is 240×320 portrait; turned a quarter for 320×240
    let Ok(mut panel) = Builder::new(ST7789, di)
        .display_size(HEIGHT as u16, WIDTH as u16)
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
