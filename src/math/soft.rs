//! Correctly rounded f32 arithmetic in integer code, for targets without an
//! FPU (ARMv6-M such as the RP2040, RV32IMC such as the ESP32-C3).
//!
//! On those targets every `+ - * /` and comparison on `f32` is a call into
//! the runtime's soft-float routines. The generic ones (compiler-builtins)
//! are written for every width at once: a 24×24-bit product goes through a
//! 64-bit multiply (itself a call on ARMv6-M, which only multiplies 32×32→32)
//! and a division runs a generic reciprocal iteration. The routines here are
//! specialised for f32 and for a 32-bit multiplier: significand products
//! from three 32-bit multiplies of 8- and 16-bit halves, quotients and
//! square roots from a small table, one Newton step and a final correction
//! that uses the exact remainder (computed modulo 2³², where it is small
//! enough to be exact).
//! The submodule `abi` installs them as the runtime's routines on those
//! targets, so the core's operators use them; on the host the tests call
//! them directly and check them against the FPU.
//!
//! All results are the IEEE 754 ones: round to nearest, ties to even;
//! subnormal inputs and results are kept (no flush to zero); infinities,
//! signed zeros and overflow to infinity as the standard says. Every NaN
//! result is the canonical quiet NaN `0x7fc0_0000` (as on RISC-V, or ARM in
//! default-NaN mode): the payload and sign of a NaN are not propagated. The
//! core never looks at a NaN's bits (it tests NaN-ness), so this keeps its
//! images identical with the FPU targets.

const SIGN: u32 = 0x8000_0000;
const ABS: u32 = 0x7fff_ffff;
const INF: u32 = 0x7f80_0000;
const FRAC: u32 = 0x007f_ffff;
const IMPLICIT: u32 = 0x0080_0000;
/// The NaN of every NaN result.
const NAN: u32 = 0x7fc0_0000;

/// Whether the bits are a NaN's.
#[inline(always)]
fn is_nan(x: u32) -> bool {
    x & ABS > INF
}

/// `a · b`, correctly rounded.
#[inline]
pub fn mul(a: f32, b: f32) -> f32 {
    f32::from_bits(mul_bits(a.to_bits(), b.to_bits()))
}

/// `a + b`, correctly rounded.
#[inline]
pub fn add(a: f32, b: f32) -> f32 {
    f32::from_bits(add_bits(a.to_bits(), b.to_bits()))
}

/// `a − b`, correctly rounded.
#[inline]
pub fn sub(a: f32, b: f32) -> f32 {
    f32::from_bits(add_bits(a.to_bits(), b.to_bits() ^ SIGN))
}

/// `a / b`, correctly rounded.
#[inline]
pub fn div(a: f32, b: f32) -> f32 {
    f32::from_bits(div_bits(a.to_bits(), b.to_bits()))
}

/// `a < b` (false if either is NaN).
#[inline]
pub fn lt(a: f32, b: f32) -> bool {
    less(a.to_bits(), b.to_bits(), false)
}

/// `a <= b` (false if either is NaN).
#[inline]
pub fn le(a: f32, b: f32) -> bool {
    less(a.to_bits(), b.to_bits(), true)
}

/// `a == b` (false if either is NaN; `-0 == +0`).
#[inline]
pub fn eq(a: f32, b: f32) -> bool {
    let (a, b) = (a.to_bits(), b.to_bits());
    !is_nan(a) && !is_nan(b) && (a == b || (a | b) & ABS == 0)
}

/// Whether either is NaN (the two are unordered).
#[inline]
pub fn unordered(a: f32, b: f32) -> bool {
    is_nan(a.to_bits()) || is_nan(b.to_bits())
}

/// `x > 0` (false for ±0 and NaN): the positive floats above +0, up to
/// +∞, are the bit patterns 1 to `0x7f80_0000`.
#[inline(always)]
pub fn gt_zero(x: f32) -> bool {
    x.to_bits().wrapping_sub(1) < INF
}

