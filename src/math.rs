//! Every float function the core uses, called explicitly.
//!
//! Host and board must compute the same bits (an image is a pure function of
//! scene, budget and seed on every target). A method call such as
//! `x.sqrt()` resolves to `std`'s intrinsic on the host but to micromath's
//! approximation on a `no_std` board, so the core never calls float methods:
//! it calls the functions of this module, which are either
//!
//! * correctly rounded (`sqrt`: the FPU's `vsqrt.f32` on Cortex-M4F/M33,
//!   [`soft::sqrt`] on targets without an FPU, libm (`sqrtss` on x86-64)
//!   elsewhere — all give the IEEE result, hence the same bits), or
//! * built only from `+ - * /`, comparisons and bit casts, which IEEE 754
//!   defines exactly (Rust never contracts `a * b + c` into a fused
//!   multiply-add), so they give the same bits on every target.
//!
//! libm's `sinf`, `cosf` and `powf` are *not* used: they compute in double precision,
//! which is software emulation on a Cortex-M4F and would pull soft-double
//! routines into the firmware. The polynomials here are accurate to a few
//! ulps, which the host tests check against double-precision references.
//!
//! micromath's fast approximations are available as the `fast_*` functions
//! (micromath is ~5 % off for `sqrt`, so never use it for intersection); the
//! integrator uses them only when [`crate::integrator::Options::fast_math`]
//! asks for it, and the benchmark measures what that costs in error.

pub mod soft;

/// π.
pub const PI: f32 = core::f32::consts::PI;
/// 1 / π.
pub const INV_PI: f32 = core::f32::consts::FRAC_1_PI;
/// 2π.
pub const TWO_PI: f32 = 2.0 * core::f32::consts::PI;
/// Machine epsilon of the error analysis: half an ulp of 1, 2⁻²⁴.
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// pbrt's γ(n) = nε / (1 − nε): bounds the relative error of `n` chained
/// floating-point operations.
#[inline(always)]
pub const fn gamma(n: u32) -> f32 {
    let ne = n as f32 * MACHINE_EPSILON;
    ne / (1.0 - ne)
}

/// Whether this target has no FPU, so that every float operation is a
/// call of a soft-float routine ([`soft`]): code with an exact integer
/// alternative (a conservative test that keeps the bits) takes it there.
pub const SOFT_FLOAT: bool = cfg!(any(
    all(target_arch = "arm", not(target_abi = "eabihf")),
    all(target_arch = "riscv32", not(target_feature = "f"))
));

/// Correctly rounded square root (the IEEE result). Negative input gives NaN.
#[inline(always)]
pub fn sqrt(x: f32) -> f32 {
    sqrt_impl(x)
}

/// Square root on the Cortex-M4F / M33 FPU: one `vsqrt.f32` instead of libm's
/// ~53-instruction software routine. The only `unsafe` in the crate.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
#[allow(unsafe_code)]
fn sqrt_impl(x: f32) -> f32 {
    let bits_in = x.to_bits();
    let bits_out: u32;
    // SAFETY: `vsqrt.f32` reads and writes only the named FPU register (s0),
    // which is declared as clobbered through the `out("s0")` operand; the
    // values move through core registers (`vmov`), because `asm!` rejects
    // `sreg` operands for f32 on this target. No memory is touched
    // (`nomem`, `nostack`), and the eabihf targets always have the FPU
    // enabled by the runtime before `main`.
    unsafe {
        core::arch::asm!(
            "vmov s0, {i}",
            "vsqrt.f32 s0, s0",
            "vmov {o}, s0",
            i = in(reg) bits_in,
            o = lateout(reg) bits_out,
            out("s0") _,
            options(pure, nomem, nostack, preserves_flags),
        );
    }
    f32::from_bits(bits_out)
}

/// Square root on targets without an FPU: [`soft::sqrt`] (a table, one
/// Newton step and exact remainders) instead of libm's bit-by-bit loop.
#[cfg(any(
    all(target_arch = "arm", not(target_abi = "eabihf")),
    all(target_arch = "riscv32", not(target_feature = "f"))
))]
#[inline(always)]
fn sqrt_impl(x: f32) -> f32 {
    soft::sqrt(x)
}

