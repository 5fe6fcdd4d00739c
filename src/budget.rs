//! The fixed budget: how a render spends samples per pixel, a total number
//! of paths, or a deadline, progressively and adaptively, in bounded memory.
//!
//! A budgeted render runs in two passes over the tiles:
//!
//! 1. **Preview.** Every pixel gets its first sample (index 0) before any
//!    pixel gets more: a complete 1-spp image that a board can show at once.
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
//! accumulators recomputes the tile's sample 0 before refining it (same bits;
//! the extra paths are counted in [`Stats`] but not in the budget).
//!
//! **Determinism.** Sample budgets (`Spp`, `Paths`) give the same image on
//! every run, thread count and target. A `Deadline` stops when a caller's
//! clock says so, which is not deterministic.

use crate::film::{FromEncoded, TILE, Tile, draw_tile_iter, tile_at, tile_count};
use crate::geometry::Color;
use crate::integrator::Stats;
use crate::math;
use crate::render::Renderer;

/// Pixels in a full tile.
pub const TILE_PIXELS: usize = (TILE * TILE) as usize;

/// Most samples traced between two looks at the stop condition (a deadline's
/// clock): a render stops within one batch of its budget.
pub const BATCH: u64 = TILE_PIXELS as u64;

/// Most samples per pixel, on average, that a budget may ask for: a
/// pixel's count (a `u32`, at most a tile's samples) never overflows, and a
/// deadline far in the future still ends. Larger budgets are clamped to it.
pub const MAX_SPP: u32 = 1 << 20;

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
}

impl Default for AdaptiveOptions {
    fn default() -> Self {
        Self {
            adaptive: true,
            floor: 0.5,
            rounds: 8,
            prior: 8.0,
        }
    }
}

/// Sample accumulators for the pixels of one tile.
#[derive(Clone, Debug)]
pub struct TileAccum {
    sum: [Color; TILE_PIXELS],
    lum2: [f32; TILE_PIXELS],
    count: [u32; TILE_PIXELS],
    len: usize,
}

impl Default for TileAccum {
    fn default() -> Self {
        Self::new()
    }
}

impl TileAccum {
    /// Empty accumulators.
    pub const fn new() -> Self {
        Self {
            sum: [Color::ZERO; TILE_PIXELS],
            lum2: [0.0; TILE_PIXELS],
            count: [0; TILE_PIXELS],
            len: 0,
        }
    }

    fn reset(&mut self, len: usize) {
        self.len = len.min(TILE_PIXELS);
        self.sum = [Color::ZERO; TILE_PIXELS];
        self.lum2 = [0.0; TILE_PIXELS];
        self.count = [0; TILE_PIXELS];
    }

    /// Number of samples pixel `i` (row-major in the tile) has.
    pub fn count(&self, i: usize) -> u32 {
        self.count.get(i).copied().unwrap_or(0)
    }

    /// Writes each pixel's mean radiance to `out` (row-major in the tile).
    pub fn means(&self, out: &mut [Color]) {
        for (o, m) in out.iter_mut().zip(self.mean_iter()) {
            *o = m;
        }
    }