/// `x < 0` (false for ±0 and NaN): the bit patterns `0x8000_0001` to
/// `0xff80_0000`.
#[inline(always)]
pub fn lt_zero(x: f32) -> bool {
    x.to_bits().wrapping_sub(SIGN + 1) < INF
}

/// `x >= 0` (true for −0, false for NaN): +0 to +∞, or −0.
#[inline(always)]
pub fn ge_zero(x: f32) -> bool {
    let b = x.to_bits();
    b <= INF || b == SIGN
}

/// `x <= 0` (true for +0, false for NaN): +0, or −0 to −∞.
#[inline(always)]
pub fn le_zero(x: f32) -> bool {
    let b = x.to_bits();
    b == 0 || b.wrapping_sub(SIGN) <= INF
}

/// `a < b`, or `a <= b` if `or_equal`, on the bits; false if either is NaN.
#[inline(always)]
fn less(a: u32, b: u32, or_equal: bool) -> bool {
    if is_nan(a) || is_nan(b) {
        return false;
    }
    if (a | b) & ABS == 0 {
        // +0 and −0
        return or_equal;
    }
    let (ia, ib) = (a as i32, b as i32);
    // sign-magnitude: for two negatives the larger magnitude (the smaller
    // number) has the larger bits, also as a signed integer
    if ia & ib < 0 {
        if or_equal { ia >= ib } else { ia > ib }
    } else if or_equal {
        ia <= ib
    } else {
        ia < ib
    }
}

/// The exponent field and the mantissa with its implicit bit, normalised to
/// [2²³, 2²⁴) with a correspondingly lower exponent, of a finite non-zero
/// number's magnitude (subnormals included).
#[inline]
fn unpack_normalised(x: u32) -> (i32, u32) {
    let e = ((x >> 23) & 0xff) as i32;
    if e != 0 {
        return (e, (x & FRAC) | IMPLICIT);
    }
    let f = x & FRAC;
    let s = f.leading_zeros() as i32 - 8;
    (1 - s, f << s)
}

/// Rounds and packs a result whose significand `h` has its leading bit at
/// bit 31, of value `h / 2³¹ · 2^(e + 1 − 127)` (`e` is the biased exponent
/// minus one of a normal result), with `sticky` set if non-zero bits were
/// dropped below `h`: overflow gives infinity, small results become
/// subnormal or zero, each correctly rounded.
#[inline(never)]
#[cold]
fn round_pack(sign: u32, e: i32, h: u32, sticky: bool) -> u32 {
    if e >= 254 {
        return sign | INF;
    }
    // significand bits kept: `h >> shift`; 8 for a normal result
    let shift = if e >= 0 { 8 } else { 8 - e };
    if shift > 32 {
        return sign;
    }
    let shift = shift as u32;
    let (kept, round, rest) = if shift == 32 {
        (0, h >> 31 != 0, (h << 1) != 0 || sticky)
    } else {
        let half = 1u32 << (shift - 1);
        (h >> shift, (h & half) != 0, (h & (half - 1)) != 0 || sticky)
    };
    let base = if e >= 0 { (e as u32) << 23 } else { 0 };
    // the implicit bit in `kept` adds one to the exponent field; a carry of
    // the rounding into the exponent (or to infinity) is the right result
    let up = round && (rest || kept & 1 != 0);
    sign | (base + kept + u32::from(up))
}

#[inline(always)]
fn mul_bits(a: u32, b: u32) -> u32 {
    let ea = (a << 1) >> 24;
    let eb = (b << 1) >> 24;
    // e: the biased exponent minus one of the result if the product of the
    // significands is in [1, 2); one more if it is in [2, 4)
    let e = (ea + eb).wrapping_sub(128);
    if ea.wrapping_sub(1) < 254 && eb.wrapping_sub(1) < 254 && e < 253 {
        let (h, dropped) = significand_product(a, b);
        // the sign and exponent fields of the result, short of the carry:
        // `e` and the sum of the sign bits (bit 31 drops a carry, leaving
        // their exclusive or); from `a` and `b`, which are still in
        // registers, after the product
        let base = (((a >> 23) + (b >> 23)).wrapping_sub(128)) << 23;
        return if (h as i32) < 0 {
            round_even(base + (1 << 23), h, dropped)
        } else {
            round_even(base, h << 1, dropped)
        };
    }
    // a zero times a finite number (the commonest special case)
    if (a << 1 == 0 && eb != 255) || (b << 1 == 0 && ea != 255) {
        return (a ^ b) & SIGN;
    }
    mul_special(a, b)
}