#[cfg(not(any(
    all(target_arch = "arm", target_abi = "eabihf"),
    all(target_arch = "arm", not(target_abi = "eabihf")),
    all(target_arch = "riscv32", not(target_feature = "f"))
)))]
#[inline(always)]
fn sqrt_impl(x: f32) -> f32 {
    libm::sqrtf(x)
}

/// `sqrt(max(x, 0))`: for quantities that are mathematically non-negative but
/// may round slightly below zero.
#[inline(always)]
pub fn safe_sqrt(x: f32) -> f32 {
    sqrt(max(x, 0.0))
}

/// |x|.
#[inline(always)]
pub fn abs(x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0x7fff_ffff)
}

/// `2x`: the product, or on targets without an FPU [`soft::twice`] (the
/// same bits without a call for a normal `x`).
#[inline(always)]
pub fn twice(x: f32) -> f32 {
    if SOFT_FLOAT { soft::twice(x) } else { 2.0 * x }
}

/// `x / 2`: the product by 0.5, or on targets without an FPU
/// [`soft::half`] (the same bits without a call where the half is normal).
#[inline(always)]
pub fn half(x: f32) -> f32 {
    if SOFT_FLOAT { soft::half(x) } else { 0.5 * x }
}

/// The magnitude of `x` with the sign of `s`.
#[inline(always)]
pub fn copysign(x: f32, s: f32) -> f32 {
    f32::from_bits((x.to_bits() & 0x7fff_ffff) | (s.to_bits() & 0x8000_0000))
}

/// `a < b` (false if either is NaN): the operator, or on targets without
/// an FPU the soft-float comparison inlined (integer tests on the bits
/// instead of a call).
#[inline(always)]
pub fn lt(a: f32, b: f32) -> bool {
    if SOFT_FLOAT { soft::lt(a, b) } else { a < b }
}

/// `a > b` (false if either is NaN), as [`lt`].
#[inline(always)]
pub fn gt(a: f32, b: f32) -> bool {
    if SOFT_FLOAT { soft::lt(b, a) } else { a > b }
}

/// `x > 0` (false for ±0 and NaN); on targets without an FPU an integer
/// comparison of the bits ([`soft::gt_zero`]) instead of a call.
#[inline(always)]
pub fn gt_zero(x: f32) -> bool {
    if SOFT_FLOAT {
        soft::gt_zero(x)
    } else {
        x > 0.0
    }
}

/// `x < 0` (false for ±0 and NaN); on the bits ([`soft::lt_zero`]) on
/// targets without an FPU.
#[inline(always)]
pub fn lt_zero(x: f32) -> bool {
    if SOFT_FLOAT {
        soft::lt_zero(x)
    } else {
        x < 0.0
    }
}

/// `x >= 0` (true for −0, false for NaN); on the bits ([`soft::ge_zero`])
/// on targets without an FPU.
#[inline(always)]
pub fn ge_zero(x: f32) -> bool {
    if SOFT_FLOAT {
        soft::ge_zero(x)
    } else {
        x >= 0.0
    }
}

/// `x <= 0` (true for +0, false for NaN); on the bits ([`soft::le_zero`])
/// on targets without an FPU.
#[inline(always)]
pub fn le_zero(x: f32) -> bool {
    if SOFT_FLOAT {
        soft::le_zero(x)
    } else {
        x <= 0.0
    }
}

/// The smaller of two numbers (`b` if either is NaN and `a < b` is false).
#[inline(always)]
pub fn min(a: f32, b: f32) -> f32 {
    if lt(a, b) { a } else { b }
}

/// The larger of two numbers (`b` if either is NaN and `a > b` is false).
#[inline(always)]
pub fn max(a: f32, b: f32) -> f32 {
    if gt(a, b) { a } else { b }
}

/// `x` clamped to `[lo, hi]`; NaN becomes `lo`.
#[inline(always)]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if gt(x, lo) {
        if lt(x, hi) { x } else { hi }
    } else {
        lo
    }
}

/// Largest integer not greater than `x`, for |x| < 2³¹.
#[inline(always)]
pub fn floor(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t > x { t - 1.0 } else { t }
}

/// Whether `x` is neither infinite nor NaN.
#[inline(always)]
pub fn is_finite(x: f32) -> bool {
    (x.to_bits() & 0x7f80_0000) != 0x7f80_0000
}