    /// Each pixel's mean radiance (row-major in the tile), computed as it is
    /// read.
    pub fn mean_iter(&self) -> impl Iterator<Item = Color> + '_ {
        self.sum
            .iter()
            .zip(&self.count)
            .take(self.len)
            .map(|(s, &n)| {
                if n > 0 {
                    *s * (1.0 / n as f32)
                } else {
                    Color::ZERO
                }
            })
    }

    /// Adds samples `count[i] .. count[i] + k` to every pixel `i` of
    /// `pixels`, each pixel's in turn. One call for a whole round of the
    /// tile: what the integrator loads once per call (the scene's arrays,
    /// the options) is loaded once per round, not once per sample.
    #[inline(never)]
    fn add(
        &mut self,
        r: &Renderer<'_>,
        tile: &Tile,
        pixels: core::ops::Range<usize>,
        k: u32,
        stats: &mut Stats,
    ) {
        let w = tile.w.max(1);
        for i in pixels {
            let i32 = i as u32;
            let (x, y) = (
                tile.x.saturating_add(i32 % w),
                tile.y.saturating_add(i32 / w),
            );
            let (Some(sum), Some(l2), Some(n)) = (
                self.sum.get_mut(i),
                self.lum2.get_mut(i),
                self.count.get_mut(i),
            ) else {
                return;
            };
            let pixel = r.pixel(x, y);
            for _ in 0..k {
                let c = r.sample_in(&pixel, x, y, *n, stats);
                let l = c.luminance();
                *sum += c;
                *l2 += l * l;
                *n += 1;
            }
        }
    }

    /// Unbiased sample variance of pixel `i`'s luminance (0 below 2 samples).
    fn variance(&self, i: usize) -> f32 {
        let (Some(s), Some(&l2), Some(&n)) = (self.sum.get(i), self.lum2.get(i), self.count.get(i))
        else {
            return 0.0;
        };
        if n < 2 {
            return 0.0;
        }
        let n = n as f32;
        let m = s.luminance();
        math::max(0.0, (l2 - m * m / n) / (n - 1.0))
    }

    /// Samples in all pixels.
    fn total(&self) -> u64 {
        self.count
            .iter()
            .take(self.len)
            .map(|&c| u64::from(c))
            .sum()
    }
}

/// `A(k) = floor(total · c_k / c_last)`: cumulative rounding of a split of
/// `total` in proportion to weights with running sum `c_k`. Consecutive
/// differences are the shares; they sum to `total` exactly, depend only on the
/// weights' order and values, and need no storage.
#[inline]
fn cumulative_share(total: u64, cum: f32, cum_total: f32, last: bool) -> u64 {
    if last || !(cum_total > 0.0) {
        return if last { total } else { 0 };
    }
    let a = total as f32 * (cum / cum_total);
    math::clamp(math::floor(a), 0.0, total as f32) as u64
}

/// The split of `total` samples over `n` items with weights `w(i)` (NaN and
/// infinities count as 0), each at least `floor` times the mean weight; even
/// when all weights are 0. Calls `give(i, share)`.
///
/// A floored weight `f·m` (mean `m`) is a share `f·m / Σ max(w, f·m)` of
/// `total`, and the sum is at most `n·m + (n − 1)·f·m` (the weights sum to
/// `n·m`; at least one is above the floor when `m > 0` and `f < 1`), so
/// every share is at least `total · f / (n + (n − 1) f)`, less one sample
/// of cumulative rounding: `f / (1 + f)` of the even share as `n` grows. One
/// item holding all the weight attains it.
fn split(
    n: usize,
    total: u64,
    floor: f32,
    w: impl Fn(usize) -> f32,
    mut give: impl FnMut(usize, u64),
) {
    let weight = |i: usize| {
        let v = w(i);
        if v.is_finite() {
            math::max(v, 0.0)
        } else {
            0.0
        }
    };
    let mut sum = 0.0f32;
    for i in 0..n {
        sum += weight(i);
    }
    let mean = sum / math::max(n as f32, 1.0);
    let eff = |i: usize| {
        if mean > 0.0 {
            math::max(weight(i), floor * mean)
        } else {
            1.0
        }
    };
    let mut cum_total = 0.0f32;
    for i in 0..n {
        cum_total += eff(i);
    }
    let (mut cum, mut prev) = (0.0f32, 0u64);
    for i in 0..n {
        cum += eff(i);
        let a = cumulative_share(total, cum, cum_total, i + 1 == n);
        give(i, a.saturating_sub(prev));
        prev = a;
    }
}

