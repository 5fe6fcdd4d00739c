//! What the two Pico examples share: each core's part of a frame (the
//! denoised frame through `denoised.rs`, or with the `raw` feature the
//! progressive raw frame through `micropt::multicore::render_shared`), and
//! what they tell the user: defmt
//! log lines (over RTT, to a debug probe) and the Pimoroni Display Pack's
//! RGB LED (GP6 red, GP7 green, GP8 blue, active low): blue while
//! rendering, green when done, red blinking a failed step's number.
//!
//! Shared by the Pico board crates in `examples/boards/` (`#[path]`).

use defmt::{error, info, warn};
use embedded_graphics::draw_target::DrawTarget;
use embedded_hal::digital::{OutputPin, PinState};
use micropt::{Renderer, Scene};
#[cfg(not(feature = "raw"))]
use {
    crate::denoised,
    crate::mailbox::{Mailbox, TwoCores},
    embedded_graphics::pixelcolor::{Rgb565, RgbColor},
    micropt::denoise::{Column, Moments},
};
#[cfg(feature = "raw")]
use {
    crate::progress::Milestone,
    core::sync::atomic::{AtomicBool, Ordering},
    micropt::budget::TileAccum,
    micropt::film::FromEncoded,
    micropt::multicore::{Pass, SharedError, WorkQueue, render_shared, wait_all},
    micropt::{AdaptiveOptions, Budget},
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

/// The scene, parsed on the board.
const SCENE_TEXT: &str = include_str!("../../scenes/cornell.scene");
/// Fixed capacities: enough for cornell.scene (3 spheres, 6 planes, 6
/// materials); a bigger scene gives a capacity error, not a panic.
type BoardScene = Scene<4, 8, 8>;

/// The scene parsed in place (static) and the renderer of a `width` ×
/// `height` image with `seed`. A failed step is logged and blinked on
/// `led`.
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

/// A denoised frame's static memory, `W` pixels wide (`N` = `W / 2`
/// rounded up): core 0's [`DenoiseMemory`], core 1's half row of moments
/// and the [`Mailbox`] between them. All zero bits (.bss, not flash).
#[cfg(not(feature = "raw"))]
pub struct Statics<const W: usize, const N: usize> {
    columns: [Column; W],
    row: [Moments; W],
    line: [Rgb565; W],
    odd: [Moments; N],
    mailbox: Mailbox<N>,
}

#[cfg(not(feature = "raw"))]
impl<const W: usize, const N: usize> Statics<W, N> {
    /// Before the frame.
    pub const fn new() -> Self {
        Self {
            columns: [Column::EMPTY; W],
            row: [Moments::ZERO; W],
            line: [Rgb565::BLACK; W],
            odd: [Moments::ZERO; N],
            mailbox: Mailbox::new(),
        }
    }
}

/// What core 1 is given to run ([`Core1Part::run`]).
#[cfg(not(feature = "raw"))]
pub struct Core1Part<const N: usize> {
    renderer: Renderer<'static>,
    spp: u32,
    mailbox: &'static Mailbox<N>,
    odd: &'static mut [Moments],
}

#[cfg(not(feature = "raw"))]
impl<const N: usize> Core1Part<N> {
    /// Core 1's part of the frame ([`denoised_core1`]).
    pub fn run(self) -> ! {
        denoised_core1(&self.renderer, self.spp, self.mailbox, self.odd)
    }
}

/// A denoised frame on both cores, and its end: `spawn` starts core 1 on
/// its part (and says whether it started); core 0 does the rest
/// ([`denoised_core0`]) into `target`. `statics` is `None` if it was
/// taken before (a bug: blinked as [`Step::Memory`]).
#[cfg(not(feature = "raw"))]
pub fn denoised<D, P, const W: usize, const N: usize>(
    renderer: Renderer<'static>,
    spp: u32,
    statics: Option<&'static mut Statics<W, N>>,
    spawn: impl FnOnce(Core1Part<N>) -> bool,
    target: D,
    led: &mut Led<P>,
    now: fn() -> u64,
) -> !
where
    D: DrawTarget<Color = Rgb565>,
    P: OutputPin,
{
    let Some(Statics {
        columns,
        row,
        line,
        odd,
        mailbox,
    }) = statics
    else {
        fail(led, Step::Memory)
    };
    let mailbox: &'static Mailbox<N> = mailbox;
    led.set(BLUE);
    info!(
        "rendering and denoising {=u32} rows at {=u32} spp on two cores",
        renderer.height(),
        spp
    );
    let start = now();
    let spawned = spawn(Core1Part {
        renderer,
        spp,
        mailbox,
        odd,
    });
    if !spawned {
        warn!("core 1 did not start: core 0 renders alone");
    }
    let mem = DenoiseMemory { columns, row, line };
    denoised_core0(
        &renderer,
        spp,
        spawned.then_some(mailbox),
        mem,
        target,
        led,
        (start, now),
    )
}

/// What a denoised frame streams through on core 0: the denoiser's rings
/// (one `Column` a pixel of a row), one row of moments and one row of
/// panel colours, each at least the image's width.
#[cfg(not(feature = "raw"))]
pub struct DenoiseMemory {
    /// The denoiser's rings.
    pub columns: &'static mut [Column],
    /// One row of moments.
    pub row: &'static mut [Moments],
    /// One row of panel colours.
    pub line: &'static mut [Rgb565],
}

/// Core 1's part of a denoised frame: the odd pixels of every row, `spp`
/// samples each, into `mailbox` (`scratch`: half a row of moments); then
/// it logs its paths and sleeps.
#[cfg(not(feature = "raw"))]
pub fn denoised_core1<const N: usize>(
    r: &Renderer<'_>,
    spp: u32,
    mailbox: &Mailbox<N>,
    scratch: &mut [Moments],
) -> ! {
    let s = mailbox.render_odd(r, spp, scratch);
    info!("core 1: {=u64} paths", s.paths);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Core 0's part of a denoised frame and its end: the even pixels of every
/// row (all of them if `mailbox` is `None`: core 1 did not start), the
/// denoiser, each row to `target` as it is chosen; then it logs the frame
/// time (from `start`, by `now`, in microseconds) and lights the LED
/// green, or red blinks if a row could not be drawn.
#[cfg(not(feature = "raw"))]
pub fn denoised_core0<D, P, const N: usize>(
    r: &Renderer<'_>,
    spp: u32,
    mailbox: Option<&Mailbox<N>>,
    mem: DenoiseMemory,
    mut target: D,
    led: &mut Led<P>,
    (start, now): (u64, fn() -> u64),
) -> !
where
    D: DrawTarget<Color = Rgb565>,
    P: OutputPin,
{
    let mut source = TwoCores {
        mailbox,
        row: mem.row,
        stats: micropt::Stats::default(),
    };
    let h = r.height();
    let result = denoised::frame(
        r,
        spp,
        1.0,
        mem.columns,
        mem.line,
        |x, y| source.pixel(r, spp, x, y),
        &mut target,
        // each tenth of the rows on the panel
        |y| {
            if (y + 1) * 10 / h != y * 10 / h {
                info!("denoised rows: {=u32}%", (y + 1) * 100 / h);
            }
        },
    );
    let micros = now().saturating_sub(start);
    match result {
        Ok(()) => {
            info!("core 0: {=u64} paths", source.stats.paths);
            info!("frame done in {=u64} ms", micros / 1000);
            led.set(GREEN);
        }
        Err(e) => {
            error!("denoised frame: {=str}", e.what());
            fail(led, Step::Draw)
        }
    }
    loop {
        cortex_m::asm::wfi();
    }
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
