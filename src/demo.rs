//! The demo every board and the host run: a small state machine that owns
//! the scene choice, the passes, the exposure, a camera orbit and the
//! status line, and draws through embedded-graphics. A board example is
//! glue around it: pins, SPI, buttons ([`Command`]s), a clock.
//!
//! **Passes at doubling budgets, no accumulator.** Pass `k` renders
//! `base · 2^k` samples in every pixel (`base` the first pass's, 1 on the
//! boards) and shows them, denoised or raw, row by row as they are chosen
//! ([`crate::denoise::denoise_while`]); the next pass renders the pixel's
//! first samples again, and more. Each pass is bit for bit the host's
//! `micropt render SCENE --spp N --denoise` at its `N` (its raw image: the
//! moments' means), so what a board shows is reproducible on the host, and
//! the work to a budget is at most twice the budget's. Why not accumulate
//! pass after pass: the denoiser needs each pixel's sample moments (32
//! bytes a pixel), which at full frame fit none of the boards, while the
//! streaming pass needs only the denoiser's rings (796 bytes a pixel of a
//! row). Nothing is summed across passes, so nothing loses precision or
//! overflows however long it runs: after pass [`LAST_PASS`] the demo holds
//! its image and waits for a button.
//!
//! Before pass 0 a block preview shows one pixel's first sample per 2 × 2
//! block (a quarter of pass 0's work). A button press ([`Demo::apply`]),
//! asked for before every pixel, stops the pass there: a new scene or a
//! new camera position starts again at the preview, a new exposure or the
//! raw/denoised switch re-renders the pass it stopped.

// without the parser there is no `Demo` (it parses its scenes); the
// passes, the buttons and the orbit stay (the firmware's
// MICROPT_FW_PASSES), and what only `Demo` uses is unused
#![cfg_attr(not(feature = "parser"), allow(unused_imports, dead_code))]

use crate::budget::Clock;
use crate::camera::{CameraError, CameraSpec};
use crate::denoise::{self, Column, DenoiseError, Moments, pixel_moments};
use crate::film::{FromEncoded, tone_map};
use crate::geometry::{Color, Vec3};
use crate::math;
#[cfg(feature = "parser")]
use crate::parse::ParseError;
use crate::render::Renderer;
use crate::scene::Scene;
use crate::stats::Stats;
use core::fmt::Write;
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::geometry::{Point, Size};
use embedded_graphics::mono_font::{MonoTextStyle, ascii::FONT_6X10};
use embedded_graphics::primitives::Rectangle;
use embedded_graphics::text::{Baseline, Text};
use embedded_graphics::transform::Transform;
use embedded_graphics::{Drawable, Pixel};

/// A scene compiled into the demo.
#[cfg(feature = "parser")]
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// Its name on the status line.
    pub name: &'static str,
    /// Its text (the scene format).
    pub text: &'static str,
}

/// The shipped scenes (the repository's `scenes/`), in the order the
/// demo steps through them: `many` (482 spheres, a scene of about 100 KB)
/// last, so that a board short of RAM takes the first four.
#[cfg(feature = "parser")]
pub const SCENES: [Entry; 5] = [
    Entry {
        name: "cornell",
        text: include_str!("../scenes/cornell.scene"),
    },
    Entry {
        name: "spheres",
        text: include_str!("../scenes/spheres.scene"),
    },
    Entry {
        name: "gloss",
        text: include_str!("../scenes/gloss.scene"),
    },
    Entry {
        name: "dof",
        text: include_str!("../scenes/dof.scene"),
    },
    Entry {
        name: "many",
        text: include_str!("../scenes/many.scene"),
    },
];

/// What a button asks of the demo.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    /// The next scene of the list (after the last, the first).
    NextScene,
    /// The next exposure of [`EXPOSURES`].
    Exposure,
    /// The camera one [`ORBIT_STEPS`]-th of a turn further around the
    /// point it looks at (about the scene's up vector).
    Orbit,
    /// Denoised or raw.
    Denoise,
    /// The status line on or off.
    Status,
}