/// Knuth's TwoSum: `(s, e)` with `s = fl(a + b)` and `s + e = a + b`
/// exactly (no overflow assumed). Only `+` and `-`: the same bits everywhere.
#[inline(always)]
pub fn two_sum(a: f32, b: f32) -> (f32, f32) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, e)
}

/// Dekker's exact square without a fused multiply-add: `(p, e)` with
/// `p = fl(a²)` and `p + e = a²` exactly, for |a| < 2¹¹⁴ and squares that
/// do not underflow. Only `+ - *`: the same bits everywhere.
#[inline(always)]
pub fn two_square(a: f32) -> (f32, f32) {
    let t = 4097.0 * a; // 2^12 + 1: splits a into two 12-bit halves
    let hi = t - (t - a);
    let lo = a - hi;
    let p = a * a;
    let e = ((hi * hi - p) + 2.0 * hi * lo) + lo * lo;
    (p, e)
}

/// Dekker's exact product without a fused multiply-add: `(p, e)` with
/// `p = fl(a·b)` and `p + e = a·b` exactly, for |a|, |b| < 2¹¹⁴ and products
/// that do not underflow. Only `+ - *`: the same bits everywhere.
#[inline(always)]
pub fn two_prod(a: f32, b: f32) -> (f32, f32) {
    let split = |x: f32| {
        let t = 4097.0 * x;
        let hi = t - (t - x);
        (hi, x - hi)
    };
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    let p = a * b;
    let e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    (p, e)
}

/// The next representable float above `x` (pbrt's `NextFloatUp`).
#[inline]
pub fn next_up(x: f32) -> f32 {
    if x.is_infinite() && x > 0.0 {
        return x;
    }
    let x = if x == -0.0 { 0.0 } else { x };
    let b = x.to_bits();
    f32::from_bits(if x >= 0.0 { b + 1 } else { b - 1 })
}

/// `0 < t < max`, NaN `t` false, for any `max` but NaN: integer
/// comparisons of the bit patterns (positive floats order as their bits)
/// instead of two float comparisons (three instructions each on a
/// Cortex-M4). A `max` ≤ 0 admits nothing.
#[inline(always)]
pub fn positive_below(t: f32, max: f32) -> bool {
    let m = (max.to_bits() as i32).max(1) as u32;
    t.to_bits().wrapping_sub(1) < m - 1
}

/// [`positive_below`] for `max` > 0 (not NaN): one subtraction and one
/// comparison.
#[inline(always)]
pub fn positive_below_positive(t: f32, max: f32) -> bool {
    t.to_bits().wrapping_sub(1) < max.to_bits() - 1
}

/// `|v| <= max` for a `max` that is +0 or positive (not NaN), false for a
/// NaN `v`: on the bits, since the magnitudes of non-NaN floats order as
/// their bit patterns and a NaN's are above every other (three integer
/// instructions instead of a float comparison and a move of the flags).
#[inline(always)]
pub fn abs_at_most(v: f32, max: f32) -> bool {
    v.to_bits() & 0x7fff_ffff <= max.to_bits()
}

/// The next float above `x` for `x` in [+0, +∞] (+∞ stays +∞): one integer
/// increment, no branch on the common path.
#[inline(always)]
pub fn next_up_positive(x: f32) -> f32 {
    let b = x.to_bits();
    f32::from_bits(b + u32::from(b < 0x7f80_0000))
}

/// The next representable float below `x` (pbrt's `NextFloatDown`).
#[inline]
pub fn next_down(x: f32) -> f32 {
    if x.is_infinite() && x < 0.0 {
        return x;
    }
    let x = if x == 0.0 { -0.0 } else { x };
    let b = x.to_bits();
    f32::from_bits(if x > 0.0 { b - 1 } else { b + 1 })
}