/// The top 32 bits of the 48-bit product of the significands of `a` and
/// `b` (their fraction fields with the implicit bit; or normalised
/// significands in [2²³, 2²⁴)), and the 16 bits below them.
#[inline(always)]
fn significand_product(a: u32, b: u32) -> (u32, u32) {
    // (a1·2¹⁶ + a0)(b1·2¹⁶ + b0) with a1, b1 < 2⁸ and a0, b0 < 2¹⁶, shifted
    // right by 16 (below 2³², the product being below 2⁴⁸), from three
    // 32-bit products: (a1·2¹⁶ + a0)·b1 + a1·b0 + (a0·b0 >> 16)
    let b1 = ((b << 9) >> 25) + 0x80;
    let b0 = b & 0xffff;
    let a0 = a & 0xffff;
    let lo = a0 * b0;
    let a1 = ((a << 9) >> 25) + 0x80;
    let mid = a1 * b0;
    let h = ((a1 << 16) + a0) * b1 + mid + (lo >> 16);
    (h, lo & 0xffff)
}

/// `base` (sign and exponent field minus one) plus the significand `h`
/// (leading bit at bit 31) rounded to 24 bits, ties to even; `dropped`
/// non-zero if there were further bits below `h`. A carry of the rounding
/// into the exponent (or to infinity) is the right result.
#[inline(always)]
fn round_even(base: u32, h: u32, dropped: u32) -> u32 {
    // round half up on bit 7; a tie (bit 7 set, everything below clear)
    // that rounded up to an odd significand goes back down
    let bits = base + (((h >> 7) + 1) >> 1);
    if h & 0xff == 0x80 && dropped == 0 {
        bits & !1
    } else {
        bits
    }
}

/// The product of significands in [2²³, 2²⁴) whose exponents sum to
/// `e_sum`, for any exponents: rounded and packed, overflow and underflow
/// included.
#[inline(always)]
fn mul_significands(sign: u32, e_sum: i32, ma: u32, mb: u32) -> u32 {
    let (mut h, dropped) = significand_product(ma, mb);
    let mut e = e_sum - 127;
    if (h as i32) >= 0 {
        h <<= 1;
        e -= 1;
    }
    round_pack(sign, e, h, dropped != 0)
}

#[inline(never)]
#[cold]
fn mul_special(a: u32, b: u32) -> u32 {
    let sign = (a ^ b) & SIGN;
    let (ma, mb) = (a & ABS, b & ABS);
    if is_nan(a) || is_nan(b) {
        return NAN;
    }
    if ma == INF || mb == INF {
        return if ma == 0 || mb == 0 { NAN } else { sign | INF };
    }
    if ma == 0 || mb == 0 {
        return sign;
    }
    // subnormal operands, or a result that may overflow or underflow
    let (ea, fa) = unpack_normalised(a);
    let (eb, fb) = unpack_normalised(b);
    mul_significands(sign, ea + eb, fa, fb)
}

#[inline(always)]
fn add_bits(a: u32, b: u32) -> u32 {
    // x the operand of larger magnitude
    let (x, y) = if a << 1 >= b << 1 { (a, b) } else { (b, a) };
    let ex = (x << 1) >> 24;
    let ey = (y << 1) >> 24;
    if ey == 0 || ex == 255 {
        // adding a zero to a finite number is the commonest special case
        if y << 1 == 0 && ex != 255 {
            // ±0 + ±0 is −0 only for two negative zeros
            return if x << 1 == 0 { x & y } else { x };
        }
        return add_special(x, y);
    }
    let d = ex - ey;
    if d > 25 {
        // |y| < a quarter of x's ulp (or of the ulp below a power of two)
        return x;
    }
    // significands with the leading bit at bit 31; y aligned to x, with a
    // sticky bit for bits shifted out (only for d > 8: the low 8 bits are
    // zero)
    let mx = (x << 8) | SIGN;
    let my = (y << 8) | SIGN;
    let mut ys = my >> d;
    if ys << d != my {
        ys |= 1;
    }
    if ((a ^ b) as i32) >= 0 {
        add_aligned(x, mx, ys)
    } else {
        sub_aligned(x, mx, ys, d)
    }
}

