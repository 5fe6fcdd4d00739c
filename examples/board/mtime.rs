//! A [`micropt::Clock`] from the RISC-V `time` counter, for the RISC-V
//! firmware (`#[path]` module).
//!
//! `time` (CSRs `time`/`timeh`) is the machine timer's `mtime` (the CLINT's
//! on QEMU's `virt`, counting at a 10 MHz timebase on QEMU's virtual clock),
//! 64 bits, so it never wraps in practice; under `-icount shift=0` it
//! advances one tick per 100 instructions, which makes it — and a deadline
//! budget — deterministic. (An ESP32-C3 has no `time` CSR: a board would
//! read its SYSTIMER instead.)

use core::num::NonZeroU64;

/// Microseconds from the `time` counter at a known timebase.
pub struct MtimeClock {
    /// Timer ticks per microsecond.
    ticks_per_us: NonZeroU64,
    /// The counter at [`MtimeClock::start`].
    start: u64,
}

impl MtimeClock {
    /// Starts counting from now; `timebase_hz` (a multiple of 1 MHz) is the
    /// timer's frequency.
    pub fn start(timebase_hz: u32) -> Self {
        Self {
            ticks_per_us: NonZeroU64::new(u64::from(timebase_hz / 1_000_000))
                .unwrap_or(NonZeroU64::MIN),
            start: riscv::register::time::read64(),
        }
    }
}

impl micropt::Clock for MtimeClock {
    fn micros(&mut self) -> u64 {
        riscv::register::time::read64().wrapping_sub(self.start) / self.ticks_per_us
    }
}
