//! One tile's samples: its accumulators ([`TileAccum`]), the preview and
//! the adaptive refinement of its pixels ([`Renderer::preview_tile`],
//! [`Renderer::refine_tile`], both at once on a recomputed preview:
//! [`Renderer::preview_and_refine_tile`]), and the split of a sample budget
//! over tiles and pixels that both use, exact to the sample.

use super::{AdaptiveOptions, BATCH, TILE_PIXELS};
use crate::film::{TILE, Tile, tile_at, tile_count};
use crate::geometry::Color;
use crate::math;
use crate::render::Renderer;
use crate::stats::Stats;

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
    /// `pixels` (pixel `i` of `tile` at steps of `step` pixels: `(tile.x +
    /// step · (i mod tile.w), tile.y + step · (i div tile.w))`), each
    /// pixel's in turn, where `k` is `shares[i]` (which is lowered by what
    /// is added), or `each` for every pixel when `shares` is
    /// empty; at most `limit` samples in all, the last pixel's cut short.
    /// Returns the samples added. One call for a whole round of the tile
    /// (or a clock check's batch of it): what the integrator loads once per
    /// call (the scene's arrays, the options) is loaded once per round, not
    /// once per sample or pixel.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn add(
        &mut self,
        r: &Renderer<'_>,
        tile: &Tile,
        step: u32,
        pixels: core::ops::Range<usize>,
        shares: &mut [u32],
        each: u32,
        limit: u32,
        stats: &mut Stats,
    ) -> u32 {
        let w = tile.w.max(1);
        let mut added = 0u32;
        for i in pixels {
            let k = match shares.get_mut(i) {
                Some(s) => {
                    let k = (*s).min(limit - added);
                    *s -= k;
                    k
                }
                None => each,
            };
            if k == 0 {
                continue;
            }
            let i32 = i as u32;
            let (x, y) = (
                tile.x.saturating_add((i32 % w).saturating_mul(step)),
                tile.y.saturating_add((i32 / w).saturating_mul(step)),
            );
            let (Some(sum), Some(l2), Some(n)) = (
                self.sum.get_mut(i),
                self.lum2.get_mut(i),
                self.count.get_mut(i),
            ) else {
                break;
            };
            let pixel = r.pixel(x, y);
            for _ in 0..k {
                let c = r.sample_in(&pixel, x, y, *n, stats);
                let l = c.luminance();
                *sum += c;
                *l2 += l * l;
                *n += 1;
            }
            added += k;
            if added == limit {
                break;
            }
        }
        added
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
    let t = total as f32;
    let v = math::clamp(math::floor(t * (cum / cum_total)), 0.0, t);
    // `v as u64`, through a 32-bit conversion (one instruction on a 32-bit
    // core, not a runtime call) where that is the same
    if v < 4_294_967_296.0 {
        u64::from(v as u32)
    } else {
        v as u64
    }
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
pub(super) fn split(
    n: usize,
    total: u64,
    floor: f32,
    w: impl Fn(usize) -> f32,
    give: impl FnMut(usize, u64),
) {
    let weight = |i: usize| sanitized(w(i));
    let mut sum = 0.0f32;
    for i in 0..n {
        sum += weight(i);
    }
    split_sanitized(n, sum, total, floor, weight, give);
}

/// A weight of [`split`]: NaN and infinities count as 0, negatives as 0.
#[inline(always)]
fn sanitized(v: f32) -> f32 {
    if v.is_finite() {
        math::max(v, 0.0)
    } else {
        0.0
    }
}

/// [`split`] of weights `w` already made [`sanitized`], whose sum in
/// index order is `sum`: the passes after the sum, so that a caller that
/// computes its weights (and their sum) once reads each of them once more
/// per pass instead of recomputing it.
fn split_sanitized(
    n: usize,
    sum: f32,
    total: u64,
    floor: f32,
    w: impl Fn(usize) -> f32,
    mut give: impl FnMut(usize, u64),
) {
    let mean = sum / math::max(n as f32, 1.0);
    let eff = |i: usize| {
        if mean > 0.0 {
            math::max(w(i), floor * mean)
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
        self.first_walk(tile, acc, 0, stats);
    }

    /// Sample 0 of every pixel of `tile` into `acc` (reset first), and
    /// sample 1 too, in the same walk, when `extra` has one for every
    /// pixel; returns the samples of `extra` spent (0 or the pixel count).
    fn first_walk(&self, tile: &Tile, acc: &mut TileAccum, extra: u64, stats: &mut Stats) -> u64 {
        acc.reset(tile.len());
        let n = acc.len as u64;
        let (each, first) = if extra >= n { (2, n) } else { (1, 0) };
        acc.add(self, tile, 1, 0..acc.len, &mut [], each, u32::MAX, stats);
        first
    }

    /// Both passes for `tile` on accumulators that no longer hold its
    /// preview, with the budget's stop never asked: sample 0 of every pixel
    /// into `acc` (reset first), as [`Renderer::preview_tile`], then
    /// `extra` more samples, as [`Renderer::refine_tile`]. When `extra` has
    /// one for every pixel, the refinement's first pass (sample 1 of every
    /// pixel) goes in the same walk over the pixels as sample 0, which sets
    /// up every pixel's sampler once for the two: the same samples in the
    /// same order, so the same image. Returns the samples of `extra` spent.
    pub fn preview_and_refine_tile(
        &self,
        tile: &Tile,
        acc: &mut TileAccum,
        extra: u64,
        opts: &AdaptiveOptions,
        stats: &mut Stats,
    ) -> u64 {
        let first = self.first_walk(tile, acc, extra, stats);
        first
            + self.refine_tile(
                tile,
                acc,
                extra.saturating_sub(first),
                opts,
                &mut |_| false,
                stats,
            )
    }

    /// The board's preview of `tile` in blocks of `side × side` pixels
    /// (cut at the tile's edges): sample 0 of each block's top-left pixel,
    /// given to every pixel of the block; `side` 1 is
    /// [`Renderer::preview_tile`]. With `side` above 1 the accumulators
    /// hold a picture to draw, not the pixels' samples: refinement starts
    /// from [`Renderer::preview_tile`].
    pub fn preview_blocks(&self, tile: &Tile, acc: &mut TileAccum, side: u32, stats: &mut Stats) {
        if side <= 1 {
            self.preview_tile(tile, acc, stats);
            return;
        }
        // the blocks' top-left pixels, a grid of `side` steps, through the
        // one call site of the integrator (another would inline it again)
        let grid = Tile {
            w: tile.w.div_ceil(side),
            h: tile.h.div_ceil(side),
            ..*tile
        };
        acc.reset(grid.len());
        acc.add(self, &grid, side, 0..acc.len, &mut [], 1, u32::MAX, stats);
        // each pixel takes its block's entry, from the last pixel back: the
        // block's index `j` is at most the pixel's `i`, so not yet
        // overwritten
        acc.len = tile.len().min(TILE_PIXELS);
        let (w, bw) = (tile.w.max(1), grid.w);
        for i in (0..acc.len).rev() {
            let (cx, cy) = (i as u32 % w, i as u32 / w);
            let j = ((cy / side) * bw + cx / side) as usize;
            if let (Some(&s), Some(&l2), Some(&n)) =
                (acc.sum.get(j), acc.lum2.get(j), acc.count.get(j))
                && let (Some(ds), Some(dl2), Some(dn)) = (
                    acc.sum.get_mut(i),
                    acc.lum2.get_mut(i),
                    acc.count.get_mut(i),
                )
            {
                (*ds, *dl2, *dn) = (s, l2, n);
            }
        }
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
            acc.add(self, tile, 1, start..head, &mut [], 1, u32::MAX, stats);
            acc.add(
                self,
                tile,
                1,
                0..take - (head - start),
                &mut [],
                1,
                u32::MAX,
                stats,
            );
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
            let (mut sig, sum_sig) = self.pixel_sigmas(acc, opts);
            // water-filling: the counts the estimates call for at the end of
            // the tile's budget; this round goes by each pixel's deficit,
            // computed once in place of its sigma, as `split` weighs it
            // (the pass that sums the weights)
            let final_total = (acc.total() + left) as f32;
            let mut sum_deficit = 0.0f32;
            for (i, v) in sig.iter_mut().enumerate().take(n) {
                let want = if sum_sig > 0.0 {
                    final_total * *v / sum_sig
                } else {
                    final_total / n as f32
                };
                *v = sanitized(want - acc.count(i) as f32);
                sum_deficit += *v;
            }
            let mut shares = [0u32; TILE_PIXELS];
            let deficit = |i: usize| sig.get(i).copied().unwrap_or(0.0);
            split_sanitized(n, sum_deficit, this, opts.floor, deficit, |i, s| {
                if let Some(x) = shares.get_mut(i) {
                    *x = s.min(u64::from(u32::MAX)) as u32;
                }
            });
            // the shares pixel by pixel, at most BATCH samples between two
            // looks at the clock: one call of `add` per batch
            let mut next = 0usize;
            loop {
                while shares.get(next).is_some_and(|&k| k == 0) {
                    next += 1;
                }
                if next >= n {
                    break;
                }
                if since_check >= BATCH {
                    if stop(spent) {
                        return spent;
                    }
                    since_check = 0;
                }
                let limit = (BATCH - since_check) as u32;
                let done = acc.add(self, tile, 1, next..n, &mut shares, 1, limit, stats);
                if done == 0 {
                    break;
                }
                spent += u64::from(done);
                since_check += u64::from(done);
            }
        }
        spent
    }

    /// Each pixel's estimated standard deviation: its luminance variance
    /// shrunk toward the tile's mean variance (a prior worth
    /// [`AdaptiveOptions::prior`] samples); and their sum, in pixel order.
    fn pixel_sigmas(&self, acc: &TileAccum, opts: &AdaptiveOptions) -> ([f32; TILE_PIXELS], f32) {
        let n = acc.len;
        // each variance computed once, kept in `sig` until it becomes the
        // pixel's sigma
        let mut sig = [0.0f32; TILE_PIXELS];
        let mut mean_var = 0.0f32;
        for (i, s) in sig.iter_mut().enumerate().take(n) {
            *s = acc.variance(i);
            mean_var += *s;
        }
        mean_var /= math::max(n as f32, 1.0);
        let mut sum = 0.0f32;
        for (i, s) in sig.iter_mut().enumerate().take(n) {
            let k = acc.count(i).saturating_sub(1) as f32;
            *s = math::sqrt((*s * k + opts.prior * mean_var) / (k + opts.prior));
            sum += *s;
        }
        (sig, sum)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `split_sanitized` after a caller's own sanitising pass gives `split`'s
    /// shares, bit for bit, for weights with NaN, infinities, negatives and
    /// zeros, every floor and total.
    #[test]
    fn split_sanitized_is_split() {
        let mut x = 0x1234_5678u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        for case in 0..400 {
            let n = 1 + (next() % 256) as usize;
            let mut w = [0.0f32; TILE_PIXELS];
            for v in w.iter_mut().take(n) {
                *v = match next() % 16 {
                    0 => f32::NAN,
                    1 => f32::INFINITY,
                    2 => -3.5,
                    3 | 4 => 0.0,
                    _ => (next() >> 8) as f32 * 1e-4 * if case % 3 == 0 { -1.0 } else { 1.0 },
                };
            }
            let total = u64::from(next() % 5000);
            let floor = [0.0, 0.1, 0.25, 1.0][case % 4];
            let mut want = [0u64; TILE_PIXELS];
            split(n, total, floor, |i| w[i], |i, s| want[i] = s);
            let mut sum = 0.0f32;
            for v in w.iter_mut().take(n) {
                *v = sanitized(*v);
                sum += *v;
            }
            let mut got = [0u64; TILE_PIXELS];
            split_sanitized(n, sum, total, floor, |i| w[i], |i, s| got[i] = s);
            assert_eq!(got[..n], want[..n], "case {case}, n {n}, total {total}");
        }
    }

    /// The share's conversion through `u32` gives what the direct `as u64`
    /// gives, below, at and above 2^32 (totals of a whole image can pass
    /// it).
    #[test]
    fn cumulative_share_converts_as_u64_does() {
        for total in [
            0u64,
            1,
            1000,
            (1 << 32) - 1,
            1 << 32,
            (1 << 32) + 1,
            1 << 40,
            u64::MAX,
        ] {
            let t = total as f32;
            for k in 0..=64u32 {
                let (cum, cum_total) = (k as f32, 64.0);
                let want = math::clamp(math::floor(t * (cum / cum_total)), 0.0, t) as u64;
                let got = cumulative_share(total, cum, cum_total, false);
                assert_eq!(got, want, "total {total}, {k}/64");
            }
        }
    }
}
