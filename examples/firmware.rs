//! The micropt core on a microcontroller, run in QEMU: Cortex-M0 to M33 and
//! RV32IMC (docs/firmware.md, "Targets"; by default a Cortex-M4F, QEMU's
//! STM32F405).
//!
//! Parses a scene file embedded at compile time with the core's parser (or,
//! without the core's `parser` feature, builds the Cornell box in code with
//! `SceneBuilder`), renders it with the core's single-core budget executor
//! (`micropt::budget::render_budget`: every tile's preview, sample 0 of one
//! pixel per 2×2 block, then every refined tile, with adaptive allocation as
//! the host CLI's default) into an embedded-graphics `Framebuffer<Rgb565>`
//! held in static memory, writes the framebuffer's big-endian Rgb565 bytes to
//! a host file through semihosting, prints a one-line summary and exits with
//! status 0 (1 on any error).
//!
//! ```text
//! cargo run --release --example firmware --features firmware --target thumbv7em-none-eabihf
//! ```
//!
//! The runner in `.cargo/config.toml` starts `qemu-system-arm -machine
//! netduinoplus2` (each target has its own runner there; the machine's
//! memory map comes from `build.rs`, `MICROPT_FW_MACHINE`). Scene, size, budget, allocation, skip switches, seed and
//! output file are compile-time choices (`MICROPT_FW_*` environment
//! variables, read by `build.rs`; see `docs/firmware.md`). With a sample
//! budget the dump is byte-identical to `micropt render SCENE --spp N --size
//! WxH --seed S -o out.rgb565` on the host (add `--uniform` for
//! `MICROPT_FW_UNIFORM=1`). The budget executor's clock is SysTick
//! (`examples/board/systick.rs`; on RISC-V the `time` counter,
//! `examples/board/mtime.rs`), which only a deadline budget reads for more
//! than the summary line.
//!
//! Before the render it checks that the core's `math::sqrt` (the FPU's
//! `vsqrt.f32` on eabihf targets, libm elsewhere) equals `libm::sqrtf` bit
//! for bit on a set of special and pseudo-random inputs; after it, it
//! reports the stack high-water mark found by scanning the stack's paint
//! pattern (cortex-m-rt's `paint-stack`; on RISC-V painted at the start of
//! `main`).
//!
//! A release build links with `panic-never`: it fails to link if any panic
//! path is left in the firmware, core included. Debug builds use
//! `panic-semihosting` (`panic-halt` on RISC-V).
#![no_std]
#![no_main]

#[cfg(all(debug_assertions, target_arch = "riscv32"))]
use panic_halt as _;
#[cfg(not(debug_assertions))]
use panic_never as _;
#[cfg(all(debug_assertions, target_arch = "arm"))]
use panic_semihosting as _;

use core::fmt::Write;
#[cfg(target_arch = "arm")]
use cortex_m_rt::entry;
#[cfg(target_arch = "arm")]
use cortex_m_semihosting::{debug, hio, nr, syscall};
use embedded_graphics::framebuffer::{Framebuffer, buffer_size};
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::pixelcolor::raw::{BigEndian, RawU16};
use micropt::budget::{Summary, TileAccum, render_budget};
use micropt::denoise::{self, Column, Moments};
use micropt::film::FromEncoded;
use micropt::{AdaptiveOptions, Budget, Options, Renderer, Scene, math};
#[cfg(target_arch = "riscv32")]
use riscv_semihosting::{debug, hio, nr, syscall};

#[cfg(target_arch = "arm")]
#[path = "board/systick.rs"]
mod systick;
#[cfg(target_arch = "arm")]
use systick::SysTickClock as BoardClock;

#[cfg(target_arch = "riscv32")]
#[path = "board/mtime.rs"]
mod mtime;

// without an FPU: the core's correctly rounded soft-float routines in place
// of the runtime's (same bits, fewer instructions)
#[cfg(any(
    all(target_arch = "arm", not(target_abi = "eabihf")),
    all(target_arch = "riscv32", not(target_feature = "f"))
))]
#[path = "board/softfloat.rs"]
mod softfloat;
#[cfg(target_arch = "riscv32")]
use mtime::MtimeClock as BoardClock;