/// `x + y` for normal `x` and `y` of the same sign, |x| ≥ |y|, from x's
/// significand `mx` and y's `ys`, aligned to it (leading bit of `mx` at
/// bit 31).
#[inline(always)]
fn add_aligned(x: u32, mx: u32, ys: u32) -> u32 {
    let (s, carry) = mx.overflowing_add(ys);
    if !carry {
        // sign and exponent field of x, less the leading bit
        return round_even(((x >> 23) - 1) << 23, s, 0);
    }
    if (x << 1) >> 24 == 254 {
        return (x & SIGN) | INF;
    }
    round_even((x >> 23) << 23, SIGN | (s >> 1), s & 1)
}

/// `x − |y|` for normal `x` and `y` of different signs, |x| ≥ |y|, from
/// x's significand `mx` and y's `ys`, aligned to it by a shift of `d`
/// (leading bit of `mx` at bit 31).
#[inline(always)]
fn sub_aligned(x: u32, mx: u32, ys: u32, d: u32) -> u32 {
    let mut s = mx - ys;
    if (s as i32) < 0 {
        return round_even(((x >> 23) - 1) << 23, s, 0);
    }
    if d >= 2 {
        // one bit of cancellation (x's exponent field is at least 3)
        return round_even(((x >> 23) - 2) << 23, s << 1, 0);
    }
    // d ≤ 1: nothing was shifted out, the difference is exact
    if s == 0 {
        return 0;
    }
    let mut n = 0;
    while s < 1 << 24 {
        s <<= 8;
        n += 8;
    }
    while (s as i32) >= 0 {
        s <<= 1;
        n += 1;
    }
    let ex = (x << 1) >> 24;
    if n >= ex {
        // subnormal result
        return round_pack(x & SIGN, ex as i32 - 1 - n as i32, s, false);
    }
    round_even(((x >> 23) - 1 - n) << 23, s, 0)
}

#[inline(never)]
#[cold]
fn add_special(x: u32, y: u32) -> u32 {
    // |x| ≥ |y| as bits: a NaN y makes x a NaN too
    let (ax, ay) = (x & ABS, y & ABS);
    if ax >= INF {
        if ax > INF || (ay == INF && (x ^ y) & SIGN != 0) {
            return NAN;
        }
        return x;
    }
    if ay == 0 {
        return if ax == 0 { x & y } else { x };
    }
    let ex = (x << 1) >> 24;
    if ex <= 2 {
        // both below 2⁻¹²⁴: exact in integer units of 2⁻¹⁴⁹ (below 2²⁶)
        let vx = if ex == 0 {
            ax
        } else {
            ((x & FRAC) | IMPLICIT) << (ex - 1)
        };
        let r = if (x ^ y) & SIGN == 0 {
            vx + ay
        } else {
            vx - ay
        };
        if r == 0 {
            return 0;
        }
        let lz = r.leading_zeros();
        return round_pack(x & SIGN, 8 - lz as i32, r << lz, false);
    }
    // a subnormal y and a normal x of exponent field 3 or more
    let (ey, my) = unpack_normalised(y);
    let d = ex as i32 - ey;
    if d > 25 {
        return x;
    }
    let d = d as u32;
    let mx = (x << 8) | SIGN;
    let my = my << 8;
    let mut ys = my >> d;
    if ys << d != my {
        ys |= 1;
    }
    if (x ^ y) & SIGN == 0 {
        add_aligned(x, mx, ys)
    } else {
        sub_aligned(x, mx, ys, d)
    }
}

