//! One budgeted render shared between the cores of a multi-core chip (or
//! threads), with the same bits as the single-core
//! [`render_budget`](crate::budget::render_budget).
//!
//! Every core calls [`render_shared`] with the same renderer, budget and
//! options, its own [`TileAccum`] and a handle on one shared image, and a
//! [`WorkQueue`] that all of them share. The render has the single-core
//! executor's two passes, each a queue of tiles that the cores take from
//! one at a time until it is empty:
//!
//! 1. **Preview**: sample 0 of every pixel of the tile, or of one pixel
//!    per block ([`AdaptiveOptions::preview_block`]), drawn at once.
//! 2. A barrier: no core starts refining before every preview is drawn (a
//!    late preview would overwrite a refined tile).
//! 3. **Refinement**: the tile's share of the budget ([`tile_share`]: by
//!    pixel count, as [`allocate_tiles`](crate::budget::allocate_tiles)),
//!    on its recomputed sample 0, drawn when done.
//!
//! A tile's refined pixels depend on the tile, the budget and the renderer
//! only — not on the other tiles, not on which core takes it or when — so
//! the image is the single-core executor's, bit for bit, for any number of
//! cores and any interleaving. The cores agree without talking: each computes
//! a tile's share from the image size and the budget.
//!
//! Only sample budgets are shared: a [`Budget::Deadline`] is refused
//! ([`SharedError::Deadline`]).
//!
//! The queues here, [`AtomicQueue`] and [`DealtQueue`], count with atomic
//! read-modify-write and exist only on targets that have it. On one that
//! has not (Armv6-M: the RP2040's two Cortex-M0+), the board implements
//! [`WorkQueue`] with a lock of its own (a hardware spinlock): the executor
//! needs nothing else of the target.

#[cfg(target_has_atomic = "ptr")]
use core::cell::Cell;
#[cfg(target_has_atomic = "ptr")]
use core::sync::atomic::AtomicUsize;
use core::sync::atomic::{AtomicU16, Ordering};

use embedded_graphics::Pixel;
use embedded_graphics::draw_target::DrawTarget;
use embedded_graphics::geometry::{OriginDimensions, Size};
use embedded_graphics::pixelcolor::{IntoStorage, Rgb565};

use crate::budget::{
    AdaptiveOptions, Budget, Summary, TileAccum, budget_samples, preview_block, tile_share,
};
use crate::film::{FromEncoded, draw_tile_iter, tile_at};
use crate::render::Renderer;

/// The two passes of a budgeted render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// The preview: sample 0 of every pixel, or of one pixel per block.
    Preview,
    /// The rest of the budget.
    Refine,
}

impl Pass {
    /// 0 for the preview, 1 for the refinement: an index into a queue's
    /// per-pass counters.
    pub fn index(self) -> usize {
        match self {
            Pass::Preview => 0,
            Pass::Refine => 1,
        }
    }
}

/// What the cores of one render share: the next tile of each pass, and how
/// many cores have finished each pass.
pub trait WorkQueue {
    /// Takes the next tile of `pass`: over all the cores, `0, 1, 2, …` each
    /// once. A number past the last tile means the pass has no tiles left.
    fn take(&self, pass: Pass) -> usize;
    /// Records that the calling core has finished its part of `pass`
    /// (everything it did before is visible to a core that then sees
    /// [`WorkQueue::all_done`]).
    fn done(&self, pass: Pass);
    /// Whether every core has finished `pass`.
    fn all_done(&self, pass: Pass) -> bool;
    /// Called while a core waits for the others: a hint (`wfe` on a board,
    /// a yield on a host); the default spins.
    fn idle(&self) {}
}

#[cfg(target_has_atomic = "ptr")]
/// A [`WorkQueue`] of atomic counters for a fixed number of cores, for one
/// render (a new render needs a new queue, or [`AtomicQueue::reset`] when no
/// core uses it).
#[derive(Debug)]
pub struct AtomicQueue {
    cores: usize,
    next: [AtomicUsize; 2],
    done: [AtomicUsize; 2],
}

#[cfg(target_has_atomic = "ptr")]
impl AtomicQueue {
    /// A queue for `cores` cores (at least 1).
    pub const fn new(cores: usize) -> Self {
        Self {
            cores: if cores == 0 { 1 } else { cores },
            next: [AtomicUsize::new(0), AtomicUsize::new(0)],
            done: [AtomicUsize::new(0), AtomicUsize::new(0)],
        }
    }

    /// Makes the queue ready for another render (no core may be using it).
    pub fn reset(&self) {
        for a in self.next.iter().chain(&self.done) {
            a.store(0, Ordering::Relaxed);
        }
    }
}

#[cfg(target_has_atomic = "ptr")]
impl WorkQueue for AtomicQueue {
    fn take(&self, pass: Pass) -> usize {
        // the count of takes only hands out distinct numbers: no ordering
        self.next[pass.index()].fetch_add(1, Ordering::Relaxed)
    }