/// `(sin 2πt, cos 2πt)` for an angle given in turns.
///
/// Sampling code draws angles as a fraction `t` of a full turn, which allows
/// an exact range reduction (`t - round(4t)/4`) instead of a reduction modulo
/// 2π. Maximum error ~2 ulp for `t` in [0, 1) (tested in double precision).
#[inline]
pub fn sincos_turns(t: f32) -> (f32, f32) {
    // quadrant q = round(4t); remainder r in [-1/8, 1/8] turns, exact for
    // |t| < 2^22 because 4t and its rounding are exact in f32.
    let q4 = t * 4.0;
    let qf = floor(q4 + 0.5);
    let r = (q4 - qf) * 0.25; // exact: power-of-two scaling
    let q = (qf as i32) & 3;
    let x = r * TWO_PI; // |x| <= pi/4
    let x2 = x * x;
    // Taylor polynomials on [-pi/4, pi/4]; truncation error < 2e-9
    let s = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let c = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 + x2 * (-1.0 / 3_628_800.0)))));
    match q {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `(sin x, cos x)` for |x| ≤ π/4, without range reduction: the minimax
/// polynomials of Cephes' `sinf`/`cosf` on that interval (about 1 ulp of 1;
/// tested in double precision). The concentric disk mapping
/// ([`crate::sampler::concentric_disk`]) only needs this interval.
#[inline(always)]
pub fn sincos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let s = x + x * z * (-1.666_665_5e-1 + z * (8.332_161e-3 + z * -1.951_529_6e-4));
    let c = 1.0 - half(z) + z * z * (4.166_664_6e-2 + z * (-1.388_731_6e-3 + z * 2.443_315_7e-5));
    (s, c)
}

/// micromath's approximate `(sin x, cos x)` for |x| ≤ π/4 (absolute error
/// ~1e-3).
#[inline(always)]
pub fn fast_sincos_quarter(x: f32) -> (f32, f32) {
    let a = micromath::F32(x);
    (a.sin().0, a.cos().0)
}

/// `(sin a, cos a)` for an angle in radians, |a| < 10⁵ (setup code only).
#[inline]
pub fn sincos(a: f32) -> (f32, f32) {
    sincos_turns(a * (1.0 / TWO_PI))
}

/// `atan2(y, x)` in [−π, π], from `+ − × ÷` only (the same bits on every
/// target): the octant's ratio in [0, 1], reduced past tan(π/8) by
/// `atan z = π/4 + atan((z − 1)/(z + 1))`, then the series to `t¹³`
/// (|t| ≤ tan(π/8): its error below 1.2e-7 rad; with rounding, below 4e-7).
/// `atan2(0, 0)` is 0.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (abs(x), abs(y));
    if !(ax > 0.0 || ay > 0.0) {
        return 0.0;
    }
    let swap = ay > ax;
    let z = if swap { ax / ay } else { ay / ax };
    let (base, t) = if z > 0.414_213_57 {
        (0.25 * PI, (z - 1.0) / (z + 1.0))
    } else {
        (0.0, z)
    };
    let t2 = t * t;
    let series = t
        * (1.0
            + t2 * (-1.0 / 3.0
                + t2 * (1.0 / 5.0
                    + t2 * (-1.0 / 7.0
                        + t2 * (1.0 / 9.0 + t2 * (-1.0 / 11.0 + t2 * (1.0 / 13.0)))))));
    let mut r = base + series;
    if swap {
        r = 0.5 * PI - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    copysign(r, y)
}

/// `asin s` for `s` in [−1, 1] (by [`atan2`]; NaN outside).
#[inline]
pub fn asin(s: f32) -> f32 {
    atan2(s, sqrt((1.0 - s) * (1.0 + s)))
}

/// log₂ x for x > 0 (finite, normal or subnormal). About 2 ulp.
pub fn log2(x: f32) -> f32 {
    if !(x > 0.0) {
        return if x == 0.0 {
            f32::NEG_INFINITY
        } else {
            f32::NAN
        };
    }
    if !is_finite(x) {
        return x;
    }
    // normalise subnormals
    let (x, bias) = if x < f32::MIN_POSITIVE {
        (x * 16_777_216.0, 24)
    } else {
        (x, 0)
    };
    let bits = x.to_bits();
    let mut e = ((bits >> 23) & 0xff) as i32 - 127 - bias;
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000); // [1, 2)
    if m > core::f32::consts::SQRT_2 {
        m *= 0.5;
        e += 1;
    }
    // log2(m) = 2/ln2 * atanh(s), s = (m-1)/(m+1), |s| <= 0.1716
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let p = s * (2.0 + s2 * (0.666_666_7 + s2 * (0.4 + s2 * (0.285_714_3 + s2 * 0.222_222_2))));
    e as f32 + p * core::f32::consts::LOG2_E
}

