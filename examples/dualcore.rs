//! The micropt core on both cores of a dual-core chip: Arm's SSE-200 (two
//! Cortex-M33 with FPU) on the MPS2+ AN521 image, run in QEMU's
//! `mps2-an521`.
//!
//! Core 0 starts through cortex-m-rt, checks its FPU square root against
//! libm, parses the scene embedded at compile time, sets up the renderer,
//! hands it to core 1 and releases core 1 from reset. Core 1 (held in
//! CPUWAIT since reset) starts from its own vector table (INITSVTOR1) on
//! its own stack, enables its FPU and takes the renderer. Both then run the
//! core's shared executor (`micropt::multicore::render_shared`): preview
//! tiles from a shared queue, a barrier, refinement tiles from the queue,
//! each drawn into one framebuffer of atomic pixels. Core 0 waits for
//! core 1, writes the image's big-endian Rgb565 bytes to a host file through
//! semihosting, prints a summary and exits (status 0; 1 on any error).
//!
//! ```text
//! MICROPT_FW_OUT=dual.rgb565 cargo build --release --example dualcore \
//!     --features firmware-an521 --target thumbv8m.main-none-eabihf
//! qemu-system-arm -machine mps2-an521 -global sse-200.CPU0_FPU=true \
//!     -nographic -semihosting-config enable=on,target=native -icount shift=0 \
//!     -kernel target/thumbv8m.main-none-eabihf/release/examples/dualcore
//! ```
//!
//! QEMU models the AN521's SSE-200 as the real image has it, with no FPU
//! on core 0; `-global sse-200.CPU0_FPU=true` gives core 0 the FPU that the
//! SSE-200 allows on both cores (a `thumbv8m.main-none-eabihf` build runs
//! float code on both). The configuration is the `firmware` example's
//! (`MICROPT_FW_*`, `docs/firmware.md`) plus `MICROPT_FW_CORES` (1 or 2;
//! 1 leaves core 1 in reset: the same code on one core, for the speed-up).
//! With a sample budget the dump is byte-identical to the host CLI's
//! `micropt render SCENE --size WxH --spp N --seed S -o out.rgb565`, and to
//! the single-core firmware's; a deadline budget is refused.
//!
//! The phase marks (`yield`) that `tools/qemu-icount` counts per core:
//! core 0 at the start of `main`, when the renderer is set up (its render
//! begins), core 1 when it starts; then each core when it has finished its
//! preview tiles, when every core has (the barrier), when it has finished
//! its refinement tiles; core 0 when every core has, and when the image is
//! written.
//!
//! With `MICROPT_FW_PASSES=K` the firmware runs the demo's passes instead
//! (`micropt::demo::render_pass`, raw or with `MICROPT_FW_DENOISE=1`
//! denoised, pass k at `SPP · 2^k` samples a pixel) on both cores as the
//! Picos' demo runs them: core 1 renders the odd pixels of each row
//! (`examples/board/two_cores.rs`, the boards' code), core 0 the even ones,
//! the denoiser and the framebuffer. The dump after the last pass is
//! byte-identical with `micropt render SCENE --spp SPP --passes K
//! [--denoise] --size WxH --seed S -o out.rgb565`; the summary gives each
//! core's paths.
//!
//! A release build links with `panic-never` (no panic path left); debug
//! builds use `panic-semihosting`.
#![no_std]
#![no_main]

#[cfg(not(debug_assertions))]
use panic_never as _;
#[cfg(debug_assertions)]
use panic_semihosting as _;

#[cfg(not(feature = "parser"))]
compile_error!("the dual-core firmware parses its scene: enable the `parser` feature");

use core::cell::{Cell, UnsafeCell};
use core::convert::Infallible;
use core::fmt::Write;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use cortex_m::asm;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{entry, exception};
use cortex_m_semihosting::debug;
use micropt::budget::{Summary, TileAccum};
use micropt::multicore::{
    AtomicQueue, DealtQueue, Pass, SharedError, SharedFramebuffer, WorkQueue, render_shared,
    wait_all,
};
use micropt::{AdaptiveOptions, Options, Renderer, Scene};