    fn done(&self, pass: Pass) {
        self.done[pass.index()].fetch_add(1, Ordering::Release);
    }

    fn all_done(&self, pass: Pass) -> bool {
        self.done[pass.index()].load(Ordering::Acquire) >= self.cores
    }
}

#[cfg(target_has_atomic = "ptr")]
/// One core's [`WorkQueue`] that deals each pass's tiles out in turn: core
/// `k` of `n` takes tiles `k, k + n, k + 2n, …`, whatever the other cores
/// do. A fixed split: each core's work does not depend on the cores' speeds
/// (nor on how an emulator schedules them), at the price of the balance a
/// shared counter gives when tiles cost more in one part of the image. The
/// cores finish the passes through a shared [`AtomicQueue`] (its counters
/// of taken tiles are not used).
#[derive(Debug)]
pub struct DealtQueue<'a> {
    shared: &'a AtomicQueue,
    core: usize,
    next: [Cell<usize>; 2],
}

#[cfg(target_has_atomic = "ptr")]
impl<'a> DealtQueue<'a> {
    /// Core `core` (`0..shared`'s cores) of the cores that share `shared`.
    pub fn new(shared: &'a AtomicQueue, core: usize) -> Self {
        Self {
            shared,
            core,
            next: [Cell::new(0), Cell::new(0)],
        }
    }
}

#[cfg(target_has_atomic = "ptr")]
impl WorkQueue for DealtQueue<'_> {
    fn take(&self, pass: Pass) -> usize {
        let k = &self.next[pass.index()];
        let turn = k.get();
        k.set(turn.saturating_add(1));
        // past the last tile (the core number too large) means no tile
        turn.saturating_mul(self.shared.cores)
            .saturating_add(self.core)
    }

    fn done(&self, pass: Pass) {
        self.shared.done(pass);
    }

    fn all_done(&self, pass: Pass) -> bool {
        self.shared.all_done(pass)
    }
}

/// Why [`render_shared`] did not render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SharedError<E> {
    /// A deadline budget: only sample budgets are shared between cores.
    Deadline,
    /// The draw target failed (the core still took part in both passes, so
    /// the others finish).
    Draw(E),
}

/// Renders this core's part of one image within `budget` (a sample
/// budget), as the module docs describe: takes preview tiles from `queue`
/// until none are left, waits for every core's previews, then takes
/// refinement tiles until none are left. Returns this core's part: the
/// samples and paths it traced (the cores' summaries add up to the
/// single-core executor's; no clock is read, the times are 0).
///
/// Each core draws into its own `target`, all of them views of one image.
/// The image is complete when every core has finished the refinement
/// ([`WorkQueue::all_done`]`(Pass::Refine)`; [`wait_all`]).
pub fn render_shared<D, Q>(
    r: &Renderer<'_>,
    budget: Budget,
    opts: &AdaptiveOptions,
    acc: &mut TileAccum,
    queue: &Q,
    target: &mut D,
    exposure: f32,
) -> Result<Summary, SharedError<D::Error>>
where
    D: DrawTarget,
    D::Color: FromEncoded,
    Q: WorkQueue + ?Sized,
{
    let (w, h) = (r.width(), r.height());
    let Some(total) = budget_samples(&budget, w, h) else {
        return Err(SharedError::Deadline);
    };
    let mut sum = Summary::default();
    let mut failed = None;
    let block = preview_block(&budget, opts);
    loop {
        let i = queue.take(Pass::Preview);
        let Some(tile) = tile_at(w, h, i) else {
            break;
        };
        if failed.is_some() {
            continue; // take the rest, so that the pass ends
        }
        r.preview_blocks(&tile, acc, block, &mut sum.stats);
        sum.samples += tile.len() as u64;
        if let Err(e) = draw_tile_iter(target, &tile, acc.mean_iter(), exposure) {
            failed = Some(e);
        }
    }
    queue.done(Pass::Preview);
    wait_all(queue, Pass::Preview);

    let extra = total.saturating_sub(u64::from(w) * u64::from(h));
    loop {
        let i = queue.take(Pass::Refine);
        let Some(tile) = tile_at(w, h, i) else {
            break;
        };
        let share = tile_share(w, h, extra, i);
        // a tile without refinement keeps its preview if that was sample 0
        // of every pixel
        if failed.is_some() || (share == 0 && block == 1) {
            continue;
        }
        // the accumulators of the preview are gone: recompute sample 0
        sum.samples += r.preview_and_refine_tile(&tile, acc, share, opts, &mut sum.stats);
        if let Err(e) = draw_tile_iter(target, &tile, acc.mean_iter(), exposure) {
            failed = Some(e);
        }
    }
    queue.done(Pass::Refine);
    match failed {
        Some(e) => Err(SharedError::Draw(e)),
        None => Ok(sum),
    }
}

/// Waits, calling [`WorkQueue::idle`], until every core has finished `pass`.
pub fn wait_all<Q: WorkQueue + ?Sized>(queue: &Q, pass: Pass) {
    while !queue.all_done(pass) {
        queue.idle();
    }
}