/// 2ˣ. About 2 ulp; 0 below −149, +∞ above 128.
pub fn exp2(x: f32) -> f32 {
    if x.is_nan() {
        return x;
    }
    if x >= 128.0 {
        return f32::INFINITY;
    }
    if x < -150.0 {
        return 0.0;
    }
    let fi = floor(x + 0.5);
    let f = x - fi; // [-0.5, 0.5], exact
    let i = fi as i32;
    // 2^f = e^(f ln2), Taylor to degree 7 on |y| <= 0.35: error < 1e-8
    let y = f * core::f32::consts::LN_2;
    let p = 1.0
        + y * (1.0
            + y * (0.5
                + y * (1.0 / 6.0
                    + y * (1.0 / 24.0
                        + y * (1.0 / 120.0 + y * (1.0 / 720.0 + y * (1.0 / 5040.0)))))));
    // scale by 2^i in two steps so that subnormal results are reachable
    let i1 = i / 2;
    let i2 = i - i1;
    p * f32::from_bits(((i1 + 127) as u32) << 23) * f32::from_bits(((i2 + 127) as u32) << 23)
}

/// xʸ for x ≥ 0, as `exp2(y · log2 x)`. `powf(0, y) = 0` for y > 0.
///
/// Within 4 ulp where tone mapping uses it (x in [0.003, 1], y = 1/2.4);
/// the error grows with |y · log2 x| (the rounding of that product is
/// magnified by exp2), to ~25 ulp at x = 1e-30.
pub fn powf(x: f32, y: f32) -> f32 {
    if x == 0.0 {
        return if y > 0.0 { 0.0 } else { 1.0 };
    }
    exp2(y * log2(x))
}

/// `x^(1/2.4)`, the power of the sRGB curve ([`crate::film::srgb_encode`]),
/// for `x` in [2⁻⁹, 1) (the curve's power segment starts at 0.0031308):
/// with `x = m · 2^e`, `m` in [1, 2), it is `m^(5/12) · 2^(5e/12)`, a
/// degree-7 polynomial in `m − 1.5` (Chebyshev fit, 3.4e-8 relative) times
/// one of nine constants. Within 2 ulp (host test), where [`powf`] is within 4,
/// in a fifth of its instructions; [`powf`] outside that range.
#[inline]
pub fn srgb_power(x: f32) -> f32 {
    // 2^(5e/12) for e = −9 ..= −1
    const SCALE: [f32; 9] = [
        0.07432544,
        0.099212565,
        0.1324329,
        0.17677669,
        0.23596857,
        0.31498027,
        0.4204482,
        0.561231,
        0.74915355,
    ];
    let bits = x.to_bits();
    // the biased exponent: 118 ..= 126 for x in [2⁻⁹, 1) (a negative x or
    // NaN has a larger field, with its sign bit)
    let k = (bits >> 23).wrapping_sub(118) as usize;
    let Some(&scale) = SCALE.get(k) else {
        return powf(x, 1.0 / 2.4);
    };
    let t = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000) - 1.5;
    let p = 0.001_471_232_4;
    let p = p * t - 0.002_743_397_1;
    let p = p * t + 0.004_593_649;
    let p = p * t - 0.009_625_968;
    let p = p * t + 0.022_503_95;
    let p = p * t - 0.063_956_68;
    let p = p * t + 0.328_903_76;
    let p = p * t + 1.184_053_7;
    p * scale
}

/// micromath's approximate square root (~5 % error; never for geometry).
#[inline(always)]
pub fn fast_sqrt(x: f32) -> f32 {
    micromath::F32(x).sqrt().0
}

