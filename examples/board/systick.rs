//! A [`micropt::Clock`] from the Cortex-M SysTick timer, shared by the
//! firmware examples (`#[path]` module).
//!
//! SysTick counts processor clock cycles down from 2²⁴ − 1; its exception
//! (once per 2²⁴ cycles, 0.1 s at 168 MHz: a dozen instructions each time)
//! counts the wraps, so the clock runs for 2⁵⁶ cycles without ambiguity, and
//! whoever reads it need not read it often. On the board it is exact to a
//! cycle. In QEMU the SysTick runs on QEMU's virtual clock: host time unless
//! QEMU runs with `-icount shift=N` (2^N virtual nanoseconds per
//! instruction), which makes it — and a deadline budget — deterministic.

use core::num::NonZeroU64;
use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::exception;

/// SysTick reload value: the largest (24 bits).
const RELOAD: u32 = 0x00ff_ffff;

/// Wraps of the SysTick counter since [`SysTickClock::start`].
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    count_wrap();
}

/// One more wrap. The exception is the only writer once the clock runs.
#[cfg(target_has_atomic = "32")]
#[inline(always)]
fn count_wrap() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// One more wrap, on cores without atomic read-modify-write (ARMv6-M): a load
/// and a store, which is enough because the exception is the only writer once
/// the clock runs (`start` writes before it enables the exception) and
/// cannot interrupt itself.
#[cfg(not(target_has_atomic = "32"))]
#[inline(always)]
fn count_wrap() {
    WRAPS.store(
        WRAPS.load(Ordering::Relaxed).wrapping_add(1),
        Ordering::Relaxed,
    );
}

/// Microseconds from SysTick at a known core clock.
pub struct SysTickClock {
    /// Core clock cycles per microsecond.
    cycles_per_us: NonZeroU64,
    _syst: SYST,
}

impl SysTickClock {
    /// Starts SysTick on the core clock (`core_hz`, a multiple of 1 MHz),
    /// free-running, with its wrap exception enabled.
    pub fn start(mut syst: SYST, core_hz: u32) -> Self {
        syst.disable_counter();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(RELOAD);
        syst.clear_current();
        WRAPS.store(0, Ordering::Relaxed);
        syst.enable_interrupt();
        syst.enable_counter();
        Self {
            cycles_per_us: NonZeroU64::new(u64::from(core_hz / 1_000_000))
                .unwrap_or(NonZeroU64::MIN),
            _syst: syst,
        }
    }

    /// Core clock cycles since [`SysTickClock::start`].
    pub fn cycles(&self) -> u64 {
        loop {
            // a wrap between the two loads of WRAPS is taken (the exception
            // runs at once) and seen as a change: read again
            let before = WRAPS.load(Ordering::Relaxed);
            let current = SYST::get_current();
            if WRAPS.load(Ordering::Relaxed) == before {
                return u64::from(before) * u64::from(RELOAD + 1) + u64::from(RELOAD - current);
            }
        }
    }
}

impl micropt::Clock for SysTickClock {
    fn micros(&mut self) -> u64 {
        self.cycles() / self.cycles_per_us
    }
}
