//! What the two Pico examples share: the demo on core 0
//! (`micropt::demo`: passes, buttons, scenes), or with the `raw` feature
//! each core's part of the progressive raw frame through
//! `micropt::multicore::render_shared`, and what they tell the user: defmt
//! log lines (over RTT, to a debug probe) and the Pimoroni Display Pack's
//! RGB LED (GP6 red, GP7 green, GP8 blue, active low): blue while
//! rendering, green when done, red blinking a failed step's number.
//!
//! And what keeps the demo alive on a desk: the watchdog, fed before each
//! pixel ([`WATCHDOG_US`]; the demo does not start a pass whose pixels
//! could outlast it); a panic's message on the panel, then a restart; a
//! record of why the board restarted (panic, hard fault, stack overflow,
//! watchdog) in the watchdog's scratch registers, shown on the line above
//! the status line after the restart ([`last_reset`]); the stack painted
//! at boot and its high-water mark on that line ([`paint_stack`],
//! [`crate::stack::note`]).
//!
//! Shared by the Pico board crates in `examples/boards/` (`#[path]`).

use crate::hal;
use core::fmt::Write;
#[cfg(feature = "raw")]
use defmt::warn;
use defmt::{error, info};
use embedded_graphics::draw_target::DrawTarget;
use embedded_hal::digital::{OutputPin, PinState};
use micropt::Scene;
#[cfg(feature = "raw")]
use {
    crate::progress::Milestone,
    core::sync::atomic::{AtomicBool, Ordering},
    micropt::Renderer,
    micropt::budget::TileAccum,
    micropt::film::FromEncoded,
    micropt::multicore::{Pass, SharedError, WorkQueue, render_shared, wait_all},
    micropt::{AdaptiveOptions, Budget},
};
#[cfg(not(feature = "raw"))]
use {
    embedded_graphics::pixelcolor::{Rgb565, RgbColor},
    micropt::demo::{Buttons, Command, Demo, DemoError, Entry, Pixels, Press, Step as DemoStep},
    micropt::denoise::Column,
};

/// The init steps; a failed one is logged and blinked on the red LED (its
/// number of blinks, a pause, again).
#[derive(Clone, Copy, defmt::Format)]
pub enum Step {
    /// Starting the crystal oscillator and the PLLs.
    Clocks = 1,
    /// Initialising the ST7789 over SPI.
    Panel = 2,
    /// Clearing the panel to black.
    Clear = 3,
    /// Parsing the scene.
    Scene = 4,
    /// Setting up the renderer (camera, image size, budget).
    Renderer = 5,
    /// A static buffer was taken twice (a bug).
    Memory = 6,
    /// Drawing a tile to the panel.
    Draw = 7,
}

/// The pack's RGB LED: red, green and blue pins, each lit when low.
pub struct Led<P>(pub [P; 3]);

/// Red only.
pub const RED: [bool; 3] = [true, false, false];
/// Green only.
pub const GREEN: [bool; 3] = [false, true, false];
/// Blue only.
pub const BLUE: [bool; 3] = [false, false, true];
/// Dark.
pub const OFF: [bool; 3] = [false, false, false];

impl<P: OutputPin> Led<P> {
    /// Lights red, green and blue as given.
    pub fn set(&mut self, rgb: [bool; 3]) {
        for (pin, on) in self.0.iter_mut().zip(rgb) {
            let _ = pin.set_state(PinState::from(!on));
        }
    }
}

/// Logs the failed step and blinks its number on the red LED, forever
/// (about 0.4 s per blink at 125–150 MHz; slower if the clocks failed).
pub fn fail<P: OutputPin>(led: &mut Led<P>, step: Step) -> ! {
    error!("init step {} failed: {}", step as u8, step);
    loop {
        for _ in 0..step as u8 {
            led.set(RED);
            cortex_m::asm::delay(25_000_000);
            led.set(OFF);
            cortex_m::asm::delay(25_000_000);
        }
        cortex_m::asm::delay(100_000_000);
    }
}