/// micromath's approximate `(sin 2πt, cos 2πt)` (absolute error ~1e-3).
#[inline(always)]
pub fn fast_sincos_turns(t: f32) -> (f32, f32) {
    let a = micromath::F32(t * TWO_PI);
    (a.sin().0, a.cos().0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_steps_one_ulp() {
        assert!(next_up(1.0) > 1.0 && next_up(1.0) - 1.0 == f32::EPSILON);
        assert!(next_down(1.0) < 1.0);
        assert!(next_up(0.0) > 0.0 && next_down(0.0) < 0.0);
        assert!(next_up(-1.0) > -1.0);
    }

    /// The bit test is the float comparison `|v| <= max` (false for NaN)
    /// on edge values and random bits, for a bound like the render's
    /// sample bound (`f32::MAX / 2²⁰`) and for bounds at the edges of the
    /// range (0, the smallest subnormal, the largest finite, +∞).
    #[test]
    fn abs_at_most_is_the_float_comparison() {
        let s = f32::MAX / 1_048_576.0;
        let edges = [
            0.0,
            -0.0,
            1.0,
            s,
            -s,
            f32::from_bits(s.to_bits() + 1),
            f32::from_bits(s.to_bits() - 1),
            f32::MAX,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::from_bits(0xffc0_0001),
            f32::from_bits(0x7f80_0001),
        ];
        for m in [s, 0.0, f32::from_bits(1), f32::MAX, f32::INFINITY] {
            for v in edges {
                assert_eq!(
                    abs_at_most(v, m),
                    abs(v) <= m,
                    "{v:e} ({:#x}) <= {m:e}",
                    v.to_bits()
                );
            }
            // xorshift32
            let mut z = 7u32;
            for _ in 0..100_000 {
                z ^= z << 13;
                z ^= z >> 17;
                z ^= z << 5;
                let v = f32::from_bits(z);
                assert_eq!(
                    abs_at_most(v, m),
                    abs(v) <= m,
                    "{:#x} <= {m:e}",
                    v.to_bits()
                );
            }
        }
    }

    #[test]
    fn positive_below_is_the_open_interval() {
        let ts = [
            -1.0f32,
            -0.0,
            0.0,
            1e-45,
            0.5,
            1.0,
            2.0,
            f32::MAX,
            f32::INFINITY,
            f32::NAN,
            -f32::NAN,
        ];
        for max in [-1.0f32, -0.0, 0.0, 1e-45, 1.0, 2.0, f32::MAX, f32::INFINITY] {
            for t in ts {
                assert_eq!(positive_below(t, max), t > 0.0 && t < max, "{t} {max}");
                if max > 0.0 {
                    assert_eq!(positive_below_positive(t, max), t > 0.0 && t < max);
                }
            }
        }
    }

    #[test]
    fn next_up_positive_is_next_up_on_its_domain() {
        for x in [0.0f32, 1e-45, 1.0, 3.0e38, f32::MAX] {
            assert_eq!(next_up_positive(x), next_up(x));
        }
        assert_eq!(next_up_positive(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn floor_abs_copysign_clamp() {
        assert_eq!(floor(-0.5), -1.0);
        assert_eq!(floor(2.0), 2.0);
        assert_eq!(floor(2.7), 2.0);
        assert_eq!(abs(-3.0), 3.0);
        assert_eq!(copysign(2.0, -0.0), -2.0);
        assert_eq!(clamp(f32::NAN, 0.0, 1.0), 0.0);
        assert!(!is_finite(f32::INFINITY) && !is_finite(f32::NAN) && is_finite(1e38));
    }

    #[test]
    fn error_free_transforms_are_exact() {
        // 2^24 + 1 is not representable: the error term holds the 1
        let (s, e) = two_sum(16_777_216.0, 1.0);
        assert_eq!((s, e), (16_777_216.0, 1.0));
        let (s, e) = two_sum(1.0e8, -0.75);
        assert_eq!((s, e), (1.0e8, -0.75));
        // (1 + 2^-12)^2 = 1 + 2^-11 + 2^-24: the last term is the error
        let a = 1.0 + 1.0 / 4096.0;
        let (p, e) = two_square(a);
        assert_eq!(p, 1.0 + 1.0 / 2048.0);
        assert_eq!(e, 1.0 / 16_777_216.0);
    }

    #[test]
    fn exact_values() {
        assert_eq!(sincos_turns(0.0), (0.0, 1.0));
        assert_eq!(sincos_turns(0.25), (1.0, 0.0));
        assert_eq!(sincos_turns(0.5), (0.0, -1.0));
        assert_eq!(powf(0.0, 0.5), 0.0);
        assert_eq!(powf(1.0, 0.4), 1.0);
        assert_eq!(exp2(3.0), 8.0);
        assert_eq!(log2(8.0), 3.0);
        assert_eq!(sqrt(4.0), 2.0);
    }
}
