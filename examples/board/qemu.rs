//! What the QEMU firmware examples share (`#[path]` module): semihosting
//! output and host files, the phase marks that `tools/qemu-icount` counts
//! up to, the stack high-water scan, and the FPU square-root self-test.

use core::fmt::Write;
use cortex_m_semihosting::{hio, nr, syscall};
use micropt::math;

/// The host's stdout or stderr; output errors are ignored (there is nowhere
/// else to report them).
pub struct HostOut(Option<hio::HostStream>);

impl HostOut {
    pub fn stdout() -> Self {
        Self(hio::hstdout().ok())
    }
    pub fn stderr() -> Self {
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

/// A host file opened for writing through semihosting.
pub struct HostFile(usize);

impl HostFile {
    /// Creates (truncates) the host file `name`, which must end with a NUL
    /// (semihosting OPEN "wb"); `None` if the host refuses.
    pub fn create(name: &str) -> Option<Self> {
        if !name.ends_with('\0') {
            return None;
        }
        // SAFETY: OPEN takes a NUL-terminated name, a mode and the name's
        // length without the NUL; `name` ends with a NUL (checked above) and
        // lives for the whole call.
        let fd = unsafe {
            syscall!(
                OPEN,
                name.as_ptr(),
                nr::open::W_TRUNC_BINARY,
                name.len() - 1
            )
        };
        (fd as isize != -1).then_some(Self(fd))
    }

    /// Writes all of `bytes`; false if the host wrote fewer.
    pub fn write(&mut self, bytes: &[u8]) -> bool {
        // SAFETY: WRITE reads `len` bytes from the pointer, which `bytes`
        // owns; it returns the number of bytes *not* written.
        let left = unsafe { syscall!(WRITE, self.0, bytes.as_ptr(), bytes.len()) };
        left == 0
    }

    /// Closes the file; false if the host reports an error.
    pub fn close(self) -> bool {
        // SAFETY: CLOSE takes the handle OPEN returned.
        (unsafe { syscall!(CLOSE, self.0) }) == 0
    }
}

/// Marks a phase boundary for `tools/qemu-icount`: a `yield` hint, which the
/// compiler never emits by itself, and which the plugin counts up to. A no-op
/// for the CPU (QEMU ends the translation block there, and on a machine of
/// several cores may run another one next).
#[inline(always)]
pub fn mark() {
    // SAFETY: `yield` is a hint instruction with no effect on registers or
    // memory.
    unsafe { core::arch::asm!("yield", options(nomem, nostack, preserves_flags)) };
}

/// The value cortex-m-rt's `paint-stack` fills the stack with.
pub const STACK_PAINT: u32 = 0xcccc_cccc;

/// Bytes of the stack `bottom..top` (word addresses) ever used: the
/// stack is filled with [`STACK_PAINT`] before it is used; the lowest
/// overwritten word is the high-water mark.
pub fn stack_high_water(bottom: usize, top: usize) -> usize {
    let mut p = bottom;
    while p < top {
        // SAFETY: the caller names a stack: every word between `bottom` and
        // `top` is RAM; reading it is always defined (volatile, so the
        // compiler cannot assume its value).
        let word = unsafe { core::ptr::read_volatile(p as *const u32) };
        if word != STACK_PAINT {
            break;
        }
        p += 4;
    }
    top - p
}

/// The high-water mark of cortex-m-rt's stack (the stack of `main`, painted
/// before `main` by its `paint-stack` feature).
pub fn main_stack_high_water() -> usize {
    unsafe extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }
    stack_high_water(
        (&raw const _stack_end) as usize,
        (&raw const _stack_start) as usize,
    )
}

/// A square root of the FPU that differs from libm's.
pub struct SqrtMismatch {
    pub input: u32,
    pub fpu: u32,
    pub libm: u32,
}

/// The FPU square root (`math::sqrt` on this target) against libm's software
/// `sqrtf`, bit for bit: zeros, subnormals, powers of two, perfect squares,
/// huge values, infinity, negative numbers and a pseudo-random sweep over all
/// positive floats. NaN results must both be NaN (their payloads may differ).
#[inline(never)]
pub fn check_fpu_sqrt() -> Result<(), SqrtMismatch> {
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
            return Err(SqrtMismatch {
                input,
                fpu: fpu.to_bits(),
                libm: soft.to_bits(),
            });
        }
    }
    Ok(())
}

/// Writes what a firmware renders, for its summary line: `NAME: SCENE WxH
/// BUDGET adaptive|uniform skip SKIP seed SEED`. Strings go out with
/// `write_str`, numbers with `{}`: a `{}` of a `&str` would link the
/// formatter's padding code into the flash (docs/firmware.md).
#[allow(clippy::too_many_arguments)]
pub fn write_run(
    o: &mut impl Write,
    name: &str,
    scene: &str,
    (width, height): (usize, usize),
    budget: micropt::Budget,
    adaptive: bool,
    skip: &str,
    seed: u64,
) {
    let _ = o.write_str(name);
    let _ = o.write_str(": ");
    let _ = o.write_str(scene);
    let _ = write!(o, " {width}x{height} ");
    let _ = match budget {
        micropt::Budget::Deadline(us) => write!(o, "deadline {} ms", us / 1000),
        micropt::Budget::Paths(p) => write!(o, "paths {p}"),
        micropt::Budget::Spp(n) => write!(o, "spp {n}"),
    };
    let _ = o.write_str(if adaptive {
        " adaptive skip "
    } else {
        " uniform skip "
    });
    let _ = o.write_str(skip);
    let _ = write!(o, " seed {seed}");
}

/// What went wrong with the host file `file` (opening it if `open`, else
/// writing it), for a firmware's error report.
pub fn write_file_error(o: &mut impl Write, file: &str, open: bool) {
    let _ = o.write_str(if open {
        "cannot open host file "
    } else {
        "writing "
    });
    let _ = o.write_str(file);
    let _ = o.write_str(if open {
        " for writing (is semihosting enabled?)\n"
    } else {
        " failed\n"
    });
}

impl SqrtMismatch {
    /// The mismatch, for a firmware's error report.
    pub fn write(&self, o: &mut impl Write) {
        let _ = writeln!(
            o,
            "vsqrt.f32 differs from libm::sqrtf: sqrt({:#010x}) = {:#010x}, libm {:#010x}",
            self.input, self.fpu, self.libm
        );
    }
}
