//! micropt on a real display board: an STM32F405 driving a 240×240 ST7789
//! SPI panel through `mipidsi`, rendering the Cornell box progressively,
//! tile by tile, straight to the panel.
//!
//! There is no framebuffer: 240×240 Rgb565 is 113 KiB, which does not fit
//! beside the renderer in the F405's 128 KiB of RAM. The core's single-core
//! budget executor (`micropt::budget::render_budget`) keeps one 16×16 tile of
//! sample accumulators (`TileAccum`, 5 KiB, static) and draws every tile
//! twice, each time tone-mapped, dithered and sent to the panel with one
//! `fill_contiguous` (a window write): first a preview (sample 0 of one pixel
//! per 2×2 block) of the whole image, then each tile refined to its share of
//! the budget, with adaptive allocation (more samples where a pixel's
//! estimated error is larger). With [`BUDGET`] = `Budget::Spp(16)` the final
//! image is what the host CLI gives for `micropt render scenes/cornell.scene
//! --size 240x240 --spp 16 --seed 0`. A `Budget::Deadline(µs)` stops refining
//! at a deadline instead, read from the SysTick clock
//! (`examples/board/systick.rs`); the preview always completes.
//!
//! Wiring (SPI1; any STM32F405 board, e.g. a "black F405" or Feather):
//!
//! | panel | MCU                  |
//! | ----- | -------------------- |
//! | GND   | GND                  |
//! | VCC   | 3V3                  |
//! | SCL   | PA5 (SPI1 SCK)       |
//! | SDA   | PA7 (SPI1 MOSI)      |
//! | RES   | PB1                  |
//! | DC    | PB0                  |
//! | CS    | PA4 (absent on some modules: SPI mode 3 works without it) |
//! | BLK   | PA1 (backlight on)   |
//!
//! Build and flash (see docs/firmware.md):
//!
//! ```text
//! cargo build --release --example st7789 --features board-st7789 --target thumbv7em-none-eabihf
//! probe-rs run --chip STM32F405RGTx target/thumbv7em-none-eabihf/release/examples/st7789
//! ```
#![no_std]
#![no_main]

use panic_halt as _;

use cortex_m_rt::entry;
use embedded_hal_bus::spi::ExclusiveDevice;
use micropt::budget::{TileAccum, render_budget};
use micropt::{AdaptiveOptions, Budget, Renderer, Scene};
use mipidsi::Builder;
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::ColorInversion;
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::Config;
use stm32f4xx_hal::spi::{Mode, Phase, Polarity};

#[path = "board/systick.rs"]
mod systick;

/// Panel size.
const WIDTH: u32 = 240;
/// Panel size.
const HEIGHT: u32 = 240;
/// Core clock.
const CORE_HZ: u32 = 168_000_000;
/// The render budget: 16 samples per pixel on average (about 21 s at
/// 168 MHz, estimated at one instruction per cycle from QEMU's instruction
/// count, docs/firmware.md); e.g. `Budget::Deadline(10_000_000)` for a
/// frame in 10 s.
const BUDGET: Budget = Budget::Spp(16);
/// Render seed.
const SEED: u64 = 0;
/// The scene, parsed on the board.
const SCENE_TEXT: &str = include_str!("../scenes/cornell.scene");
/// Fixed capacities: enough for cornell.scene (3 spheres, 6 planes, 6
/// materials); a bigger scene gives a capacity error, not a panic.
type BoardScene = Scene<4, 8, 8>;

#[entry]
fn main() -> ! {
    // static memory, handed out once as `&'static mut` by `#[entry]`
    static mut SPI_BUFFER: [u8; 512] = [0; 512];
    static mut ACCUM: TileAccum = TileAccum::new();
    // `Scene::EMPTY` is all zeros (.bss, not flash); parsed into in place
    static mut SCENE: BoardScene = BoardScene::EMPTY;

    let (Some(dp), Some(cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take()) else {
        halt()
    };
    // 168 MHz from the internal 16 MHz oscillator: no crystal assumed
    let mut rcc = dp.RCC.freeze(Config::hsi().sysclk(CORE_HZ.Hz()));
    let mut delay = cp.SYST.delay(&rcc.clocks);
    let gpioa = dp.GPIOA.split(&mut rcc);
    let gpiob = dp.GPIOB.split(&mut rcc);

    let mut backlight = gpioa.pa1.into_push_pull_output();
    backlight.set_high();
    let spi = dp.SPI1.spi(
        (Some(gpioa.pa5), pac::SPI1::NoMiso, Some(gpioa.pa7)),
        Mode {
            polarity: Polarity::IdleHigh,
            phase: Phase::CaptureOnSecondTransition,
        },
        21.MHz(),
        &mut rcc,
    );
    let cs = gpioa.pa4.into_push_pull_output();
    let dc = gpiob.pb0.into_push_pull_output();
    let rst = gpiob.pb1.into_push_pull_output();
    // the HAL's pins cannot fail (Infallible errors)
    let Ok(device) = ExclusiveDevice::new_no_delay(spi, cs);
    let di = SpiInterface::new(device, dc, SPI_BUFFER);
    let Ok(mut display) = Builder::new(ST7789, di)
        .display_size(WIDTH as u16, HEIGHT as u16)
        .invert_colors(ColorInversion::Inverted)
        .reset_pin(rst)
        .init(&mut delay)
    else {
        halt()
    };

    // SysTick did the panel's reset delays; now it is the render's clock
    let mut clock = systick::SysTickClock::start(delay.release().release(), CORE_HZ);

    // parsed in place into static memory: the stack holds only the parser
    if micropt::parse::parse_into(SCENE_TEXT, SCENE).is_err() {
        halt()
    }
    let scene: &BoardScene = SCENE;
    let Ok(renderer) = Renderer::new(scene, WIDTH, HEIGHT) else {
        halt()
    };
    let renderer = renderer.seed(SEED);
    // preview first, then refined tiles, each straight to the panel
    let _ = render_budget(
        &renderer,
        BUDGET,
        &AdaptiveOptions::default(),
        ACCUM,
        &mut clock,
        &mut display,
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
