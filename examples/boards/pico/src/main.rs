//! micropt on a Raspberry Pi Pico (RP2040, two Cortex-M0+ cores at 125 MHz,
//! no FPU) with a Pimoroni Pico Display Pack (ST7789, 1.14", 240×135),
//! rendering the Cornell box at 16 samples a pixel on both cores and
//! denoising it on the board, row by row, straight to the panel through
//! `mipidsi`.
//!
//! The denoised frame (`examples/board/denoised.rs`): core 1 renders the
//! odd pixels of each row and hands them to core 0 (`mailbox.rs`, under
//! the RP2040's hardware spinlock); core 0 renders the even ones and runs
//! micropt's streaming denoiser, which asks for each pixel a few rows ahead
//! of the row it filters and gives each row as soon as it is chosen; the
//! row goes to the panel at once. No frame of samples and no framebuffer:
//! static RAM is the denoiser's rings (one `Column` of 796 bytes a pixel of
//! a row: 191,040 bytes), a row of moments each side and one of colours.
//! The image is the host's `micropt render scenes/cornell.scene --size
//! 240x135 --spp 16 --seed 0 --uniform --denoise`, bit for bit. With
//! `--features raw` the example renders the raw frame instead, through the
//! core's shared tile executor: a preview of every tile, then every tile
//! refined with adaptive allocation, each core taking the next tile from
//! one queue (`queue.rs`: the M0+ has no atomic read-modify-write, so it
//! counts under the spinlock); that image is `micropt render
//! scenes/cornell.scene --size 240x135 --spp 16 --seed 0`.
//!
//! The M0+ has no FPU: every f32 add, subtract, multiply, divide, compare
//! and int-to-float conversion is micropt's correctly rounded routine
//! (`micropt::math::soft`, exported under the ARM EABI names by
//! `examples/board/softfloat.rs`; the HAL's `disable-intrinsics` feature
//! keeps it from installing the boot ROM's, which flush subnormals to zero
//! and so could change bits). A frame takes minutes (docs/boards.md).
//!
//! What it shows: the panel is cleared to black before the backlight comes
//! on, then the denoised rows appear from the top (the raw frame: the
//! preview fills it in tile by tile, then the refined tiles replace it).
//! The pack's RGB LED: blue while rendering, green when the frame is done,
//! red blinking N times (then a pause, again) when init step N failed
//! ([`Step`]). Over a debug probe (`cargo run --release`: `probe-rs run`),
//! defmt prints each step, each tenth of the rows (or of the refinement),
//! and the frame time.
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

#[cfg(feature = "raw")]
#[path = "../../../board/locked_panel.rs"]
mod locked_panel;
#[path = "../../../board/pico.rs"]
mod pico;
#[cfg(feature = "raw")]
#[path = "../../../board/progress.rs"]
mod progress;
#[cfg(feature = "raw")]
mod queue;

use defmt_rtt as _;
use panic_probe as _;

use core::cell::Cell;
use critical_section::Mutex;
use defmt::info;
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::pixelcolor::{Rgb565, RgbColor};
use embedded_hal::digital::OutputPin;
use embedded_hal_bus::spi::{ExclusiveDevice, NoDelay};
use hal::Clock as _;
use hal::fugit::RateExtU32;
use hal::gpio::bank0::{Gpio16, Gpio17, Gpio18, Gpio19};
use hal::gpio::{FunctionSioOutput, FunctionSpi, Pin, PinState, PullDown};
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::{ColorInversion, Orientation, Rotation};
use mipidsi::{Builder, NoResetPin};
use pico::{Led, Step, fail};
use rp2040_hal as hal;
#[cfg(feature = "raw")]
use {
    core::cell::RefCell,
    core::sync::atomic::AtomicBool,
    embedded_graphics::geometry::Size,
    hal::multicore::{Multicore, Stack},
    locked_panel::LockedPanel,
    micropt::Budget,
    micropt::film::tile_count,
    progress::Progress,
    queue::LockedQueue,
};
#[cfg(not(feature = "raw"))]
use {
    embedded_hal::digital::InputPin,
    micropt::demo::{Entry, SCENES as SHIPPED},
    static_cell::ConstStaticCell,
};

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
/// The raw frame's budget: 16 samples per pixel on average. A sample
/// budget (`Spp` or `Paths`): the two-core executor refuses a deadline.
#[cfg(feature = "raw")]
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