/// Reciprocals of the divisor's leading 16 bits at the middle of each of
/// 128 intervals: `RECIP[i] ≈ 2³¹ / (2¹⁵ + 2⁸ i + 2⁷)`, all below 2¹⁶.
const RECIP: [u16; 128] = {
    let mut t = [0u16; 128];
    let mut i = 0;
    while i < 128 {
        let mid = (1u32 << 15) + ((i as u32) << 8) + (1 << 7);
        t[i] = ((1u32 << 31) / mid) as u16;
        i += 1;
    }
    t
};

#[inline(always)]
fn div_bits(a: u32, b: u32) -> u32 {
    let ea = (a << 1) >> 24;
    let eb = (b << 1) >> 24;
    // the biased exponent minus one of the result if the quotient of the
    // significands is in [½, 1); one more if it is in [1, 2)
    let e = ea.wrapping_sub(eb).wrapping_add(125);
    if ea.wrapping_sub(1) < 254 && eb.wrapping_sub(1) < 254 && e < 253 {
        let (q, rem, ge) = significand_quotient((a & FRAC) | IMPLICIT, (b & FRAC) | IMPLICIT);
        // sign and exponent fields: the difference of the sign bits leaves
        // their exclusive or in bit 31
        let base = ((a >> 23)
            .wrapping_sub(b >> 23)
            .wrapping_add(125 + u32::from(ge)))
            << 23;
        // q's bit 0 is the rounding bit; a tie only with a zero remainder
        let bits = base + ((q + 1) >> 1);
        return if q & 1 != 0 && rem == 0 {
            bits & !1
        } else {
            bits
        };
    }
    div_special(a, b)
}

/// The quotient of significands `ma`, `mb` in [2²³, 2²⁴): `q =
/// floor(ma · 2²⁴ / mb)` if `ma ≥ mb` (the third value), else `floor(ma ·
/// 2²⁵ / mb)`, in [2²⁴, 2²⁵) either way, and its remainder.
#[inline(always)]
fn significand_quotient(ma: u32, mb: u32) -> (u32, u32, bool) {
    let ge = ma >= mb;
    let ma = if ge { ma } else { ma << 1 };
    // q in two parts of 13 and 12 bits, each estimated with r ≈ 2³¹ / (mb
    // >> 8) and corrected with its exact remainder (computed modulo 2³²,
    // where it is small)
    let b16 = mb >> 8;
    let t = u32::from(RECIP[((mb >> 16) & 0x7f) as usize]);
    // one Newton step: t (~8 bits) -> r (~15 bits)
    let err = (1u32 << 31).wrapping_sub(b16 * t) as i32;
    let r = (t as i32 + ((t as i32 * (err >> 8)) >> 23)) as u32;
    // q1 = floor(ma · 2¹² / mb) in [2¹², 2¹³); the estimate is within one
    // (and so is q2's below)
    let mut q1 = ((ma >> 9) * r) >> 18;
    let mut r1 = (ma << 12).wrapping_sub(q1.wrapping_mul(mb));
    if (r1 as i32) < 0 {
        q1 -= 1;
        r1 = r1.wrapping_add(mb);
    } else if r1 >= mb {
        q1 += 1;
        r1 -= mb;
    }
    // q2 = floor(r1 · 2¹² / mb) in [0, 2¹²)
    let mut q2 = ((r1 >> 8) * r) >> 19;
    let mut r2 = (r1 << 12).wrapping_sub(q2.wrapping_mul(mb));
    if (r2 as i32) < 0 {
        q2 -= 1;
        r2 = r2.wrapping_add(mb);
    } else if r2 >= mb {
        q2 += 1;
        r2 -= mb;
    }
    ((q1 << 12) + q2, r2, ge)
}

/// The quotient of significands in [2²³, 2²⁴) whose exponents differ by
/// `e_diff`, for any exponents: rounded and packed, overflow and underflow
/// included.
#[inline(always)]
fn div_significands(sign: u32, e_diff: i32, ma: u32, mb: u32) -> u32 {
    let (q, rem, ge) = significand_quotient(ma, mb);
    let e = e_diff + 125 + i32::from(ge);
    round_pack(sign, e, q << 7, rem != 0)
}

