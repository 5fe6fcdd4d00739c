//! The demo's passes on two cores: core 1 renders the odd pixels of every
//! row into a small ring, core 0 renders the even ones and takes the odd
//! ones from the ring as the denoiser asks for them ([`TwoCores`], the
//! demo's [`Pixels`]). A pixel's moments depend only on the renderer, the
//! budget and the pixel, so the image is the one core's, bit for bit.
//!
//! Lock-free, with atomic loads and stores only (the RP2040's Cortex-M0+
//! has no atomic read-modify-write): one producer (core 1) and one
//! consumer (core 0) per counter; a pixel's moments travel as the bits of
//! its eight `f32`s.
//!
//! Shared by the Pico board crates in `examples/boards/` and the AN521
//! dual-core firmware (`examples/dualcore.rs`, which checks it in QEMU)
//! through `#[path]`.

use core::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};
use micropt::demo::Pixels;
use micropt::denoise::{Moments, pixel_moments};
use micropt::{Renderer, Stats};

/// How many odd pixels core 1 may render ahead of core 0.
const RING: usize = 64;

/// A pixel's moments as bits: the scattered and direct sums, the square,
/// the half sum, the count of samples that saw a light.
type Bits = [AtomicU32; 9];

/// What the two cores share.
pub struct Shared {
    /// The pass's renderer's address (0: no pass), valid from
    /// [`TwoCores::begin`] until [`TwoCores::end`] has seen core 1 leave
    /// it (`busy` false).
    renderer: AtomicUsize,
    /// The pass's samples a pixel, width and height (written before
    /// `renderer`).
    spp: AtomicU32,
    width: AtomicU32,
    height: AtomicU32,
    /// Counts passes, so that core 1 tells a new one from the last.
    pass: AtomicU32,
    /// Core 1 may be inside the renderer.
    busy: AtomicBool,
    /// The odd pixels core 1 has made this pass (written by core 1 only,
    /// reset by core 0 while no pass is published).
    made: AtomicU32,
    /// The odd pixels core 0 has taken (written by core 0 only).
    taken: AtomicU32,
    /// Core 1's paths this pass.
    paths: AtomicU32,
    /// The pixels made and not yet taken, at `index % RING`.
    ring: [Bits; RING],
}

impl Shared {
    /// No pass.
    pub const fn new() -> Self {
        Self {
            renderer: AtomicUsize::new(0),
            spp: AtomicU32::new(0),
            width: AtomicU32::new(0),
            height: AtomicU32::new(0),
            pass: AtomicU32::new(0),
            busy: AtomicBool::new(false),
            made: AtomicU32::new(0),
            taken: AtomicU32::new(0),
            paths: AtomicU32::new(0),
            ring: [const { [const { AtomicU32::new(0) }; 9] }; RING],
        }
    }

