//! A denoised frame on two cores: core 1 renders the odd pixels of each
//! row and leaves them in a [`Mailbox`]; core 0 renders the even ones
//! ([`TwoCores`]), denoises and draws (`denoised.rs`). Which core renders a
//! pixel does not change its bits.
//!
//! Shared by the Pico board crates in `examples/boards/` (`#[path]`).

use crate::denoised::moments;
use core::cell::RefCell;
use critical_section::Mutex;
use micropt::denoise::Moments;
use micropt::{Renderer, Stats};

/// Where core 1 leaves the odd pixels' moments of a row for core 0: two
/// slots (core 1 may be a row ahead), each holding one row's odd pixels
/// (`N` = half the width, rounded up), behind a critical section (on the
/// RP2040 and RP2350 a SIO hardware spinlock, which excludes the other
/// core).
pub struct Mailbox<const N: usize> {
    slots: Mutex<RefCell<[Slot<N>; 2]>>,
}

/// One row's odd pixels, and which row: `row` is its index plus one, 0
/// ([`EMPTY`]) when taken (so the mailbox starts as zero bits, in .bss).
struct Slot<const N: usize> {
    row: u32,
    moments: [Moments; N],
}

/// A slot that holds no row.
const EMPTY: u32 = 0;

impl<const N: usize> Mailbox<N> {
    /// Both slots empty.
    pub const fn new() -> Self {
        Self {
            slots: Mutex::new(RefCell::new(
                [const {
                    Slot {
                        row: EMPTY,
                        moments: [Moments::ZERO; N],
                    }
                }; 2],
            )),
        }
    }

    /// Core 1: leaves row `y`'s odd pixels, waiting while its slot still
    /// holds the row before last.
    fn put(&self, y: u32, moments: &[Moments]) {
        loop {
            let done = critical_section::with(|cs| {
                let mut slots = self.slots.borrow_ref_mut(cs);
                match slots.get_mut(y as usize % 2) {
                    Some(s) if s.row == EMPTY => {
                        for (to, from) in s.moments.iter_mut().zip(moments) {
                            *to = *from;
                        }
                        s.row = y + 1;
                        true
                    }
                    _ => false,
                }
            });
            if done {
                return;
            }
            core::hint::spin_loop();
        }
    }

    /// Core 0: takes row `y`'s odd pixels into the odd entries of `row`,
    /// waiting until core 1 has left them.
    fn take(&self, y: u32, row: &mut [Moments]) {
        loop {
            let done = critical_section::with(|cs| {
                let mut slots = self.slots.borrow_ref_mut(cs);
                match slots.get_mut(y as usize % 2) {
                    Some(s) if s.row == y + 1 => {
                        for (to, from) in row.iter_mut().skip(1).step_by(2).zip(&s.moments) {
                            *to = *from;
                        }
                        s.row = EMPTY;
                        true
                    }
                    _ => false,
                }
            });
            if done {
                return;
            }
            core::hint::spin_loop();
        }
    }

    /// Core 1's part of a frame: the odd pixels of every row of `r`'s
    /// image at `spp` samples, into the mailbox (`scratch`: at least `N`
    /// moments). Returns its paths' statistics.
    pub fn render_odd(&self, r: &Renderer<'_>, spp: u32, scratch: &mut [Moments]) -> Stats {
        let mut stats = Stats::default();
        for y in 0..r.height() {
            for (slot, x) in scratch.iter_mut().zip((1..r.width()).step_by(2)) {
                *slot = moments(r, x, y, spp, &mut stats);
            }
            self.put(y, scratch);
        }
        stats
    }
}

/// Core 0's pixel source on two cores: it renders a row's even pixels
/// into `row` when the denoiser asks for the row's first pixel, and takes
/// the odd ones from core 1 through `mailbox` (or renders them too when
/// `mailbox` is `None`: core 1 did not start).
pub struct TwoCores<'a, const N: usize> {
    /// Core 1's mailbox, if it runs.
    pub mailbox: Option<&'a Mailbox<N>>,
    /// One row of moments (at least the image's width).
    pub row: &'a mut [Moments],
    /// Core 0's paths.
    pub stats: Stats,
}

impl<const N: usize> TwoCores<'_, N> {
    /// Pixel (x, y)'s moments, at `spp` samples.
    pub fn pixel(&mut self, r: &Renderer<'_>, spp: u32, x: u32, y: u32) -> Moments {
        if x == 0 {
            let step = if self.mailbox.is_some() { 2 } else { 1 };
            let w = r.width() as usize;
            for (x, m) in self.row.iter_mut().enumerate().take(w).step_by(step) {
                *m = moments(r, x as u32, y, spp, &mut self.stats);
            }
            if let Some(mailbox) = self.mailbox {
                mailbox.take(y, self.row);
            }
        }
        self.row.get(x as usize).copied().unwrap_or(Moments::ZERO)
    }
}
