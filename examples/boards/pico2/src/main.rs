//! micropt on a Raspberry Pi Pico 2 (RP2350, two Cortex-M33 cores with
//! FPUs, 150 MHz) with a Pimoroni Pico Display Pack 2.0 (ST7789, 320×240),
//! rendering the Cornell box on both cores, progressively, straight to the
//! panel through `mipidsi`.
//!
//! There is no framebuffer (one would fit in the RP2350's 520 KiB, but the
//! render does not need it): each core keeps one 16×16 tile of sample
//! accumulators (`TileAccum`, 5 KiB) and the cores split the tiles through
//! an atomic work counter (`split.rs`): first a 1-sample preview of every
//! tile, then every tile refined to its share of [`BUDGET`] with adaptive
//! allocation. A core draws each finished tile itself, holding the panel
//! for one window write (the HAL's critical section is a hardware spinlock,
//! so it excludes the other core). The image does not depend on which core
//! rendered which tile: it is the host's
//! `micropt render scenes/cornell.scene --size 320x240 --spp 16 --seed 0`.
//!
//! Wiring: none, the Display Pack plugs onto the Pico 2's headers. It uses
//! (Pimoroni's pinout):
//!
//! | panel     | RP2350 |
//! | --------- | ------ |
//! | SCK       | GP18 (SPI0 SCK) |
//! | MOSI      | GP19 (SPI0 TX)  |
//! | CS        | GP17   |
//! | DC        | GP16   |
//! | backlight | GP20 (driven high) |
//! | reset     | not wired (the panel resets at power-on) |
//!
//! Build and flash (picotool 2; elf2uf2-rs does not know the RP2350), the
//! Pico 2 in BOOTSEL mode:
//!
//! ```text
//! cd examples/boards/pico2
//! cargo build --release
//! picotool load -u -v -x -t elf target/thumbv8m.main-none-eabihf/release/micropt-pico2
//! ```
#![no_std]
#![no_main]

use panic_halt as _;

use core::cell::RefCell;
use critical_section::Mutex;
use embedded_hal::digital::OutputPin;
use embedded_hal_bus::spi::{ExclusiveDevice, NoDelay};
use hal::Clock as _;
use hal::fugit::RateExtU32;
use hal::gpio::bank0::{Gpio16, Gpio17, Gpio18, Gpio19};
use hal::gpio::{FunctionSioOutput, FunctionSpi, Pin, PullDown};
use hal::multicore::{Multicore, Stack};
use micropt::budget::TileAccum;
use micropt::film::{Tile, draw_tile_iter, tile_count};
use micropt::{AdaptiveOptions, Budget, Renderer, Scene, Stats};
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::{ColorInversion, Orientation, Rotation};
use mipidsi::{Builder, NoResetPin};
use rp235x_hal as hal;

mod split;

/// Tells the boot ROM that this is an Arm executable.
#[unsafe(link_section = ".start_block")]
#[used]
pub static IMAGE_DEF: hal::block::ImageDef = hal::block::ImageDef::secure_exe();

/// The Pico 2's crystal.
const XTAL_HZ: u32 = 12_000_000;
/// Panel size (landscape).
const WIDTH: u32 = 320;
/// Panel size (landscape).
const HEIGHT: u32 = 240;
/// Tiles of the image.
const TILES: usize = tile_count(WIDTH, HEIGHT);
/// The render budget: 16 samples per pixel on average. A sample budget
/// (`Spp`, `Paths`): the two-core split has no deadline.
const BUDGET: Budget = Budget::Spp(16);
/// Render seed.
const SEED: u64 = 0;
/// The scene, parsed on the board.
const SCENE_TEXT: &str = include_str!("../../../../scenes/cornell.scene");
/// Fixed capacities: enough for cornell.scene (3 spheres, 6 planes, 6
/// materials); a bigger scene gives a capacity error, not a panic.
type BoardScene = Scene<4, 8, 8>;

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
static PANEL: Mutex<RefCell<Option<Panel>>> = Mutex::new(RefCell::new(None));
/// The two cores' work counters.
static SPLIT: split::Split = split::Split::new();
/// Core 1's stack (core 0 has the rest of RAM). 16 KiB: the render's deepest
/// stack is under 4 KiB (docs/firmware.md).
static CORE1_STACK: Stack<4096> = Stack::new();
/// Set by core 1 when it has taken its last work item and drawn it.
static CORE1_DONE: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