/// The raw frame's scene, parsed on the board.
#[cfg(feature = "raw")]
const SCENE_TEXT: &str = include_str!("../../scenes/cornell.scene");
/// Fixed capacities: enough for cornell.scene (3 spheres, 6 planes, 6
/// materials); a bigger scene gives a capacity error, not a panic.
#[cfg(feature = "raw")]
type BoardScene = Scene<4, 8, 8>;

/// The scene parsed in place (static) and the renderer of a `width` ×
/// `height` image with `seed`. A failed step is logged and blinked on
/// `led`.
#[cfg(feature = "raw")]
pub fn setup<P: OutputPin>(
    led: &mut Led<P>,
    width: u32,
    height: u32,
    seed: u64,
) -> Renderer<'static> {
    let Some(scene) = cortex_m::singleton!(: BoardScene = BoardScene::EMPTY) else {
        fail(led, Step::Memory)
    };
    if micropt::parse::parse_into(SCENE_TEXT, scene).is_err() {
        fail(led, Step::Scene)
    }
    let scene: &'static BoardScene = scene;
    let Ok(renderer) = Renderer::new(scene, width, height) else {
        fail(led, Step::Renderer)
    };
    renderer.seed(seed)
}

/// The demo's static memory: the denoiser's rings (one `Column` a pixel
/// of a row, `W` wide), one row of panel colours, and the scene being
/// shown (`S` spheres, `P` planes, `M` materials at most). All zero bits
/// (.bss, not flash).
#[cfg(not(feature = "raw"))]
pub struct DemoMemory<const W: usize, const S: usize, const P: usize, const M: usize> {
    columns: [Column; W],
    line: [Rgb565; W],
    scene: Scene<S, P, M>,
}

#[cfg(not(feature = "raw"))]
impl<const W: usize, const S: usize, const P: usize, const M: usize> DemoMemory<W, S, P, M> {
    /// Before the demo.
    pub const fn new() -> Self {
        Self {
            columns: [Column::EMPTY; W],
            line: [Rgb565::BLACK; W],
            scene: Scene::EMPTY,
        }
    }
}

/// The Display Pack's buttons A, B, X, Y (GP12–GP15) as the demo's
/// commands: A the next scene, B the exposure, X the camera's orbit, Y
/// raw or denoised, Y held the status line.
#[cfg(not(feature = "raw"))]
pub fn command(p: Press) -> Option<Command> {
    match p {
        Press::Short(0) | Press::Long(0) => Some(Command::NextScene),
        Press::Short(1) | Press::Long(1) => Some(Command::Exposure),
        Press::Short(2) | Press::Long(2) => Some(Command::Orbit),
        Press::Short(3) => Some(Command::Denoise),
        Press::Long(3) => Some(Command::Status),
        _ => None,
    }
}

/// The init step a demo error is blinked as.
#[cfg(not(feature = "raw"))]
fn step_of(e: &DemoError) -> Step {
    match e {
        DemoError::NoScenes | DemoError::Scene(..) => Step::Scene,
        DemoError::Camera(_) => Step::Renderer,
        DemoError::Workspace => Step::Memory,
        DemoError::Draw => Step::Draw,
    }
}

/// The time since boot for the demo's status line.
#[cfg(not(feature = "raw"))]
struct Micros(fn() -> u64);

#[cfg(not(feature = "raw"))]
impl micropt::Clock for Micros {
    fn micros(&mut self) -> u64 {
        (self.0)()
    }
}

/// The watchdog's period: the longest the demo may go without feeding it
/// (the RP2040's and RP2350's watchdogs count at most 8.39 s).
#[cfg(not(feature = "raw"))]
pub const WATCHDOG_US: u32 = 8_000_000;