impl Renderer<'_> {
    /// Pass 1 for `tile`: sample 0 of every pixel into `acc` (reset first).
    pub fn preview_tile(&self, tile: &Tile, acc: &mut TileAccum, stats: &mut Stats) {
        acc.reset(tile.len());
        acc.add(self, tile, 0..acc.len, 1, stats);
    }

    /// Pass 2 for `tile`: spends `extra` more samples on the pixels of `acc`
    /// (which holds the tile's preview, restored or recomputed by
    /// [`Renderer::preview_tile`], and any samples an earlier call added) as
    /// the module docs describe; a later call on the same accumulators
    /// continues where the earlier one stopped. `stop` is asked, with the
    /// samples spent so far, before the first and after at most every
    /// [`BATCH`] samples, and ends the refinement when it returns true.
    /// Returns the samples spent.
    ///
    /// Never inlined: its per-pixel arrays (2 KiB for a 16×16 tile) then
    /// live on the stack only while it runs, not in the frame of a caller
    /// that also parses a scene.
    #[inline(never)]
    pub fn refine_tile(
        &self,
        tile: &Tile,
        acc: &mut TileAccum,
        extra: u64,
        opts: &AdaptiveOptions,
        stop: &mut dyn FnMut(u64) -> bool,
        stats: &mut Stats,
    ) -> u64 {
        let n = acc.len;
        if n == 0 || extra == 0 {
            return 0;
        }
        let mut spent = 0u64;
        let mut since_check = BATCH;
        // one sample for every pixel (the first `extra` when fewer): the
        // uniform scheme's every round, the adaptive scheme's first while a
        // pixel has fewer than two (a later call on the same accumulators,
        // a deadline's next round, continues without it)
        let per = if opts.adaptive {
            u64::from((0..n).any(|i| acc.count(i) < 2))
        } else {
            extra / n as u64 + u64::from(!extra.is_multiple_of(n as u64))
        };
        // a pass starts at the first pixel with fewer samples than pixel 0:
        // where the last partial pass of an earlier call stopped (0 on a
        // first call, whose counts are all equal), so that counts stay level
        let start = (0..n).find(|&i| acc.count(i) < acc.count(0)).unwrap_or(0);
        for _ in 0..per {
            if stop(spent) {
                return spent;
            }
            let before = spent;
            // `take` pixels from `start` on, cyclically, when fewer than all
            // are left
            let take = (extra - spent).min(n as u64) as usize;
            let head = (start + take).min(n);
            acc.add(self, tile, start..head, 1, stats);
            acc.add(self, tile, 0..take - (head - start), 1, stats);
            spent += take as u64;
            // at most n <= BATCH samples since the look above
            since_check = spent - before;
        }
        let rounds = if opts.adaptive { opts.rounds.max(1) } else { 0 };
        for r in 0..rounds {
            let left = extra - spent;
            if left == 0 {
                break;
            }
            let this = if r + 1 == rounds {
                left
            } else {
                left / u64::from(rounds - r)
            };
            let sig = self.pixel_sigmas(acc, opts);
            // water-filling: the counts the estimates call for at the end of
            // the tile's budget; this round goes by each pixel's deficit
            let final_total = (acc.total() + left) as f32;
            let mut sum_sig = 0.0f32;
            for v in sig.iter().take(n) {
                sum_sig += *v;
            }
            let deficit = |i: usize| {
                let want = if sum_sig > 0.0 {
                    final_total * sig.get(i).copied().unwrap_or(0.0) / sum_sig
                } else {
                    final_total / n as f32
                };
                want - acc.count(i) as f32
            };
            let mut shares = [0u32; TILE_PIXELS];
            split(n, this, opts.floor, deficit, |i, s| {
                if let Some(x) = shares.get_mut(i) {
                    *x = s.min(u64::from(u32::MAX)) as u32;
                }
            });
            for (i, &k) in shares.iter().enumerate().take(n) {
                // at most BATCH samples between two looks at the clock
                let mut k = k;
                while k > 0 {
                    if since_check >= BATCH {
                        if stop(spent) {
                            return spent;
                        }
                        since_check = 0;
                    }
                    let chunk = k.min((BATCH - since_check) as u32);
                    acc.add(self, tile, i..i + 1, chunk, stats);
                    spent += u64::from(chunk);
                    since_check += u64::from(chunk);
                    k -= chunk;
                }
            }
        }
        spent
    }

    /// Each pixel's estimated standard deviation: its luminance variance
    /// shrunk toward the tile's mean variance (a prior worth
    /// [`AdaptiveOptions::prior`] samples).
    fn pixel_sigmas(&self, acc: &TileAccum, opts: &AdaptiveOptions) -> [f32; TILE_PIXELS] {
        let n = acc.len;
        let mut mean_var = 0.0f32;
        for i in 0..n {
            mean_var += acc.variance(i);
        }
        mean_var /= math::max(n as f32, 1.0);
        let mut sig = [0.0f32; TILE_PIXELS];
        for (i, s) in sig.iter_mut().enumerate().take(n) {
            let k = acc.count(i).saturating_sub(1) as f32;
            *s = math::sqrt((acc.variance(i) * k + opts.prior * mean_var) / (k + opts.prior));
        }
        sig
    }
}

