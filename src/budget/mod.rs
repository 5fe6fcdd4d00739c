//! The fixed budget: how a render spends samples per pixel, a total number
//! of paths, or a deadline, progressively and adaptively, in bounded memory.
//!
//! A budgeted render runs in two passes over the tiles:
//!
//! 1. **Preview.** Every pixel gets its first sample (index 0) before any
//!    pixel gets more: a complete 1-spp image that a board can show at once.
//!    A board, which keeps one tile of accumulators and so recomputes a
//!    tile's sample 0 before refining it, draws a coarser preview under a
//!    sample budget: sample 0 of one pixel per block of
//!    [`AdaptiveOptions::preview_block`]² (the image is the same).
//! 2. **Refinement.** The rest of the budget is split among the tiles in
//!    proportion to their pixel counts, and within a tile among its pixels:
//!    first one more sample for every pixel, so that each has two and a
//!    variance estimate, then in [`AdaptiveOptions::rounds`] equal rounds, each
//!    in proportion to how far a pixel's count is below the count its
//!    estimated standard deviation calls for, with every weight raised to at
//!    least [`AdaptiveOptions::floor`] times the mean weight. Raising the
//!    small weights also raises their sum, so a pixel is guaranteed
//!    `f / (1 + f)` of the round's even share for a floor `f` (a third with
//!    the default ½; `f·n / (n + (n − 1) f)` exactly for `n` pixels, less one
//!    sample of rounding), not `f`. A pixel's samples always
//!    have consecutive indices from 0, summed in order, so with uniform
//!    allocation (`--uniform`) the image equals the plain `spp` render bit
//!    for bit.
//!
//! **Why σ.** With `n_p` samples a pixel's error variance is `σ_p² / n_p`;
//! the image MSE `Σ σ_p² / n_p` under `Σ n_p = N` is smallest for
//! `n_p ∝ σ_p`. σ is estimated from the luminance of the pixel's samples,
//! shrunk toward the tile's mean variance (a prior worth
//! [`AdaptiveOptions::prior`] samples), because a few samples are a poor
//! estimate, and re-estimated every round.
//!
//! **Adaptive allocation is biased, and consistent.** The allocation depends
//! on a pixel's own samples: a pixel whose early samples found a rare bright
//! path (a caustic, the edge of a light) gets more samples, which dilute that
//! path's weight toward its true share, while a pixel that has not found it
//! yet gets fewer. The mean of a pixel is therefore biased (low, where rare
//! bright paths carry the light), by a term that vanishes as the budget
//! grows: every pixel gets at least a third of the even share of each round
//! (above), so every count grows without bound, and the estimates that steer
//! the allocation converge. It is the default because at the budgets a
//! board can afford it lowers the MSE at equal paths on most shipped scenes;
//! the gain fades as the budget grows, where the remaining error is spread
//! over the image and the Sobol sampler already makes the error of high-σ
//! pixels fall faster than σ²/n. Unbiased schemes (allocation steered only
//! by neighbours' samples, per-round weights fixed before each round, one
//! decision from a pilot, tiles split by preview contrast) do not beat
//! uniform stratified sampling on these scenes: the Sobol sampler already
//! removes most of the variance that is spread evenly, and what is left sits
//! in rare bright paths that only a pixel's own samples reveal (and with
//! stratified samples even per-round weights are not exactly unbiased: later
//! points of a scrambled Sobol sequence are not independent of earlier
//! ones). The bias and the gain, per scene and budget, and the schemes
//! compared: docs/bench.md ("Adaptive sampling"). Uniform allocation
//! (`AdaptiveOptions { adaptive: false, .. }`, the CLI's `--uniform`) gives
//! the unbiased estimator.
//!
//! **Deadlines.** A deadline cannot be turned into a number of samples up
//! front: the preview's rate is a poor guide (on a host it is several times
//! lower than the refinement's), and the rate changes as the render goes.
//! So a deadline refines in rounds that each re-read the clock and are sized
//! by [`Pace`] from the rate measured so far and the time left: the host
//! (which keeps every tile's accumulators) in rounds over the whole image,
//! each half of what the time left affords and the first at most one sample
//! per pixel, which measures the rate; the board tile by tile, each
//! tile its pixels' share of the time left, the last tile in rounds up to the
//! deadline. The stop condition is also asked every [`BATCH`] samples, so a
//! render ends within one batch (plus a round's start-up) of its deadline.
//!
//! **Memory.** Only one tile's accumulators ([`TileAccum`], 5 KiB for a
//! 16×16 tile, plus 2 KiB of stack while allocating) are needed: no
//! full-image float buffer on a board. A board that cannot keep the preview's
//! accumulators recomputes the tile's sample 0 before refining it, with
//! sample 1 (the refinement's first pass) in the same walk over the pixels
//! ([`Renderer::preview_and_refine_tile`]; same bits; the extra paths are
//! counted in [`Stats`] but not in the budget).
//!
//! **Determinism.** Sample budgets (`Spp`, `Paths`) give the same image on
//! every run, thread count and target. A `Deadline` stops when a caller's
//! clock says so, which is not deterministic.