/// The exposures [`Command::Exposure`] steps through.
pub const EXPOSURES: [f32; 4] = [1.0, 2.0, 4.0, 0.5];
/// Camera positions of a full orbit.
pub const ORBIT_STEPS: u32 = 12;
/// The last pass: `base · 2^16` samples a pixel.
pub const LAST_PASS: u32 = 16;
/// The status line's height in pixels (one line of the 6 × 10 font).
pub const STATUS_HEIGHT: u32 = 10;

/// The samples a pixel of pass `k` when the first pass has `base`
/// (saturating at `u32::MAX`).
pub const fn pass_spp(base: u32, k: u32) -> u32 {
    let k = if k > LAST_PASS { LAST_PASS } else { k };
    base.saturating_mul(1 << k)
}

/// What the buttons have set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Index of the scene in the demo's list.
    pub scene: usize,
    /// Index into [`EXPOSURES`].
    pub exposure: usize,
    /// Orbit steps from the scene's own camera.
    pub orbit: u32,
    /// Raw (else denoised).
    pub raw: bool,
    /// Whether the status line is drawn.
    pub status: bool,
}

impl Settings {
    /// The first scene, exposure 1, the scene's camera, denoised, with
    /// the status line.
    pub const START: Self = Self {
        scene: 0,
        exposure: 0,
        orbit: 0,
        raw: false,
        status: true,
    };
}

/// What one finished pass measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassStats {
    /// The pass's index.
    pub pass: u32,
    /// Its samples a pixel.
    pub spp: u32,
    /// Its time, by the demo's clock.
    pub micros: u64,
    /// The raw image's relative RMS error as its own samples estimate it:
    /// `√(mean over pixels of σ² / (b² + 0.01))`, `σ²` the variance of a
    /// pixel's mean luminance from its samples' spread, `b` the mean (the
    /// relative MSE of the benches, as a root). 0 below two samples.
    pub noise: f32,
    /// The paths traced.
    pub paths: u64,
    /// The slowest pixel's time, by the demo's clock, when the demo
    /// measures it ([`Demo::set_pixel_limit`]); 0 otherwise.
    pub slowest_us: u64,
}

/// How a call of [`Demo::step`] ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// The pass is on the panel.
    Done(PassStats),
    /// A button was pressed during the pass (already applied).
    Interrupted(Command),
    /// Every pass is done and no button was pressed: the image stays (a
    /// press, asked for once in each such call, is applied and reported
    /// as `Interrupted`).
    Idle,
}

/// Why the demo cannot go on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DemoError {
    /// The demo has no scenes.
    NoScenes,
    /// A compiled-in scene does not parse (its index, and why).
    #[cfg(feature = "parser")]
    Scene(usize, ParseError),
    /// The camera (the scene's, or its orbit) is unusable.
    Camera(CameraError),
    /// The denoiser's workspace, or the row of colours, is narrower than
    /// the image.
    Workspace,
    /// The panel refused a drawing call.
    Draw,
}

impl core::fmt::Display for DemoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DemoError::NoScenes => f.write_str("the demo has no scenes"),
            #[cfg(feature = "parser")]
            DemoError::Scene(i, e) => write!(f, "compiled-in scene {i}: {e}"),
            DemoError::Camera(e) => write!(f, "camera: {e:?}"),
            DemoError::Workspace => {
                f.write_str("the denoiser's workspace or the row buffer is narrower than the image")
            }
            DemoError::Draw => f.write_str("the panel refused a drawing call"),
        }
    }
}

impl From<DenoiseError> for DemoError {
    fn from(_: DenoiseError) -> Self {
        DemoError::Workspace
    }
}

/// Where a pass's pixels come from: each pixel's `spp` samples summed in
/// sample order into its moments (so that the bits do not depend on who
/// renders them). One core: [`OneCore`]; a two-core board hands the odd
/// pixels of each row to its other core. [`Demo::step`] calls
/// [`Pixels::begin`] before a pass's first pixel and [`Pixels::end`] after
/// its last, however the pass ends (finished, stopped by a press, failed),
/// before the renderer is dropped: a source that lets another core use the
/// renderer between the two must have it stop before `end` returns.
pub trait Pixels {
    /// A pass of `renderer`'s image at `spp` samples a pixel begins.
    fn begin(&mut self, renderer: &Renderer<'_>, spp: u32) {
        let _ = (renderer, spp);
    }

