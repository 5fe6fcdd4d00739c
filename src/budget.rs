//! The fixed budget: how a render spends samples per pixel, a total number
//! of paths, or a deadline, progressively and adaptively, in bounded memory.
//!
//! A budgeted render runs in two passes over the tiles:
//!
//! 1. **Preview.** Every pixel gets its first sample (index 0) before any
//!    pixel gets more: a complete 1-spp image that a board can show at once.
//!    Each tile also yields one number, its estimated error weight (below).
//! 2. **Refinement.** The remaining budget is split among tiles in proportion
//!    to their weights (at least [`AdaptiveOptions::floor`] of the uniform
//!    share each), and within a tile among pixels in rounds: first one more
//!    sample for every pixel, so that each has two and a variance estimate,
//!    then in proportion to each pixel's estimated standard deviation. A pixel's
//!    samples always have consecutive indices from 0, summed in order, so
//!    with uniform allocation the image equals the plain `spp` render bit for
//!    bit.
//!
//! **Why σ.** With `n_p` samples a pixel's error variance is `σ_p² / n_p`;
//! the image MSE `Σ σ_p² / n_p` under `Σ n_p = N` is smallest for
//! `n_p ∝ σ_p`. The standard deviation is estimated from the luminance of the
//! samples, shrunk toward the tile's mean variance (a prior worth two
//! samples), because two samples alone are a poor estimate. For the tile
//! split, one sample per pixel has no variance, so the preview uses the
//! differences between neighbouring pixels, `(x_p − x_q)²/2`, whose mean is
//! `σ²` plus the local contrast — a high-contrast tile (edges) also needs
//! more samples for anti-aliasing.
//!
//! **Bias.** Allocation depends on the samples themselves, so the estimate
//! of a pixel is biased, but only by a term that vanishes as the budget grows:
//! the floor gives every pixel a fixed fraction of the average sample count,
//! so every pixel's count grows without bound, and the decision rests on a
//! shrinking fraction of its samples. The tests check the image mean against
//! the references.
//!
//! **Memory.** Only one tile's accumulators ([`TileAccum`], 5 KiB for a
//! 16×16 tile) and one `f32` weight per tile are needed: no full-image float
//! buffer on a board. A board that cannot keep the preview's accumulators
//! recomputes the tile's sample 0 before refining it (same bits; the extra
//! paths are counted in [`Stats`] but not in the budget).
//!
//! **Determinism.** Sample budgets (`Spp`, `Paths`) give the same image on
//! every run, thread count and target. A `Deadline` stops when a caller's
//! clock says so, which is not deterministic.

use crate::film::{FromEncoded, TILE, Tile, draw_tile, tile_at, tile_count};
use crate::geometry::Color;
use crate::integrator::Stats;
use crate::math;
use crate::render::Renderer;

/// Pixels in a full tile.
pub const TILE_PIXELS: usize = (TILE * TILE) as usize;

/// How much work a render may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Budget {
    /// This many samples per pixel on average (exactly, per pixel, when
    /// allocation is uniform).
    Spp(u32),
    /// This many path samples for the whole image (at least one per pixel).
    Paths(u64),
    /// Stop refining when the caller's [`Clock`] reaches this many
    /// microseconds after the start. The preview pass always completes.
    Deadline(u64),
}

/// A monotonic clock supplied by the caller: SysTick or DWT on a board,
/// `std::time::Instant` on a host.
pub trait Clock {
    /// Microseconds since an arbitrary fixed origin.
    fn micros(&mut self) -> u64;
}

/// How the budget is spread.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveOptions {
    /// Allocate where the estimated error is largest (`false`: the same
    /// number of samples for every pixel).
    pub adaptive: bool,
    /// Every tile and pixel gets at least this fraction of its uniform share
    /// of the refinement samples (keeps the bias vanishing).
    pub floor: f32,
    /// Rounds of per-pixel allocation after the first extra sample.
    pub rounds: u32,
    /// Weight, in samples, of the tile's mean variance in each pixel's
    /// variance estimate (shrinkage toward the tile).
    pub prior: f32,
    /// A pixel's standard deviation is at least this fraction of its
    /// neighbours' (high variance comes in features: edges, caustics).
    pub dilate: f32,
}

