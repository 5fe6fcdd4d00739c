//! The stack's high-water mark: the free stack is painted with a known
//! word at boot, and the mark is how far from the top the paint has been
//! written over. cortex-m-rt and esp-hal's linker scripts both name the
//! stack's top `_stack_start` and its lowest address `_stack_end`.
//!
//! Shared by the board crates in `examples/boards/` (`#[path]`).

/// What fills the unused stack at boot ([`paint`]).
const PAINT: u32 = 0x5354_4b21;

unsafe extern "C" {
    /// The stack's top.
    static _stack_start: u32;
    /// Its lowest address.
    static _stack_end: u32;
}

/// The stack's lowest address and its top.
pub fn bounds() -> (usize, usize) {
    (
        core::ptr::addr_of!(_stack_end) as usize,
        core::ptr::addr_of!(_stack_start) as usize,
    )
}

/// An address in the caller's frame: where the stack is now.
#[inline(always)]
fn here() -> usize {
    let marker = 0u32;
    core::ptr::addr_of!(marker) as usize
}

/// Fills the stack from `low` (word-aligned, at or above the stack's
/// lowest address; a guard below it is left alone) to 256 bytes below the
/// caller's frame with a known word, for [`high_water`]. Called first
/// thing in `main`.
#[inline(always)]
pub fn paint(low: usize) {
    let sp = here();
    let mut p = low.max(bounds().0);
    while p + 256 < sp {
        // SAFETY: between the end of static data (and its guard) and 256
        // bytes below the live frame is memory no one uses yet (no heap;
        // the stack grows down into it later); `p` is word-aligned
        unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// The stack's high-water mark and its size from `low` ([`paint`]'s), in
/// bytes: how much of the painted stack has been written, from the top.
/// (The raw frame's builds do not show it.)
#[cfg_attr(feature = "raw", allow(dead_code))]
pub fn high_water(low: usize) -> (usize, usize) {
    let top = bounds().1;
    let mut p = low.max(bounds().0);
    // SAFETY: reads of the stack's own words, between `low` and the top
    while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    (top - p, top - low)
}

/// The demo's note line: why the board last restarted (`reset`, if it
/// did) and the stack's high-water mark above `low` ([`high_water`]), for
/// example `reset: watchdog, stack 5120/52584 B`.
#[cfg_attr(feature = "raw", allow(dead_code))]
pub fn note(reset: &str, low: usize) -> heapless::String<48> {
    use core::fmt::Write;
    let mut note = heapless::String::new();
    let (used, size) = high_water(low);
    if !reset.is_empty() {
        let _ = write!(note, "{reset}, ");
    }
    let _ = write!(note, "stack {used}/{size} B");
    note
}