    /// The pass has ended: nothing may use its renderer after this
    /// returns. The paths traced for it elsewhere (another core's), for
    /// the pass's count.
    fn end(&mut self) -> u64 {
        0
    }

    /// Pixel (x, y)'s moments at `spp` samples, asked row by row, left to
    /// right, by a pass of `renderer`'s image; `stats` counts the paths.
    fn moments(
        &mut self,
        renderer: &Renderer<'_>,
        spp: u32,
        x: u32,
        y: u32,
        stats: &mut Stats,
    ) -> Moments;
}

/// Every pixel rendered where it is asked for.
#[derive(Clone, Copy, Debug, Default)]
pub struct OneCore;

impl Pixels for OneCore {
    fn moments(
        &mut self,
        renderer: &Renderer<'_>,
        spp: u32,
        x: u32,
        y: u32,
        stats: &mut Stats,
    ) -> Moments {
        pixel_moments(renderer, spp, x, y, stats)
    }
}

/// One pass of `renderer`'s image at `spp` samples a pixel, raw (each
/// pixel's mean) or denoised, row by row: `pixel(x, y)` gives each pixel's
/// moments when asked (row by row, left to right; [`denoise::pixel_moments`], or a
/// [`Pixels`] source), `emit(y, x, colour)` receives each output pixel
/// (linear radiance), `go_on(y)` after each row says whether to go on.
/// Returns whether every row was emitted, and the raw image's noise
/// estimate ([`PassStats::noise`]). The demo's pass, the firmware's
/// `MICROPT_FW_PASSES` and the host's `--passes` all run this.
pub fn render_pass(
    renderer: &Renderer<'_>,
    spp: u32,
    raw: bool,
    columns: &mut [Column],
    mut pixel: impl FnMut(u32, u32) -> Moments,
    mut emit: impl FnMut(u32, u32, Color),
    mut go_on: impl FnMut(u32) -> bool,
) -> Result<(bool, f32), DemoError> {
    let (w, h) = (renderer.width(), renderer.height());
    let mut noise = 0.0f32;
    let mut pixel = |x: u32, y: u32| {
        let m = pixel(x, y);
        noise += relative_variance(&m, spp);
        m
    };
    // below two samples the denoiser keeps every pixel as rendered, and
    // its output has the raw mean's bits (n = 1: the sums times 1.0); the
    // raw path skips its guide rays
    let done = if raw || spp < 2 {
        let mut done = true;
        'rows: for y in 0..h {
            for x in 0..w {
                let m = pixel(x, y);
                emit(y, x, m.mean(spp));
            }
            if !go_on(y) {
                done = false;
                break 'rows;
            }
        }
        done
    } else {
        denoise::denoise_while(renderer, pixel, spp, columns, |_, _, _| {}, emit, go_on)?
    };
    let pixels = (w as f32) * (h as f32);
    Ok((done, math::sqrt(noise / pixels)))
}

/// A pixel's `σ² / (b² + 0.01)` from its moments ([`PassStats::noise`]):
/// the variance of its mean luminance from the scattered part's spread
/// (the part whose moments are kept), over its mean's luminance squared.
fn relative_variance(m: &Moments, n: u32) -> f32 {
    if n < 2 {
        return 0.0;
    }
    let nf = n as f32;
    let sum = Color::new(m.scattered[0], m.scattered[1], m.scattered[2]).luminance();
    let var = math::max(m.square - sum * sum / nf, 0.0) / (nf * (nf - 1.0));
    let b = m.mean(n).luminance();
    let r = var / (b * b + 0.01);
    if math::is_finite(r) { r } else { 0.0 }
}

/// How long a button must read the same before its state counts (contact
/// bounce).
pub const DEBOUNCE_US: u64 = 20_000;
/// A press held this long is a long press.
pub const LONG_PRESS_US: u64 = 600_000;