    /// Core 1, for ever: the odd pixels of each pass core 0 begins, in
    /// order, each into the ring once there is room.
    pub fn serve(&self) -> ! {
        let mut done = 0;
        loop {
            let pass = self.pass.load(Ordering::SeqCst);
            let (w, h) = (
                self.width.load(Ordering::SeqCst),
                self.height.load(Ordering::SeqCst),
            );
            let odd = w / 2;
            let k = self.made.load(Ordering::SeqCst);
            let room = k.wrapping_sub(self.taken.load(Ordering::SeqCst)) < RING as u32;
            if pass == done || self.renderer.load(Ordering::SeqCst) == 0 || !room {
                idle();
                continue;
            }
            if k >= odd * h {
                done = pass;
                continue;
            }
            // announce, then check that the pass is still published: `end`
            // withdraws the renderer and then waits for `busy` to clear
            // (both sides store, then load, sequentially consistent), so
            // either this sees the withdrawal or `end` sees `busy`
            self.busy.store(true, Ordering::SeqCst);
            let addr = self.renderer.load(Ordering::SeqCst);
            if addr == 0 || self.pass.load(Ordering::SeqCst) != pass {
                self.busy.store(false, Ordering::SeqCst);
                continue;
            }
            // SAFETY: `addr` is the renderer `TwoCores::begin` published for
            // this pass (it was still published after `busy` was set), and
            // `TwoCores::end`, which the demo calls before the renderer is
            // dropped (`Pixels`' contract, kept by `Demo::step`), withdraws
            // it and then waits for `busy` to clear: the renderer lives
            // while it is read here.
            let renderer = unsafe { &*(addr as *const Renderer<'static>) };
            let mut stats = Stats::default();
            let spp = self.spp.load(Ordering::SeqCst);
            // (`odd` is not 0 here: `k < odd · h`)
            let (Some(col), Some(y)) = (k.checked_rem(odd), k.checked_div(odd)) else {
                self.busy.store(false, Ordering::SeqCst);
                continue;
            };
            let m = pixel_moments(renderer, spp, 2 * col + 1, y, &mut stats);
            let slot = &self.ring[k as usize % RING];
            let f = |v: f32| v.to_bits();
            let bits = [
                f(m.scattered[0]),
                f(m.scattered[1]),
                f(m.scattered[2]),
                f(m.direct[0]),
                f(m.direct[1]),
                f(m.direct[2]),
                f(m.square),
                f(m.half),
                m.seen,
            ];
            for (a, v) in slot.iter().zip(bits) {
                a.store(v, Ordering::Relaxed);
            }
            let paths = self.paths.load(Ordering::Relaxed);
            self.paths
                .store(paths.wrapping_add(stats.paths as u32), Ordering::Relaxed);
            // the slot's bits before the count that hands them over
            self.made.store(k + 1, Ordering::SeqCst);
            self.busy.store(false, Ordering::SeqCst);
        }
    }
}

/// A short wait between looks at the other core's counters.
fn idle() {
    core::hint::spin_loop();
    cortex_m::asm::delay(200);
}

/// Core 0's pixel source: even pixels rendered here, odd ones from core 1
/// through `shared` (all of them here if core 1 did not start).
pub struct TwoCores {
    /// What the cores share.
    pub shared: &'static Shared,
    /// Whether core 1 runs [`Shared::serve`].
    pub helper: bool,
}

impl Pixels for TwoCores {
    fn begin(&mut self, renderer: &Renderer<'_>, spp: u32) {
        if !self.helper {
            return;
        }
        let s = self.shared;
        // no pass is published (`end` withdrew the last): core 1 reads
        // none of these until the renderer's store below
        s.made.store(0, Ordering::SeqCst);
        s.taken.store(0, Ordering::SeqCst);
        s.paths.store(0, Ordering::SeqCst);
        s.spp.store(spp, Ordering::SeqCst);
        s.width.store(renderer.width(), Ordering::SeqCst);
        s.height.store(renderer.height(), Ordering::SeqCst);
        let pass = s.pass.load(Ordering::SeqCst).wrapping_add(1).max(1);
        s.pass.store(pass, Ordering::SeqCst);
        s.renderer
            .store(core::ptr::from_ref(renderer) as usize, Ordering::SeqCst);
    }

    fn moments(
        &mut self,
        renderer: &Renderer<'_>,
        spp: u32,
        x: u32,
        y: u32,
        stats: &mut Stats,
    ) -> Moments {
        if !self.helper || x.is_multiple_of(2) {
            return pixel_moments(renderer, spp, x, y, stats);
        }
        let s = self.shared;
        // the odd pixels arrive in the order the demo asks for them (row
        // by row, left to right, each once)
        let want = y * (renderer.width() / 2) + x / 2;
        if s.taken.load(Ordering::SeqCst) != want {
            // asked out of order (not the demo's way): render it here
            return pixel_moments(renderer, spp, x, y, stats);
        }
        while s.made.load(Ordering::SeqCst) <= want {
            idle();
        }
        let slot = &s.ring[want as usize % RING];
        let v = |i: usize| f32::from_bits(slot[i].load(Ordering::Relaxed));
        let m = Moments {
            scattered: [v(0), v(1), v(2)],
            direct: [v(3), v(4), v(5)],
            square: v(6),
            half: v(7),
            seen: slot[8].load(Ordering::Relaxed),
        };
        // the slot read before it is handed back
        s.taken.store(want + 1, Ordering::SeqCst);
        m
    }

    fn end(&mut self) -> u64 {
        if !self.helper {
            return 0;
        }
        let s = self.shared;
        // withdraw the renderer, then wait for core 1 to leave it
        s.renderer.store(0, Ordering::SeqCst);
        while s.busy.load(Ordering::SeqCst) {
            idle();
        }
        u64::from(s.paths.load(Ordering::SeqCst))
    }
}
