//! The micropt core on a Cortex-M4F (STM32F405), run in QEMU.
//!
//! Parses a scene file embedded at compile time with the core's parser,
//! renders it tile by tile into an embedded-graphics `Framebuffer<Rgb565>`
//! held in static memory, writes the framebuffer's big-endian Rgb565 bytes to
//! a host file through semihosting, prints a one-line summary and exits with
//! status 0 (1 on any error).
//!
//! ```text
//! cargo run --release --example firmware --features firmware --target thumbv7em-none-eabihf
//! ```
//!
//! The runner in `.cargo/config.toml` starts `qemu-system-arm -machine
//! netduinoplus2`. Scene, size, samples per pixel, seed and output file are
//! compile-time choices (`MICROPT_FW_*` environment variables, read by
//! `build.rs`; see `docs/firmware.md`). The dump is byte-identical to
//! `micropt render SCENE --spp N --size WxH --seed S -o out.rgb565` on the host.
//!
//! Before the render it checks that the FPU's `vsqrt.f32` (the core's
//! `math::sqrt` on this target) equals `libm::sqrtf` bit for bit on a set of
//! special and pseudo-random inputs; after it, it reports the stack
//! high-water mark found by scanning cortex-m-rt's `paint-stack` pattern.
//!
//! A release build links with `panic-never`: it fails to link if any panic
//! path is left in the firmware, core included. Debug builds use
//! `panic-semihosting`.
#![no_std]
#![no_main]

#[cfg(not(debug_assertions))]
use panic_never as _;
#[cfg(debug_assertions)]
use panic_semihosting as _;

use core::fmt::Write;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hio, nr, syscall};
use embedded_graphics::framebuffer::{Framebuffer, buffer_size};
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::pixelcolor::raw::{BigEndian, RawU16};
use micropt::film::{TILE, draw_tile, tiles};
use micropt::parse::ParseError;
use micropt::{Color, Renderer, Scene, Stats, math};

/// The compile-time configuration written by `build.rs`.
mod config {
    include!(concat!(env!("OUT_DIR"), "/firmware_config.rs"));
}
use config::{HEIGHT, MAX_MATERIALS, MAX_PLANES, MAX_SPHERES, SEED, SPP, WIDTH};

/// The scene file chosen at compile time (`MICROPT_FW_SCENE`).
const SCENE_TEXT: &str = include_str!(concat!(env!("OUT_DIR"), "/firmware.scene"));

/// Exposure of the tone mapping (the host CLI's default).
const EXPOSURE: f32 = 1.0;

type FirmwareScene = Scene<MAX_SPHERES, MAX_PLANES, MAX_MATERIALS>;
type Fb =
    Framebuffer<Rgb565, RawU16, BigEndian, WIDTH, HEIGHT, { buffer_size::<Rgb565>(WIDTH, HEIGHT) }>;

/// Everything that can go wrong, each reported on the host's stderr.
enum Error {
    Parse(ParseError),
    Camera,
    SqrtMismatch { input: u32, fpu: u32, libm: u32 },
    Open,
    Write,
}

#[entry]
fn main() -> ! {
    // Static memory, handed out once as `&'static mut` by cortex-m-rt's
    // `#[entry]` (no `unsafe`, no panicking singleton).
    static mut FRAMEBUFFER: Fb = Fb::new();
    static mut TILE_PIXELS: [Color; (TILE * TILE) as usize] = [Color::ZERO; (TILE * TILE) as usize];
    static mut SCENE: Option<FirmwareScene> = None;

    mark(); // start of main: reset handler, stack paint and RAM init done
    let status = match run(FRAMEBUFFER, TILE_PIXELS, SCENE) {
        Ok(()) => debug::EXIT_SUCCESS,
        Err(e) => {
            report(&e);
            debug::EXIT_FAILURE
        }
    };
    debug::exit(status);
    loop {
        cortex_m::asm::wfi();
    }
}

fn run(
    fb: &'static mut Fb,
    tile_px: &'static mut [Color; (TILE * TILE) as usize],
    scene_slot: &'static mut Option<FirmwareScene>,
) -> Result<(), Error> {
    check_fpu_sqrt()?;
    mark(); // sqrt self-test done
    let scene = scene_slot.insert(
        micropt::parse::parse_with_capacity::<MAX_SPHERES, MAX_PLANES, MAX_MATERIALS>(SCENE_TEXT)
            .map_err(Error::Parse)?,
    );
    let renderer = Renderer::new(scene, WIDTH as u32, HEIGHT as u32)
        .map_err(|_| Error::Camera)?
        .seed(SEED);
    mark(); // scene parsed, camera set up

    let mut stats = Stats::default();
    for tile in tiles(WIDTH as u32, HEIGHT as u32) {
        renderer.render_tile(&tile, SPP, tile_px, &mut stats);
        // the framebuffer's error type is Infallible
        let _ = draw_tile(fb, &tile, tile_px, EXPOSURE);
    }
    mark(); // image rendered into the framebuffer

    dump(fb.data())?;
    mark(); // dump written

    let stack = stack_high_water();
    let mut out = HostOut::stdout();
    let _ = writeln!(
        out,
        "micropt firmware: {} {}x{} spp {} seed {}: {} paths, {} bounce rays, {} shadow rays, \
         {} non-finite; wrote {} ({} bytes); stack high-water {} bytes",
        config::SCENE_NAME,
        WIDTH,
        HEIGHT,
        SPP,
        SEED,
        stats.paths,
        stats.bounce_rays,
        stats.shadow_rays,
        stats.nonfinite,
        output_name(),
        fb.data().len(),
        stack,
    );
    Ok(())
}