mod pace;
mod tile;

pub use crate::render::MAX_SPP;
pub use pace::Pace;
pub use tile::{TileAccum, allocate_tiles, tile_share};

use crate::film::{FromEncoded, TILE, draw_tile_iter, tile_at, tile_count};
use crate::render::Renderer;
use crate::stats::Stats;

/// Pixels in a full tile.
pub const TILE_PIXELS: usize = (TILE * TILE) as usize;

/// Most samples traced between two looks at the stop condition (a deadline's
/// clock): a render stops within one batch of its budget.
pub const BATCH: u64 = TILE_PIXELS as u64;

/// How much work a render may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Budget {
    /// This many samples per pixel on average (exactly, per pixel, when
    /// allocation is uniform), at most [`MAX_SPP`].
    Spp(u32),
    /// This many path samples for the whole image (at least one and at most
    /// [`MAX_SPP`] per pixel).
    Paths(u64),
    /// Refine until the caller's [`Clock`] reaches this many microseconds
    /// after the start, in rounds sized from the clock ([`Pace`]); at most
    /// [`MAX_SPP`] per pixel. The preview pass always completes.
    Deadline(u64),
}

/// A monotonic clock supplied by the caller: SysTick or DWT on a board,
/// `std::time::Instant` on a host.
pub trait Clock {
    /// Microseconds since an arbitrary fixed origin.
    fn micros(&mut self) -> u64;
}

/// How the budget is spread over the pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveOptions {
    /// Allocate where the estimated error is largest (`false`: the same
    /// number of samples for every pixel, and an unbiased image).
    pub adaptive: bool,
    /// Every pixel's weight in a round is at least this fraction `f` of the
    /// mean weight, which guarantees it `f / (1 + f)` of the round's even
    /// share (a third for the default ½; see the module docs), less one
    /// sample of rounding.
    pub floor: f32,
    /// Rounds of per-pixel allocation after the second sample.
    pub rounds: u32,
    /// Weight, in samples, of the tile's mean variance in each pixel's
    /// variance estimate.
    pub prior: f32,
    /// Side, in pixels, of the square blocks of the board executors'
    /// preview under a sample budget: 1 traces every pixel's sample 0, 2
    /// one pixel in four and draws its sample over its block. The image
    /// does not change: those executors keep one tile of accumulators and
    /// recompute every tile's sample 0, at full resolution, before
    /// refining it. A deadline's preview traces every pixel (a tile the
    /// deadline leaves unrefined keeps its preview). The host's executor,
    /// which keeps its preview, ignores it.
    pub preview_block: u32,
}

impl Default for AdaptiveOptions {
    fn default() -> Self {
        Self {
            adaptive: true,
            floor: 0.5,
            rounds: 8,
            prior: 8.0,
            preview_block: 2,
        }
    }
}

/// The total number of image samples a sample budget asks for (at most
/// [`MAX_SPP`] per pixel), or `None` for a deadline (known only as the render
/// goes).
pub fn budget_samples(budget: &Budget, width: u32, height: u32) -> Option<u64> {
    let pixels = u64::from(width) * u64::from(height);
    let most = pixels.saturating_mul(u64::from(MAX_SPP));
    match *budget {
        Budget::Spp(s) => Some(pixels.saturating_mul(u64::from(s.clamp(1, MAX_SPP)))),
        // max then min, not clamp: clamp's panic on min > max (impossible
        // here: most = pixels · MAX_SPP) would stay in a firmware that
        // cannot prove it
        Budget::Paths(p) => Some(p.max(pixels).min(most)),
        Budget::Deadline(_) => None,
    }
}

/// What a budgeted render did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    /// Samples in the image (what the budget counts).
    pub samples: u64,
    /// Work counters (all traced paths, including recomputed previews).
    pub stats: Stats,
    /// Clock time of the preview pass, microseconds.
    pub preview_micros: u64,
    /// Clock time of the whole render, microseconds.
    pub total_micros: u64,
}