/// The compile-time configuration written by `build.rs`.
mod config {
    include!(concat!(env!("OUT_DIR"), "/firmware_config.rs"));
}
use config::{HEIGHT, MAX_MATERIALS, MAX_PLANES, MAX_SPHERES, SEED, WIDTH};

/// The scene file chosen at compile time (`MICROPT_FW_SCENE`).
#[cfg(feature = "parser")]
const SCENE_TEXT: &str = include_str!(concat!(env!("OUT_DIR"), "/firmware.scene"));

/// Exposure of the tone mapping (the host CLI's default).
const EXPOSURE: f32 = 1.0;

/// The frequency of the clock the firmware reads, in QEMU: SysTick's core
/// clock (168 MHz on the STM32F405, as on the board at full speed), or the
/// RISC-V timer's timebase.
const CLOCK_HZ: u32 = config::CLOCK_HZ;

type FirmwareScene = Scene<MAX_SPHERES, MAX_PLANES, MAX_MATERIALS>;
type Fb =
    Framebuffer<Rgb565, RawU16, BigEndian, WIDTH, HEIGHT, { buffer_size::<Rgb565>(WIDTH, HEIGHT) }>;

/// Pixels of the whole-frame sample moments (none without the denoiser,
/// none for the demo's passes, which stream).
const MOMENT_PIXELS: usize = if config::DENOISE && !config::DEMO {
    WIDTH * HEIGHT
} else {
    0
};
/// Columns of the denoiser's rings (none without it).
const DENOISE_COLUMNS: usize = if config::DENOISE { WIDTH } else { 0 };

/// What `MICROPT_FW_DENOISE=1` adds to static RAM: every pixel's sample
/// moments and denoised colour (so that the render, the denoiser and the
/// tone mapping into the framebuffer are separate phases, each counted
/// between its marks), and the denoiser's rings of rows (one `Column` a
/// pixel of a row). A board that streams (renders each pixel as the rings
/// need it and tone-maps each output pixel straight to the panel:
/// `denoise::denoise_with`, `demo::render_pass`) keeps only the rings.
struct DenoiseMemory {
    moments: [Moments; MOMENT_PIXELS],
    colours: [micropt::Color; MOMENT_PIXELS],
    columns: [Column; DENOISE_COLUMNS],
}

impl DenoiseMemory {
    const EMPTY: Self = Self {
        moments: [Moments::ZERO; MOMENT_PIXELS],
        colours: [micropt::Color::ZERO; MOMENT_PIXELS],
        columns: [Column::EMPTY; DENOISE_COLUMNS],
    };
}

/// Everything that can go wrong, each reported on the host's stderr.
enum Error {
    Denoise(denoise::DenoiseError),
    Demo(micropt::demo::DemoError),
    #[cfg(feature = "parser")]
    Parse(micropt::parse::ParseError),
    #[cfg(not(feature = "parser"))]
    Scene(micropt::SceneError),
    Camera,
    #[cfg(target_arch = "arm")]
    Peripherals,
    SqrtMismatch {
        input: u32,
        fpu: u32,
        libm: u32,
    },
    Open,
    Write,
}

#[cfg(target_arch = "arm")]
#[entry]
fn main() -> ! {
    // Static memory, handed out once as `&'static mut` by cortex-m-rt's
    // `#[entry]` (no `unsafe`, no panicking singleton).
    static mut FRAMEBUFFER: Fb = Fb::new();
    static mut ACCUM: TileAccum = TileAccum::new();
    // `Scene::EMPTY` is all zeros: it goes to .bss (where an
    // `Option<Scene>::None`, a non-zero niche, would put the whole scene's
    // size in .data, and so in flash); the scene is parsed into it in place
    static mut SCENE: FirmwareScene = FirmwareScene::EMPTY;
    // the denoiser's memory (empty unless MICROPT_FW_DENOISE=1; all zeros,
    // so in .bss)
    static mut DENOISE: DenoiseMemory = DenoiseMemory::EMPTY;

    mark(); // start of main: reset handler, stack paint and RAM init done
    exit_with(run(FRAMEBUFFER, ACCUM, SCENE, DENOISE))
}