/// A finished press of button `i` of a [`Buttons`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Press {
    /// Released before [`LONG_PRESS_US`].
    Short(usize),
    /// Held [`LONG_PRESS_US`] (reported then; its release is not a press).
    Long(usize),
}

/// `N` debounced buttons, read by the board whenever it likes (the demo
/// asks before each pixel): a state counts once it has read the same for
/// [`DEBOUNCE_US`].
#[derive(Clone, Copy, Debug)]
pub struct Buttons<const N: usize> {
    /// The last reading, and since when it has read so.
    raw: [bool; N],
    since: [u64; N],
    /// The debounced state, and since when it has been down.
    down: [bool; N],
    down_at: [u64; N],
    /// Whether this press was reported as long already.
    long: [bool; N],
}

impl<const N: usize> Buttons<N> {
    /// Every button up.
    pub const fn new() -> Self {
        Self {
            raw: [false; N],
            since: [0; N],
            down: [false; N],
            down_at: [0; N],
            long: [false; N],
        }
    }

    /// One reading of every button (`true`: pressed) at `now`
    /// microseconds: the press it finishes, if any (the lowest button's,
    /// if several).
    pub fn update(&mut self, now: u64, pressed: [bool; N]) -> Option<Press> {
        let mut out = None;
        for (i, &p) in pressed.iter().enumerate() {
            let (Some(raw), Some(since)) = (self.raw.get_mut(i), self.since.get_mut(i)) else {
                continue;
            };
            if p != *raw {
                *raw = p;
                *since = now;
                continue;
            }
            let stable = now.saturating_sub(*since) >= DEBOUNCE_US;
            let (Some(down), Some(down_at), Some(long)) = (
                self.down.get_mut(i),
                self.down_at.get_mut(i),
                self.long.get_mut(i),
            ) else {
                continue;
            };
            let event = if stable && p != *down {
                *down = p;
                if p {
                    *down_at = *since;
                    *long = false;
                    None
                } else {
                    (!*long).then_some(Press::Short(i))
                }
            } else if *down && !*long && now.saturating_sub(*down_at) >= LONG_PRESS_US {
                *long = true;
                Some(Press::Long(i))
            } else {
                None
            };
            out = out.or(event);
        }
        out
    }
}

impl<const N: usize> Default for Buttons<N> {
    fn default() -> Self {
        Self::new()
    }
}

/// `spec`'s eye turned by `steps` [`ORBIT_STEPS`]-ths of a turn about the
/// axis through its target along its up vector (Rodrigues' rotation).
pub fn orbit(spec: &CameraSpec, steps: u32) -> CameraSpec {
    let turns = (steps % ORBIT_STEPS) as f32 / ORBIT_STEPS as f32;
    let (s, c) = math::sincos_turns(turns);
    let k = spec.up.normalize();
    let v = spec.eye - spec.target;
    let r: Vec3 = v * c + k.cross(v) * s + k * (k.dot(v) * (1.0 - c));
    CameraSpec {
        eye: spec.target + r,
        ..*spec
    }
}

/// The demo: its scenes, the scene being shown (parsed into caller-owned
/// memory), the denoiser's rings, the settings and the pass.
#[cfg(feature = "parser")]
#[derive(Debug)]
pub struct Demo<'a, const S: usize, const P: usize, const M: usize> {
    entries: &'a [Entry],
    scene: &'a mut Scene<S, P, M>,
    columns: &'a mut [Column],
    /// The scene's own camera (the orbit's start).
    camera: CameraSpec,
    width: u32,
    height: u32,
    seed: u64,
    base: u32,
    settings: Settings,
    pass: u32,
    last: Option<PassStats>,
    /// The longest a pixel may take ([`Demo::set_pixel_limit`]).
    pixel_limit: Option<u64>,
    /// The board's line above the status line ([`Demo::set_note`]).
    note: heapless::String<NOTE_LEN>,
    /// The block preview's block size ([`Demo::set_preview_block`]).
    preview_block: u32,
}