#[inline(never)]
#[cold]
fn div_special(a: u32, b: u32) -> u32 {
    let sign = (a ^ b) & SIGN;
    let (ma, mb) = (a & ABS, b & ABS);
    if is_nan(a) || is_nan(b) {
        return NAN;
    }
    if ma == INF {
        return if mb == INF { NAN } else { sign | INF };
    }
    if mb == INF {
        return sign;
    }
    if mb == 0 {
        return if ma == 0 { NAN } else { sign | INF };
    }
    if ma == 0 {
        return sign;
    }
    let (ea, fa) = unpack_normalised(a);
    let (eb, fb) = unpack_normalised(b);
    div_significands(sign, ea - eb, fa, fb)
}

/// `x as f32` for an unsigned integer, correctly rounded.
#[inline]
pub fn from_u32(x: u32) -> f32 {
    f32::from_bits(from_magnitude(0, x))
}

/// `2x`, correctly rounded: one integer addition to the exponent field for
/// a normal `x` below 2¹²⁶ (where doubling is exact), [`mul`] otherwise.
#[inline(always)]
pub fn twice(x: f32) -> f32 {
    let b = x.to_bits();
    let e = b & INF;
    if e != 0 && e < 0x7f00_0000 {
        f32::from_bits(b + IMPLICIT)
    } else {
        mul(x, 2.0)
    }
}

/// `x / 2`, correctly rounded: one integer subtraction from the exponent
/// field where the half is normal (exact), [`mul`] otherwise.
#[inline(always)]
pub fn half(x: f32) -> f32 {
    let b = x.to_bits();
    let e = b & INF;
    if e > IMPLICIT && e < INF {
        f32::from_bits(b - IMPLICIT)
    } else {
        mul(x, 0.5)
    }
}

/// `n · 2⁻²⁴` for `n < 2²⁴` (exact: 24 bits fit the significand), the
/// samplers' uniform floats, built on the bits: no conversion and no
/// product call, whose results it equals.
#[inline(always)]
pub fn unit_u24(n: u32) -> f32 {
    let n = n & 0x00ff_ffff;
    if n == 0 {
        return 0.0;
    }
    // `s = n · 2^k` with its leading bit at bit 31 (k ≥ 8): the value is
    // `1.f · 2^(7 − k)`, and the significand's low 8 bits are zeros
    let (s, k) = to_bit31(n);
    f32::from_bits(((134 - k) << 23) | ((s >> 8) & FRAC))
}

/// `x as f32` for a signed integer, correctly rounded.
#[inline]
pub fn from_i32(x: i32) -> f32 {
    f32::from_bits(from_magnitude((x as u32) & SIGN, x.unsigned_abs()))
}

/// The float of sign `sign` and magnitude `x`, rounded.
#[inline(always)]
fn from_magnitude(sign: u32, x: u32) -> u32 {
    if x == 0 {
        return 0;
    }
    // 157: the biased exponent of 2³¹, less one (the significand's leading
    // bit is added into the exponent field by the rounding)
    let (s, k) = to_bit31(x);
    round_even(sign | ((157 - k) << 23), s, 0)
}

/// `(x << k, k)` with the leading bit of a non-zero `x` moved to bit 31,
/// in steps (no count-leading-zeros instruction on ARMv6-M).
#[inline(always)]
fn to_bit31(x: u32) -> (u32, u32) {
    let (mut s, mut k) = (x, 0);
    if s < 1 << 16 {
        s <<= 16;
        k += 16;
    }
    if s < 1 << 24 {
        s <<= 8;
        k += 8;
    }
    if s < 1 << 28 {
        s <<= 4;
        k += 4;
    }
    if s < 1 << 30 {
        s <<= 2;
        k += 2;
    }
    if s < 1 << 31 {
        s <<= 1;
        k += 1;
    }
    (s, k)
}