/// The refinement samples each tile gets: `total` split over the tiles of a
/// `width × height` image in proportion to their pixel counts. Calls
/// `give(tile_index, samples)` in tile order; the shares sum to `total`.
pub fn allocate_tiles(width: u32, height: u32, total: u64, give: impl FnMut(usize, u64)) {
    let sizes = |i: usize| tile_at(width, height, i).map_or(0.0, |t| t.len() as f32);
    split(tile_count(width, height), total, 0.0, sizes, give);
}

/// The share of tile `i` in [`allocate_tiles`]`(width, height, total, ..)`,
/// without the walk over the tiles before it (0 for a tile past the last):
/// an executor that hands out tiles in any order computes each one's share
/// on its own.
///
/// The same bits: `split`'s running f32 sum of tile sizes is, before the
/// last tile, a sum of even integers (every tile but the corner one has a
/// side of [`TILE`] pixels) below 2²⁵ (`scene::MAX_PIXELS`), so exact, and
/// the last addition is one rounding of the exact total, as is the
/// conversion of that total here.
pub fn tile_share(width: u32, height: u32, total: u64, i: usize) -> u64 {
    let n = tile_count(width, height);
    let tx = width.div_ceil(TILE) as usize;
    if i >= n || tx == 0 {
        return 0;
    }
    // pixels in tiles 0..=k (row-major tiles of TILE × TILE, cut at the
    // image's right and bottom edges)
    let (w, h) = (u64::from(width), u64::from(height));
    let cum = |k: usize| -> u64 {
        let (row, col) = ((k / tx) as u64, (k % tx) as u64);
        let top = (row * u64::from(TILE)).min(h);
        let row_h = (h - top).min(u64::from(TILE));
        top * w + ((col + 1) * u64::from(TILE)).min(w) * row_h
    };
    let pixels = (w * h) as f32;
    let upto = |k: usize| cumulative_share(total, cum(k) as f32, pixels, k + 1 == n);
    let before = if i == 0 { 0 } else { upto(i - 1) };
    upto(i).saturating_sub(before)
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

/// Sizes a deadline's refinement from the clock: the rate measured so far
/// and the time left. The executors refine in rounds and ask before each one,
/// so a rate that was wrong at first (the preview's: on a host several times
/// lower than the refinement's, from thread start-up and the first touch of
/// memory) is replaced by the refinement's own after the first round.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pace {
    deadline: u64,
    paths: u64,
    micros: u64,
    /// Whether the rate is a round's (not the first guess's).
    measured: bool,
}