/// The longest note a board can put above the status line
/// ([`Demo::set_note`]), in characters: the width of a 320-pixel panel in
/// the 6 × 10 font is 53.
pub const NOTE_LEN: usize = 48;

#[cfg(feature = "parser")]
impl<'a, const S: usize, const P: usize, const M: usize> Demo<'a, S, P, M> {
    /// A `width × height` demo of `entries` (the first shown first),
    /// parsing each into `scene` when it is chosen, denoising through
    /// `columns` (at least `width`), its first pass at `base` samples a
    /// pixel (1 on a board: a preview), rendered with `seed`.
    pub fn new(
        entries: &'a [Entry],
        scene: &'a mut Scene<S, P, M>,
        columns: &'a mut [Column],
        (width, height): (u32, u32),
        base: u32,
        seed: u64,
    ) -> Result<Self, DemoError> {
        if columns.len() < width as usize {
            return Err(DemoError::Workspace);
        }
        let entry = entries.first().ok_or(DemoError::NoScenes)?;
        crate::parse::parse_into(entry.text, scene).map_err(|e| DemoError::Scene(0, e))?;
        Ok(Self {
            entries,
            camera: *scene.camera(),
            scene,
            columns,
            width,
            height,
            seed,
            base: base.max(1),
            settings: Settings::START,
            pass: 0,
            last: None,
            pixel_limit: None,
            note: heapless::String::new(),
            preview_block: 2,
        })
    }

    /// Sets the block preview's block: before pass 0 each `n` × `n` block
    /// shows its top-left pixel's first sample, `1 / n²` of pass 0's work
    /// (2 by default; 4 where pass 0 is slow, as on the soft-float boards;
    /// 0 or 1: no preview). At most 16.
    pub fn set_preview_block(&mut self, n: u32) {
        self.preview_block = n.min(16);
    }

    /// Sets the longest a pixel may take, in the clock's microseconds (a
    /// board's watchdog period, fed before each pixel): each pixel of a
    /// pass is then timed, and the next pass, whose pixels take about
    /// twice as long, is not started when twice its slowest pixel's
    /// estimate would exceed `micros` (the image stays, as after
    /// [`LAST_PASS`]). A changed scene, camera or setting starts again.
    pub fn set_pixel_limit(&mut self, micros: u64) {
        self.pixel_limit = Some(micros);
    }

    /// Whether the passes stop short of [`LAST_PASS`] because the next
    /// one's pixels could outlast the pixel limit.
    pub fn held(&self) -> bool {
        match (self.pixel_limit, self.last) {
            (Some(limit), Some(p)) => {
                // the next pass doubles each pixel's samples; a factor 2
                // more for the spread of a pixel's time between passes
                p.pass + 1 == self.pass && p.slowest_us.saturating_mul(4) > limit
            }
            _ => false,
        }
    }

    /// Sets the line drawn above the status line (when the status line is
    /// on and the note is not empty): what the board adds, e.g. why it
    /// last reset and its stack's high-water mark. Cut at [`NOTE_LEN`]
    /// characters.
    pub fn set_note(&mut self, text: &str) {
        self.note.clear();
        for c in text.chars() {
            if self.note.push(c).is_err() {
                break;
            }
        }
    }

    /// The note above the status line ([`Demo::set_note`]).
    pub fn note(&self) -> &str {
        &self.note
    }

    /// What the buttons have set.
    pub fn settings(&self) -> Settings {
        self.settings
    }

    /// The next pass's index.
    pub fn pass(&self) -> u32 {
        self.pass
    }

    /// The last finished pass's figures.
    pub fn last(&self) -> Option<PassStats> {
        self.last
    }

    /// The scene being shown.
    pub fn scene(&self) -> &Scene<S, P, M> {
        self.scene
    }

    /// Parses the chosen scene and places its camera on the orbit.
    fn load(&mut self) -> Result<(), DemoError> {
        let i = self.settings.scene;
        let entry = self.entries.get(i).ok_or(DemoError::NoScenes)?;
        crate::parse::parse_into(entry.text, self.scene).map_err(|e| DemoError::Scene(i, e))?;
        self.camera = *self.scene.camera();
        self.place_camera()
    }

