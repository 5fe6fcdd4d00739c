//! micropt's demo on a Raspberry Pi Pico (RP2040, two Cortex-M0+ cores at
//! 125 MHz, no FPU) with a Pimoroni Pico Display Pack: the 1.14" 240×135
//! pack (feature `pack-114`, the default) or the 2.0" 320×240 pack
//! (`--no-default-features --features pack-20`: the image is rendered at
//! 160×120 and drawn at twice its size, since the RP2040's RAM holds the
//! denoiser's rings for 160 columns beside the scenes, not for 320).
//!
//! The demo (`micropt::demo`, docs/demo.md) on core 0: a block preview,
//! then passes at 1, 2, 4, … samples a pixel, each streamed through the
//! denoiser row by row to the panel; the buttons A (next scene), B
//! (exposure), X (orbit the camera), Y (raw or denoised; held: the status
//! line). Board code: `examples/board/display_pack.rs` (pins, SPI,
//! buttons, LED), `examples/board/pico.rs` (the demo loop, the watchdog,
//! the panic and restart records, the stack's high-water mark). Here:
//! the clocks, the RP2040's boot block, the MPU's stack guard and the hard
//! fault handler. With `--features raw` the example renders cornell's raw
//! frame on both cores instead, through the core's shared tile executor
//! (`queue.rs`: the M0+ has no atomic read-modify-write, so the queue
//! counts under the spinlock); that image is `micropt render
//! scenes/cornell.scene --size 240x135 --spp 16 --seed 0`.
//!
//! The M0+ has no FPU: every f32 add, subtract, multiply, divide, compare
//! and int-to-float conversion is micropt's correctly rounded routine
//! (`micropt::math::soft`, exported under the ARM EABI names by
//! `examples/board/softfloat.rs`; the HAL's `disable-intrinsics` feature
//! keeps it from installing the boot ROM's, which flush subnormals to zero
//! and so could change bits).
//!
//! Wiring: none, the Display Pack plugs onto the Pico's headers
//! (`examples/board/display_pack.rs` has the pins). Build and flash:
//! docs/boards.md.
#![no_std]
#![no_main]

// micropt's soft-float routines under the runtime's names (same bits as the
// host, about half the instructions of compiler-builtins' on Armv6-M)
#[path = "../../../board/softfloat.rs"]
mod softfloat;

#[path = "../../../board/display_pack.rs"]
mod display_pack;
#[cfg(all(feature = "pack-20", not(feature = "raw")))]
mod doubled;
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
#[cfg(feature = "raw")]
mod queue;
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
use rp2040_hal as hal;

/// The second-stage bootloader for the Pico's W25Q080 flash.
#[unsafe(link_section = ".boot2")]
#[used]
pub static BOOT2: [u8; 256] = rp2040_boot2::BOOT_LOADER_W25Q080;

/// The Pico's crystal.
const XTAL_HZ: u32 = 12_000_000;
/// The raw frame's budget: 16 samples per pixel on average. A sample
/// budget (`Spp` or `Paths`): the two-core executor refuses a deadline.
#[cfg(feature = "raw")]
const BUDGET: Budget = Budget::Spp(16);
/// Render seed.
const SEED: u64 = 0;

/// The demo's scenes (button A steps through them): the first 4 shipped.
#[cfg(not(feature = "raw"))]
const SCENES: &[Entry] = match SHIPPED.split_at_checked(4) {
    Some((first, _)) => first,
    None => &SHIPPED,
};
/// The shipped scenes left out, and why (logged at boot).
#[cfg(not(feature = "raw"))]
const LEFT_OUT: [(&str, &str); 1] = [(
    "many",
    "482 spheres: its scene (about 100 KB) does not fit beside the denoiser's rings (191 KB) in the RP2040's 264 KB",
)];

/// Core 0's stack guard: the MPU makes the 32 bytes at the stack's lowest
/// end ([`pico::stack_guard`]) inaccessible, so a stack that grows into
/// them faults instead of writing over static data (as the HAL guards core
/// 1's stack). On the M0+ that fault cannot push its frame into the guard
/// either, so the core locks up and the watchdog restarts the board
/// ("reset: watchdog" after the restart).
fn guard_stack(mpu: &mut cortex_m::peripheral::MPU) {
    let addr = pico::stack_guard() as u32;
    // one 256-byte region with only the guard's 32-byte subregion enabled
    let subregion_off = 0xff ^ (1 << ((addr >> 5) & 7));
    // SAFETY: the region covers only the guard (the other subregions are
    // disabled), below every live stack frame and above all static data;
    // PRIVDEFENA keeps the default map everywhere else
    unsafe {
        mpu.ctrl.write(0b101); // enable, with the default map as background
        mpu.rbar.write((addr & !0xff) | 0x10); // region 0, valid
        mpu.rasr.write(
            1 // enable
                | (7 << 1) // 2^(7 + 1) = 256 bytes
                | (subregion_off << 8)
                | 1 << 28, // no execution; AP = 0: no access
        );
    }
}

/// A hard fault (the MPU's stack guard included, when the core can still
/// push the frame): recorded, shown on the panel and over USB, then the
/// board restarts.
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    pico::restart(pico::Kind::Fault, frame.pc())
}

// 125 MHz from the 12 MHz crystal; SPI0 at 62.5 MHz, half the peripheral
// clock, the SPI's maximum; with the Display Pack 2.0 the demo renders
// 160×120, drawn doubled
pico_main! {
    board: "Raspberry Pi Pico",
    timer: hal::Timer = |pac, clocks| hal::Timer::new(pac.TIMER, &mut pac.RESETS, &clocks),
    usb: (USBCTRL_REGS, USBCTRL_DPRAM),
    clock_hz: 125_000_000,
    queue: queue::LockedQueue,
    memory: pico::DemoMemory<{ (WIDTH / SCALE) as usize }, 80, 8, 16>,
    scale: if cfg!(feature = "pack-20") { 2 } else { 1 },
    // soft float: 4 × 4 blocks, a sixteenth of pass 0 (about 0.7 s)
    preview_block: 4,
    target: |panel| {
        #[cfg(feature = "pack-20")]
        let panel = doubled::Doubled(panel);
        panel
    },
    guard: |core| guard_stack(&mut core.MPU),
}