impl Default for AdaptiveOptions {
    fn default() -> Self {
        Self {
            adaptive: true,
            floor: 0.5,
            rounds: 8,
            prior: 8.0,
            dilate: 0.5,
        }
    }
}

/// Sample accumulators for the pixels of one tile.
#[derive(Clone, Debug)]
pub struct TileAccum {
    sum: [Color; TILE_PIXELS],
    sum_lum2: [f32; TILE_PIXELS],
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
            sum_lum2: [0.0; TILE_PIXELS],
            count: [0; TILE_PIXELS],
            len: 0,
        }
    }

    fn reset(&mut self, len: usize) {
        self.len = len.min(TILE_PIXELS);
        self.sum = [Color::ZERO; TILE_PIXELS];
        self.sum_lum2 = [0.0; TILE_PIXELS];
        self.count = [0; TILE_PIXELS];
    }

    /// Number of samples pixel `i` (row-major in the tile) has.
    pub fn count(&self, i: usize) -> u32 {
        self.count.get(i).copied().unwrap_or(0)
    }

    /// Writes each pixel's mean radiance to `out` (row-major in the tile).
    pub fn means(&self, out: &mut [Color]) {
        for ((o, s), &n) in out
            .iter_mut()
            .zip(&self.sum)
            .zip(&self.count)
            .take(self.len)
        {
            *o = if n > 0 {
                *s * (1.0 / n as f32)
            } else {
                Color::ZERO
            };
        }
    }

    /// Adds samples `count[i] .. count[i] + k` to pixel `i`.
    #[inline]
    fn add(&mut self, r: &Renderer<'_>, tile: &Tile, i: usize, k: u32, stats: &mut Stats) {
        let w = tile.w.max(1);
        let (x, y) = (tile.x + i as u32 % w, tile.y + i as u32 / w);
        let (Some(sum), Some(l2), Some(n)) = (
            self.sum.get_mut(i),
            self.sum_lum2.get_mut(i),
            self.count.get_mut(i),
        ) else {
            return;
        };
        for _ in 0..k {
            let c = r.sample(x, y, *n, stats);
            let l = c.luminance();
            *sum += c;
            *l2 += l * l;
            *n += 1;
        }
    }

    /// Unbiased sample variance of pixel `i`'s luminance (0 below 2 samples).
    fn variance(&self, i: usize) -> f32 {
        let (Some(s), Some(&l2), Some(&n)) =
            (self.sum.get(i), self.sum_lum2.get(i), self.count.get(i))
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
}