    fn place_camera(&mut self) -> Result<(), DemoError> {
        let spec = orbit(&self.camera, self.settings.orbit);
        self.scene.set_camera(spec).map_err(DemoError::Camera)
    }

    /// Applies a button's command: the settings change, and the next pass
    /// is the first (a new scene or camera position) or the same again (a
    /// new exposure, raw or denoised); the status line's switch keeps the
    /// pass.
    pub fn apply(&mut self, c: Command) -> Result<(), DemoError> {
        let s = &mut self.settings;
        match c {
            Command::NextScene => {
                s.scene = (s.scene + 1) % self.entries.len().max(1);
                s.orbit = 0;
                self.pass = 0;
                self.last = None;
                self.load()?;
            }
            Command::Orbit => {
                s.orbit = (s.orbit + 1) % ORBIT_STEPS;
                self.pass = 0;
                self.last = None;
                self.place_camera()?;
            }
            Command::Exposure => {
                s.exposure = (s.exposure + 1) % EXPOSURES.len();
                self.again();
            }
            Command::Denoise => {
                s.raw = !s.raw;
                self.again();
            }
            Command::Status => s.status = !s.status,
        }
        Ok(())
    }

    /// The pass shown last, again (with new settings).
    fn again(&mut self) {
        if let Some(last) = self.last {
            self.pass = last.pass;
        }
    }

    /// Renders the next pass into `target` (its panel, `width × height`),
    /// each row as it is ready, tone-mapped at the exposure and dithered
    /// (`line`: one row of colours); `pixels` renders the pixels, `clock`
    /// times the pass, `poll()` is asked before each pixel whether a
    /// button was pressed (the command is applied and the pass left there,
    /// its rows not yet drawn left as they were). After a finished pass the
    /// status line is drawn (if on).
    pub fn step<D, K>(
        &mut self,
        target: &mut D,
        line: &mut [D::Color],
        pixels: &mut impl Pixels,
        clock: &mut K,
        mut poll: impl FnMut() -> Option<Command>,
    ) -> Result<Step, DemoError>
    where
        D: DrawTarget,
        D::Color: FromEncoded,
        K: Clock,
    {
        if self.pass > LAST_PASS || self.held() {
            // the last pass stays on the panel until a button changes it
            if let Some(c) = poll() {
                self.apply(c)?;
                return Ok(Step::Interrupted(c));
            }
            return Ok(Step::Idle);
        }
        let (w, h) = (self.width, self.height);
        if line.len() < w as usize {
            return Err(DemoError::Workspace);
        }
        let renderer = Renderer::new(&*self.scene, w, h)
            .map_err(DemoError::Camera)?
            .seed(self.seed);
        let spp = pass_spp(self.base, self.pass);
        let exposure = EXPOSURES
            .get(self.settings.exposure)
            .copied()
            .unwrap_or(1.0);
        let start = clock.micros();
        let mut stats = Stats::default();
        // the first pass is preceded by a quarter of it: each 2 × 2 block
        // shows its top-left pixel's first sample (a quarter of the work,
        // drawn over by the pass as its rows land)
        let preview = if self.pass == 0 && self.preview_block > 1 {
            self.block_preview(&renderer, target, line, exposure, &mut poll)?
        } else {
            None
        };
        if let Some(c) = preview {
            self.apply(c)?;
            if self.settings.status {
                self.draw_status(target)?;
            }
            return Ok(Step::Interrupted(c));
        }
        let failed = core::cell::Cell::new(false);
        // a press, asked for before each pixel: the pass stops within a
        // pixel's samples (the rest of its row is not rendered, and no row
        // is drawn after it)
        let pressed = core::cell::Cell::new(None);
        let timed = self.pixel_limit.is_some();
        let mut slowest = 0u64;
        pixels.begin(&renderer, spp);
        let pass = render_pass(
            &renderer,
            spp,
            self.settings.raw,
            self.columns,
            |x, y| {
                if pressed.get().is_none() {
                    pressed.set(poll());
                }
                if pressed.get().is_some() {
                    return Moments::ZERO;
                }
                if !timed {
                    return pixels.moments(&renderer, spp, x, y, &mut stats);
                }
                let t0 = clock.micros();
                let m = pixels.moments(&renderer, spp, x, y, &mut stats);
                slowest = slowest.max(clock.micros().saturating_sub(t0));
                m
            },
            |y, x, c| {
                if pressed.get().is_some() {
                    return;
                }
                if let Some(px) = line.get_mut(x as usize) {
                    *px = D::Color::from_encoded(tone_map(c, exposure), x, y);
                }
                if x + 1 == w {
                    let row = Rectangle::new(Point::new(0, y as i32), Size::new(w, 1));
                    let colours = line.iter().take(w as usize).copied();
                    if target.fill_contiguous(&row, colours).is_err() {
                        failed.set(true);
                    }
                }
            },
            |_| pressed.get().is_none() && !failed.get(),
        );
        // the other core's part stops before the renderer goes
        stats.paths += pixels.end();
        let (done, noise) = pass?;
        if failed.get() {
            return Err(DemoError::Draw);
        }
        if let Some(c) = pressed.get() {
            self.apply(c)?;
            if self.settings.status {
                self.draw_status(target)?;
            }
            return Ok(Step::Interrupted(c));
        }
        // (not done only when a press or a failed draw stopped it)
        let _ = done;
        let pass = PassStats {
            pass: self.pass,
            spp,
            micros: clock.micros().saturating_sub(start),
            noise,
            paths: stats.paths,
            slowest_us: slowest,
        };
        self.last = Some(pass);
        self.pass += 1;
        if self.settings.status {
            self.draw_status(target)?;
        }
        Ok(Step::Done(pass))
    }