/// The demo, forever, on core 0: pass after pass of `entries` into
/// `target` (`size`, rendered with `seed`, the block preview's blocks
/// `preview_block` wide; the pixels from `pixels`: both
/// cores, [`crate::two_cores::TwoCores`]), `pressed()` read before each
/// pixel (A, B, X, Y; `true`: pressed; it also feeds the watchdog),
/// debounced ([`Buttons`]). No pass is started whose pixels could outlast
/// [`WATCHDOG_US`] ([`Demo::set_pixel_limit`]). The line above the status
/// line: `reset` (why the board last restarted, [`last_reset`]) and the
/// stack's high-water mark. The LED: blue while a pass renders, green
/// when the passes are done; a failure is logged and blinked (`step_of`:
/// [`Step::Scene`] for a scene that does not parse, [`Step::Draw`] for the
/// panel).
#[cfg(not(feature = "raw"))]
#[allow(clippy::too_many_arguments)]
pub fn demo<D, P, const W: usize, const S: usize, const PL: usize, const M: usize>(
    entries: &'static [Entry],
    memory: Option<&'static mut DemoMemory<W, S, PL, M>>,
    (size, seed, preview_block): ((u32, u32), u64, u32),
    mut target: D,
    mut pixels: impl Pixels,
    mut pressed: impl FnMut() -> [bool; 4],
    led: &mut Led<P>,
    now: fn() -> u64,
    reset: &str,
) -> !
where
    D: DrawTarget<Color = Rgb565>,
    P: OutputPin,
{
    let Some(DemoMemory {
        columns,
        line,
        scene,
    }) = memory
    else {
        fail(led, Step::Memory)
    };
    let mut demo = match Demo::new(entries, scene, columns, size, 1, seed) {
        Ok(d) => d,
        Err(e) => {
            error!("demo: {}", defmt::Display2Format(&e));
            fail(led, step_of(&e))
        }
    };
    demo.set_pixel_limit(u64::from(WATCHDOG_US));
    demo.set_preview_block(preview_block);
    let mut buttons: Buttons<4> = Buttons::new();
    let mut clock = Micros(now);
    let mut poll = move || buttons.update(now(), pressed()).and_then(command);
    led.set(BLUE);
    loop {
        let note = crate::stack::note(reset, stack_guard() + GUARD);
        demo.set_note(&note);
        match demo.step(&mut target, line, &mut pixels, &mut clock, &mut poll) {
            Ok(DemoStep::Done(_)) => {
                let mut text: heapless::String<120> = heapless::String::new();
                let _ = demo.status(&mut text);
                let _ = write!(text, " ({note})");
                log(&text);
                led.set(BLUE);
            }
            Ok(DemoStep::Interrupted(c)) => {
                let mut text: heapless::String<32> = heapless::String::new();
                let _ = write!(text, "button: {c:?}");
                log(&text);
                led.set(BLUE);
            }
            Ok(DemoStep::Idle) => led.set(GREEN),
            Err(e) => {
                error!("demo: {}", defmt::Display2Format(&e));
                fail(led, step_of(&e))
            }
        }
    }
}

/// A log line: over defmt (RTT, to a debug probe) and over USB serial.
pub fn log(line: &str) {
    info!("{=str}", line);
    crate::usb_serial::print(line);
}

/// What a restart record says ([`restart`], [`last_reset`]), in the
/// watchdog's scratch register 0 beside [`RECORD`].
#[derive(Clone, Copy)]
pub enum Kind {
    /// A panic: scratch 1 its line, scratch 2–3 its file's name (8 bytes).
    Panic = 1,
    /// A hard fault: scratch 1 the faulting instruction's address.
    Fault = 2,
    /// The stack limit was hit (the RP2350's MSPLIM): scratch 1 the pc.
    StackOverflow = 3,
}

/// The tag of a restart record in scratch register 0 (`mpt` and the
/// [`Kind`] in the low byte). The watchdog's scratch registers keep their
/// value through a watchdog or software reset, not through power-on; the
/// boot ROMs use 4–7 only (the RP2040 and RP2350 datasheets, "Watchdog").
const RECORD: u32 = 0x6d70_7400;

