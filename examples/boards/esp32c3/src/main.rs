//! micropt's demo on an ESP32-C3 (one RISC-V RV32IMC core at 160 MHz, no
//! FPU) with a 240×240 ST7789 SPI panel.
//!
//! The demo (`micropt::demo`, docs/demo.md): a block preview, then passes
//! at 1, 2, 4, … samples a pixel, each streamed through the denoiser row
//! by row to the panel; the BOOT button (GPIO9): a short press the next
//! scene, a long one raw or denoised. No frame of samples and no
//! framebuffer: static RAM is the denoiser's rings (one `Column` of 796
//! bytes a pixel of a row: 191,040 bytes), a row of colours and the
//! scene. Kept alive on a desk: the RTC watchdog (8 s) is fed before each
//! pixel, and no pass is started whose pixels could outlast it; esp-hal's
//! stack guard (a watchpoint on a word near the stack's end) turns an
//! overflow into an exception and so a panic; a panic's message goes to
//! the serial port and onto the panel (white on red), and after 8 s the
//! chip restarts; the line above the status line says why it last
//! restarted (watchdog, panic, brown-out) and the stack's high-water mark.
//! With `--features raw` the example renders cornell's raw frame instead,
//! through the core's single-core budget executor
//! (`micropt::budget::render_budget`: a preview of the whole image, then
//! each tile refined with adaptive allocation; with `Budget::Spp(16)` the
//! host's `micropt render scenes/cornell.scene --size 240x240 --spp 16
//! --seed 0`).
//!
//! The C3 has no FPU: every f32 add, subtract, multiply, divide, compare
//! and int-to-float conversion is micropt's correctly rounded routine
//! (`micropt::math::soft`, exported under the libgcc names by
//! `examples/board/softfloat.rs`), not the chip's mask-ROM libgcc, which
//! esp-hal's linker script would bind them to (`build.rs` says how that is
//! kept off).
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
//! Over USB (`espflash flash --monitor`, or any serial monitor on the
//! board's USB port: esp-println writes to the C3's USB serial/JTAG or to
//! UART0, whichever the board's USB connector is wired to) it prints each
//! init step, each pass's status line and any panic.
//!
//! Build and flash: docs/boards.md.
#![no_std]
#![no_main]

// micropt's soft-float routines under the runtime's names (same bits as the
// host; build.rs keeps the ROM's libgcc table from overriding them)
#[path = "../../../board/softfloat.rs"]
mod softfloat;

#[path = "../../../board/locked_panel.rs"]
mod locked_panel;
#[path = "../../../board/panic_screen.rs"]
mod panic_screen;
#[cfg(feature = "raw")]
#[path = "../../../board/progress.rs"]
mod progress;
#[path = "../../../board/stack.rs"]
mod stack;

use core::cell::RefCell;
use core::fmt::Write;
use critical_section::Mutex;
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::pixelcolor::{Rgb565, RgbColor};
use embedded_hal_bus::spi::{ExclusiveDevice, NoDelay};
use esp_hal::Blocking;
use esp_hal::clock::CpuClock;
use esp_hal::delay::Delay;
use esp_hal::gpio::{Level, Output, OutputConfig};
use esp_hal::rtc_cntl::SocResetReason;
use esp_hal::spi::Mode;
use esp_hal::spi::master::{Config, Spi};
use esp_hal::time::{Instant, Rate};
use esp_println::println;
use micropt::Scene;
use mipidsi::Builder;
use mipidsi::interface::SpiInterface;
use mipidsi::models::ST7789;
use mipidsi::options::ColorInversion;
use static_cell::ConstStaticCell;
#[cfg(not(feature = "raw"))]
use {
    esp_hal::gpio::{Input, InputConfig, Pull},
    esp_hal::rtc_cntl::{Rtc, RwdtStage},
    esp_hal::time::Duration,
    micropt::demo::{Buttons, Command, Demo, Entry, OneCore, Press, SCENES as SHIPPED, Step},
    micropt::denoise::Column,
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

/// The panel through `mipidsi`.
type Panel = mipidsi::Display<
    SpiInterface<
        'static,
        ExclusiveDevice<Spi<'static, Blocking>, Output<'static>, NoDelay>,
        Output<'static>,
    >,
    ST7789,
    Output<'static>,
>;

/// The panel, where the demo draws and a panic writes its message.
static PANEL: Mutex<RefCell<Option<Panel>>> = Mutex::new(RefCell::new(None));
/// The SPI interface's buffer.
static BUFFER: ConstStaticCell<[u8; 512]> = ConstStaticCell::new([0; 512]);

/// The watchdog's period: the longest the demo may go without feeding it.
#[cfg(not(feature = "raw"))]
const WATCHDOG_US: u64 = 8_000_000;
/// The bytes above the stack's lowest address that esp-hal's stack guard
/// word sits in (`ESP_HAL_CONFIG_STACK_GUARD_OFFSET`, 60 by default):
/// never painted, since a write to the guard is the overflow it watches
/// for.
const GUARD: usize = 64;

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

/// A panic (a stack overflow included: esp-hal's stack guard raises
/// one): printed, written on the panel (white on red, if the panel is set
/// up and not in the middle of a drawing call), then after 8 s to read it
/// the chip restarts (a software reset; the line above the status line
/// says so after the restart).
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    println!("panic: {info}");
    let mut text: heapless::String<320> = heapless::String::new();
    let _ = write!(text, "{info}");
    panic_screen::show(&PANEL, &text);
    Delay::new().delay_millis(8_000);
    esp_hal::system::software_reset()
}