    /// The block preview before pass 0: one sample of the top-left pixel
    /// of each block ([`Demo::set_preview_block`]; the pixel's sample 0,
    /// as pass 0 renders it), drawn over the block, a block's rows at a
    /// time. Returns the button
    /// pressed, if one stopped it (asked before each block).
    fn block_preview<D>(
        &self,
        renderer: &Renderer<'_>,
        target: &mut D,
        line: &mut [D::Color],
        exposure: f32,
        poll: &mut impl FnMut() -> Option<Command>,
    ) -> Result<Option<Command>, DemoError>
    where
        D: DrawTarget,
        D::Color: FromEncoded,
    {
        let (w, h) = (self.width, self.height);
        let n = self.preview_block.max(1);
        let mut stats = Stats::default();
        for y in (0..h).step_by(n as usize) {
            for x in (0..w).step_by(n as usize) {
                if let Some(c) = poll() {
                    return Ok(Some(c));
                }
                let m = pixel_moments(renderer, 1, x, y, &mut stats);
                let colour = D::Color::from_encoded(tone_map(m.mean(1), exposure), x, y);
                for px in line.iter_mut().skip(x as usize).take(n as usize) {
                    *px = colour;
                }
            }
            let rows = Rectangle::new(Point::new(0, y as i32), Size::new(w, 1));
            for dy in 0..n.min(h - y) {
                let row = rows.translate(Point::new(0, dy as i32));
                let colours = line.iter().take(w as usize).copied();
                target
                    .fill_contiguous(&row, colours)
                    .map_err(|_| DemoError::Draw)?;
            }
        }
        Ok(None)
    }

    /// The status line's text: scene, samples a pixel, seconds, the noise
    /// estimate, raw or denoised (`dn`), exposure and orbit when not the
    /// scene's own.
    pub fn status(&self, out: &mut impl Write) -> core::fmt::Result {
        let name = self
            .entries
            .get(self.settings.scene)
            .map_or("?", |e| e.name);
        out.write_str(name)?;
        match self.last {
            Some(p) => {
                write!(out, " {}spp ", p.spp)?;
                // tenths of a second
                decimal(out, p.micros / 100_000, 6, 1)?;
                out.write_str("s err ")?;
                decimal(out, (p.noise * 1000.0) as u64, 3, 3)?;
            }
            None => out.write_str(" preview")?,
        }
        out.write_str(if self.settings.raw { " raw" } else { " dn" })?;
        if self.settings.exposure != 0 {
            let e = EXPOSURES
                .get(self.settings.exposure)
                .copied()
                .unwrap_or(1.0);
            write!(out, " x{}", ExposureText(e))?;
        }
        if self.settings.orbit != 0 {
            write!(out, " orbit {}/{}", self.settings.orbit, ORBIT_STEPS)?;
        }
        Ok(())
    }