#[hal::entry]
fn main() -> ! {
    let Some(mut pac) = hal::pac::Peripherals::take() else {
        halt()
    };
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
        halt()
    };
    let mut timer = hal::Timer::new_timer0(pac.TIMER0, &mut pac.RESETS, &clocks);
    let mut sio = hal::Sio::new(pac.SIO);
    let pins = hal::gpio::Pins::new(
        pac.IO_BANK0,
        pac.PADS_BANK0,
        sio.gpio_bank0,
        &mut pac.RESETS,
    );

    let mut backlight = pins.gpio20.into_push_pull_output();
    let _ = backlight.set_high();
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
        halt()
    };
    let di = SpiInterface::new(device, dc, buffer);
    // the panel is 240×320 portrait; turned a quarter for 320×240
    let Ok(panel) = Builder::new(ST7789, di)
        .display_size(HEIGHT as u16, WIDTH as u16)
        .orientation(Orientation::new().rotate(Rotation::Deg90))
        .invert_colors(ColorInversion::Inverted)
        .init(&mut timer)
    else {
        halt()
    };
    critical_section::with(|cs| PANEL.borrow_ref_mut(cs).replace(panel));

    // static memory: the scene (parsed in place), the tile shares, and one
    // tile of accumulators per core
    let Some(scene) = cortex_m::singleton!(: BoardScene = BoardScene::EMPTY) else {
        halt()
    };
    if micropt::parse::parse_into(SCENE_TEXT, scene).is_err() {
        halt()
    }
    let scene: &'static BoardScene = scene;
    let Ok(renderer) = Renderer::new(scene, WIDTH, HEIGHT) else {
        halt()
    };
    let renderer = renderer.seed(SEED);
    let Some(shares) = cortex_m::singleton!(: [u64; TILES] = [0; TILES]) else {
        halt()
    };
    if split::shares(&BUDGET, WIDTH, HEIGHT, shares).is_none() {
        halt()
    }
    let shares: &'static [u64; TILES] = shares;
    let (Some(acc0), Some(acc1)) = (
        cortex_m::singleton!(: TileAccum = TileAccum::new()),
        cortex_m::singleton!(: TileAccum = TileAccum::new()),
    ) else {
        halt()
    };

    let start = timer.get_counter();
    let mut mc = Multicore::new(&mut pac.PSM, &mut pac.PPB, &mut sio.fifo);
    let cores = mc.cores();
    let Some(stack) = CORE1_STACK.take() else {
        halt()
    };
    let core1 = cores[1].spawn(stack, move || {
        let mut stats = Stats::default();
        SPLIT.work(
            &renderer,
            shares,
            &AdaptiveOptions::default(),
            acc1,
            &mut stats,
            draw,
        );
        CORE1_DONE.store(true, core::sync::atomic::Ordering::Release);
        halt()
    });
    let mut stats = Stats::default();
    SPLIT.work(
        &renderer,
        shares,
        &AdaptiveOptions::default(),
        acc0,
        &mut stats,
        draw,
    );
    // core 1 renders alone if it did not start
    if core1.is_ok() {
        while !CORE1_DONE.load(core::sync::atomic::Ordering::Acquire) {
            cortex_m::asm::nop();
        }
    }
    // the frame time, for a debugger (`FRAME_MICROS`)
    let micros = (timer.get_counter() - start).to_micros();
    FRAME_MICROS.store(micros as u32, core::sync::atomic::Ordering::Relaxed);
    halt()
}

/// The whole frame's time in microseconds once both cores are done (0
/// before): read it with a debug probe.
#[unsafe(no_mangle)]
pub static FRAME_MICROS: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

/// Draws a tile's means to the panel (tone-mapped, dithered, one window
/// write), holding the panel against the other core.
fn draw(tile: &Tile, acc: &TileAccum) {
    critical_section::with(|cs| {
        if let Some(panel) = PANEL.borrow_ref_mut(cs).as_mut() {
            let _ = draw_tile_iter(panel, tile, acc.mean_iter(), 1.0);
        }
    });
}

/// Stops here (done, or no way to report an error without a debugger).
fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}