/// Writes a restart record into the watchdog's scratch registers 0–3.
fn record(kind: Kind, value: u32, name: [u8; 8]) {
    // SAFETY: the watchdog's scratch registers 0–3 are written by nothing
    // else on this board (the HAL's `Watchdog` only on request, which
    // these examples never make), and plain register writes cannot break
    // the HAL's view of the watchdog's other registers.
    let wd = unsafe { &*hal::pac::WATCHDOG::ptr() };
    let word = |i: usize| u32::from_le_bytes([name[i], name[i + 1], name[i + 2], name[i + 3]]);
    // SAFETY: any 32-bit value is valid in a scratch register.
    unsafe {
        wd.scratch1().write(|w| w.bits(value));
        wd.scratch2().write(|w| w.bits(word(0)));
        wd.scratch3().write(|w| w.bits(word(4)));
        wd.scratch0().write(|w| w.bits(RECORD | kind as u32));
    }
}

/// A hard fault: records why the board restarts; unless the stack
/// overflowed (then the handler's own stack is the guard's few bytes, and
/// it restarts at once), writes the fault and its address on the panel
/// and over USB as the panic handler does ([`show_and_restart`]); then
/// restarts (a system reset request; the watchdog's scratch registers
/// survive it).
pub fn restart(kind: Kind, value: u32) -> ! {
    record(kind, value, [0; 8]);
    if matches!(kind, Kind::StackOverflow) {
        cortex_m::peripheral::SCB::sys_reset()
    }
    let mut text: heapless::String<64> = heapless::String::new();
    let _ = write!(text, "hard fault at {value:#010x}\nrestarting");
    error!("{=str}", text.as_str());
    show_and_restart(&text)
}

/// A fatal message: the LED red, `text` white on red on the panel (if it
/// is set up and not in the middle of a drawing call) and over USB serial
/// (the device polled here: interrupts are off), about 8 seconds to read
/// it, then a restart (the watchdog, if it runs, restarts the board at
/// about the same time).
fn show_and_restart(text: &str) -> ! {
    cortex_m::interrupt::disable();
    // the LED red: GP6 low, GP7 and GP8 high (active low)
    // SAFETY: single writes to the SIO's set and clear registers, which
    // change only the LED's three outputs
    let sio = unsafe { &*hal::pac::SIO::ptr() };
    unsafe {
        sio.gpio_out_set().write(|w| w.bits(1 << 7 | 1 << 8));
        sio.gpio_out_clr().write(|w| w.bits(1 << 6));
    }
    crate::panic_screen::show(&crate::display_pack::PANEL, text);
    crate::usb_serial::print_polling(text, 8_000, crate::SYS_HZ);
    cortex_m::peripheral::SCB::sys_reset()
}

/// Why the board last restarted, from the watchdog's reason register and
/// the record of [`restart`] or the panic handler (then cleared): empty
/// after power-on or the reset button.
pub fn last_reset(wd: &hal::pac::WATCHDOG) -> heapless::String<32> {
    let mut out = heapless::String::new();
    let tag = wd.scratch0().read().bits();
    let value = wd.scratch1().read().bits();
    let mut name = [0u8; 8];
    name[..4].copy_from_slice(&wd.scratch2().read().bits().to_le_bytes());
    name[4..].copy_from_slice(&wd.scratch3().read().bits().to_le_bytes());
    // SAFETY: any value is valid in scratch register 0; clearing it means
    // the record is shown once
    unsafe { wd.scratch0().write(|w| w.bits(0)) };
    let reason = wd.reason().read();
    let name = core::str::from_utf8(&name)
        .unwrap_or("?")
        .trim_end_matches('\0');
    let _ = match tag {
        t if t == RECORD | Kind::Panic as u32 => write!(out, "reset: panic {name}:{value}"),
        t if t == RECORD | Kind::Fault as u32 => write!(out, "reset: hard fault {value:08x}"),
        t if t == RECORD | Kind::StackOverflow as u32 => write!(out, "reset: stack overflow"),
        _ if reason.timer().bit_is_set() => write!(out, "reset: watchdog"),
        _ if reason.force().bit_is_set() => write!(out, "reset: forced"),
        _ => Ok(()),
    };
    out
}

/// The stack guard's bytes ([`stack_guard`]).
pub const GUARD: usize = 32;

