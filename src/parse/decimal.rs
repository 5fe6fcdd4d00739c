//! Decimal text → `f32`, correctly rounded (round half to even), with no
//! tables, no double precision and no panicking branch.
//!
//! `core`'s `str::parse::<f32>` is correctly rounded too, but its slow path
//! indexes arrays with runtime indices, so a firmware that uses it cannot be
//! proven panic-free at link time (`panic-never`), and its 10 KiB table of
//! powers of five is a sixth of the firmware's flash budget. This module
//! accepts exactly the strings `core` accepts and gives the same value for
//! each (the tests compare the two on edge cases and on a random sweep), so
//! a scene means what `core`'s parser would read, on every target.
//!
//! Method: numbers of at most 24 significant bits with a decimal exponent in
//! ±10 (most of a scene file) take Clinger's fast path, one exact f32
//! operation. Otherwise the first [`MAX_DIGITS`] significant digits form an integer `D`
//! (any further non-zero digit only sets a sticky bit: every halfway point
//! between two `f32`s has at most 113 significant digits, so truncating
//! beyond that never changes the rounding), the value is `D · 10^e`, and an
//! exact long division of fixed-size big integers gives 26–27 quotient bits
//! plus a remainder, which are rounded to 24 bits (or to the subnormal
//! quantum 2⁻¹⁴⁹).

use core::cmp::Ordering;

use crate::math;

/// Significant digits kept exactly; more only set the sticky bit.
const MAX_DIGITS: usize = 120;
/// 32-bit limbs of the big integers: 640 bits. The largest value formed is
/// below 2⁵⁶⁰ (`10^159` shifted left by 27, see [`parse_f32`]).
const LIMBS: usize = 20;

/// The powers of ten that are exact in f32 (5^10 < 2^24).
const POW10: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// A fixed-size unsigned big integer, little-endian limbs.
#[derive(Clone, Copy, PartialEq, Eq)]
struct Big([u32; LIMBS]);

impl Big {
    const ZERO: Big = Big([0; LIMBS]);

    fn from_u32(v: u32) -> Big {
        let mut b = Big::ZERO;
        if let Some(l) = b.0.first_mut() {
            *l = v;
        }
        b
    }

    /// `self = self · m + a`.
    fn mul_add(&mut self, m: u32, a: u32) {
        let mut carry = u64::from(a);
        for l in self.0.iter_mut() {
            let t = u64::from(*l) * u64::from(m) + carry;
            *l = t as u32;
            carry = t >> 32;
        }
    }

    /// Number of significant bits (0 for zero).
    fn bits(&self) -> u32 {
        let mut n = 0;
        for (i, l) in self.0.iter().enumerate() {
            if *l != 0 {
                n = i as u32 * 32 + (32 - l.leading_zeros());
            }
        }
        n
    }

    fn is_zero(&self) -> bool {
        self.0.iter().all(|&l| l == 0)
    }

    /// `self · 2^n` (bits shifted beyond the top are lost; callers stay
    /// below 2⁶⁴⁰).
    fn shl(&self, n: u32) -> Big {
        let limbs = (n / 32) as usize;
        let b = n % 32;
        let limb = |i: usize, back: usize| -> u32 {
            i.checked_sub(back)
                .and_then(|j| self.0.get(j))
                .copied()
                .unwrap_or(0)
        };
        let mut out = Big::ZERO;
        for (i, o) in out.0.iter_mut().enumerate() {
            let hi = limb(i, limbs);
            *o = if b == 0 {
                hi
            } else {
                (hi << b) | (limb(i, limbs + 1) >> (32 - b))
            };
        }
        out
    }

    fn compare(&self, o: &Big) -> Ordering {
        for (a, b) in self.0.iter().rev().zip(o.0.iter().rev()) {
            if a != b {
                return a.cmp(b);
            }
        }
        Ordering::Equal
    }

    /// `self -= o`, for `o <= self`.
    fn sub(&mut self, o: &Big) {
        let mut borrow = false;
        for (a, b) in self.0.iter_mut().zip(o.0.iter()) {
            let (d1, o1) = a.overflowing_sub(*b);
            let (d2, o2) = d1.overflowing_sub(u32::from(borrow));
            *a = d2;
            borrow = o1 || o2;
        }
    }
}

