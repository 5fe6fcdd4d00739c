//! What the two Pico examples share: the demo on core 0
//! (`micropt::demo`: passes, buttons, scenes), or with the `raw` feature
//! each core's part of the progressive raw frame through
//! `micropt::multicore::render_shared`, and what they tell the user: defmt
//! log lines (over RTT, to a debug probe) and the Pimoroni Display Pack's
//! RGB LED (GP6 red, GP7 green, GP8 blue, active low): blue while
//! rendering, green when done, red blinking a failed step's number.
//!
//! Shared by the Pico board crates in `examples/boards/` (`#[path]`).

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
    micropt::demo::{Buttons, Command, Demo, DemoError, Entry, OneCore, Press, Step as DemoStep},
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

/// The demo, forever, on core 0: pass after pass of `entries` into
/// `target` (`size`, rendered with `seed`), `pressed()` read before each pixel (A, B, X, Y;
/// `true`: pressed), debounced ([`Buttons`]). The LED: blue while a pass
/// renders, green when the last pass is on the panel; a failure is logged
/// and blinked (`step_of`: [`Step::Scene`] for a scene that does not
/// parse, [`Step::Draw`] for the panel).
#[cfg(not(feature = "raw"))]
pub fn demo<D, P, const W: usize, const S: usize, const PL: usize, const M: usize>(
    entries: &'static [Entry],
    memory: Option<&'static mut DemoMemory<W, S, PL, M>>,
    (size, seed): ((u32, u32), u64),
    mut target: D,
    mut pressed: impl FnMut() -> [bool; 4],
    led: &mut Led<P>,
    now: fn() -> u64,
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
    let mut buttons: Buttons<4> = Buttons::new();
    let mut clock = Micros(now);
    let mut poll = move || buttons.update(now(), pressed()).and_then(command);
    loop {
        led.set(BLUE);
        match demo.step(&mut target, line, &mut OneCore, &mut clock, &mut poll) {
            Ok(DemoStep::Done(_)) => {
                let mut text: heapless::String<64> = heapless::String::new();
                let _ = demo.status(&mut text);
                info!("{=str}", text.as_str());
            }
            Ok(DemoStep::Interrupted(c)) => info!("button: {}", defmt::Debug2Format(&c)),
            Ok(DemoStep::Idle) => led.set(GREEN),
            Err(e) => {
                error!("demo: {}", defmt::Display2Format(&e));
                fail(led, step_of(&e))
            }
        }
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