/// The entry point on RISC-V: riscv-rt's `#[entry]` does not hand out its
/// `static mut`s as `&'static mut` as cortex-m-rt's does, so the statics are
/// borrowed here, once.
#[cfg(target_arch = "riscv32")]
#[riscv_rt::entry]
fn main() -> ! {
    static mut FRAMEBUFFER: Fb = Fb::new();
    static mut ACCUM: TileAccum = TileAccum::new();
    static mut SCENE: FirmwareScene = FirmwareScene::EMPTY;
    static mut DENOISE: DenoiseMemory = DenoiseMemory::EMPTY;

    paint_stack();
    mark(); // start of main: reset handler, RAM init and stack paint done
    // SAFETY: `main` runs once and never returns, and nothing else names
    // these statics: each `&'static mut` is the only reference ever made.
    let (fb, acc, scene, dn) = unsafe {
        (
            &mut *core::ptr::addr_of_mut!(FRAMEBUFFER),
            &mut *core::ptr::addr_of_mut!(ACCUM),
            &mut *core::ptr::addr_of_mut!(SCENE),
            &mut *core::ptr::addr_of_mut!(DENOISE),
        )
    };
    exit_with(run(fb, acc, scene, dn))
}

/// Reports an error on the host's stderr, and exits QEMU through
/// semihosting with status 0 or 1.
#[inline(always)]
fn exit_with(result: Result<(), Error>) -> ! {
    let status = match result {
        Ok(()) => debug::EXIT_SUCCESS,
        Err(e) => {
            report(&e);
            debug::EXIT_FAILURE
        }
    };
    debug::exit(status);
    loop {
        #[cfg(target_arch = "arm")]
        cortex_m::asm::wfi();
        #[cfg(target_arch = "riscv32")]
        riscv::asm::wfi();
    }
}

/// The scene: parsed from the embedded file, in place into `slot`. (Not
/// inlined: the parser's stack is not live during the render.)
#[cfg(feature = "parser")]
#[inline(never)]
fn load_scene(slot: &'static mut FirmwareScene) -> Result<&'static FirmwareScene, Error> {
    micropt::parse::parse_into(SCENE_TEXT, slot).map_err(Error::Parse)?;
    force_tree(slot);
    Ok(slot)
}

/// The scene: `scenes/cornell.scene`, built in code (no parser in the
/// build), into `slot`. The numbers are the file's, so the image is the
/// same bits.
#[cfg(not(feature = "parser"))]
#[inline(never)]
fn load_scene(slot: &'static mut FirmwareScene) -> Result<&'static FirmwareScene, Error> {
    use micropt::{CameraSpec, Material, SceneBuilder, Vec3};
    let build = |slot: &mut FirmwareScene| -> Result<(), micropt::SceneError> {
        let mut b = SceneBuilder::<MAX_SPHERES, MAX_PLANES, MAX_MATERIALS>::new();
        b.camera(CameraSpec::pinhole(
            Vec3::new(0.5, 0.5, 0.98),
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            60.0,
        ))?;
        b.resolution(64, 64)?;
        let white = b.material(Material::Diffuse(Vec3::new(0.725, 0.71, 0.68)))?;
        let red = b.material(Material::Diffuse(Vec3::new(0.63, 0.065, 0.05)))?;
        let green = b.material(Material::Diffuse(Vec3::new(0.14, 0.45, 0.091)))?;
        let matte = b.material(Material::Diffuse(Vec3::new(0.8, 0.8, 0.8)))?;
        let chrome = b.material(Material::Mirror(Vec3::new(0.95, 0.95, 0.95)))?;
        let lamp = b.material(Material::Light(Vec3::new(20.0, 20.0, 20.0)))?;
        let v = Vec3::new;
        b.plane(v(0.0, 0.0, 0.0), v(0.0, 1.0, 0.0), white)?; // floor
        b.plane(v(0.0, 1.0, 0.0), v(0.0, -1.0, 0.0), white)?; // ceiling
        b.plane(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), white)?; // back wall
        b.plane(v(0.0, 0.0, 1.0), v(0.0, 0.0, -1.0), white)?; // front wall
        b.plane(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), red)?; // left wall
        b.plane(v(1.0, 0.0, 0.0), v(-1.0, 0.0, 0.0), green)?; // right wall
        b.sphere(v(0.5, 0.85, 0.4), 0.08, lamp)?;
        b.sphere(v(0.3, 0.2, 0.35), 0.2, chrome)?;
        b.sphere(v(0.72, 0.15, 0.6), 0.15, matte)?;
        b.build_into(slot)
    };
    build(slot).map_err(Error::Scene)?;
    force_tree(slot);
    Ok(slot)
}