/// `inf`, `infinity` or `nan` (ASCII case-insensitive), as `core` accepts.
fn inf_or_nan(s: &[u8]) -> Option<f32> {
    if s.eq_ignore_ascii_case(b"inf") || s.eq_ignore_ascii_case(b"infinity") {
        Some(f32::INFINITY)
    } else if s.eq_ignore_ascii_case(b"nan") {
        Some(f32::NAN)
    } else {
        None
    }
}

/// Parses `s` exactly as `core`'s `str::parse::<f32>` does (`None` where it
/// returns an error): an optional sign, then `inf`, `infinity`, `nan`, or
/// digits with an optional point (at least one digit) and an optional
/// exponent `e`/`E` with optional sign and at least one digit. Values beyond
/// the `f32` range give ±∞, values below half the smallest subnormal ±0.
pub fn parse_f32(s: &str) -> Option<f32> {
    let bytes = s.as_bytes();
    let (negative, body) = match bytes.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, bytes),
    };
    if body.is_empty() {
        return None;
    }
    let magnitude = match parse_decimal(body) {
        Some(v) => v,
        None => inf_or_nan(body)?,
    };
    Some(if negative { -magnitude } else { magnitude })
}

/// What the decimal `s` lacks beyond `hi`, its correctly rounded f32 value
/// ([`parse_f32`]), to about 2⁻²⁰ of itself: `hi + residual(s, hi)` is `s`
/// to some 44 bits, for a string that `parse_f32` accepts (others give 0 or
/// a meaningless value, never a panic). 0 for infinities, NaN and zero, and
/// where the value or its residual would leave the normal f32 range.
///
/// The digits accumulate in double-f32 arithmetic (an unevaluated sum of
/// two f32s, exact products and sums by [`math::two_prod`] and
/// [`math::two_sum`]), and the decimal exponent is applied by exact steps
/// of ×10 or ÷10; each step rounds at about 2⁻⁴⁶ of the value. `hi` lies
/// within an ulp of the high part, so their difference is exact. Used for
/// the centres and radii of spheres, where the rounding of a coordinate of
/// 1e5 is a visible distance in a room of 100 units.
#[inline(never)]
pub fn residual(s: &str, hi: f32) -> f32 {
    if !math::is_finite(hi) || hi == 0.0 {
        return 0.0;
    }
    let bytes = s.as_bytes();
    let (negative, body) = match bytes.split_first() {
        Some((b'-', rest)) => (true, rest),
        Some((b'+', rest)) => (false, rest),
        _ => (false, bytes),
    };
    let (mut h, mut l) = (0.0f32, 0.0f32);
    let mut exp10: i32 = 0;
    let mut seen_point = false;
    let mut rest = body;
    while let Some((&c, tail)) = rest.split_first() {
        match c {
            b'0'..=b'9' => {
                if h < 1.0e30 {
                    (h, l) = dd_mul10_add(h, l, f32::from(c - b'0'));
                    if seen_point {
                        exp10 -= 1;
                    }
                } else if !seen_point {
                    exp10 += 1;
                }
            }
            b'.' => seen_point = true,
            b'e' | b'E' => break,
            _ => return 0.0,
        }
        rest = tail;
    }
    if let Some((_, tail)) = rest.split_first() {
        let (neg, tail) = match tail.split_first() {
            Some((b'-', t)) => (true, t),
            Some((b'+', t)) => (false, t),
            _ => (false, tail),
        };
        let mut e: i32 = 0;
        for &c in tail {
            if !c.is_ascii_digit() {
                return 0.0;
            }
            if e < 10_000 {
                e = e * 10 + i32::from(c - b'0');
            }
        }
        exp10 += if neg { -e } else { e };
    }
    while exp10 > 0 {
        if h > 1.0e36 {
            return 0.0;
        }
        (h, l) = dd_mul10_add(h, l, 0.0);
        exp10 -= 1;
    }
    while exp10 < 0 {
        if h < 1.0e-28 {
            return 0.0;
        }
        (h, l) = dd_div10(h, l);
        exp10 += 1;
    }
    let magnitude = if negative { -hi } else { hi };
    let lo = (h - magnitude) + l;
    let lo = if negative { -lo } else { lo };
    if math::is_finite(lo) && math::abs(lo) <= math::abs(hi) * (1.0 / 1_048_576.0) {
        lo
    } else {
        0.0
    }
}

