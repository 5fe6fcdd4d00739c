//! micropt on an ESP32-C3 (one RISC-V RV32IMC core at 160 MHz, no FPU) with
//! a 240×240 ST7789 SPI panel, rendering the Cornell box at 16 samples a
//! pixel and denoising it on the board, row by row, straight to the panel
//! through `mipidsi`.
//!
//! The denoised frame (`examples/board/denoised.rs`): micropt's streaming
//! denoiser asks for each pixel's samples a few rows ahead of the row it
//! filters and gives each row as soon as it is chosen; the row goes to the
//! panel at once. No frame of samples and no framebuffer: static RAM is the
//! denoiser's rings (one `Column` of 796 bytes a pixel of a row: 191,040
//! bytes) and one row of colours. The image is the host's `micropt render
//! scenes/cornell.scene --size 240x240 --spp 16 --seed 0 --uniform
//! --denoise`, bit for bit. With `--features raw` the example renders the
//! raw frame instead, through the core's single-core budget executor
//! (`micropt::budget::render_budget`: one 16×16 tile of accumulators, a
//! preview of the whole image, then each tile refined with adaptive
//! allocation; with `Budget::Spp(16)` the host's `micropt render
//! scenes/cornell.scene --size 240x240 --spp 16 --seed 0`; a
//! `Budget::Deadline(µs)` caps it instead). The C3 has no FPU: every f32
//! add, subtract, multiply, divide, compare and int-to-float conversion is
//! micropt's correctly rounded routine (`micropt::math::soft`, exported
//! under the libgcc names by `examples/board/softfloat.rs`), not the chip's
//! mask-ROM libgcc, which esp-hal's linker script would bind them to
//! (`build.rs` says how that is kept off). So a frame is many times slower
//! than on an M4F (docs/boards.md).
//!
//! Wiring (SPI2 on its IO MUX pins; any ESP32-C3 board, e.g. an
//! ESP32-C3-DevKitM-1 or a "C3 SuperMini", and an ST7789 240×240 module):
//!
//! | panel | ESP32-C3           |
//! | ----- | ------------------ |
//! | GND   | GND                |
//! | VCC   | 3V3                |
//! | SCL   | GPIO6 (SPI2 SCK)   |
//! | SDA   | GPIO7 (SPI2 MOSI)  |
//! | RES   | GPIO5              |
//! | DC    | GPIO4              |
//! | CS    | GPIO10 (absent on some modules: leave it unconnected) |
//! | BLK   | GPIO3 (high after the panel is cleared) |
//!
//! (Clear of the strapping pins GPIO2/8/9, the flash pins GPIO12–17 and
//! USB's GPIO18/19.)
//!
//! What it shows: the panel is cleared to black before the backlight comes
//! on, then the denoised rows appear from the top (the raw frame: the
//! preview fills it in tile by tile, then the refined tiles replace it).
//! Over USB (`espflash flash --monitor`, or any serial monitor
//! on the board's USB port: esp-println writes to the C3's USB serial/JTAG
//! or to UART0, whichever the board's USB connector is wired to) it prints
//! each init step, each tenth of the rows (or the preview and each tenth of
//! the refinement), and the frame time; a failed step says which. The backlight
//! stays off if the panel could not be set up.
//!
//! Build and flash: docs/boards.md.
#![no_std]
#![no_main]

// micropt's soft-float routines under the runtime's names (same bits as the
// host; build.rs keeps the ROM's libgcc table from overriding them)
#[path = "../../../board/softfloat.rs"]
mod softfloat;

#[cfg(feature = "raw")]
#[path = "../../../board/progress.rs"]
mod progress;

use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::pixelcolor::{Rgb565, RgbColor};
use embedded_hal_bus::spi::ExclusiveDevice;
use esp_hal::clock::CpuClock;
use esp_hal::delay::Delay;
use esp_hal::gpio::{Level, Output, OutputConfig};
use esp_hal::spi::Mode;
use esp_hal::spi::master::{Config, Spi};
use esp_hal::time::{Instant, Rate};
use esp_println::println;
use micropt::Scene;
use mipidsi::Builder;
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::ColorInversion;
#[cfg(not(feature = "raw"))]
use {
    esp_hal::gpio::{Input, InputConfig, Pull},
    micropt::demo::{Buttons, Command, Demo, Entry, OneCore, Press, SCENES as SHIPPED, Step},
    micropt::denoise::Column,
    static_cell::ConstStaticCell,
};
#[cfg(feature = "raw")]
use {
    micropt::Renderer,
    micropt::budget::{TileAccum, render_budget},
    micropt::film::tile_count,
    micropt::{AdaptiveOptions, Budget},
    progress::{Milestone, Progress},
};

