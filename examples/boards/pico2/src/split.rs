//! One sample-budget render shared by several cores through the core's
//! per-tile API: a work counter hands out tiles, each core renders a tile
//! into its own accumulators and draws it.
//!
//! Work items `0..n` are the previews of the `n` tiles, items `n..2n` their
//! refinements. A core takes the next item with one atomic add, so the
//! cores split the tiles by speed, not by a fixed plan. A tile's pixels are
//! a pure function of the renderer, the tile and its sample share (computed
//! once by [`shares`], before the cores start): its preview is sample 0 of
//! every pixel, its refinement recomputes sample 0 and spends the tile's
//! share exactly as the core's single-core executor
//! (`micropt::budget::render_budget`) does. So the image does not depend on
//! which core did which tile, and equals the single-core image (and the host
//! CLI's `micropt render` at the same size, samples and seed) bit for bit.
//!
//! The previews come first: a core that takes a refinement waits until every
//! preview is drawn, so the panel shows the whole 1-sample image before any
//! tile is refined (at most one preview tile's wait, on one core).
//!
//! Needs atomic read-modify-write (`fetch_add`): Armv7-M/Armv8-M and the
//! host, not Armv6-M.

use core::sync::atomic::{AtomicUsize, Ordering};
use micropt::budget::{TileAccum, allocate_tiles, budget_samples};
use micropt::film::{Tile, tile_at, tile_count};
use micropt::{AdaptiveOptions, Budget, Renderer, Stats};

/// The work counters one render's cores share.
pub struct Split {
    /// The next work item.
    next: AtomicUsize,
    /// Preview tiles drawn so far.
    previewed: AtomicUsize,
}

impl Split {
    /// Counters for a render that has not started.
    pub const fn new() -> Self {
        Self {
            next: AtomicUsize::new(0),
            previewed: AtomicUsize::new(0),
        }
    }

    /// Takes work items until none is left: renders each tile into `acc` and
    /// hands it to `draw` (the tile and its accumulators), first as a
    /// preview, then refined by its entry of `shares`. Every core of the
    /// render calls this with its own `acc` and the same `r`, `shares` and
    /// `opts`; it returns when every item is taken (the other cores may
    /// still be finishing theirs).
    pub fn work(
        &self,
        r: &Renderer<'_>,
        shares: &[u64],
        opts: &AdaptiveOptions,
        acc: &mut TileAccum,
        stats: &mut Stats,
        mut draw: impl FnMut(&Tile, &TileAccum),
    ) {
        let (w, h) = (r.width(), r.height());
        let n = tile_count(w, h).min(shares.len());
        loop {
            let item = self.next.fetch_add(1, Ordering::Relaxed);
            if item >= 2 * n {
                return;
            }
            let (i, refine) = if item < n {
                (item, false)
            } else {
                (item - n, true)
            };
            let Some(tile) = tile_at(w, h, i) else {
                continue;
            };
            if refine {
                // every preview on the panel before the first refined tile
                while self.previewed.load(Ordering::Acquire) < n {
                    core::hint::spin_loop();
                }
            }
            let share = shares.get(i).copied().unwrap_or(0);
            if refine && share == 0 {
                // nothing to add: the preview on the panel is final
                continue;
            }
            r.preview_tile(&tile, acc, stats);
            if refine {
                r.refine_tile(&tile, acc, share, opts, &mut |_| false, stats);
            }
            draw(&tile, acc);
            if !refine {
                self.previewed.fetch_add(1, Ordering::Release);
            }
        }
    }
}

/// Each tile's refinement samples for a sample `budget` (`Spp` or `Paths`;
/// a `Deadline` refines nothing here) over a `width × height` image, as the
/// single-core executor splits them, written to `out` in tile order. Returns
/// the number of tiles, or `None` when `out` is shorter than that.
pub fn shares(budget: &Budget, width: u32, height: u32, out: &mut [u64]) -> Option<usize> {
    let n = tile_count(width, height);
    if out.len() < n {
        return None;
    }
    let pixels = u64::from(width) * u64::from(height);
    let extra = budget_samples(budget, width, height)
        .unwrap_or(pixels)
        .saturating_sub(pixels);
    allocate_tiles(width, height, extra, |i, s| {
        if let Some(x) = out.get_mut(i) {
            *x = s;
        }
    });
    Some(n)
}