#[path = "board/qemu.rs"]
mod qemu;
#[path = "board/two_cores.rs"]
mod two_cores;
use qemu::{HostFile, HostOut, STACK_PAINT, mark};

/// The compile-time configuration written by `build.rs`.
mod config {
    include!(concat!(env!("OUT_DIR"), "/firmware_config.rs"));
}
use config::{CLOCK_HZ, CORES, HEIGHT, MAX_MATERIALS, MAX_PLANES, MAX_SPHERES, SEED, WIDTH};

/// The scene file chosen at compile time (`MICROPT_FW_SCENE`).
const SCENE_TEXT: &str = include_str!(concat!(env!("OUT_DIR"), "/firmware.scene"));

/// Exposure of the tone mapping (the host CLI's default).
const EXPOSURE: f32 = 1.0;

type FirmwareScene = Scene<MAX_SPHERES, MAX_PLANES, MAX_MATERIALS>;

/// The image, drawn into by both cores.
static FRAMEBUFFER: SharedFramebuffer<{ WIDTH * HEIGHT }> =
    SharedFramebuffer::new(WIDTH as u32, HEIGHT as u32);
/// The cores that have finished each pass.
static QUEUE: AtomicQueue = AtomicQueue::new(CORES);
/// The renderer, from core 0 to core 1.
static RENDERER: Handoff<Renderer<'static>> = Handoff::new();
/// Core 1's result, from core 1 to core 0.
static CORE1_RESULT: Handoff<Result<Summary, SharedError<Infallible>>> = Handoff::new();
/// Set by core 1's fault handler: core 0 stops waiting and fails.
static CORE1_FAULT: AtomicBool = AtomicBool::new(false);
/// The demo's passes (`MICROPT_FW_PASSES`): what the two cores share.
static SHARED: two_cores::Shared = two_cores::Shared::new();
/// The denoiser's columns for the demo's passes (none in other builds).
const DEMO_COLUMNS: usize = if config::DEMO { WIDTH } else { 0 };

/// The SSE-200 system control registers (secure alias): INITSVTOR1, the
/// vector table core 1 starts from; CPUWAIT, bit `n` holds core `n` in
/// reset (core 1's bit is set at power-on, and clearing it starts core 1).
const SYSCTL: usize = 0x5002_1000;
const INITSVTOR1: *mut u32 = (SYSCTL + 0x114) as *mut u32;
const CPUWAIT: *mut u32 = (SYSCTL + 0x118) as *mut u32;
/// The Coprocessor Access Control Register (of the core that accesses it).
const CPACR: *mut u32 = 0xe000_ed88 as *mut u32;

/// Core 0's SysTick period in core clock cycles: 1 ms at QEMU's 20 MHz
/// (with `-icount shift=0`, a million instructions). Its exception does
/// nothing; it is there because QEMU, running the vCPUs one at a time under
/// `-icount`, switches vCPU at timer deadlines: without a timer one core
/// would run for a whole pass before the other got a turn. With it the
/// cores take turns of half a period (half a million instructions, a small
/// part of a tile), as if they ran side by side.
const SLICE_CYCLES: u32 = CLOCK_HZ / 1000;

#[exception]
fn SysTick() {}

/// Core 1's stack, in words.
const CORE1_STACK_WORDS: usize = 4096;
/// Core 1's stack (16 KiB: its tile accumulators live on it).
static mut CORE1_STACK: [u32; CORE1_STACK_WORDS] = [0; CORE1_STACK_WORDS];

/// An Armv8-M vector table: the initial stack pointer, then the reset
/// handler and the 14 system exceptions' (reserved ones included). VTOR
/// ignores the low 7 bits: 128-byte alignment.
#[repr(C, align(128))]
struct Vectors {
    stack_top: *const u32,
    handlers: [extern "C" fn() -> !; 15],
}

// SAFETY: the table is never written; the pointer is only read by the
// hardware as core 1's initial stack pointer.
unsafe impl Sync for Vectors {}