/// Where the stack's guard starts: the first 32-byte boundary at or above
/// the stack's lowest address (the M0+'s MPU guards 32-byte subregions;
/// the M33's MSPLIM is set at its end). The stack ends at the guard's end.
pub fn stack_guard() -> usize {
    let (bottom, _) = crate::stack::bounds();
    (bottom + GUARD - 1) & !(GUARD - 1)
}

/// Paints the stack above its guard ([`crate::stack::paint`]). Called
/// first thing in `main`.
#[inline(always)]
pub fn paint_stack() {
    crate::stack::paint(stack_guard() + GUARD);
}

/// The name of a source file (after its last `/`), 8 bytes at most.
fn short_name(file: &str) -> [u8; 8] {
    let name = file.rsplit('/').next().unwrap_or(file);
    let mut out = [0u8; 8];
    for (o, b) in out.iter_mut().zip(name.bytes()) {
        *o = b;
    }
    out
}

/// A panic: logged, recorded ([`last_reset`] says so after the
/// restart), its message written on the panel (white on red, if the panel
/// is set up and not in the middle of a drawing call) and sent over USB
/// serial, the LED red; then, after about 8 seconds to read it, the board
/// restarts (the watchdog, if it runs, restarts it at about the same
/// time).
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    let (line, file) = info.location().map_or((0, ""), |l| (l.line(), l.file()));
    record(Kind::Panic, line, short_name(file));
    error!("{}", defmt::Display2Format(info));
    let mut text: heapless::String<320> = heapless::String::new();
    let _ = write!(text, "{info}");
    show_and_restart(&text)
}

/// What core 1 is given to run for a raw frame ([`RawCore1::run`]).
#[cfg(feature = "raw")]
pub struct RawCore1<Q: 'static, D> {
    renderer: Renderer<'static>,
    budget: Budget,
    acc: &'static mut TileAccum,
    queue: &'static Q,
    target: D,
    failed: &'static AtomicBool,
}

#[cfg(feature = "raw")]
impl<Q: WorkQueue, D: DrawTarget> RawCore1<Q, D>
where
    D::Color: FromEncoded,
{
    /// Core 1's part of the frame ([`core1`]).
    pub fn run(self) -> ! {
        core1(
            &self.renderer,
            self.budget,
            self.acc,
            self.queue,
            self.target,
            self.failed,
        )
    }
}

/// A raw frame on both cores, and its end: `spawn` starts core 1 on its
/// part (and says whether it started); each core draws its tiles into
/// its own `target()`. `queues`: the two cores' queue and core 0's alone
/// (if core 1 did not start); `failed`: set by core 1 if it could not
/// draw.
#[cfg(feature = "raw")]
#[allow(clippy::too_many_arguments)]
pub fn raw<Q, D, P>(
    renderer: Renderer<'static>,
    budget: Budget,
    queues: (&'static Q, &'static Q),
    failed: &'static AtomicBool,
    target: impl Fn() -> D,
    spawn: impl FnOnce(RawCore1<Q, D>) -> bool,
    led: &mut Led<P>,
    now: fn() -> u64,
) -> !
where
    Q: WorkQueue,
    D: DrawTarget,
    D::Color: FromEncoded,
    P: OutputPin,
{
    let (Some(acc0), Some(acc1)) = (
        cortex_m::singleton!(: TileAccum = TileAccum::new()),
        cortex_m::singleton!(: TileAccum = TileAccum::new()),
    ) else {
        fail(led, Step::Memory)
    };
    led.set(BLUE);
    info!("rendering on two cores: preview, then refinement");
    let start = now();
    let spawned = spawn(RawCore1 {
        renderer,
        budget,
        acc: acc1,
        queue: queues.0,
        target: target(),
        failed,
    });
    let queue = if spawned {
        queues.0
    } else {
        warn!("core 1 did not start: core 0 renders alone");
        queues.1
    };
    core0(
        &renderer,
        budget,
        acc0,
        queue,
        target(),
        failed,
        led,
        (start, now),
    )
}

/// Logs how far the frame has come.
#[cfg(feature = "raw")]
pub fn report(m: Milestone) {
    match m {
        Milestone::Preview => info!("preview on the panel"),
        Milestone::Refined(p) => info!("refined: {=u32}%", p),
    }
}