/// `(h + l)·10 + d` in double-f32, renormalised.
fn dd_mul10_add(h: f32, l: f32, d: f32) -> (f32, f32) {
    let (p, e) = math::two_prod(h, 10.0);
    let (s, e2) = math::two_sum(p, d);
    let lo = e + e2 + l * 10.0;
    math::two_sum(s, lo)
}

/// `(h + l) / 10` in double-f32, renormalised: the quotient of the high
/// part, then the exact remainder divided again.
fn dd_div10(h: f32, l: f32) -> (f32, f32) {
    let q = h / 10.0;
    let (p, e) = math::two_prod(q, 10.0);
    let r = ((h - p) - e) + l;
    math::two_sum(q, r / 10.0)
}

/// The unsigned decimal grammar and its correctly rounded value.
fn parse_decimal(s: &[u8]) -> Option<f32> {
    let mut d = Big::ZERO;
    let mut kept = 0usize; // significant digits in `d`
    let mut sticky = false; // a non-zero digit beyond MAX_DIGITS
    let mut digits = 0usize; // all mantissa digits, for the grammar
    // decimal exponent of the last digit kept in `d`, relative to the point
    let mut exp10: i64 = 0;
    let mut seen_point = false;
    let mut rest = s;
    while let Some((&c, tail)) = rest.split_first() {
        match c {
            b'0'..=b'9' => {
                digits += 1;
                let v = u32::from(c - b'0');
                if seen_point {
                    // a fraction digit: kept ones and leading zeros both
                    // shift the exponent of the integer formed so far
                    if kept < MAX_DIGITS {
                        exp10 -= 1;
                    }
                } else if kept >= MAX_DIGITS {
                    // an integer digit that is not kept multiplies by 10
                    exp10 += 1;
                }
                if kept < MAX_DIGITS {
                    if kept > 0 || v != 0 {
                        d.mul_add(10, v);
                        kept += 1;
                    }
                } else if v != 0 {
                    sticky = true;
                }
            }
            b'.' if !seen_point => seen_point = true,
            _ => break,
        }
        rest = tail;
    }
    if digits == 0 {
        return None;
    }
    if let Some((&e, tail)) = rest.split_first() {
        if e != b'e' && e != b'E' {
            return None;
        }
        let (neg, tail) = match tail.split_first() {
            Some((b'-', t)) => (true, t),
            Some((b'+', t)) => (false, t),
            _ => (false, tail),
        };
        if tail.is_empty() || !tail.iter().all(u8::is_ascii_digit) {
            return None;
        }
        let mut e: i64 = 0;
        for c in tail {
            // saturate: anything this large overflows or underflows anyway
            if e < 0x10000 {
                e = e * 10 + i64::from(c - b'0');
            }
        }
        exp10 += if neg { -e } else { e };
    }
    if d.is_zero() {
        return Some(0.0);
    }
    Some(round_to_f32(&d, kept as i64, exp10, sticky))
}