/// With `MICROPT_FW_FORCE_BVH=1`, builds the bounding volume hierarchy of a
/// scene the analysis left without one (below its threshold), as the host
/// CLI's `--force-bvh`: to measure what the tree costs on a small scene.
/// Nothing otherwise (a constant false: no code).
#[inline(always)]
fn force_tree(slot: &mut FirmwareScene) {
    if config::FORCE_BVH && slot.bvh().is_empty() {
        slot.set_bvh(true);
    }
}

fn run(
    fb: &'static mut Fb,
    acc: &'static mut TileAccum,
    scene_slot: &'static mut FirmwareScene,
    dn: &'static mut DenoiseMemory,
) -> Result<(), Error> {
    check_fpu_sqrt()?;
    // the render's clock: SysTick on the core clock, or on RISC-V the
    // `time` counter at the machine's timebase
    #[cfg(target_arch = "arm")]
    let mut clock = match cortex_m::Peripherals::take() {
        Some(p) => BoardClock::start(p.SYST, CLOCK_HZ),
        None => return Err(Error::Peripherals),
    };
    #[cfg(target_arch = "riscv32")]
    let mut clock = BoardClock::start(CLOCK_HZ);
    mark(); // sqrt self-test done, clock started
    let scene = load_scene(scene_slot)?;
    let renderer = Renderer::new(scene, WIDTH as u32, HEIGHT as u32)
        .map_err(|_| Error::Camera)?
        .seed(SEED)
        .options(Options {
            // opaque to the optimiser: every MICROPT_FW_SKIP_OFF choice runs
            // the same machine code, as the host does with its run-time
            // options, so instruction counts differ only by the work skipped
            skip: core::hint::black_box(config::SKIP),
            ..Options::default()
        });
    let adaptive = AdaptiveOptions {
        adaptive: config::ADAPTIVE,
        ..AdaptiveOptions::default()
    };
    mark(); // scene loaded, camera set up

    let sum = if config::DEMO {
        // the demo's passes, each streamed into the framebuffer (a mark
        // after each)
        render_passes(&renderer, dn, fb, &mut clock)?
    } else if config::DENOISE {
        // every pixel's SPP samples into its moments, the denoiser, then
        // the tone mapping into the framebuffer (the marks: rendered,
        // denoised, tone-mapped)
        render_denoised(&renderer, dn, fb, &mut clock)?
    } else {
        // the framebuffer's error type is Infallible
        let Ok(sum) = render_budget(
            &renderer,
            config::BUDGET,
            &adaptive,
            acc,
            &mut clock,
            fb,
            EXPOSURE,
        );
        mark(); // image rendered into the framebuffer
        sum
    };

    dump(fb.data())?;
    mark(); // dump written

    summary(&sum, fb.data().len(), stack_high_water());
    Ok(())
}

/// Pixel (x, y) of a denoised or passes image into the framebuffer,
/// tone-mapped and dithered as the host's `.rgb565` output.
#[inline(always)]
fn put(fb: &mut Fb, x: u32, y: u32, c: micropt::Color) {
    let colour = Rgb565::from_encoded(micropt::film::tone_map(c, EXPOSURE), x, y);
    fb.set_pixel(
        embedded_graphics::prelude::Point::new(x as i32, y as i32),
        colour,
    );
}