/// The panel as both cores see it, each drawing its tiles (counted for
/// the progress log): the raw frame. (The denoised frame is drawn by core
/// 0 alone.)
#[cfg(feature = "raw")]
static PANEL: Mutex<RefCell<Option<Progress<Panel>>>> = Mutex::new(RefCell::new(None));
/// The two cores' tile queue.
#[cfg(feature = "raw")]
static QUEUE: LockedQueue = LockedQueue::new(2);
/// The queue when core 1 did not start.
#[cfg(feature = "raw")]
static QUEUE_ALONE: LockedQueue = LockedQueue::new(1);
/// Set by core 1 if it could not draw to the panel.
#[cfg(feature = "raw")]
static CORE1_FAILED: AtomicBool = AtomicBool::new(false);

/// The demo's scenes (button A steps through them): the first 4 shipped.
#[cfg(not(feature = "raw"))]
const SCENES: &[Entry] = match SHIPPED.split_at_checked(4) {
    Some((first, _)) => first,
    None => &SHIPPED,
};
/// The shipped scenes left out, and why (logged at boot).
/// many: 482 spheres: its scene (about 100 KB) does not fit beside the denoiser's rings (191 KB) in the RP2040's 264 KB.
#[cfg(not(feature = "raw"))]
const LEFT_OUT: [(&str, &str); 1] = [(
    "many",
    "482 spheres: its scene (about 100 KB) does not fit beside the denoiser's rings (191 KB) in the RP2040's 264 KB",
)];
/// The demo's memory: the denoiser's rings, a row of colours, the scene
/// (at most 80 spheres, 8 planes, 16 materials).
#[cfg(not(feature = "raw"))]
static MEMORY: ConstStaticCell<pico::DemoMemory<{ WIDTH as usize }, 80, 8, 16>> =
    ConstStaticCell::new(pico::DemoMemory::new());
#[cfg(feature = "raw")]
/// Core 1's stack: 16 KiB, its tile accumulators static (the render's
/// stack depth measured in QEMU: docs/boards.md).
static CORE1_STACK: Stack<4096> = Stack::new();
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
    let sio = hal::Sio::new(pac.SIO);
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
    let Ok::<Panel, _>(mut panel) = Builder::new(ST7789, di)
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
    #[cfg(not(feature = "raw"))]
    {
        // the Display Pack's buttons A, B, X, Y: to ground when pressed
        let mut buttons = [
            pins.gpio12.into_pull_up_input().into_dyn_pin(),
            pins.gpio13.into_pull_up_input().into_dyn_pin(),
            pins.gpio14.into_pull_up_input().into_dyn_pin(),
            pins.gpio15.into_pull_up_input().into_dyn_pin(),
        ];
        for (name, why) in LEFT_OUT {
            info!("scene {=str} left out: {=str}", name, why);
        }
        pico::demo(
            SCENES,
            MEMORY.try_take(),
            ((WIDTH, HEIGHT), SEED),
            panel,
            move || {
                let mut down = [false; 4];
                for (d, pin) in down.iter_mut().zip(buttons.iter_mut()) {
                    *d = pin.is_low().unwrap_or(false);
                }
                down
            },
            &mut led,
            now_us,
        )
    }

    #[cfg(feature = "raw")]
    {
        let renderer = pico::setup(&mut led, WIDTH, HEIGHT, SEED);
        let mut fifo = sio.fifo;
        let mut mc = Multicore::new(&mut pac.PSM, &mut pac.PPB, &mut fifo);
        let cores = mc.cores();
        let tiles = tile_count(WIDTH, HEIGHT) as u32;
        let counted = Progress::new(panel, tiles, pico::report);
        critical_section::with(|cs| PANEL.borrow_ref_mut(cs).replace(counted));
        let target = || LockedPanel {
            panel: &PANEL,
            size: Size::new(WIDTH, HEIGHT),
        };
        pico::raw(
            renderer,
            BUDGET,
            (&QUEUE, &QUEUE_ALONE),
            &CORE1_FAILED,
            target,
            |part| match CORE1_STACK.take() {
                Some(stack) => cores[1].spawn(stack, move || part.run()).is_ok(),
                None => false,
            },
            &mut led,
            now_us,
        )
    }
}