impl Pace {
    /// A pace for a deadline at clock reading `deadline` (microseconds), with
    /// a first rate of `paths` traced in `micros`.
    pub const fn new(deadline: u64, paths: u64, micros: u64) -> Self {
        Self {
            deadline,
            paths,
            micros,
            measured: false,
        }
    }

    /// Replaces the rate: `paths` traced in `micros` (everything the rounds
    /// so far cost: recomputed previews, drawing, waiting for threads).
    pub fn measured(&mut self, paths: u64, micros: u64) {
        self.paths = paths;
        self.micros = micros;
        self.measured = true;
    }

    /// The paths the time from `now` to the deadline affords at the measured
    /// rate, for `part` of the `whole` (pixels) still to refine.
    pub fn afford(&self, now: u64, part: u64, whole: u64) -> u64 {
        let left = self.deadline.saturating_sub(now) as f32;
        let rate = self.paths as f32 / math::max(self.micros as f32, 1.0);
        let share = part as f32 / math::max(whole as f32, 1.0);
        let a = math::floor(rate * left * math::min(share, 1.0));
        math::clamp(a, 0.0, 1.0e18) as u64
    }

    /// The next round for `pixels` pixels: half of what the time left
    /// affords while that is at least two samples per pixel (a rate that is
    /// too high by up to 2x still ends the round before the deadline), else
    /// all of it, which the deadline's stop may cut. The first round, sized
    /// by the first guess (which may be wrong either way), is at most one
    /// sample per pixel: it measures the rate. 0: nothing is affordable.
    pub fn round(&self, now: u64, pixels: u64) -> u64 {
        let a = self.afford(now, 1, 1);
        let r = if a >= pixels.saturating_mul(2) {
            a / 2
        } else {
            a
        };
        if self.measured { r } else { r.min(pixels) }
    }
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
    for i in 0..tile_count(w, h) {
        let Some(tile) = tile_at(w, h, i) else {
            continue;
        };
        r.preview_tile(&tile, acc, &mut sum.stats);
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
            if result.is_err() || share == 0 {
                return;
            }
            let Some(tile) = tile_at(w, h, i) else { return };
            // the accumulators of the preview are gone: recompute sample 0
            r.preview_tile(&tile, acc, &mut sum.stats);
            sum.samples += r.refine_tile(&tile, acc, share, opts, &mut |_| false, &mut sum.stats);
            result = draw_tile_iter(target, &tile, acc.mean_iter(), exposure);
        });
        result?;
    }
    sum.total_micros = clock.micros().saturating_sub(start);
    Ok(sum)
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
mod tests {
    use super::*;

    #[test]
    fn cumulative_split_is_exact_and_proportional() {
        let w = [1.0f32, 3.0, 0.0, 4.0];
        let mut got = [0u64; 4];
        split(4, 1000, 0.0, |i| w[i], |i, s| got[i] = s);
        assert_eq!(got.iter().sum::<u64>(), 1000);
        assert_eq!(got, [125, 375, 0, 500]);
        // the floor lifts the zero weight to a quarter of the mean (2)
        split(4, 1000, 0.25, |i| w[i], |i, s| got[i] = s);
        assert_eq!(got.iter().sum::<u64>(), 1000);
        assert!(got[2] > 0 && got[2] < got[0]);
        // all zero: even
        split(4, 10, 0.25, |_| 0.0, |i, s| got[i] = s);
        assert_eq!(got.iter().sum::<u64>(), 10);
        assert!(got.iter().all(|&s| s == 2 || s == 3));
        // NaN and negative weights do not poison the split
        split(
            2,
            7,
            0.25,
            |i| if i == 0 { f32::NAN } else { -1.0 },
            |i, s| got[i] = s,
        );
        assert_eq!(got[0] + got[1], 7);
    }

