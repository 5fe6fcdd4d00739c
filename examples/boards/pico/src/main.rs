//! micropt on a Raspberry Pi Pico (RP2040, Cortex-M0+ at 125 MHz, no FPU)
//! with a Pimoroni Pico Display Pack (ST7789, 1.14", 240×135), rendering the
//! Cornell box progressively, tile by tile, straight to the panel through
//! `mipidsi`.
//!
//! The core's single-core budget executor (`micropt::budget::render_budget`)
//! keeps one 16×16 tile of sample accumulators (`TileAccum`, 5 KiB, static)
//! and draws every tile twice, tone-mapped, dithered, with one window write:
//! first a 1-sample preview of the whole image, then each tile refined to
//! its share of [`BUDGET`] with adaptive allocation. With
//! `Budget::Spp(16)` the final image is the host's
//! `micropt render scenes/cornell.scene --size 240x135 --spp 16 --seed 0`.
//! The M0+ has no FPU: every float operation is a software routine, micropt's
//! correctly rounded ones (`micropt::math::soft`, exported under the
//! runtime's names by `examples/board/softfloat.rs`; the HAL's
//! `disable-intrinsics` feature keeps it from installing the boot ROM's,
//! which flush subnormals to zero and so could change bits), so a frame is
//! many times slower than on an M4F (docs/boards.md); a
//! `Budget::Deadline(µs)` caps it instead, read from the RP2040's 1 MHz
//! timer. One core renders (the RP2350 example splits tiles over two with
//! atomic read-modify-write, which Armv6-M lacks).
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
//! | backlight | GP20 (driven high) |
//! | reset     | not wired (the panel resets at power-on) |
//!
//! Build and flash, the Pico in BOOTSEL mode (it mounts as a USB drive):
//!
//! ```text
//! cd examples/boards/pico
//! cargo build --release
//! elf2uf2-rs -d target/thumbv6m-none-eabi/release/micropt-pico
//! ```
//!
//! (or `picotool load -u -v -x -t elf` with the same file).
#![no_std]
#![no_main]

// micropt's soft-float routines under the runtime's names (same bits as the
// host, about half the instructions of compiler-builtins' on Armv6-M)
#[path = "../../../board/softfloat.rs"]
mod softfloat;

use panic_halt as _;

use embedded_hal::digital::OutputPin;
use embedded_hal_bus::spi::ExclusiveDevice;
use hal::Clock as _;
use hal::fugit::RateExtU32;
use hal::gpio::FunctionSpi;
use micropt::budget::{TileAccum, render_budget};
use micropt::{AdaptiveOptions, Budget, Renderer, Scene};
use mipidsi::Builder;
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::{ColorInversion, Orientation, Rotation};
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
/// The render budget: 16 samples per pixel on average; e.g.
/// `Budget::Deadline(60_000_000)` for a frame in a minute.
const BUDGET: Budget = Budget::Spp(16);
/// Render seed.
const SEED: u64 = 0;
/// The scene, parsed on the board.
const SCENE_TEXT: &str = include_str!("../../../../scenes/cornell.scene");
/// Fixed capacities: enough for cornell.scene (3 spheres, 6 planes, 6
/// materials); a bigger scene gives a capacity error, not a panic.
type BoardScene = Scene<4, 8, 8>;

/// Microseconds from the RP2040's 64-bit 1 MHz timer.
struct TimerClock(hal::Timer);

impl micropt::Clock for TimerClock {
    fn micros(&mut self) -> u64 {
        self.0.get_counter().ticks()
    }
}

#[hal::entry]
fn main() -> ! {
    let Some(mut pac) = hal::pac::Peripherals::take() else {
        halt()
    };
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
        halt()
    };
    let mut timer = hal::Timer::new(pac.TIMER, &mut pac.RESETS, &clocks);
    let sio = hal::Sio::new(pac.SIO);
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
    // 62.5 MHz: half the 125 MHz peripheral clock, the SPI's maximum
    let spi = hal::spi::Spi::<_, _, _, 8>::new(pac.SPI0, (mosi, sck)).init(
        &mut pac.RESETS,
        clocks.peripheral_clock.freq(),
        62_500_000u32.Hz(),
        embedded_hal::spi::MODE_0,
    );
    let cs = pins.gpio17.into_push_pull_output();
    let dc = pins.gpio16.into_push_pull_output();
    let Ok(device) = ExclusiveDevice::new_no_delay(spi, cs);
    let Some(buffer) = cortex_m::singleton!(: [u8; 512] = [0; 512]) else {
        halt()
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
        halt()
    };

    // static memory: the scene (parsed in place) and the tile accumulators
    let (Some(scene), Some(acc)) = (
        cortex_m::singleton!(: BoardScene = BoardScene::EMPTY),
        cortex_m::singleton!(: TileAccum = TileAccum::new()),
    ) else {
        halt()
    };
    if micropt::parse::parse_into(SCENE_TEXT, scene).is_err() {
        halt()
    }
    let scene: &BoardScene = scene;
    let Ok(renderer) = Renderer::new(scene, WIDTH, HEIGHT) else {
        halt()
    };
    let renderer = renderer.seed(SEED);
    let mut clock = TimerClock(timer);
    // preview first, then refined tiles, each straight to the panel
    let _ = render_budget(
        &renderer,
        BUDGET,
        &AdaptiveOptions::default(),
        acc,
        &mut clock,
        &mut panel,
        1.0,
    );
    halt()
}

/// Stops here (done, or no way to report an error without a debugger).
fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}
