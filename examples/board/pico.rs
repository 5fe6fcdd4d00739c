//! What the two Pico examples share: each core's part of a frame through
//! `micropt::multicore::render_shared`, and what they tell the user: defmt
//! log lines (over RTT, to a debug probe) and the Pimoroni Display Pack's
//! RGB LED (GP6 red, GP7 green, GP8 blue, active low): blue while
//! rendering, green when done, red blinking a failed step's number.
//!
//! Shared by the Pico board crates in `examples/boards/` (`#[path]`).

use crate::progress::Milestone;
use core::sync::atomic::{AtomicBool, Ordering};
use defmt::{error, info};
use embedded_graphics::draw_target::DrawTarget;
use embedded_hal::digital::{OutputPin, PinState};
use micropt::budget::TileAccum;
use micropt::film::FromEncoded;
use micropt::multicore::{Pass, SharedError, WorkQueue, render_shared, wait_all};
use micropt::{AdaptiveOptions, Budget, Renderer, Scene};

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

/// Static memory and the renderer: the scene parsed in place, one tile of
/// accumulators per core, and the renderer of a `width` × `height` image
/// with `seed`. A failed step is logged and blinked on `led`.
pub fn setup<P: OutputPin>(
    led: &mut Led<P>,
    width: u32,
    height: u32,
    seed: u64,
) -> (
    Renderer<'static>,
    &'static mut TileAccum,
    &'static mut TileAccum,
) {
    let (Some(scene), Some(acc0), Some(acc1)) = (
        cortex_m::singleton!(: BoardScene = BoardScene::EMPTY),
        cortex_m::singleton!(: TileAccum = TileAccum::new()),
        cortex_m::singleton!(: TileAccum = TileAccum::new()),
    ) else {
        fail(led, Step::Memory)
    };
    if micropt::parse::parse_into(SCENE_TEXT, scene).is_err() {
        fail(led, Step::Scene)
    }
    let scene: &'static BoardScene = scene;
    let Ok(renderer) = Renderer::new(scene, width, height) else {
        fail(led, Step::Renderer)
    };
    (renderer.seed(seed), acc0, acc1)
}

/// Logs how far the frame has come.
pub fn report(m: Milestone) {
    match m {
        Milestone::Preview => info!("preview on the panel"),
        Milestone::Refined(p) => info!("refined: {=u32}%", p),
    }
}

/// Core 1's part of a frame: renders tiles from `queue` into `target` (its
/// view of the shared panel), logs its paths, records a failed draw in
/// `failed`, and stops.
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

/// Core 0's part of a frame and its end: renders tiles from `queue` into
/// `target`, waits for every core of the queue, then logs the frame time
/// (from `start`, by `now`, in microseconds) and lights the LED green, or
/// red blinks if a core could not draw (`failed`).
#[allow(clippy::too_many_arguments)]
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