    /// Draws the status line over the image's last rows: white on black,
    /// the 6 × 10 mono font.
    pub fn draw_status<D>(&self, target: &mut D) -> Result<(), DemoError>
    where
        D: DrawTarget,
        D::Color: FromEncoded,
    {
        let mut text: heapless::String<64> = heapless::String::new();
        // a longer line is cut, not an error
        let _ = self.status(&mut text);
        let black = D::Color::from_encoded([0.0; 3], 0, 0);
        let white = D::Color::from_encoded([1.0; 3], 0, 0);
        let top = self.height.saturating_sub(STATUS_HEIGHT) as i32;
        text_band(target, &text, top, self.width, (black, white))?;
        if !self.note.is_empty() {
            let above = top - STATUS_HEIGHT as i32;
            text_band(target, &self.note, above, self.width, (black, white))?;
        }
        Ok(())
    }
}

/// A band of [`STATUS_HEIGHT`] rows at `top`, `width` wide, filled with
/// `colours.0`, `text` on it in `colours.1` (the 6 × 10 mono font).
fn text_band<D: DrawTarget>(
    target: &mut D,
    text: &str,
    top: i32,
    width: u32,
    (back, fore): (D::Color, D::Color),
) -> Result<(), DemoError> {
    let band = Rectangle::new(Point::new(0, top), Size::new(width, STATUS_HEIGHT));
    target
        .fill_solid(&band, back)
        .map_err(|_| DemoError::Draw)?;
    Text::with_baseline(
        text,
        Point::new(1, top),
        MonoTextStyle::new(&FONT_6X10, fore),
        Baseline::Top,
    )
    .draw(&mut Clipped(target))
    .map_err(|_| DemoError::Draw)?;
    Ok(())
}

/// Writes `v / 10^frac` with `frac` decimals, `v / 10^frac` cut at `int`
/// digits' worth (no float formatting: its code is large on a board).
fn decimal(out: &mut impl Write, v: u64, int: u32, frac: u32) -> core::fmt::Result {
    let scale = 10u64.pow(frac);
    let whole = (v / scale).min(10u64.pow(int) - 1);
    write!(out, "{whole}.")?;
    let mut rest = v % scale;
    let mut div = scale / 10;
    while div > 0 {
        write!(out, "{}", rest / div)?;
        rest %= div;
        div /= 10;
    }
    Ok(())
}

/// An exposure as the status line writes it: `0.5`, `2`, `4`.
struct ExposureText(f32);

impl core::fmt::Display for ExposureText {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let tenths = (self.0 * 10.0) as u64;
        if tenths.is_multiple_of(10) {
            write!(f, "{}", tenths / 10)
        } else {
            write!(f, "{}.{}", tenths / 10, tenths % 10)
        }
    }
}

/// A target whose pixels outside it are dropped (embedded-graphics'
/// `Text` draws pixel by pixel; a panel driver may refuse those outside).
struct Clipped<'t, D>(&'t mut D);

impl<D: DrawTarget> embedded_graphics::geometry::Dimensions for Clipped<'_, D> {
    fn bounding_box(&self) -> Rectangle {
        self.0.bounding_box()
    }
}

impl<D: DrawTarget> DrawTarget for Clipped<'_, D> {
    type Color = D::Color;
    type Error = D::Error;

    fn draw_iter<I>(&mut self, pixels: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Pixel<Self::Color>>,
    {
        let area = self.0.bounding_box();
        self.0
            .draw_iter(pixels.into_iter().filter(|p| area.contains(p.0)))
    }
}

#[cfg(all(test, feature = "parser"))]
mod tests;