/// Core 1's vector table (INITSVTOR1 points here): its stack, its entry, and
/// a fault handler for every other exception (core 1 enables no interrupt).
static CORE1_VECTORS: Vectors = Vectors {
    stack_top: (&raw const CORE1_STACK)
        .cast::<u32>()
        .wrapping_add(CORE1_STACK_WORDS),
    handlers: {
        let mut h: [extern "C" fn() -> !; 15] = [core1_fault; 15];
        h[0] = core1_reset;
        h
    },
};

/// A value handed from one core to another once: written by the first
/// `put`, readable by any core once written, never changed after.
struct Handoff<T> {
    state: AtomicU8,
    value: UnsafeCell<MaybeUninit<T>>,
}

const EMPTY: u8 = 0;
const WRITING: u8 = 1;
const READY: u8 = 2;

// SAFETY: the value is written once, by the one core that won the exchange
// from EMPTY, and read (shared) only after READY is published with
// release/acquire ordering; T may be sent to and shared by another core.
unsafe impl<T: Send + Sync> Sync for Handoff<T> {}

impl<T> Handoff<T> {
    const fn new() -> Self {
        Self {
            state: AtomicU8::new(EMPTY),
            value: UnsafeCell::new(MaybeUninit::uninit()),
        }
    }

    /// Stores `v` if nothing was stored yet; false (and `v` dropped) if
    /// something was.
    fn put(&self, v: T) -> bool {
        if self
            .state
            .compare_exchange(EMPTY, WRITING, Ordering::Acquire, Ordering::Relaxed)
            .is_err()
        {
            return false;
        }
        // SAFETY: this caller alone won the exchange from EMPTY: no one else
        // writes the value, and no one reads it before READY below.
        unsafe { (*self.value.get()).write(v) };
        self.state.store(READY, Ordering::Release);
        true
    }

    /// The value, once stored.
    fn get(&self) -> Option<&T> {
        if self.state.load(Ordering::Acquire) != READY {
            return None;
        }
        // SAFETY: READY is published after the value was written (release /
        // acquire), and the value is never written again.
        Some(unsafe { (*self.value.get()).assume_init_ref() })
    }
}

/// One core's queue: the tiles dealt out in turn (`DealtQueue`: core 0 the
/// even tiles, core 1 the odd ones), so that each core's instruction count
/// is its own share of the work and not a product of how QEMU, which runs
/// one vCPU at a time under `-icount`, hands out turns (a shared counter,
/// `AtomicQueue`, gives the same image). It waits with `wfe`, wakes the
/// other core with `sev` when it finishes a pass, and marks for the
/// instruction-count plugin the end of its own part of each pass and the
/// moment it sees every core done.
struct CoreQueue {
    tiles: DealtQueue<'static>,
    seen: [Cell<bool>; 2],
}

impl CoreQueue {
    fn new(core: usize) -> Self {
        Self {
            tiles: DealtQueue::new(&QUEUE, core),
            seen: [Cell::new(false), Cell::new(false)],
        }
    }
}

impl WorkQueue for CoreQueue {
    fn take(&self, pass: Pass) -> usize {
        self.tiles.take(pass)
    }

    fn done(&self, pass: Pass) {
        mark(); // this core's tiles of the pass done
        self.tiles.done(pass);
        asm::dsb();
        asm::sev();
    }

    fn all_done(&self, pass: Pass) -> bool {
        let all = self.tiles.all_done(pass);
        let seen = &self.seen[usize::from(pass == Pass::Refine)];
        if all && !seen.replace(true) {
            mark(); // every core's tiles of the pass done
        }
        all
    }

    fn idle(&self) {
        if CORE1_FAULT.load(Ordering::Relaxed) {
            report(&Error::Core1Fault);
            debug::exit(debug::EXIT_FAILURE);
        }
        asm::wfe();
    }
}

/// Everything that can go wrong, each reported on the host's stderr.
enum Error {
    Parse(micropt::parse::ParseError),
    Camera,
    SqrtMismatch(qemu::SqrtMismatch),
    Deadline,
    Core1Fault,
    Open,
    Write,
    Demo(micropt::demo::DemoError),
}