/// Renders a whole image within `budget` on one core with one tile of
/// accumulators, drawing every tile into `target` twice: its preview, then
/// its refined pixels. This is the board's executor; the host's threaded
/// executor gives the same image for sample budgets.
///
/// A deadline's refinement goes tile by tile (the board keeps one tile's
/// accumulators): before each tile the clock is read and the tile gets its
/// pixels' share of what the time left affords at the rate measured so far;
/// the last tile is refined in rounds ([`Pace::round`]) until the deadline.
pub fn render_budget<D>(
    r: &Renderer<'_>,
    budget: Budget,
    opts: &AdaptiveOptions,
    acc: &mut TileAccum,
    clock: &mut dyn Clock,
    target: &mut D,
    exposure: f32,
) -> Result<Summary, D::Error>
where
    D: embedded_graphics::draw_target::DrawTarget,
    D::Color: FromEncoded,
{
    let (w, h) = (r.width(), r.height());
    let start = clock.micros();
    let mut sum = Summary::default();
    let block = preview_block(&budget, opts);
    for i in 0..tile_count(w, h) {
        let Some(tile) = tile_at(w, h, i) else {
            continue;
        };
        r.preview_blocks(&tile, acc, block, &mut sum.stats);
        // means drawn as computed: no tile buffer on the stack
        draw_tile_iter(target, &tile, acc.mean_iter(), exposure)?;
    }
    let pixels = u64::from(w) * u64::from(h);
    sum.samples = pixels;
    sum.preview_micros = clock.micros().saturating_sub(start);
    if let Budget::Deadline(us) = budget {
        let deadline = start.saturating_add(us);
        let mut pace = Pace::new(deadline, pixels, sum.preview_micros);
        refine_to_deadline(r, &mut pace, opts, acc, clock, target, exposure, &mut sum)?;
    } else {
        let extra = budget_samples(&budget, w, h)
            .unwrap_or(pixels)
            .saturating_sub(pixels);
        let mut result = Ok(());
        allocate_tiles(w, h, extra, |i, share| {
            // a tile without refinement keeps its preview if that was
            // sample 0 of every pixel
            if result.is_err() || (share == 0 && block == 1) {
                return;
            }
            let Some(tile) = tile_at(w, h, i) else { return };
            // the accumulators of the preview are gone: recompute sample 0
            sum.samples += r.preview_and_refine_tile(&tile, acc, share, opts, &mut sum.stats);
            result = draw_tile_iter(target, &tile, acc.mean_iter(), exposure);
        });
        result?;
    }
    sum.total_micros = clock.micros().saturating_sub(start);
    Ok(sum)
}

/// The block side of a board executor's preview: [`AdaptiveOptions::preview_block`]
/// (at least 1) under a sample budget, 1 under a deadline.
pub(crate) fn preview_block(budget: &Budget, opts: &AdaptiveOptions) -> u32 {
    match budget {
        Budget::Deadline(_) => 1,
        _ => opts.preview_block.max(1),
    }
}

/// The refinement of [`render_budget`] for a deadline (see there).
#[allow(clippy::too_many_arguments)]
fn refine_to_deadline<D>(
    r: &Renderer<'_>,
    pace: &mut Pace,
    opts: &AdaptiveOptions,
    acc: &mut TileAccum,
    clock: &mut dyn Clock,
    target: &mut D,
    exposure: f32,
    sum: &mut Summary,
) -> Result<(), D::Error>
where
    D: embedded_graphics::draw_target::DrawTarget,
    D::Color: FromEncoded,
{
    let (w, h) = (r.width(), r.height());
    let deadline = pace.deadline;
    let begin = clock.micros();
    let paths_before = sum.stats.paths;
    let mut left = u64::from(w) * u64::from(h);
    for i in 0..tile_count(w, h) {
        let Some(tile) = tile_at(w, h, i) else {
            continue;
        };
        let part = tile.len() as u64;
        let last = left <= part;
        // samples this tile may still take (the preview's included)
        let mut room = part.saturating_mul(u64::from(MAX_SPP)).saturating_sub(part);
        let mut recomputed = false;
        loop {
            let now = clock.micros();
            let want = if last {
                pace.round(now, part)
            } else {
                pace.afford(now, part, left)
            };
            // the first round pays for recomputing the preview
            let share = if recomputed {
                want
            } else {
                want.saturating_sub(part)
            }
            .min(room);
            if share == 0 || now >= deadline {
                break;
            }
            if !recomputed {
                r.preview_tile(&tile, acc, &mut sum.stats);
                recomputed = true;
            }
            let mut stop = |_: u64| clock.micros() >= deadline;
            let spent = r.refine_tile(&tile, acc, share, opts, &mut stop, &mut sum.stats);
            sum.samples += spent;
            room -= spent;
            pace.measured(
                sum.stats.paths - paths_before,
                clock.micros().saturating_sub(begin),
            );
            if !last {
                break;
            }
        }
        if recomputed {
            draw_tile_iter(target, &tile, acc.mean_iter(), exposure)?;
        }
        left = left.saturating_sub(part);
    }
    Ok(())
}

#[cfg(test)]
mod tests;