    /// The guarantee of `split` (its docs): with weights floored at `f`
    /// times the mean, every share is at least `total · f / (n + (n − 1) f)`
    /// less one sample of rounding (and the f32 rounding of the cumulative
    /// sums, a few ulps of `total`), and one item holding all the weight
    /// brings the others down to that bound: a third of the even share for
    /// `f = ½`, not a half.
    #[test]
    fn split_floor_guarantees_f_over_1_plus_f_of_the_even_share() {
        // a small deterministic generator for weights (LCG, top bits)
        let mut state = 0x2545_f491_u32;
        let mut next = move || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut shares = [0u64; TILE_PIXELS];
        for &n in &[1usize, 2, 3, 7, 16, 100, 255, 256] {
            for &f in &[0.5f32, 0.25, 0.1, 0.9] {
                for &total in &[10u64, 999, 256 * 64, 256 * 1000] {
                    let bound = total as f32 * f / (n as f32 + (n as f32 - 1.0) * f);
                    let slack = 1.0 + 4.0 * total as f32 / (1u32 << 24) as f32;
                    // weights: one heavy item, random ones, sparse random ones
                    let mut cases: [[f32; TILE_PIXELS]; 3] = [[0.0; TILE_PIXELS]; 3];
                    cases[0][n / 2] = 1.0;
                    let [_, random, sparse] = &mut cases;
                    for (r, s) in random.iter_mut().zip(sparse.iter_mut()).take(n) {
                        *r = next();
                        *s = if next() < 0.1 { 100.0 * next() } else { 0.0 };
                    }
                    for (k, w) in cases.iter().enumerate() {
                        split(n, total, f, |i| w[i], |i, s| shares[i] = s);
                        assert_eq!(shares[..n].iter().sum::<u64>(), total);
                        let min = *shares[..n].iter().min().unwrap();
                        assert!(
                            min as f32 + slack >= bound,
                            "n {n}, f {f}, total {total}, case {k}: min share {min} < bound {bound}"
                        );
                        if k == 0 && n > 1 {
                            // attained: the others get the bound, not f of the even share
                            assert!(
                                min as f32 <= bound + slack,
                                "n {n}, f {f}, total {total}: min share {min} above bound {bound}"
                            );
                        }
                    }
                }
            }
        }
        // the default floor at a full tile: a third of the even share (64),
        // not a half
        let mut w = [0.0f32; TILE_PIXELS];
        w[0] = 1.0;
        split(
            TILE_PIXELS,
            256 * 64,
            AdaptiveOptions::default().floor,
            |i| w[i],
            |i, s| shares[i] = s,
        );
        let min = *shares.iter().min().unwrap();
        assert!((21..=22).contains(&min), "{min}");
    }

    #[test]
    fn tiles_get_shares_by_pixel_count() {
        let mut got = [0u64; 4];
        // 20x20: tiles of 256, 64, 64, 16 pixels
        allocate_tiles(20, 20, 400, |i, s| got[i] = s);
        assert_eq!(got, [256, 64, 64, 16]);
    }

    /// `tile_share` is `allocate_tiles`' share of each tile, bit for bit:
    /// small images with cut edge tiles, and the largest images the scene
    /// format allows (2²⁵ pixels, where f32 sums of sizes stop being exact
    /// for odd values) with an odd corner tile.
    #[test]
    fn tile_share_equals_the_walk_over_the_tiles() {
        let sizes = [
            (1, 1),
            (15, 17),
            (16, 16),
            (20, 20),
            (64, 64),
            (100, 37),
            (16_384, 2_048),
            (16_383, 2_048),
            (2_047, 16_383),
        ];
        for (w, h) in sizes {
            let pixels = u64::from(w) * u64::from(h);
            for total in [0, 1, 7, pixels - 1, pixels * 15, pixels * 15 + 13] {
                let (mut tiles, mut sum) = (0usize, 0u64);
                allocate_tiles(w, h, total, |i, s| {
                    assert_eq!(tile_share(w, h, total, i), s, "{w}x{h}, {total}: tile {i}");
                    tiles += 1;
                    sum += s;
                });
                assert_eq!((tiles, sum), (tile_count(w, h), total), "{w}x{h}, {total}");
                assert_eq!(tile_share(w, h, total, tiles), 0);
            }
        }
    }

