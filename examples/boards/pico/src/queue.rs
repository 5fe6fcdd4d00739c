//! The two cores' work queue on the RP2040, whose Cortex-M0+ cores have no
//! atomic read-modify-write (Armv6-M): `micropt::multicore`'s atomic
//! queues do not exist there, so this one keeps its counters under the
//! critical section, which rp2040-hal (`critical-section-impl`) implements
//! with SIO hardware spinlock 31 and interrupts masked: one core at a time,
//! whichever core asks. The lock is held for a few instructions per tile.
//!
//! The queue hands out each pass's tiles `0, 1, 2, ...` once each over both
//! cores, as `micropt::multicore::AtomicQueue` does; the image does not
//! depend on which core takes which tile.

use core::cell::Cell;
use critical_section::Mutex;
use micropt::multicore::{Pass, WorkQueue};

/// Counters of one render shared by `cores` cores: per pass, the next tile
/// and the cores that have finished it.
pub struct LockedQueue {
    cores: usize,
    next: Mutex<Cell<[usize; 2]>>,
    done: Mutex<Cell<[usize; 2]>>,
}

impl LockedQueue {
    /// A queue for `cores` cores (at least 1).
    pub const fn new(cores: usize) -> Self {
        Self {
            cores: if cores == 0 { 1 } else { cores },
            next: Mutex::new(Cell::new([0; 2])),
            done: Mutex::new(Cell::new([0; 2])),
        }
    }
}

/// Adds 1 to `counter[pass]` under the lock; returns the old value.
fn increment(counter: &Mutex<Cell<[usize; 2]>>, pass: Pass) -> usize {
    critical_section::with(|cs| {
        let c = counter.borrow(cs);
        let mut v = c.get();
        let old = v.get(pass.index()).copied().unwrap_or(0);
        if let Some(x) = v.get_mut(pass.index()) {
            *x = old.saturating_add(1);
        }
        c.set(v);
        old
    })
}

impl WorkQueue for LockedQueue {
    fn take(&self, pass: Pass) -> usize {
        increment(&self.next, pass)
    }

    fn done(&self, pass: Pass) {
        increment(&self.done, pass);
        // wake a core waiting in `idle`
        cortex_m::asm::sev();
    }

    fn all_done(&self, pass: Pass) -> bool {
        let done = critical_section::with(|cs| self.done.borrow(cs).get());
        done.get(pass.index()).is_some_and(|&d| d >= self.cores)
    }

    fn idle(&self) {
        cortex_m::asm::wfe();
    }
}