/// Core 1's part of a raw frame: renders tiles from `queue` into `target` (its
/// view of the shared panel), logs its paths, records a failed draw in
/// `failed`, and stops.
#[cfg(feature = "raw")]
pub fn core1<D, Q>(
    r: &Renderer<'_>,
    budget: Budget,
    acc: &mut TileAccum,
    queue: &Q,
    mut target: D,
    failed: &AtomicBool,
) -> !
where
    D: DrawTarget,
    D::Color: FromEncoded,
    Q: WorkQueue,
{
    let opts = AdaptiveOptions::default();
    match render_shared(r, budget, &opts, acc, queue, &mut target, 1.0) {
        Ok(s) => info!("core 1: {=u64} paths", s.stats.paths),
        Err(_) => failed.store(true, Ordering::Release),
    }
    loop {
        cortex_m::asm::wfi();
    }
}

/// Core 0's part of a raw frame and its end: renders tiles from `queue` into
/// `target`, waits for every core of the queue, then logs the frame time
/// (from `start`, by `now`, in microseconds) and lights the LED green, or
/// red blinks if a core could not draw (`failed`).
#[allow(clippy::too_many_arguments)]
#[cfg(feature = "raw")]
pub fn core0<D, Q, P>(
    r: &Renderer<'_>,
    budget: Budget,
    acc: &mut TileAccum,
    queue: &Q,
    mut target: D,
    failed: &AtomicBool,
    led: &mut Led<P>,
    (start, now): (u64, fn() -> u64),
) -> !
where
    D: DrawTarget,
    D::Color: FromEncoded,
    Q: WorkQueue,
    P: OutputPin,
{
    let opts = AdaptiveOptions::default();
    let result = render_shared(r, budget, &opts, acc, queue, &mut target, 1.0);
    wait_all(queue, Pass::Refine);
    let micros = now().saturating_sub(start);
    match result {
        Ok(s) if !failed.load(Ordering::Acquire) => {
            info!("core 0: {=u64} paths", s.stats.paths);
            info!("frame done in {=u64} ms", micros / 1000);
            led.set(GREEN);
        }
        Err(SharedError::Deadline) => {
            error!("a deadline budget: the two-core executor needs Spp or Paths");
            fail(led, Step::Renderer)
        }
        _ => fail(led, Step::Draw),
    }
    loop {
        cortex_m::asm::wfi();
    }
}