    #[test]
    fn budgets_in_samples() {
        assert_eq!(budget_samples(&Budget::Spp(4), 10, 10), Some(400));
        assert_eq!(budget_samples(&Budget::Paths(50), 10, 10), Some(100));
        assert_eq!(budget_samples(&Budget::Paths(500), 10, 10), Some(500));
        assert_eq!(budget_samples(&Budget::Deadline(5), 10, 10), None);
    }

    #[test]
    fn pace_sizes_rounds_from_the_measured_rate_and_the_time_left() {
        // 1000 paths in 100 us (10 per us); deadline at 1100: at 100, 1000 us
        // left afford 10,000 paths, a quarter of the pixels 2,500
        let mut p = Pace::new(1100, 1000, 100);
        assert_eq!(p.afford(100, 1, 1), 10_000);
        assert_eq!(p.afford(100, 1, 4), 2_500);
        // the first round, from the first guess, is at most 1 per pixel
        assert_eq!(p.round(100, 1000), 1_000);
        assert_eq!(p.round(100, 20_000), 10_000);
        // a measurement replaces the rate (30 per us, 500 us left)
        p.measured(3000, 100);
        assert_eq!(p.afford(600, 1, 1), 15_000);
        // a round is half of it while that leaves 2 samples per pixel
        assert_eq!(p.round(600, 1000), 7_500);
        assert_eq!(p.round(600, 7_500), 7_500);
        // else all of it
        assert_eq!(p.round(600, 7_501), 15_000);
        // at or past the deadline nothing is affordable
        assert_eq!(p.afford(1100, 1, 1), 0);
        assert_eq!(p.round(5000, 1), 0);
        // no time measured yet counts as one microsecond
        assert_eq!(Pace::new(10, 5, 0).afford(0, 1, 1), 50);
    }

    /// The round policy with a scripted clock: time advances by a scripted
    /// cost per sample (a preview 4x dearer per sample than the refinement,
    /// as the host measures, and a refinement whose cost per sample changes
    /// by 2x half-way). Rounds re-read the clock, so the render uses at least
    /// 90 % of the deadline and ends within one round of it.
    #[test]
    fn rounds_spend_the_deadline_with_a_scripted_clock() {
        for (deadline, pixels) in [(500_000u64, 4096u64), (2_000_000, 4096), (20_000, 64)] {
            // the preview: 4 us per sample
            let preview = 4 * pixels;
            let mut pace = Pace::new(deadline, pixels, preview);
            let (mut now, mut spent, mut rounds) = (preview, 0u64, 0);
            loop {
                let round = pace.round(now, pixels);
                if round == 0 {
                    break;
                }
                rounds += 1;
                // in batches, the stop asked before each: 1 us per sample in
                // the first half of the time, 2 us after
                let mut done = 0;
                while done < round && now < deadline {
                    let k = (round - done).min(BATCH);
                    now += k * if now < deadline / 2 { 1 } else { 2 };
                    done += k;
                }
                spent += done;
                pace.measured(spent, now - preview);
            }
            assert!(
                now * 10 >= deadline * 9 && now <= deadline + 2 * BATCH,
                "deadline {deadline}: ended at {now} after {rounds} rounds"
            );
            assert!(rounds <= 40, "{rounds} rounds");
            // and it traced what that time affords at the scripted costs (up
            // to a batch more at the change of cost and at the deadline,
            // which both fall inside a batch)
            let ideal = (deadline / 2 - preview) + deadline / 2 / 2;
            assert!(
                spent * 10 >= ideal * 9 && spent <= ideal + 2 * BATCH,
                "deadline {deadline}: {spent} samples of {ideal} after {rounds} rounds"
            );
        }
    }
}