/// Why the chip last restarted (empty after power-on): the ROM's reset
/// reason. This firmware's only software reset is its panic handler's.
fn last_reset() -> heapless::String<32> {
    let mut out = heapless::String::new();
    let _ = match esp_hal::system::reset_reason() {
        None | Some(SocResetReason::ChipPowerOn) => Ok(()),
        Some(SocResetReason::CoreSw | SocResetReason::Cpu0Sw) => out.write_str("reset: panic"),
        Some(
            SocResetReason::CoreMwdt0
            | SocResetReason::CoreMwdt1
            | SocResetReason::CoreRtcWdt
            | SocResetReason::Cpu0Mwdt0
            | SocResetReason::Cpu0Mwdt1
            | SocResetReason::Cpu0RtcWdt
            | SocResetReason::SysRtcWdt
            | SocResetReason::SysSuperWdt,
        ) => out.write_str("reset: watchdog"),
        Some(SocResetReason::SysBrownOut) => out.write_str("reset: brown-out"),
        Some(r) => write!(out, "reset: {r:?}"),
    };
    out
}

#[esp_hal::main]
fn main() -> ! {
    stack::paint(stack::bounds().0 + GUARD);
    let p = esp_hal::init(esp_hal::Config::default().with_cpu_clock(CpuClock::max()));
    println!("micropt on ESP32-C3 + ST7789: the demo, {WIDTH}x{HEIGHT}");
    let reset = last_reset();
    if !reset.is_empty() {
        println!("{reset}");
    }
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
    let di = SpiInterface::new(device, dc, BUFFER.take());
    let Ok::<Panel, _>(mut panel) = Builder::new(ST7789, di)
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

    critical_section::with(|cs| PANEL.borrow_ref_mut(cs).replace(panel));
    let target = locked_panel::LockedPanel {
        panel: &PANEL,
        size: embedded_graphics::geometry::Size::new(WIDTH, HEIGHT),
    };

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
        demo.set_pixel_limit(WATCHDOG_US);
        // soft float: 4 × 4 blocks, a sixteenth of pass 0 (about 0.8 s)
        demo.set_preview_block(4);
        let mut target = target;
        // the RTC watchdog (esp_hal::init stops it): stage 0 resets the
        // system after 8 s without a feed
        let mut rtc = Rtc::new(p.RTC_TIMER);
        rtc.rwdt
            .set_timeout(RwdtStage::Stage0, Duration::from_micros(WATCHDOG_US));
        rtc.rwdt.enable();
        let mut buttons: Buttons<1> = Buttons::new();
        let mut poll = || {
            rtc.rwdt.feed();
            let now = Instant::now().duration_since_epoch().as_micros();
            match buttons.update(now, [boot.is_low()]) {
                Some(Press::Short(_)) => Some(Command::NextScene),
                Some(Press::Long(_)) => Some(Command::Denoise),
                None => None,
            }
        };
        loop {
            let note = stack::note(&reset, stack::bounds().0 + GUARD);
            demo.set_note(&note);
            match demo.step(&mut target, line, &mut OneCore, &mut SysClock, &mut poll) {
                Ok(Step::Done(_)) => {
                    let mut text: heapless::String<64> = heapless::String::new();
                    let _ = demo.status(&mut text);
                    let (s, ms) = stamp();
                    println!("[{s}.{ms:03}] {text} ({note})");
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
        let mut target = Progress::new(target, tiles, report);
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