/// `1 / √N` at the middle of each of the 96 intervals of `N` in [2²⁴, 2²⁶)
/// with the same `N >> 19` = `i` (32 to 127): `RSQRT[i] ≈ 2²⁸ / √((i + ½) ·
/// 2¹⁹)`, all below 2¹⁶ (the first 32 entries are not used: indexing with
/// `i & 127` needs no bounds check).
const RSQRT: [u16; 128] = {
    let mut t = [0u16; 128];
    let mut i = 32;
    while i < 128 {
        // 2²⁸ / √n = √(2⁵⁶ / n), the integer square root by bisection
        let n = (2 * i as u64 + 1) << 18;
        let target = (1u64 << 56) / n;
        let (mut lo, mut hi) = (0u64, 1u64 << 17);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if mid * mid <= target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        t[i] = lo as u16;
        i += 1;
    }
    t
};

/// √x, correctly rounded; −0 for −0, NaN for x < 0.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    f32::from_bits(sqrt_bits(x.to_bits()))
}

#[inline(always)]
fn sqrt_bits(x: u32) -> u32 {
    let e = (x >> 23) as i32; // the sign bit makes a negative x > 255
    if e.wrapping_sub(1) as u32 >= 254 {
        return sqrt_special(x);
    }
    sqrt_normalised(e, (x & FRAC) | IMPLICIT)
}

/// √ of the positive number with significand `m` in [2²³, 2²⁴) and
/// exponent `e` (the biased exponent field, or less for a subnormal).
#[inline(always)]
fn sqrt_normalised(e: i32, m: u32) -> u32 {
    // x = n · 2^(e − 150 − s) with an even power: n = m · 2^s, s in {1, 2},
    // n in [2²⁴, 2²⁶); the result's significand (with a rounding bit) is
    // floor(√(n · 2²⁴)) in [2²⁴, 2²⁵)
    let s = 1 + ((e ^ 1) & 1);
    let n = m << s;
    // 1/√n to ~15 bits: the table, one Newton step
    let y0 = u32::from(RSQRT[((n >> 19) & 127) as usize]);
    let p = ((y0 * y0) >> 16) * (n >> 10); // ≈ 2³⁰
    let d = (1u32 << 30).wrapping_sub(p) as i32;
    let y = (y0 as i32 + ((y0 as i32 * (d >> 10)) >> 21)) as u32;
    // s1 = floor(√n) in [2¹², 2¹³): the estimate is within one, corrected
    // with the remainder n − s1²
    let mut s1 = ((n >> 10) * y) >> 18;
    let mut r1 = n.wrapping_sub(s1 * s1) as i32;
    if r1 < 0 {
        s1 -= 1;
        r1 += (2 * s1 + 1) as i32;
    } else if r1 > (2 * s1) as i32 {
        s1 += 1;
        r1 -= (2 * s1 - 1) as i32;
    }
    // the 12 bits below: (s1 · 2¹² + q)² ≈ n · 2²⁴ for q ≈ r1 · 2¹¹ / s1;
    // within one, corrected with the remainder n · 2²⁴ − q², exact modulo
    // 2³² (it is below 2²⁷ in magnitude)
    let mut q = (s1 << 12) + ((r1 as u32 * y) >> 17);
    let rem = (n << 24).wrapping_sub(q.wrapping_mul(q)) as i32;
    if rem < 0 {
        q -= 1;
    } else if rem > (2 * q) as i32 {
        q += 1;
    }
    // biased exponent minus one: 139 + (e − 150 − s) / 2 − 1; never a tie
    // (an odd 25-bit q cannot be the exact root of an even n · 2²⁴)
    let base = ((e - 150 - s) / 2 + 138) as u32;
    (base << 23) + ((q + 1) >> 1)
}

#[inline(never)]
#[cold]
fn sqrt_special(x: u32) -> u32 {
    if x & ABS == 0 {
        return x; // ±0
    }
    if x & SIGN != 0 || is_nan(x) {
        return NAN;
    }
    if x == INF {
        return x;
    }
    let (e, m) = unpack_normalised(x);
    sqrt_normalised(e, m)
}

#[cfg(test)]
mod tests;