// the application descriptor the ESP-IDF second-stage bootloader checks
esp_bootloader_esp_idf::esp_app_desc!();

/// Panel size.
const WIDTH: u32 = 240;
/// Panel size.
const HEIGHT: u32 = 240;
/// The raw frame's budget: 16 samples per pixel on average; e.g.
/// `Budget::Deadline(60_000_000)` for a frame in a minute.
#[cfg(feature = "raw")]
const BUDGET: Budget = Budget::Spp(16);
/// Render seed.
const SEED: u64 = 0;
/// The raw frame's scene, parsed on the board.
#[cfg(feature = "raw")]
const SCENE_TEXT: &str = include_str!("../../../../scenes/cornell.scene");
/// Fixed capacities: enough for cornell.scene (3 spheres, 6 planes, 6
/// materials); a bigger scene gives a capacity error, not a panic.
#[cfg(feature = "raw")]
type BoardScene = Scene<4, 8, 8>;

/// The demo's scenes (a short press of BOOT steps through them): the
/// first four shipped.
#[cfg(not(feature = "raw"))]
const SCENES: &[Entry] = match SHIPPED.split_at_checked(4) {
    Some((first, _)) => first,
    None => &SHIPPED,
};
/// The shipped scenes left out, and why (printed at boot): many, 482
/// spheres, whose scene (about 100 KB) does not fit beside the denoiser's
/// rings (191 KB) and the stack in the C3's SRAM.
#[cfg(not(feature = "raw"))]
const LEFT_OUT: [(&str, &str); 1] = [(
    "many",
    "482 spheres: its scene (about 100 KB) does not fit beside the denoiser's rings (191 KB) and the stack in the C3's SRAM",
)];

/// The demo's memory: the denoiser's rings (one `Column` a pixel of a
/// row), a row of panel colours, the scene (at most 80 spheres, 8 planes,
/// 16 materials). All zero bits: .bss.
#[cfg(not(feature = "raw"))]
struct DemoMemory {
    columns: [Column; WIDTH as usize],
    line: [Rgb565; WIDTH as usize],
    scene: Scene<80, 8, 16>,
}

#[cfg(not(feature = "raw"))]
static MEMORY: ConstStaticCell<DemoMemory> = ConstStaticCell::new(DemoMemory {
    columns: [Column::EMPTY; WIDTH as usize],
    line: [Rgb565::BLACK; WIDTH as usize],
    scene: Scene::EMPTY,
});

/// Microseconds since boot, from esp-hal's system timer.
struct SysClock;

impl micropt::Clock for SysClock {
    fn micros(&mut self) -> u64 {
        Instant::now().duration_since_epoch().as_micros()
    }
}

/// Seconds since boot, with milliseconds, for the log.
fn stamp() -> (u64, u64) {
    let ms = Instant::now().duration_since_epoch().as_millis();
    (ms / 1000, ms % 1000)
}

/// Logs how far the frame has come.
#[cfg(feature = "raw")]
fn report(m: Milestone) {
    let (s, ms) = stamp();
    match m {
        Milestone::Preview => println!("[{s}.{ms:03}] preview on the panel"),
        Milestone::Refined(p) => println!("[{s}.{ms:03}] refined: {p}%"),
    }
}

/// Says which init step failed, and stops.
fn fail(step: &str) -> ! {
    let (s, ms) = stamp();
    println!("[{s}.{ms:03}] error: {step} failed; stopped");
    halt()
}

/// Stops here on a panic, after printing it.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    println!("panic: {info}");
    halt()
}