/// The f32 nearest to `d · 10^exp10` (more if `sticky`), `d` having `kept`
/// decimal digits.
fn round_to_f32(d: &Big, kept: i64, exp10: i64, sticky: bool) -> f32 {
    // the value lies in [10^(kept + exp10 - 1), 10^(kept + exp10))
    let magnitude = kept + exp10;
    if magnitude > 39 {
        return f32::INFINITY; // >= 10^39 > f32::MAX + half an ulp
    }
    if magnitude <= -46 {
        return 0.0; // < 10^-46 < 2^-150, half the smallest subnormal
    }
    // Clinger's fast path (what most scene numbers take): an integer below
    // 2^24 and a power of ten up to 10^10 are both exact in f32, so one
    // IEEE multiplication or division rounds their product or quotient
    // correctly, on every target
    if !sticky && d.bits() <= 24 && (-10..=10).contains(&exp10) {
        let v = d.0.first().copied().unwrap_or(0) as f32;
        let p = POW10
            .get(exp10.unsigned_abs() as usize)
            .copied()
            .unwrap_or(1.0);
        return if exp10 >= 0 { v * p } else { v / p };
    }
    // value = a / b; here exp10 lies in [-46 - MAX_DIGITS, 39]
    let mut a = *d;
    let mut b = Big::from_u32(1);
    for _ in 0..exp10.max(0) {
        a.mul_add(10, 0);
    }
    for _ in 0..(-exp10).max(0) {
        b.mul_add(10, 0);
    }
    // scale so that q = floor(a · 2^s / b) has 26 or 27 bits:
    // a / b lies in (2^(la - lb - 1), 2^(la - lb + 1))
    let s = 26 - (a.bits() as i32 - b.bits() as i32);
    let (mut x, y) = if s >= 0 {
        (a.shl(s as u32), b)
    } else {
        (a, b.shl((-s) as u32))
    };
    let mut q = 0u32;
    for i in (0..28).rev() {
        let t = y.shl(i);
        if x.compare(&t) != Ordering::Less {
            x.sub(&t);
            q |= 1 << i;
        }
    }
    let inexact = sticky || !x.is_zero();
    // value = (q + frac) · 2^-s, with q in [2^25, 2^27)
    let len = 32 - q.leading_zeros() as i32; // 26 or 27
    let e2 = len - 1 - s; // unbiased binary exponent of the value
    // bits of q dropped: down to 24 significant bits, or to the subnormal
    // quantum 2^-149
    let subnormal = e2 < -126;
    let drop = if subnormal { s - 149 } else { len - 24 };
    let m = if drop >= 32 {
        0 // below 2^-151: rounds to zero
    } else {
        let drop = drop as u32; // >= 2 by construction
        let kept_bits = q >> drop;
        let half = 1u32 << (drop - 1);
        let rem = q & ((half << 1) - 1);
        let round_up = rem > half || (rem == half && (inexact || kept_bits & 1 == 1));
        kept_bits + u32::from(round_up)
    };
    let bits = if subnormal {
        // m <= 2^23; m == 2^23 is exactly the smallest normal's encoding
        m
    } else {
        // m in [2^23, 2^24] with the hidden bit: adding it to the biased
        // exponent field carries a rounded-up 2^24 into the exponent, and a
        // carry out of exponent 254 gives exactly the encoding of +inf
        let field = (e2 + 126) as u32;
        if field >= 254 {
            return f32::INFINITY;
        }
        (field << 23) + m
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::fmt::Write;

    /// The function must agree with `core`'s parser, bit for bit (NaN with
    /// NaN).
    fn check(s: &str) {
        let ours = parse_f32(s);
        let core = s.parse::<f32>().ok();
        let same = match (ours, core) {
            (Some(a), Some(b)) => a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
            (None, None) => true,
            _ => false,
        };
        assert!(same, "{s:?}: ours {ours:?}, core {core:?}");
    }

    struct Buf {
        b: [u8; 400],
        n: usize,
    }
    impl Write for Buf {
        fn write_str(&mut self, s: &str) -> core::fmt::Result {
            let end = self.n + s.len();
            self.b
                .get_mut(self.n..end)
                .ok_or(core::fmt::Error)?
                .copy_from_slice(s.as_bytes());
            self.n = end;
            Ok(())
        }
    }
    impl Buf {
        fn new() -> Self {
            Buf { b: [0; 400], n: 0 }
        }
        fn as_str(&self) -> &str {
            core::str::from_utf8(&self.b[..self.n]).unwrap()
        }
    }

    fn xorshift(state: &mut u64) -> u64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        *state
    }

    #[test]
    fn grammar_matches_core() {
        for s in [
            "",
            "+",
            "-",
            ".",
            "+.",
            "e5",
            ".e5",
            "1e",
            "1e+",
            "1e-",
            "1.",
            "1.e5",
            ".5",
            "-.5",
            "+1",
            "--1",
            "+-1",
            "1..2",
            "1.2.3",
            "1e5e5",
            "1 ",
            " 1",
            "1x",
            "0x10",
            "inf",
            "-inf",
            "+Infinity",
            "INF",
            "infinit",
            "infinityy",
            "nan",
            "NaN",
            "-nan",
            "nana",
            "1_000",
            "1e1.5",
            "١",
            "1E5",
            "1e+05",
            "00000",
            "-0",
            "-0.0e-999",
            "0e99999999999",
            "1e99999999999999999999",
            "1e-99999999999999999999",
        ] {
            check(s);
        }
    }

    #[test]
    fn edge_values_match_core() {
        for s in [
            "0.1",
            "0.2",
            "0.3",
            "1",
            "2",
            "10",
            "3.4028235e38",
            "3.4028236e38",
            "3.40282356779733661637539395458142568448e38", // MAX + half ulp: tie -> inf
            "3.40282356779733661637539395458142568447e38",
            "340282346638528859811704183484516925440",
            "1e38",
            "1e39",
            "1.17549435e-38",
            "1.1754942e-38",
            "1.4e-45",
            "1.401298464324817e-45",
            "7.006492321624085e-46", // half the smallest subnormal: tie -> 0
            "7.006492321624086e-46",
            "7.0064923216240862e-46",
            "2.1019476964872256e-45", // 1.5 × smallest subnormal: tie -> even (2)
            "1e-45",
            "1e-46",
            "9.99e-46",
            "16777217",
            "16777216",
            "16777218",
            "16777219",
            "33554431",
            "0.000000000000000000000000000000000000000000001",
            "123456789012345678901234567890",
            "1.00000005960464477539062499999999999",
            "1.000000059604644775390625", // 1 + half ulp: tie -> even (1)
            "1.0000001788139343261718750", // 1 + 1.5 ulp: tie -> even (1 + 2 ulp)
            "0.725",
            "0.71",
            "0.68",
            "1e5",
            "-1e5",
            "1e-4",
            "0.98",
            "60",
        ] {
            check(s);
        }
        // a halfway point with many digits, plus a trailing non-zero digit far
        // beyond MAX_DIGITS: must round up
        let mut b = Buf::new();
        write!(b, "1.000000059604644775390625").unwrap();
        for _ in 0..200 {
            b.write_str("0").unwrap();
        }
        b.write_str("1").unwrap();
        check(b.as_str());
        // the same with leading zeros and an exponent
        let mut b = Buf::new();
        b.write_str("0.0000000000").unwrap();
        b.write_str("1000000059604644775390625").unwrap();
        for _ in 0..150 {
            b.write_str("0").unwrap();
        }
        b.write_str("3e10").unwrap();
        check(b.as_str());
    }

    #[test]
    fn every_f32_printed_round_trips_like_core() {
        // random bit patterns printed shortest (Display) and in scientific
        // notation with extra digits, which lands near halfway points
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..20_000 {
            let bits = xorshift(&mut state) as u32;
            let x = f32::from_bits(bits);
            if !x.is_finite() {
                continue;
            }
            let mut b = Buf::new();
            write!(b, "{x}").unwrap();
            check(b.as_str());
            let mut b = Buf::new();
            let prec = (xorshift(&mut state) % 40) as usize;
            write!(b, "{x:.prec$e}").unwrap();
            check(b.as_str());
        }
    }

    #[test]
    fn random_strings_match_core() {
        // short strings over the alphabet of the grammar
        let alphabet = b"0123456789..eE+-0019";
        let mut state = 12345u64;
        for _ in 0..100_000 {
            let len = (xorshift(&mut state) % 12) as usize;
            let mut buf = [0u8; 12];
            for c in buf.iter_mut().take(len) {
                *c = alphabet[(xorshift(&mut state) % alphabet.len() as u64) as usize];
            }
            check(core::str::from_utf8(&buf[..len]).unwrap());
        }
    }
}