/// `MICROPT_FW_PASSES=K`: the demo's passes 0 to K − 1 (pass k at `SPP ·
/// 2^k` samples in every pixel), each streamed into the framebuffer as the
/// demo streams it to a panel (`micropt::demo::render_pass`: raw, or
/// denoised with `MICROPT_FW_DENOISE=1`; no whole-frame moments), a mark
/// after each. The image after the last is bit-identical with `micropt
/// render SCENE --spp SPP --passes K [--denoise] --size WxH --seed S -o
/// out.rgb565`. (Not inlined: its stack is not live in the other paths.)
#[inline(never)]
// PASSES is a build setting, 0 (an empty range) in builds that never call
// this
#[allow(clippy::reversed_empty_ranges)]
fn render_passes(
    renderer: &Renderer<'_>,
    dn: &mut DenoiseMemory,
    fb: &mut Fb,
    clock: &mut BoardClock,
) -> Result<Summary, Error> {
    use micropt::budget::Clock;
    use micropt::demo::{pass_spp, render_pass};
    let start = clock.micros();
    let mut stats = micropt::Stats::default();
    let mut samples = 0u64;
    for k in 0..config::PASSES {
        let spp = pass_spp(config::SPP, k);
        render_pass(
            renderer,
            spp,
            !config::DENOISE,
            &mut dn.columns,
            |x, y| denoise::pixel_moments(renderer, spp, x, y, &mut stats),
            |y, x, c| put(fb, x, y, c),
            |_| true,
        )
        .map_err(Error::Demo)?;
        samples += (WIDTH * HEIGHT) as u64 * u64::from(spp);
        mark(); // pass k in the framebuffer
    }
    Ok(Summary {
        samples,
        stats,
        preview_micros: 0,
        total_micros: clock.micros().saturating_sub(start),
    })
}

/// `MICROPT_FW_DENOISE=1`: `SPP` samples of every pixel into its moments
/// (uniform: the denoiser's variance needs every pixel's samples), the
/// `rendered` mark, the core's denoiser into every pixel's colour, the
/// `denoised` mark, the tone mapping into the framebuffer (the output
/// stage a raw frame runs too), the `tone-mapped` mark. The image is
/// bit-identical with `micropt render SCENE --spp N --size WxH --seed S
/// --denoise -o out.rgb565`. (Not inlined:
/// its stack is not live in the other path.)
#[inline(never)]
fn render_denoised(
    renderer: &Renderer<'_>,
    dn: &mut DenoiseMemory,
    fb: &mut Fb,
    clock: &mut BoardClock,
) -> Result<Summary, Error> {
    use micropt::budget::Clock;
    let start = clock.micros();
    let mut stats = micropt::Stats::default();
    // the loop of denoise::pixel_moments written out: called here, it
    // shifts the compiler's inlining in this function and moves 2 % of
    // the instructions between the two phases the marks count
    for (i, m) in dn.moments.iter_mut().enumerate() {
        let (x, y) = ((i % WIDTH) as u32, (i / WIDTH) as u32);
        let pixel = renderer.pixel(x, y);
        for k in 0..config::SPP {
            m.add(
                renderer.sample_parts_in(&pixel, x, y, k, &mut stats),
                k < config::SPP / 2,
            );
        }
    }
    mark(); // every pixel's samples in its moments
    let colours = &mut dn.colours;
    denoise::denoise_moments(
        renderer,
        &dn.moments,
        config::SPP,
        &mut dn.columns,
        |_, _, _| {},
        |y, x, c| {
            if let Some(slot) = colours.get_mut(y as usize * WIDTH + x as usize) {
                *slot = c;
            }
        },
    )
    .map_err(Error::Denoise)?;
    mark(); // denoised: every pixel's colour
    // the output stage a raw frame runs too (tone mapping, dithering,
    // RGB565 into the framebuffer), counted apart from the denoiser
    for (i, &c) in dn.colours.iter().enumerate() {
        put(fb, (i % WIDTH) as u32, (i / WIDTH) as u32, c);
    }
    mark(); // tone-mapped into the framebuffer
    Ok(Summary {
        samples: (WIDTH * HEIGHT) as u64 * u64::from(config::SPP),
        stats,
        preview_micros: 0,
        total_micros: clock.micros().saturating_sub(start),
    })
}