#[entry]
fn main() -> ! {
    // Static memory, handed out once as `&'static mut` by cortex-m-rt's
    // `#[entry]`: the scene (all zeros: .bss) and core 0's accumulators.
    static mut SCENE: FirmwareScene = FirmwareScene::EMPTY;
    static mut ACCUM: TileAccum = TileAccum::new();
    static mut COLUMNS: [micropt::denoise::Column; DEMO_COLUMNS] =
        [micropt::denoise::Column::EMPTY; DEMO_COLUMNS];

    mark(); // start of main: reset handler, stack paint and RAM init done
    let status = match run(SCENE, ACCUM, COLUMNS) {
        Ok(()) => debug::EXIT_SUCCESS,
        Err(e) => {
            report(&e);
            debug::EXIT_FAILURE
        }
    };
    debug::exit(status);
    loop {
        asm::wfi();
    }
}

/// The scene, parsed from the embedded file in place into `slot`. (Not
/// inlined: the parser's stack is not live during the render.)
#[inline(never)]
fn load_scene(slot: &'static mut FirmwareScene) -> Result<&'static FirmwareScene, Error> {
    micropt::parse::parse_into(SCENE_TEXT, slot).map_err(Error::Parse)?;
    Ok(slot)
}

fn adaptive() -> AdaptiveOptions {
    AdaptiveOptions {
        adaptive: config::ADAPTIVE,
        ..AdaptiveOptions::default()
    }
}

fn run(
    scene_slot: &'static mut FirmwareScene,
    acc: &'static mut TileAccum,
    columns: &'static mut [micropt::denoise::Column],
) -> Result<(), Error> {
    qemu::check_fpu_sqrt().map_err(Error::SqrtMismatch)?;
    let scene = load_scene(scene_slot)?;
    let renderer = Renderer::new(scene, WIDTH as u32, HEIGHT as u32)
        .map_err(|_| Error::Camera)?
        .seed(SEED)
        .options(Options {
            // opaque to the optimiser, as in the single-core firmware
            skip: core::hint::black_box(config::SKIP),
            ..Options::default()
        });
    RENDERER.put(renderer);
    if let Some(p) = cortex_m::Peripherals::take() {
        let mut syst = p.SYST;
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(SLICE_CYCLES - 1);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
    }
    if CORES > 1 {
        start_core1();
    }
    mark(); // renderer set up, core 1 released: core 0's render begins
    if config::DEMO {
        let (mine, theirs) = passes(&renderer, columns)?;
        dump()?;
        mark(); // dump written
        let mut out = HostOut::stdout();
        let _ = writeln!(
            out,
            "micropt dualcore: {} passes of the demo ({}): core 0 {} paths, core 1 {} paths",
            config::PASSES,
            if config::DENOISE { "denoised" } else { "raw" },
            mine,
            theirs
        );
        return Ok(());
    }

    let queue = CoreQueue::new(0);
    let mine = render_shared(
        &renderer,
        config::BUDGET,
        &adaptive(),
        acc,
        &queue,
        &mut &FRAMEBUFFER,
        EXPOSURE,
    );
    wait_all(&queue, Pass::Refine);
    let theirs = if CORES > 1 {
        loop {
            if let Some(r) = CORE1_RESULT.get() {
                break Some(*r);
            }
            queue.idle();
        }
    } else {
        None
    };
    let Ok(mine) = mine.map_err(|_| Error::Deadline) else {
        return Err(Error::Deadline);
    };
    let theirs = match theirs {
        Some(Ok(s)) => Some(s),
        Some(Err(_)) => return Err(Error::Deadline),
        None => None,
    };

    dump()?;
    mark(); // dump written

    summary(&mine, theirs.as_ref());
    Ok(())
}

/// `MICROPT_FW_PASSES=K`: the demo's passes 0 to K − 1 into the
/// framebuffer, the odd pixels of each from core 1 (a mark after each).
/// Returns each core's paths. (Not inlined: its stack is not live in the
/// other path.)
#[inline(never)]
// PASSES is a build setting, 0 (an empty range) in builds that never call
// this
#[allow(clippy::reversed_empty_ranges)]
fn passes(
    renderer: &Renderer<'_>,
    columns: &mut [micropt::denoise::Column],
) -> Result<(u64, u64), Error> {
    use embedded_graphics::Pixel;
    use embedded_graphics::draw_target::DrawTarget;
    use embedded_graphics::geometry::Point;
    use embedded_graphics::pixelcolor::Rgb565;
    use micropt::demo::{Pixels, pass_spp, render_pass};
    use micropt::film::FromEncoded;
    let mut pixels = two_cores::TwoCores {
        shared: &SHARED,
        helper: CORES > 1,
    };
    let mut stats = micropt::Stats::default();
    let mut theirs = 0;
    for k in 0..config::PASSES {
        let spp = pass_spp(config::SPP, k);
        pixels.begin(renderer, spp);
        let pass = render_pass(
            renderer,
            spp,
            !config::DENOISE,
            columns,
            |x, y| pixels.moments(renderer, spp, x, y, &mut stats),
            |y, x, c| {
                let colour = Rgb565::from_encoded(micropt::film::tone_map(c, EXPOSURE), x, y);
                let at = Point::new(x as i32, y as i32);
                let _ = (&FRAMEBUFFER).draw_iter(core::iter::once(Pixel(at, colour)));
            },
            |_| true,
        );
        theirs += pixels.end();
        pass.map_err(Error::Demo)?;
        if CORE1_FAULT.load(Ordering::Relaxed) {
            return Err(Error::Core1Fault);
        }
        mark(); // pass k in the framebuffer
    }
    Ok((stats.paths, theirs))
}

/// Paints core 1's stack, points INITSVTOR1 at core 1's vector table and
/// clears core 1's CPUWAIT bit: core 1 comes out of reset.
fn start_core1() {
    let bottom = (&raw mut CORE1_STACK).cast::<u32>();
    for i in 0..CORE1_STACK_WORDS {
        // SAFETY: core 1 is held in reset and nothing else uses its stack;
        // `i` is within the array.
        unsafe { bottom.add(i).write_volatile(STACK_PAINT) };
    }
    let vectors = (&raw const CORE1_VECTORS) as u32;
    // SAFETY: INITSVTOR1 and CPUWAIT are the SSE-200's system control
    // registers (32-bit, secure, read/write); core 0 runs secure. Core 1 is
    // in reset until the CPUWAIT write; everything it reads (the renderer,
    // the statics) is written before it (the barrier orders the writes).
    unsafe {
        INITSVTOR1.write_volatile(vectors);
        asm::dsb();
        let wait = CPUWAIT.read_volatile();
        CPUWAIT.write_volatile(wait & !0b10);
    }
}

/// Core 1's reset handler: the hardware has loaded its stack pointer from
/// `CORE1_VECTORS`. Enables the FPU (full access to CP10 and CP11) before
/// any float instruction, then runs `core1_main`.
extern "C" fn core1_reset() -> ! {
    // SAFETY: CPACR is this core's own System Control Block register; setting
    // CP10/CP11 to full access only enables the FPU.
    unsafe { CPACR.write_volatile(CPACR.read_volatile() | (0b1111 << 20)) };
    asm::dsb();
    asm::isb();
    core1_main()
}

/// Core 1: its part of the render, its result to core 0, then sleep.
/// (Not inlined into the reset handler: no float code before the FPU is
/// enabled.)
#[inline(never)]
fn core1_main() -> ! {
    mark(); // core 1 started: its render begins
    if config::DEMO {
        SHARED.serve()
    }
    let queue = CoreQueue::new(1);
    let renderer = loop {
        if let Some(r) = RENDERER.get() {
            break r;
        }
        queue.idle();
    };
    let mut acc = TileAccum::new();
    let result = render_shared(
        renderer,
        config::BUDGET,
        &adaptive(),
        &mut acc,
        &queue,
        &mut &FRAMEBUFFER,
        EXPOSURE,
    );
    CORE1_RESULT.put(result);
    asm::dsb();
    asm::sev();
    loop {
        asm::wfe();
    }
}

/// Every exception of core 1 but reset: record it for core 0, and stop.
extern "C" fn core1_fault() -> ! {
    CORE1_FAULT.store(true, Ordering::Relaxed);
    asm::dsb();
    asm::sev();
    loop {
        asm::wfe();
    }
}

/// The host file name without its terminating NUL.
fn output_name() -> &'static str {
    config::OUTPUT.trim_end_matches('\0')
}