/// A Pico example's statics and `main`, written once for the RP2040 and
/// the RP2350: what differs is given. `board`: the name the log starts
/// with; `timer`: the 1 MHz timer's type, and how `pac` and `clocks` make
/// it; `queue`: the raw frame's tile queue type; `memory`: the demo's
/// static memory type ([`DemoMemory`]); `scale`: the demo's image is the
/// panel's size divided by it, `target` wraps the panel to draw it at
/// that scale; `preview_block`: the demo's block preview's block size;
/// `guard`: sets core 0's stack guard from `core` (the Cortex-M
/// peripherals); `usb`: the PAC's names of the USB controller's registers
/// and its RAM; `clock_hz`: the system clock. The caller has `SCENES` (the demo's), `LEFT_OUT` (the
/// shipped ones it leaves out, and why), `SEED`, `BUDGET` (raw) and
/// `XTAL_HZ`.
macro_rules! pico_main {
    (
        board: $board:literal,
        timer: $timer:ty = |$pac:ident, $clocks:ident| $make_timer:expr,
        usb: ($usb_regs:ident, $usb_dpram:ident),
        clock_hz: $hz:expr,
        queue: $queue:ty,
        memory: $memory:ty,
        scale: $scale:expr,
        preview_block: $preview:expr,
        target: |$t:ident| $wrap:expr,
        guard: |$core:ident| $guard:expr $(,)?
    ) => {
        /// The panel's size (landscape).
        const WIDTH: u32 = crate::display_pack::PACK.size.0;
        /// The panel's size (landscape).
        const HEIGHT: u32 = crate::display_pack::PACK.size.1;
        /// The demo's image is the panel's size divided by this.
        const SCALE: u32 = $scale;
        /// The system clock (the panic handler's delays).
        const SYS_HZ: u32 = $hz;

        /// The panel as both cores see it, each drawing its tiles (counted
        /// for the progress log): the raw frame. (The demo draws through
        /// `display_pack::PANEL`, on core 0 alone.)
        #[cfg(feature = "raw")]
        static RAW_PANEL: critical_section::Mutex<
            core::cell::RefCell<Option<crate::progress::Progress<crate::display_pack::Panel>>>,
        > = critical_section::Mutex::new(core::cell::RefCell::new(None));
        /// The two cores' tile queue.
        #[cfg(feature = "raw")]
        static QUEUE: $queue = <$queue>::new(2);
        /// The queue when core 1 did not start.
        #[cfg(feature = "raw")]
        static QUEUE_ALONE: $queue = <$queue>::new(1);
        /// Set by core 1 if it could not draw to the panel.
        #[cfg(feature = "raw")]
        static CORE1_FAILED: core::sync::atomic::AtomicBool =
            core::sync::atomic::AtomicBool::new(false);
        /// Core 1's stack: 16 KiB, its tile accumulators static (the
        /// render's stack depth measured in QEMU: docs/boards.md).
        #[cfg(feature = "raw")]
        static CORE1_STACK: crate::hal::multicore::Stack<4096> =
            crate::hal::multicore::Stack::new();
        /// Core 1's stack in the demo: 8 KiB (it renders pixels only; the
        /// render's deepest stack measured in QEMU is 4,288 bytes on the
        /// M0, 3,840 on the M33: docs/boards.md).
        #[cfg(not(feature = "raw"))]
        static CORE1_STACK: crate::hal::multicore::Stack<2048> =
            crate::hal::multicore::Stack::new();
        /// What the demo's two cores share.
        #[cfg(not(feature = "raw"))]
        static SHARED: crate::two_cores::Shared = crate::two_cores::Shared::new();
        /// The demo's memory: the denoiser's rings, a row of colours, the
        /// scene.
        #[cfg(not(feature = "raw"))]
        static MEMORY: static_cell::ConstStaticCell<$memory> =
            static_cell::ConstStaticCell::new(<$memory>::new());
        /// The 1 MHz timer, for log timestamps (set once the clocks run).
        static TIMER: critical_section::Mutex<core::cell::Cell<Option<$timer>>> =
            critical_section::Mutex::new(core::cell::Cell::new(None));

        /// Microseconds since the timer started (0 before).
        fn now_us() -> u64 {
            critical_section::with(|cs| TIMER.borrow(cs).get())
                .map_or(0, |t| t.get_counter().ticks())
        }

        defmt::timestamp!("{=u64:us}", now_us());

        #[crate::hal::entry]
        fn main() -> ! {
            use crate::hal::Clock as _;
            use crate::pico::{Step, fail};
            crate::pico::paint_stack();
            defmt::info!(
                "micropt on {=str} + {=str}: the demo, {=u32}x{=u32}",
                $board,
                crate::display_pack::PACK.name,
                WIDTH / SCALE,
                HEIGHT / SCALE
            );
            let (Some(mut $pac), Some(mut $core)) = (
                crate::hal::pac::Peripherals::take(),
                cortex_m::Peripherals::take(),
            ) else {
                // taken once, here: cannot fail
                loop {
                    cortex_m::asm::wfi();
                }
            };
            let reset = crate::pico::last_reset(&$pac.WATCHDOG);
            $guard;
            let sio = crate::hal::Sio::new($pac.SIO);
            let pins = crate::hal::gpio::Pins::new(
                $pac.IO_BANK0,
                $pac.PADS_BANK0,
                sio.gpio_bank0,
                &mut $pac.RESETS,
            );
            let (mut led, buttons, panel_pins) = crate::display_pack::split(pins);
            let mut watchdog = crate::hal::Watchdog::new($pac.WATCHDOG);
            let Ok($clocks) = crate::hal::clocks::init_clocks_and_plls(
                XTAL_HZ,
                $pac.XOSC,
                $pac.CLOCKS,
                $pac.PLL_SYS,
                $pac.PLL_USB,
                &mut $pac.RESETS,
                &mut watchdog,
            ) else {
                fail(&mut led, Step::Clocks)
            };
            let mut timer: $timer = $make_timer;
            critical_section::with(|cs| TIMER.borrow(cs).set(Some(timer)));
            defmt::info!("clocks: {=u32} Hz", $clocks.system_clock.freq().to_Hz());
            crate::usb_serial::start(crate::hal::usb::UsbBus::new(
                $pac.$usb_regs,
                $pac.$usb_dpram,
                $clocks.usb_clock,
                true,
                &mut $pac.RESETS,
            ));
            crate::pico::log(crate::display_pack::PACK.name);
            if !reset.is_empty() {
                crate::pico::log(&reset);
            }
            let panel = match panel_pins.panel(
                $pac.SPI0,
                &mut $pac.RESETS,
                $clocks.peripheral_clock.freq(),
                &mut timer,
            ) {
                Ok(p) => p,
                Err(step) => fail(&mut led, step),
            };
            crate::pico::log("panel ready (cleared, backlight on)");

            #[cfg(not(feature = "raw"))]
            {
                use crate::hal::fugit::ExtU32;
                for (name, why) in LEFT_OUT {
                    let mut line: heapless::String<160> = heapless::String::new();
                    let _ = core::fmt::Write::write_fmt(
                        &mut line,
                        format_args!("scene {name} left out: {why}"),
                    );
                    crate::pico::log(&line);
                }
                critical_section::with(|cs| {
                    crate::display_pack::PANEL.borrow_ref_mut(cs).replace(panel)
                });
                let $t = crate::locked_panel::LockedPanel {
                    panel: &crate::display_pack::PANEL,
                    size: embedded_graphics::geometry::Size::new(WIDTH, HEIGHT),
                };
                let target = $wrap;
                // core 1 renders the odd pixels of each pass
                let mut fifo = sio.fifo;
                let mut mc =
                    crate::hal::multicore::Multicore::new(&mut $pac.PSM, &mut $pac.PPB, &mut fifo);
                let cores = mc.cores();
                let helper = match CORE1_STACK.take() {
                    Some(stack) => cores[1].spawn(stack, || SHARED.serve()).is_ok(),
                    None => false,
                };
                crate::pico::log(if helper {
                    "two cores: core 1 renders the odd pixels"
                } else {
                    "core 1 did not start: core 0 renders alone"
                });
                let pixels = crate::two_cores::TwoCores {
                    shared: &SHARED,
                    helper,
                };
                watchdog.pause_on_debug(true);
                watchdog.start(crate::pico::WATCHDOG_US.micros());
                let mut buttons = buttons;
                crate::pico::demo(
                    SCENES,
                    MEMORY.try_take(),
                    ((WIDTH / SCALE, HEIGHT / SCALE), SEED, $preview),
                    target,
                    pixels,
                    move || {
                        watchdog.feed();
                        buttons.pressed()
                    },
                    &mut led,
                    now_us,
                    &reset,
                )
            }

            #[cfg(feature = "raw")]
            {
                let _ = buttons;
                let renderer = crate::pico::setup(&mut led, WIDTH, HEIGHT, SEED);
                let mut fifo = sio.fifo;
                let mut mc =
                    crate::hal::multicore::Multicore::new(&mut $pac.PSM, &mut $pac.PPB, &mut fifo);
                let cores = mc.cores();
                let tiles = micropt::film::tile_count(WIDTH, HEIGHT) as u32;
                let counted = crate::progress::Progress::new(panel, tiles, crate::pico::report);
                critical_section::with(|cs| RAW_PANEL.borrow_ref_mut(cs).replace(counted));
                let target = || crate::locked_panel::LockedPanel {
                    panel: &RAW_PANEL,
                    size: embedded_graphics::geometry::Size::new(WIDTH, HEIGHT),
                };
                crate::pico::raw(
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
    };
}