/// Prints the one-line summary. (Not inlined: its formatting stack is not
/// live during the render.) Strings go out with `write_str`, numbers with
/// `{}`: a `{}` of a `&str` would link the formatter's padding code into
/// the flash (docs/firmware.md).
#[inline(never)]
fn summary(sum: &Summary, bytes: usize, stack: usize) {
    let mut out = HostOut::stdout();
    let o = &mut out;
    let _ = o.write_str("micropt firmware: ");
    let _ = o.write_str(config::SCENE_NAME);
    let _ = write!(o, " {WIDTH}x{HEIGHT} ");
    let _ = match config::BUDGET {
        Budget::Deadline(us) => write!(o, "deadline {} ms", us / 1000),
        Budget::Paths(p) => write!(o, "paths {p}"),
        Budget::Spp(n) => write!(o, "spp {n}"),
    };
    if config::DEMO {
        let _ = write!(o, " {} demo passes", config::PASSES);
    }
    let _ = o.write_str(if config::DENOISE {
        " uniform denoised skip "
    } else if config::DEMO {
        " uniform raw skip "
    } else if config::ADAPTIVE {
        " adaptive skip "
    } else {
        " uniform skip "
    });
    let _ = o.write_str(config::SKIP_LABEL);
    let _ = write!(
        o,
        " seed {SEED}: {} samples, {} paths, {} bounce rays, {} shadow rays, {} non-finite; ",
        sum.samples,
        sum.stats.paths,
        sum.stats.bounce_rays,
        sum.stats.shadow_rays,
        sum.stats.nonfinite,
    );
    // SysTick time: deterministic under QEMU's `-icount` (the runner's
    // `shift=0` makes it the instruction count / 1000), not on a board
    let _ = write!(
        o,
        "preview {} us, total {} us; ",
        sum.preview_micros, sum.total_micros
    );
    let _ = o.write_str("wrote ");
    let _ = o.write_str(output_name());
    let _ = writeln!(o, " ({bytes} bytes); stack high-water {stack} bytes");
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

/// The core's square root (`math::sqrt`: the FPU's on eabihf targets, libm's
/// on the others) against libm's software `sqrtf`, bit for bit: zeros, subnormals, powers of two, perfect squares,
/// huge values, infinity, negative numbers and a pseudo-random sweep over all
/// positive floats. NaN results must both be NaN (their payloads may differ).
#[inline(never)]
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

/// The stack's paint pattern (cortex-m-rt's `paint-stack`).
const STACK_PAINT: u32 = 0xcccc_cccc;

/// The bottom and the top (one past the end) of the stack: cortex-m-rt's
/// `_stack_end` and `_stack_start`, or riscv-rt's `__estack` and
/// `_stack_start`.
fn stack_bounds() -> (usize, usize) {
    #[cfg(target_arch = "arm")]
    unsafe extern "C" {
        static _stack_end: u32;
    }
    #[cfg(target_arch = "riscv32")]
    unsafe extern "C" {
        #[link_name = "__estack"]
        static _stack_end: u32;
    }
    unsafe extern "C" {
        static _stack_start: u32;
    }
    (
        (&raw const _stack_end) as usize,
        (&raw const _stack_start) as usize,
    )
}

/// Fills the stack below the current stack pointer with [`STACK_PAINT`], as
/// cortex-m-rt's `paint-stack` does before `main` (riscv-rt has no such
/// option). What `main` and the reset code used above it counts as used.
#[cfg(target_arch = "riscv32")]
#[inline(always)]
fn paint_stack() {
    let sp: usize;
    // SAFETY: reads the stack pointer into a register, nothing else.
    unsafe { core::arch::asm!("mv {}, sp", out(reg) sp, options(nomem, nostack)) };
    let (mut p, _) = stack_bounds();
    while p < sp {
        // SAFETY: the words from the stack's bottom up to the stack pointer
        // belong to the stack and are not in use (the stack grows down, and
        // the RISC-V ABI has no red zone below the stack pointer).
        unsafe { core::ptr::write_volatile(p as *mut u32, STACK_PAINT) };
        p += 4;
    }
}

/// What `math::sqrt` is on this target, for the self-test's error message
/// (a literal, so that the message stays one format string).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
macro_rules! sqrt_name {
    () => {
        "vsqrt.f32"
    };
}
#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
macro_rules! sqrt_name {
    () => {
        "math::sqrt"
    };
}

/// Bytes of stack ever used: the stack was filled with [`STACK_PAINT`] before
/// `main` (or at its start); the lowest overwritten word is the high-water
/// mark.
fn stack_high_water() -> usize {
    let (mut p, top) = stack_bounds();
    while p < top {
        // SAFETY: every word between cortex-m-rt's `_stack_end` and
        // `_stack_start` is RAM that belongs to the stack; reading it is
        // always defined (volatile, so the compiler cannot assume its value).
        let word = unsafe { core::ptr::read_volatile(p as *const u32) };
        if word != STACK_PAINT {
            break;
        }
        p += 4;
    }
    top - p
}

/// Marks a phase boundary for `tools/qemu-icount`: a `yield` hint, which the
/// compiler never emits by itself, and which the plugin counts up to. A no-op
/// for the CPU.
#[cfg(target_arch = "arm")]
#[inline(always)]
fn mark() {
    // SAFETY: `yield` is a hint instruction with no effect on registers or
    // memory on a single-core Cortex-M.
    unsafe { core::arch::asm!("yield", options(nomem, nostack, preserves_flags)) };
}

/// Marks a phase boundary for `tools/qemu-icount` on RISC-V: `slti x0, x0,
/// 0x7ad`, a HINT (a write to `x0`) that the base ISA reserves for custom use
/// and the compiler never emits; the plugin counts up to it. A no-op for the
/// CPU.
#[cfg(target_arch = "riscv32")]
#[inline(always)]
fn mark() {
    // SAFETY: an instruction whose only destination is x0 changes no
    // register and no memory.
    unsafe {
        core::arch::asm!(
            "slti x0, x0, 0x7ad",
            options(nomem, nostack, preserves_flags)
        )
    };
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
    let o = &mut err;
    // strings with `write_str` (see `summary`)
    let _ = o.write_str("micropt firmware: ");
    let _ = match e {
        #[cfg(feature = "parser")]
        Error::Parse(p) => {
            let _ = o.write_str(config::SCENE_NAME);
            writeln!(o, ": {p}")
        }
        #[cfg(not(feature = "parser"))]
        Error::Scene(e) => writeln!(o, "the scene built in code: {e}"),
        Error::Denoise(e) => writeln!(o, "denoiser: {e}"),
        Error::Demo(e) => writeln!(o, "demo pass: {e}"),
        Error::Camera => o.write_str("invalid camera for the image size\n"),
        #[cfg(target_arch = "arm")]
        Error::Peripherals => o.write_str("core peripherals already taken\n"),
        Error::SqrtMismatch { input, fpu, libm } => writeln!(
            o,
            concat!(
                sqrt_name!(),
                " differs from libm::sqrtf: sqrt({:#010x}) = {:#010x}, libm {:#010x}"
            ),
            input, fpu, libm
        ),
        Error::Open => {
            let _ = o.write_str("cannot open host file ");
            let _ = o.write_str(output_name());
            o.write_str(" for writing (is semihosting enabled?)\n")
        }
        Error::Write => {
            let _ = o.write_str("writing ");
            let _ = o.write_str(output_name());
            o.write_str(" failed\n")
        }
    };
}