/// Samples in the first `n` pixels of `acc`.
fn acc_total(acc: &TileAccum, n: usize) -> u64 {
    acc.count.iter().take(n).map(|&c| u64::from(c)).sum()
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

/// The split of `total` samples over `n` items with weights `w(i)`, each at
/// least `floor` of its uniform share (weights given per unit of `size(i)`,
/// shares proportional to `size(i)` when uniform). Calls `give(i, share)`.
fn split(
    n: usize,
    total: u64,
    floor: f32,
    size: impl Fn(usize) -> f32,
    w: impl Fn(usize) -> f32,
    mut give: impl FnMut(usize, u64),
) {
    // mean weight per unit of size, for the floor
    let (mut sw, mut ss) = (0.0f32, 0.0f32);
    for i in 0..n {
        sw += w(i) * size(i);
        ss += size(i);
    }
    let mean = if ss > 0.0 { sw / ss } else { 0.0 };
    let eff = |i: usize| {
        let v = w(i);
        let v = if v.is_finite() { v } else { 0.0 };
        let v = math::max(v, floor * mean);
        // all-zero weights: uniform
        if mean > 0.0 { v * size(i) } else { size(i) }
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
    /// Returns the tile's error weight: the sum over its pixels of the
    /// estimated standard deviation from neighbour differences.
    pub fn preview_tile(&self, tile: &Tile, acc: &mut TileAccum, stats: &mut Stats) -> f32 {
        acc.reset(tile.len());
        for i in 0..acc.len {
            acc.add(self, tile, i, 1, stats);
        }
        let (w, h) = (tile.w as usize, tile.h as usize);
        let lum = |x: usize, y: usize| acc.sum.get(y * w + x).map_or(0.0, |c| c.luminance());
        let mut total = 0.0f32;
        for y in 0..h {
            for x in 0..w {
                let v = lum(x, y);
                let (mut d2, mut k) = (0.0f32, 0u32);
                for (nx, ny) in [
                    (x.wrapping_sub(1), y),
                    (x + 1, y),
                    (x, y.wrapping_sub(1)),
                    (x, y + 1),
                ] {
                    if nx < w && ny < h {
                        let d = v - lum(nx, ny);
                        d2 += d * d;
                        k += 1;
                    }
                }
                if k > 0 {
                    total += math::sqrt(d2 / (2.0 * k as f32));
                }
            }
        }
        total
    }

    /// Pass 2 for `tile`: spends `extra` more samples on the pixels of
    /// `acc` (which holds the tile's preview, restored or recomputed by
    /// [`Renderer::preview_tile`]): one more per pixel first, then rounds in
    /// proportion to each pixel's estimated standard deviation. `stop` is
    /// asked between batches of at most [`TILE_PIXELS`] samples and ends the
    /// refinement when it returns true. Returns the samples spent.
    pub fn refine_tile(
        &self,
        tile: &Tile,
        acc: &mut TileAccum,
        extra: u64,
        opts: &AdaptiveOptions,
        stop: &mut dyn FnMut() -> bool,
        stats: &mut Stats,
    ) -> u64 {
        let n = acc.len;
        if n == 0 || extra == 0 {
            return 0;
        }
        let mut spent = 0u64;
        if !opts.adaptive {
            // uniform: every pixel the same count (the first `extra % n`
            // pixels one more), in rounds of one sample per pixel
            let per = extra / n as u64;
            let rest = (extra % n as u64) as usize;
            let mut round = 0u64;
            while round < per + u64::from(rest > 0) {
                if stop() {
                    return spent;
                }
                for i in 0..n {
                    if round < per || i < rest {
                        acc.add(self, tile, i, 1, stats);
                        spent += 1;
                    }
                }
                round += 1;
            }
            return spent;
        }
        // round 0: a second sample for every pixel (as far as the budget goes)
        let first = extra.min(n as u64) as usize;
        if stop() {
            return spent;
        }
        for i in 0..first {
            acc.add(self, tile, i, 1, stats);
        }
        spent += first as u64;
        let rounds = opts.rounds.max(1);
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
            // each pixel's standard deviation, its variance shrunk toward the
            // tile's mean, then dilated: high variance comes in features
            // (edges, caustics) that the neighbours' samples may have found
            let mut mean_var = 0.0f32;
            for i in 0..n {
                mean_var += acc.variance(i);
            }
            mean_var /= n as f32;
            let mut sig = [0.0f32; TILE_PIXELS];
            for (i, s) in sig.iter_mut().enumerate().take(n) {
                let k = acc.count(i).saturating_sub(1) as f32;
                *s = math::sqrt((acc.variance(i) * k + opts.prior * mean_var) / (k + opts.prior));
            }
            let (tw, th) = (tile.w as usize, tile.h as usize);
            let mut dil = [0.0f32; TILE_PIXELS];
            for y in 0..th {
                for x in 0..tw {
                    let i = y * tw + x;
                    let mut m = sig.get(i).copied().unwrap_or(0.0);
                    for (nx, ny) in [
                        (x.wrapping_sub(1), y),
                        (x + 1, y),
                        (x, y.wrapping_sub(1)),
                        (x, y + 1),
                    ] {
                        if nx < tw && ny < th {
                            m = math::max(
                                m,
                                opts.dilate * sig.get(ny * tw + nx).copied().unwrap_or(0.0),
                            );
                        }
                    }
                    if let Some(d) = dil.get_mut(i) {
                        *d = m;
                    }
                }
            }
            // water-filling: the counts the estimates call for at the end of
            // the tile's budget, minus what each pixel has; the floor and the
            // split of this round's samples go by those deficits
            let final_total = (acc_total(acc, n) + left) as f32;
            let mut sum_sig = 0.0f32;
            for d in dil.iter().take(n) {
                sum_sig += *d;
            }
            let deficit = |i: usize| {
                let want = if sum_sig > 0.0 {
                    final_total * dil.get(i).copied().unwrap_or(0.0) / sum_sig
                } else {
                    final_total / n as f32
                };
                math::max(0.0, want - acc.count(i) as f32)
            };
            let mut shares = [0u32; TILE_PIXELS];
            split(
                n,
                this,
                opts.floor,
                |_| 1.0,
                deficit,
                |i, s| {
                    if let Some(x) = shares.get_mut(i) {
                        *x = s.min(u64::from(u32::MAX)) as u32;
                    }
                },
            );
            let mut since_check = 0u64;
            for (i, &k) in shares.iter().enumerate().take(n) {
                if since_check >= TILE_PIXELS as u64 {
                    if stop() {
                        return spent;
                    }
                    since_check = 0;
                }
                acc.add(self, tile, i, k, stats);
                spent += u64::from(k);
                since_check += u64::from(k);
            }
        }
        spent
    }
}

/// The refinement samples each tile gets: `total` split over the tiles of a
/// `width × height` image in proportion to `weights` (one per tile, in
/// [`crate::film::tiles`] order, from [`Renderer::preview_tile`]), at least `floor` of the
/// uniform share each; uniform (∝ pixel count) when not adaptive. Calls
/// `give(tile_index, samples)` in tile order; the shares sum to `total`.
pub fn allocate_tiles(
    width: u32,
    height: u32,
    weights: &[f32],
    total: u64,
    opts: &AdaptiveOptions,
    give: impl FnMut(usize, u64),
) {
    let sizes = |i: usize| tile_at(width, height, i).map_or(0.0, |t| t.len() as f32);
    let n = tile_count(width, height);
    if opts.adaptive {
        // weights are sums over pixels: per pixel for the floor
        let per_pixel = |i: usize| {
            let s = sizes(i);
            if s > 0.0 {
                weights.get(i).copied().unwrap_or(0.0) / s
            } else {
                0.0
            }
        };
        split(n, total, opts.floor, sizes, per_pixel, give);
    } else {
        split(n, total, 0.0, sizes, |_| 1.0, give);
    }
}

/// The total number of image samples a sample budget asks for, or `None`
/// for a deadline (known only as the render goes).
pub fn budget_samples(budget: &Budget, width: u32, height: u32) -> Option<u64> {
    let pixels = u64::from(width) * u64::from(height);
    match *budget {
        Budget::Spp(s) => Some(pixels * u64::from(s.max(1))),
        Budget::Paths(p) => Some(p.max(pixels)),
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

/// The refinement budget of a deadline: what the preview's rate affords in
/// the time left, minus `overhead` paths (a recomputed preview), with 10 %
/// held back so that the last tiles are not cut short.
pub fn deadline_samples(
    deadline_us: u64,
    preview_us: u64,
    preview_paths: u64,
    overhead: u64,
) -> u64 {
    let left = deadline_us.saturating_sub(preview_us) as f32;
    let rate = preview_paths as f32 / math::max(preview_us as f32, 1.0);
    let afford = math::floor(0.9 * rate * left);
    (math::clamp(afford, 0.0, 1.0e18) as u64).saturating_sub(overhead)
}

/// Renders a whole image within `budget` on one core with one tile of
/// accumulators, drawing every tile into `target` twice: its preview, then
/// its refined pixels. This is the board's executor; the host's threaded
/// executor gives the same image for sample budgets.
///
/// `weights` needs [`tile_count`]`(width, height)` entries (a board keeps
/// them in a static array); tiles beyond its length get the floor weight.
#[allow(clippy::too_many_arguments)]
pub fn render_budget<D>(
    r: &Renderer<'_>,
    budget: Budget,
    opts: &AdaptiveOptions,
    weights: &mut [f32],
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
    let n = tile_count(w, h);
    let start = clock.micros();
    let mut sum = Summary::default();
    let mut px = [Color::ZERO; TILE_PIXELS];
    for i in 0..n {
        let Some(tile) = tile_at(w, h, i) else {
            continue;
        };
        let wt = r.preview_tile(&tile, acc, &mut sum.stats);
        if let Some(slot) = weights.get_mut(i) {
            *slot = wt;
        }
        acc.means(&mut px);
        draw_tile(target, &tile, &px, exposure)?;
    }
    let pixels = u64::from(w) * u64::from(h);
    sum.samples = pixels;
    sum.preview_micros = clock.micros().saturating_sub(start);
    let (extra, deadline) = match budget {
        Budget::Deadline(us) => (
            deadline_samples(us, sum.preview_micros, pixels, pixels),
            Some(start.saturating_add(us)),
        ),
        _ => (
            budget_samples(&budget, w, h)
                .unwrap_or(pixels)
                .saturating_sub(pixels),
            None,
        ),
    };
    let mut result = Ok(());
    allocate_tiles(w, h, weights, extra, opts, |i, share| {
        if result.is_err() || share == 0 || deadline.is_some_and(|d| clock.micros() >= d) {
            return;
        }
        let Some(tile) = tile_at(w, h, i) else { return };
        // the accumulators of the preview are gone: recompute sample 0
        r.preview_tile(&tile, acc, &mut sum.stats);
        let mut stop = || deadline.is_some_and(|d| clock.micros() >= d);
        sum.samples += r.refine_tile(&tile, acc, share, opts, &mut stop, &mut sum.stats);
        acc.means(&mut px);
        result = draw_tile(target, &tile, &px, exposure);
    });
    result?;
    sum.total_micros = clock.micros().saturating_sub(start);
    Ok(sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cumulative_split_is_exact_and_proportional() {
        let w = [1.0f32, 3.0, 0.0, 4.0];
        let mut got = [0u64; 4];
        split(4, 1000, 0.0, |_| 1.0, |i| w[i], |i, s| got[i] = s);
        assert_eq!(got.iter().sum::<u64>(), 1000);
        assert_eq!(got, [125, 375, 0, 500]);
        // the floor lifts the zero weight to a quarter of the mean (2)
        split(4, 1000, 0.25, |_| 1.0, |i| w[i], |i, s| got[i] = s);
        assert_eq!(got.iter().sum::<u64>(), 1000);
        assert!(got[2] > 0 && got[2] < got[0]);
        // all zero: uniform
        split(4, 10, 0.25, |_| 1.0, |_| 0.0, |i, s| got[i] = s);
        assert_eq!(got.iter().sum::<u64>(), 10);
        assert!(got.iter().all(|&s| s == 2 || s == 3));
        // NaN weights do not poison the split
        split(
            2,
            7,
            0.25,
            |_| 1.0,
            |i| if i == 0 { f32::NAN } else { 1.0 },
            |i, s| got[i] = s,
        );
        assert_eq!(got[0] + got[1], 7);
    }

    #[test]
    fn uniform_tiles_get_shares_by_pixel_count() {
        let mut got = [0u64; 4];
        let opts = AdaptiveOptions {
            adaptive: false,
            ..AdaptiveOptions::default()
        };
        // 20x20: tiles of 256, 64, 64, 16 pixels
        allocate_tiles(20, 20, &[9.0, 0.0, 0.0, 0.0], 400, &opts, |i, s| got[i] = s);
        assert_eq!(got, [256, 64, 64, 16]);
    }

    #[test]
    fn budgets_in_samples() {
        assert_eq!(budget_samples(&Budget::Spp(4), 10, 10), Some(400));
        assert_eq!(budget_samples(&Budget::Paths(50), 10, 10), Some(100));
        assert_eq!(budget_samples(&Budget::Paths(500), 10, 10), Some(500));
        assert_eq!(budget_samples(&Budget::Deadline(5), 10, 10), None);
    }
}
