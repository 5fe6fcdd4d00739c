//! The core's soft-float routines (`micropt::math::soft`) under the names the compiler calls for `f32`
//! arithmetic on a target without an FPU (the ARM EABI's `__aeabi_*`, the
//! libgcc names on RISC-V), so that every operator in the core — and in the
//! rest of the program — uses them instead of the runtime's generic ones.
//!
//! A symbol defined here takes precedence over compiler-builtins' (the
//! linker only takes a member of that library for a symbol still
//! undefined). A board support crate that installs float routines of its
//! own (the RP2040 HAL maps them to the boot ROM's, which flush subnormals
//! to zero) must have them disabled (`rp2040-hal`'s `disable-intrinsics`),
//! or the link fails with duplicate symbols.
//!
//! A firmware for a target without an FPU includes this module (`#[path]`):
//! exporting an unmangled symbol is `unsafe`, and the core has no unsafe
//! code but the FPU square root; the routines themselves are the core's
//! safe integer code.

use micropt::math::soft::{add, div, eq, from_i32, from_u32, le, lt, mul, sub, unordered};

/// Defines `extern "C"` functions with unmangled names.
macro_rules! export {
    ($($(#[$m:meta])* fn $name:ident($($a:ident: $t:ty),*) -> $r:ty $body:block)*) => {
        $(
            $(#[$m])*
            // SAFETY: the name is one the runtime reserves for exactly this
            // operation and signature; no other definition is linked (see
            // the module documentation).
            #[unsafe(no_mangle)]
            pub extern "C" fn $name($($a: $t),*) -> $r $body
        )*
    };
}

#[cfg(target_arch = "arm")]
export! {
    /// `a + b`.
    fn __aeabi_fadd(a: f32, b: f32) -> f32 { add(a, b) }
    /// `a − b`.
    fn __aeabi_fsub(a: f32, b: f32) -> f32 { sub(a, b) }
    /// `b − a`.
    fn __aeabi_frsub(a: f32, b: f32) -> f32 { sub(b, a) }
    /// `a · b`.
    fn __aeabi_fmul(a: f32, b: f32) -> f32 { mul(a, b) }
    /// `a / b`.
    fn __aeabi_fdiv(a: f32, b: f32) -> f32 { div(a, b) }
    /// `a == b` as 1 or 0.
    fn __aeabi_fcmpeq(a: f32, b: f32) -> i32 { i32::from(eq(a, b)) }
    /// `a < b` as 1 or 0.
    fn __aeabi_fcmplt(a: f32, b: f32) -> i32 { i32::from(lt(a, b)) }
    /// `a <= b` as 1 or 0.
    fn __aeabi_fcmple(a: f32, b: f32) -> i32 { i32::from(le(a, b)) }
    /// `a >= b` as 1 or 0.
    fn __aeabi_fcmpge(a: f32, b: f32) -> i32 { i32::from(le(b, a)) }
    /// `a > b` as 1 or 0.
    fn __aeabi_fcmpgt(a: f32, b: f32) -> i32 { i32::from(lt(b, a)) }
    /// 1 if `a` or `b` is NaN, else 0.
    fn __aeabi_fcmpun(a: f32, b: f32) -> i32 { i32::from(unordered(a, b)) }
    /// `x as f32`.
    fn __aeabi_ui2f(x: u32) -> f32 { from_u32(x) }
    /// `x as f32`.
    fn __aeabi_i2f(x: i32) -> f32 { from_i32(x) }
}

#[cfg(target_arch = "riscv32")]
export! {
    /// `a + b`.
    fn __addsf3(a: f32, b: f32) -> f32 { add(a, b) }
    /// `a − b`.
    fn __subsf3(a: f32, b: f32) -> f32 { sub(a, b) }
    /// `a · b`.
    fn __mulsf3(a: f32, b: f32) -> f32 { mul(a, b) }
    /// `a / b`.
    fn __divsf3(a: f32, b: f32) -> f32 { div(a, b) }
    /// 0 if `a == b`, non-zero otherwise (also if unordered).
    fn __eqsf2(a: f32, b: f32) -> i32 { i32::from(!eq(a, b)) }
    /// Non-zero if `a != b` (also if unordered), else 0.
    fn __nesf2(a: f32, b: f32) -> i32 { i32::from(!eq(a, b)) }
    /// Negative if `a < b`, else non-negative (1 if unordered).
    fn __ltsf2(a: f32, b: f32) -> i32 { if lt(a, b) { -1 } else { 1 } }
    /// Non-positive if `a <= b`, else positive (1 if unordered).
    fn __lesf2(a: f32, b: f32) -> i32 { if le(a, b) { 0 } else { 1 } }
    /// Positive if `a > b`, else non-positive (−1 if unordered).
    fn __gtsf2(a: f32, b: f32) -> i32 { if lt(b, a) { 1 } else { -1 } }
    /// Non-negative if `a >= b`, else negative (−1 if unordered).
    fn __gesf2(a: f32, b: f32) -> i32 { if le(b, a) { 0 } else { -1 } }
    /// Non-zero if `a` or `b` is NaN.
    fn __unordsf2(a: f32, b: f32) -> i32 { i32::from(unordered(a, b)) }
    /// `x as f32`.
    fn __floatunsisf(x: u32) -> f32 { from_u32(x) }
    /// `x as f32`.
    fn __floatsisf(x: i32) -> f32 { from_i32(x) }
}