/// Writes the framebuffer's big-endian Rgb565 bytes to the host file
/// `config::OUTPUT`, a chunk at a time (the pixels are atomics, not bytes).
fn dump() -> Result<(), Error> {
    let mut file = HostFile::create(config::OUTPUT).ok_or(Error::Open)?;
    let mut chunk = [0u8; 256];
    let mut len = 0;
    let mut ok = true;
    for b in FRAMEBUFFER.bytes_be() {
        if let Some(slot) = chunk.get_mut(len) {
            *slot = b;
            len += 1;
        }
        if len == chunk.len() {
            ok &= file.write(&chunk);
            len = 0;
        }
    }
    if let Some(rest) = chunk.get(..len) {
        ok &= rest.is_empty() || file.write(rest);
    }
    if !(file.close() && ok) {
        return Err(Error::Write);
    }
    Ok(())
}

/// Prints the one-line summary (strings with `write_str`, as the
/// single-core firmware does, to keep the formatter's padding code out).
#[inline(never)]
fn summary(core0: &Summary, core1: Option<&Summary>) {
    let mut out = HostOut::stdout();
    let o = &mut out;
    qemu::write_run(
        o,
        "micropt dualcore",
        config::SCENE_NAME,
        (WIDTH, HEIGHT),
        config::BUDGET,
        config::ADAPTIVE,
        config::SKIP_LABEL,
        SEED,
    );
    let _ = write!(o, ", {CORES} cores:");
    let mut total = *core0;
    for (k, s) in core::iter::once(core0).chain(core1).enumerate() {
        let _ = write!(
            o,
            " core {k} {} samples {} paths;",
            s.samples, s.stats.paths
        );
        if k > 0 {
            total.samples += s.samples;
            total.stats.merge(&s.stats);
        }
    }
    let _ = write!(
        o,
        " {} samples, {} paths, {} bounce rays, {} shadow rays, {} non-finite; ",
        total.samples,
        total.stats.paths,
        total.stats.bounce_rays,
        total.stats.shadow_rays,
        total.stats.nonfinite,
    );
    let _ = o.write_str("wrote ");
    let _ = o.write_str(output_name());
    let _ = write!(
        o,
        " ({} bytes); stack high-water core 0 {} bytes",
        WIDTH * HEIGHT * 2,
        qemu::main_stack_high_water()
    );
    if CORES > 1 {
        let bottom = (&raw const CORE1_STACK) as usize;
        let top = bottom + CORE1_STACK_WORDS * 4;
        let _ = write!(o, ", core 1 {} bytes", qemu::stack_high_water(bottom, top));
    }
    let _ = o.write_str("\n");
}

fn report(e: &Error) {
    let mut err = HostOut::stderr();
    let o = &mut err;
    let _ = o.write_str("micropt dualcore: ");
    let _ = match e {
        Error::Parse(p) => {
            let _ = o.write_str(config::SCENE_NAME);
            writeln!(o, ": {p}")
        }
        Error::Camera => o.write_str("invalid camera for the image size\n"),
        Error::SqrtMismatch(m) => {
            m.write(o);
            Ok(())
        }
        Error::Deadline => {
            o.write_str("a deadline budget is not shared between cores (use a sample budget)\n")
        }
        Error::Core1Fault => o.write_str("core 1 took a fault\n"),
        Error::Demo(d) => writeln!(o, "the demo's pass: {d}"),
        Error::Open => {
            qemu::write_file_error(o, output_name(), true);
            Ok(())
        }
        Error::Write => {
            qemu::write_file_error(o, output_name(), false);
            Ok(())
        }
    };
}