/// The host file name without its terminating NUL.
fn output_name() -> &'static str {
    config::OUTPUT.trim_end_matches('\0')
}

/// Writes `bytes` to the host file `config::OUTPUT` (semihosting
/// OPEN "wb" / WRITE / CLOSE).
fn dump(bytes: &[u8]) -> Result<(), Error> {
    let name = config::OUTPUT;
    // SAFETY: OPEN takes a NUL-terminated name, a mode and the name's length
    // without the NUL; `name` ends with the NUL build.rs appends and lives
    // for the whole call.
    let fd = unsafe {
        syscall!(
            OPEN,
            name.as_ptr(),
            nr::open::W_TRUNC_BINARY,
            name.len().saturating_sub(1)
        )
    };
    if fd as isize == -1 {
        return Err(Error::Open);
    }
    // SAFETY: WRITE reads `len` bytes from the pointer, which `bytes` owns;
    // it returns the number of bytes *not* written.
    let left = unsafe { syscall!(WRITE, fd, bytes.as_ptr(), bytes.len()) };
    // SAFETY: CLOSE takes the handle OPEN returned.
    let closed = unsafe { syscall!(CLOSE, fd) };
    if left != 0 || closed != 0 {
        return Err(Error::Write);
    }
    Ok(())
}

/// The FPU square root (`math::sqrt` on this target) against libm's software
/// `sqrtf`, bit for bit: zeros, subnormals, powers of two, perfect squares,
/// huge values, infinity, negative numbers and a pseudo-random sweep over all
/// positive floats. NaN results must both be NaN (their payloads may differ).
fn check_fpu_sqrt() -> Result<(), Error> {
    let specials = [
        0x0000_0000u32, // +0
        0x8000_0000,    // -0
        0x0000_0001,    // smallest subnormal
        0x007f_ffff,    // largest subnormal
        0x0080_0000,    // smallest normal
        0x3f80_0000,    // 1
        0x4000_0000,    // 2
        0x4080_0000,    // 4
        0x4110_0000,    // 9
        0x3f80_0001,    // 1 + ulp
        0x3f7f_ffff,    // 1 - ulp
        0x7f7f_ffff,    // largest finite
        0x7f80_0000,    // +inf
        0xbf80_0000,    // -1
        0x7fc0_0000,    // NaN
    ];
    let mut state = 0x2545_f491u32;
    let random = (0..4096).map(move |_| {
        // xorshift32, restricted to non-negative floats
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state & 0x7fff_ffff
    });
    for input in specials.into_iter().chain(random) {
        let x = f32::from_bits(input);
        let (fpu, soft) = (math::sqrt(x), libm::sqrtf(x));
        let same = fpu.to_bits() == soft.to_bits() || (fpu.is_nan() && soft.is_nan());
        if !same {
            return Err(Error::SqrtMismatch {
                input,
                fpu: fpu.to_bits(),
                libm: soft.to_bits(),
            });
        }
    }
    Ok(())
}

/// Bytes of stack ever used: cortex-m-rt's `paint-stack` fills the stack with
/// `0xcccc_cccc` before `main`; the lowest overwritten word is the high-water
/// mark.
fn stack_high_water() -> usize {
    unsafe extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }
    let top = (&raw const _stack_start) as usize;
    let mut p = (&raw const _stack_end) as usize;
    while p < top {
        // SAFETY: every word between cortex-m-rt's `_stack_end` and
        // `_stack_start` is RAM that belongs to the stack; reading it is
        // always defined (volatile, so the compiler cannot assume its value).
        let word = unsafe { core::ptr::read_volatile(p as *const u32) };
        if word != 0xcccc_cccc {
            break;
        }
        p += 4;
    }
    top - p
}

/// Marks a phase boundary for `tools/qemu-icount`: a `yield` hint, which the
/// compiler never emits by itself, and which the plugin counts up to. A no-op
/// for the CPU.
#[inline(always)]
fn mark() {
    // SAFETY: `yield` is a hint instruction with no effect on registers or
    // memory on a single-core Cortex-M.
    unsafe { core::arch::asm!("yield", options(nomem, nostack, preserves_flags)) };
}

/// The host's stdout or stderr; output errors are ignored (there is nowhere
/// else to report them).
struct HostOut(Option<hio::HostStream>);

impl HostOut {
    fn stdout() -> Self {
        Self(hio::hstdout().ok())
    }
    fn stderr() -> Self {
        Self(hio::hstderr().ok())
    }
}

impl Write for HostOut {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        if let Some(h) = self.0.as_mut() {
            let _ = h.write_all(s.as_bytes());
        }
        Ok(())
    }
}

fn report(e: &Error) {
    let mut err = HostOut::stderr();
    let _ = match e {
        Error::Parse(p) => writeln!(err, "micropt firmware: {}: {p}", config::SCENE_NAME),
        Error::Camera => writeln!(err, "micropt firmware: invalid camera for the image size"),
        Error::SqrtMismatch { input, fpu, libm } => writeln!(
            err,
            "micropt firmware: vsqrt.f32 differs from libm::sqrtf: sqrt({input:#010x}) = {fpu:#010x}, libm {libm:#010x}"
        ),
        Error::Open => writeln!(
            err,
            "micropt firmware: cannot open host file {} for writing (is semihosting enabled?)",
            output_name()
        ),
        Error::Write => writeln!(err, "micropt firmware: writing {} failed", output_name()),
    };
}