#[esp_hal::main]
fn main() -> ! {
    let p = esp_hal::init(esp_hal::Config::default().with_cpu_clock(CpuClock::max()));
    println!("micropt on ESP32-C3 + ST7789: cornell {WIDTH}x{HEIGHT}");
    // backlight off until the panel is cleared
    let mut backlight = Output::new(p.GPIO3, Level::Low, OutputConfig::default());
    // mode 3: CS-less 240×240 modules only answer in it, and it works with
    // CS wired too
    let Ok(spi) = Spi::new(
        p.SPI2,
        Config::default()
            .with_frequency(Rate::from_mhz(40))
            .with_mode(Mode::_3),
    ) else {
        fail("SPI2 setup (40 MHz, mode 3)")
    };
    let spi = spi.with_sck(p.GPIO6).with_mosi(p.GPIO7);
    let cs = Output::new(p.GPIO10, Level::High, OutputConfig::default());
    let dc = Output::new(p.GPIO4, Level::Low, OutputConfig::default());
    let rst = Output::new(p.GPIO5, Level::High, OutputConfig::default());
    let Ok(device) = ExclusiveDevice::new_no_delay(spi, cs);
    // on the stack, as are the scene and the accumulators below: main never
    // returns, and the C3's stack is most of its 400 KiB of SRAM
    let mut buffer = [0u8; 512];
    let di = SpiInterface::new(device, dc, &mut buffer);
    let Ok(mut panel) = Builder::new(ST7789, di)
        .display_size(WIDTH as u16, HEIGHT as u16)
        .invert_colors(ColorInversion::Inverted)
        .reset_pin(rst)
        .init(&mut Delay::new())
    else {
        fail("panel init (ST7789 reset and commands over SPI2)")
    };
    if panel.clear(Rgb565::BLACK).is_err() {
        fail("panel clear")
    }
    backlight.set_high();
    println!("panel ready (cleared, backlight on)");

    #[cfg(not(feature = "raw"))]
    {
        // BOOT (GPIO9): to ground when pressed; a short press the next
        // scene, a long one raw or denoised
        let boot = Input::new(p.GPIO9, InputConfig::default().with_pull(Pull::Up));
        let Some(DemoMemory {
            columns,
            line,
            scene,
        }) = MEMORY.try_take()
        else {
            fail("static memory (taken twice)")
        };
        for (name, why) in LEFT_OUT {
            println!("scene {name} left out: {why}");
        }
        let mut demo = match Demo::new(SCENES, scene, columns, (WIDTH, HEIGHT), 1, SEED) {
            Ok(d) => d,
            Err(e) => {
                println!("demo: {e}");
                fail("demo setup")
            }
        };
        let mut buttons: Buttons<1> = Buttons::new();
        let mut poll = || {
            let now = Instant::now().duration_since_epoch().as_micros();
            match buttons.update(now, [boot.is_low()]) {
                Some(Press::Short(_)) => Some(Command::NextScene),
                Some(Press::Long(_)) => Some(Command::Denoise),
                None => None,
            }
        };
        loop {
            match demo.step(&mut panel, line, &mut OneCore, &mut SysClock, &mut poll) {
                Ok(Step::Done(_)) => {
                    let mut text: heapless::String<64> = heapless::String::new();
                    let _ = demo.status(&mut text);
                    let (s, ms) = stamp();
                    println!("[{s}.{ms:03}] {text}");
                }
                Ok(Step::Interrupted(c)) => println!("button: {c:?}"),
                Ok(Step::Idle) => {}
                Err(e) => {
                    println!("demo: {e}");
                    fail("demo")
                }
            }
        }
    }

    #[cfg(feature = "raw")]
    {
        let mut scene = BoardScene::EMPTY;
        if let Err(e) = micropt::parse::parse_into(SCENE_TEXT, &mut scene) {
            println!("scene: {e:?}");
            fail("scene parse")
        }
        let Ok(renderer) = Renderer::new(&scene, WIDTH, HEIGHT) else {
            fail("renderer setup")
        };
        let renderer = renderer.seed(SEED);
        let mut acc = TileAccum::new();
        let tiles = tile_count(WIDTH, HEIGHT) as u32;
        let mut target = Progress::new(panel, tiles, report);
        println!("rendering {tiles} tiles: preview, then refinement");
        // preview first, then refined tiles, each straight to the panel
        match render_budget(
            &renderer,
            BUDGET,
            &AdaptiveOptions::default(),
            &mut acc,
            &mut SysClock,
            &mut target,
            1.0,
        ) {
            Ok(s) => println!(
                "frame done in {} ms (preview {} ms): {} samples, {} paths",
                s.total_micros / 1000,
                s.preview_micros / 1000,
                s.samples,
                s.stats.paths
            ),
            Err(_) => fail("drawing a tile"),
        }
        halt()
    }
}

/// Stops here.
fn halt() -> ! {
    loop {
        core::hint::spin_loop();
    }
}
