//! micropt's demo on a Raspberry Pi Pico 2 (RP2350, two Cortex-M33 cores
//! with FPUs at 150 MHz) with a Pimoroni Pico Display Pack: the 2.0"
//! 320×240 pack (feature `pack-20`, the default) or the 1.14" 240×135
//! pack (`--no-default-features --features pack-114`).
//!
//! The demo (`micropt::demo`, docs/demo.md) on core 0: a block preview,
//! then passes at 1, 2, 4, … samples a pixel, each streamed through the
//! denoiser row by row to the panel; the buttons A (next scene), B
//! (exposure), X (orbit the camera), Y (raw or denoised; held: the status
//! line). Board code: `examples/board/display_pack.rs` (pins, SPI,
//! buttons, LED), `examples/board/pico.rs` (the demo loop, the watchdog,
//! the panic and restart records, the stack's high-water mark). Here:
//! the clocks, the RP2350's image definition, the MSPLIM stack limit and
//! the hard fault handler. With `--features raw` the example renders
//! cornell's raw frame on both cores instead, through the core's shared
//! tile executor (each core taking the next tile from one queue of atomic
//! counters); that image is `micropt render scenes/cornell.scene --size
//! 320x240 --spp 16 --seed 0`. The FPUs do the f32 arithmetic (no float
//! routine is linked for it).
//!
//! Wiring: none, the Display Pack plugs onto the Pico 2's headers
//! (`examples/board/display_pack.rs` has the pins). Build and flash:
//! docs/boards.md.
#![no_std]
#![no_main]

#[path = "../../../board/display_pack.rs"]
mod display_pack;
#[path = "../../../board/locked_panel.rs"]
mod locked_panel;
#[path = "../../../board/panic_screen.rs"]
mod panic_screen;
#[macro_use]
#[path = "../../../board/pico.rs"]
mod pico;
#[cfg(feature = "raw")]
#[path = "../../../board/progress.rs"]
mod progress;
#[path = "../../../board/stack.rs"]
mod stack;
#[cfg(not(feature = "raw"))]
#[path = "../../../board/two_cores.rs"]
mod two_cores;
#[path = "../../../board/usb_serial.rs"]
mod usb_serial;

use defmt_rtt as _;

#[cfg(feature = "raw")]
use micropt::Budget;
#[cfg(not(feature = "raw"))]
use micropt::demo::{Entry, SCENES as SHIPPED};
use rp235x_hal as hal;

/// Tells the boot ROM that this is an Arm executable (in the first 4 KiB
/// of flash: memory.x).
#[unsafe(link_section = ".start_block")]
#[used]
pub static IMAGE_DEF: hal::block::ImageDef = hal::block::ImageDef::secure_exe();

/// The Pico 2's crystal.
const XTAL_HZ: u32 = 12_000_000;
/// The raw frame's budget: 16 samples per pixel on average. A sample
/// budget (`Spp` or `Paths`): the two-core executor refuses a deadline.
#[cfg(feature = "raw")]
const BUDGET: Budget = Budget::Spp(16);
/// Render seed.
const SEED: u64 = 0;

/// The demo's scenes (button A steps through them): every shipped one.
#[cfg(not(feature = "raw"))]
const SCENES: &[Entry] = &SHIPPED;
/// The shipped scenes left out: none.
#[cfg(not(feature = "raw"))]
const LEFT_OUT: [(&str, &str); 0] = [];

/// Core 0's stack limit: MSPLIM at the end of the stack's guard
/// ([`pico::stack_guard`]), so a push below it raises a stack-overflow
/// fault (escalated to a hard fault), and CCR.STKOFHFNMIGN lets the hard
/// fault handler run below the limit, within the guard's 32 bytes (as the
/// HAL limits core 1's stack).
fn guard_stack(scb: &mut cortex_m::peripheral::SCB) {
    let limit = (pico::stack_guard() + pico::GUARD) as u32;
    // SAFETY: the limit is below every live stack frame (the stack has
    // barely begun: main's first lines) and above all static data
    unsafe {
        cortex_m::register::msplim::write(limit);
        scb.ccr.modify(|v| v | 1 << 10);
    }
}

/// A hard fault: a stack overflow (CFSR's STKOF: recorded, then the board
/// restarts at once) or another fault (recorded, shown on the panel and
/// over USB, then the board restarts).
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    // SAFETY: a read of the fault status register
    let cfsr = unsafe { (*cortex_m::peripheral::SCB::PTR).cfsr.read() };
    let kind = if cfsr & 1 << 20 != 0 {
        pico::Kind::StackOverflow
    } else {
        pico::Kind::Fault
    };
    pico::restart(kind, frame.pc())
}

// 150 MHz from the 12 MHz crystal; SPI0 at 37.5 MHz, a quarter of the
// peripheral clock (the next step, 75 MHz, is above the ST7789's 62.5 MHz)
pico_main! {
    board: "Raspberry Pi Pico 2",
    timer: hal::Timer<hal::timer::CopyableTimer0> =
        |pac, clocks| hal::Timer::new_timer0(pac.TIMER0, &mut pac.RESETS, &clocks),
    usb: (USB, USB_DPRAM),
    clock_hz: 150_000_000,
    queue: micropt::multicore::AtomicQueue,
    memory: pico::DemoMemory<{ WIDTH as usize }, 512, 8, 32>,
    scale: 1,
    // 2 × 2 blocks, a quarter of pass 0 (about 0.3 s at 320×240)
    preview_block: 2,
    target: |panel| panel,
    guard: |core| guard_stack(&mut core.SCB),
}