/// An Rgb565 image of up to `N` pixels that several cores draw into at once
/// without a lock: one atomic per pixel. Draw through `&SharedFramebuffer`
/// (a [`DrawTarget`]; pixels outside the image are dropped); read it, when
/// every core has finished, with [`SharedFramebuffer::bytes_be`].
#[derive(Debug)]
pub struct SharedFramebuffer<const N: usize> {
    px: [AtomicU16; N],
    width: u32,
    height: u32,
}

impl<const N: usize> SharedFramebuffer<N> {
    /// A black `width × height` image; a size of more than `N` pixels is cut
    /// to the rows that fit.
    pub const fn new(width: u32, height: u32) -> Self {
        let rows = if width == 0 {
            0
        } else {
            let fit = N / width as usize;
            if (height as usize) < fit {
                height
            } else {
                fit as u32
            }
        };
        Self {
            px: [const { AtomicU16::new(0) }; N],
            width,
            height: rows,
        }
    }

    /// The image's pixels as big-endian Rgb565 bytes, row-major (the byte
    /// order of an SPI panel and of an embedded-graphics
    /// `Framebuffer<Rgb565, RawU16, BigEndian, ..>`).
    pub fn bytes_be(&self) -> impl Iterator<Item = u8> + '_ {
        let len = self.width as usize * self.height as usize;
        self.px
            .iter()
            .take(len)
            .flat_map(|p| p.load(Ordering::Relaxed).to_be_bytes())
    }
}

impl<const N: usize> OriginDimensions for &SharedFramebuffer<N> {
    fn size(&self) -> Size {
        Size::new(self.width, self.height)
    }
}

impl<const N: usize> DrawTarget for &SharedFramebuffer<N> {
    type Color = Rgb565;
    type Error = core::convert::Infallible;

    fn draw_iter<I>(&mut self, pixels: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Pixel<Self::Color>>,
    {
        for Pixel(p, c) in pixels {
            let (Ok(x), Ok(y)) = (u32::try_from(p.x), u32::try_from(p.y)) else {
                continue;
            };
            if x >= self.width || y >= self.height {
                continue;
            }
            let i = y as usize * self.width as usize + x as usize;
            if let Some(slot) = self.px.get(i) {
                slot.store(c.into_storage(), Ordering::Relaxed);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_graphics::prelude::*;

    #[test]
    fn atomic_queue_hands_out_each_number_once_and_counts_finished_cores() {
        let q = AtomicQueue::new(2);
        assert_eq!(
            [q.take(Pass::Preview), q.take(Pass::Preview)],
            [0, 1],
            "numbers in order"
        );
        assert_eq!(q.take(Pass::Refine), 0, "each pass its own numbers");
        q.done(Pass::Preview);
        assert!(!q.all_done(Pass::Preview));
        q.done(Pass::Preview);
        assert!(q.all_done(Pass::Preview));
        assert!(!q.all_done(Pass::Refine));
        q.reset();
        assert!(!q.all_done(Pass::Preview));
        assert_eq!(q.take(Pass::Preview), 0);
        // zero cores means one
        let one = AtomicQueue::new(0);
        one.done(Pass::Refine);
        assert!(one.all_done(Pass::Refine));
    }

    #[test]
    fn dealt_queue_deals_tiles_in_turn_and_shares_the_barrier() {
        let shared = AtomicQueue::new(3);
        let cores = [0, 1, 2].map(|k| DealtQueue::new(&shared, k));
        let first: [[usize; 3]; 3] =
            core::array::from_fn(|k| core::array::from_fn(|_| cores[k].take(Pass::Preview)));
        assert_eq!(first, [[0, 3, 6], [1, 4, 7], [2, 5, 8]]);
        assert_eq!(cores[1].take(Pass::Refine), 1, "each pass its own turns");
        for (k, c) in cores.iter().enumerate() {
            assert!(!c.all_done(Pass::Preview), "core {k}");
            c.done(Pass::Preview);
        }
        assert!(cores.iter().all(|c| c.all_done(Pass::Preview)));
    }

    #[test]
    fn shared_framebuffer_stores_pixels_in_bounds_big_endian() {
        let fb = SharedFramebuffer::<6>::new(3, 2);
        let mut t = &fb;
        let red = Rgb565::new(31, 0, 0);
        t.draw_iter([
            Pixel(Point::new(1, 1), red),
            Pixel(Point::new(3, 0), red),
            Pixel(Point::new(-1, 0), red),
        ])
        .unwrap();
        let mut bytes = [0u8; 12];
        for (b, v) in bytes.iter_mut().zip(fb.bytes_be()) {
            *b = v;
        }
        assert_eq!(bytes, [0, 0, 0, 0, 0, 0, 0, 0, 0xf8, 0, 0, 0]);
        assert_eq!(fb.bytes_be().count(), 12);
        // an image larger than the buffer keeps the rows that fit
        let cut = SharedFramebuffer::<6>::new(4, 4);
        assert_eq!((&cut).size(), Size::new(4, 1));
    }
}
