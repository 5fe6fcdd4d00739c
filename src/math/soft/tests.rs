//! Bit-exact checks against the host FPU (x86-64 SSE, or whatever the host
//! has: IEEE 754 single precision, round to nearest even, no flush to zero).

use super::*;

/// splitmix64: operands for the random checks.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// A pair of operand bit patterns from one of several distributions:
    /// uniform bits (every class at its natural frequency), nearby
    /// exponents (cancellation, carries), short significands (exact results
    /// and ties) and exponents near the subnormal range and overflow.
    fn pair(&mut self) -> (u32, u32) {
        let r = self.next();
        let (a, b) = (r as u32, (r >> 32) as u32);
        let k = self.next();
        match k & 7 {
            0 | 1 => (a, b),
            2 | 3 => {
                // b's exponent within ±3 of a's
                let e = ((a >> 23) & 0xff) as i32 + ((k >> 3) % 7) as i32 - 3;
                let e = e.clamp(0, 255) as u32;
                (a, (b & 0x807f_ffff) | (e << 23))
            }
            4 | 5 => {
                // significands cut to a few leading bits
                let ka = ((k >> 3) % 24) as u32;
                let kb = ((k >> 8) % 24) as u32;
                (a & !((1 << ka) - 1), b & !((1 << kb) - 1))
            }
            _ => {
                // exponents in the low or the high end of the range
                let low = (k >> 3) & 1 == 0;
                let ea = ((k >> 4) % 40) as u32;
                let eb = ((k >> 10) % 40) as u32;
                let (ea, eb) = if low {
                    (ea, 127 - 20 + eb)
                } else {
                    (254 - ea.min(30), 127 + eb)
                };
                let sh = ((k >> 16) % 24) as u32;
                let a = (a & 0x807f_ffff & !((1 << sh) - 1)) | (ea << 23);
                let b = (b & 0x807f_ffff) | (eb << 23);
                if (k >> 20) & 1 == 0 { (a, b) } else { (b, a) }
            }
        }
    }
}

/// Operands that exercise every special case.
const EDGES: [u32; 24] = [
    0x0000_0000, // +0
    0x0000_0001, // smallest subnormal
    0x0000_0002,
    0x0000_0003,
    0x003f_ffff,
    0x0040_0000,
    0x007f_ffff, // largest subnormal
    0x0080_0000, // smallest normal
    0x0080_0001,
    0x00ff_ffff,
    0x0100_0000,
    0x3f00_0000, // 0.5
    0x3f7f_ffff,
    0x3f80_0000, // 1
    0x3f80_0001,
    0x3fc0_0000, // 1.5
    0x3fff_ffff,
    0x4000_0000, // 2
    0x4b80_0000, // 2^24
    0x3380_0000, // 2^-24
    0x7f7f_ffff, // largest finite
    0x7f00_0000,
    0x7f80_0000, // +inf
    0x7fc0_0000, // NaN
];

fn same(soft: u32, hw: u32) -> bool {
    // NaN results: any NaN from the FPU, the canonical one from here
    if hw & ABS > INF {
        soft == NAN
    } else {
        soft == hw
    }
}

fn check_binary(a: u32, b: u32) {
    let (fa, fb) = (f32::from_bits(a), f32::from_bits(b));
    let cases = [
        ("add", add(fa, fb).to_bits(), (fa + fb).to_bits()),
        ("sub", sub(fa, fb).to_bits(), (fa - fb).to_bits()),
        ("mul", mul(fa, fb).to_bits(), (fa * fb).to_bits()),
        ("div", div(fa, fb).to_bits(), (fa / fb).to_bits()),
    ];
    for (name, soft, hw) in cases {
        assert!(
            same(soft, hw),
            "{name}({a:#010x}, {b:#010x}) = {soft:#010x}, FPU {hw:#010x}"
        );
    }
    assert_eq!(lt(fa, fb), fa < fb, "lt({a:#010x}, {b:#010x})");
    assert_eq!(le(fa, fb), fa <= fb, "le({a:#010x}, {b:#010x})");
    assert_eq!(eq(fa, fb), fa == fb, "eq({a:#010x}, {b:#010x})");
    assert_eq!(unordered(fa, fb), fa.is_nan() || fb.is_nan());
}

/// Every pair of edge operands with either sign, and their neighbours.
#[test]
fn edge_cases_match_the_fpu() {
    let mut ops = [0u32; 6 * EDGES.len()];
    let mut n = 0;
    for e in EDGES {
        for x in [e, e.wrapping_add(1), e.wrapping_sub(1)] {
            ops[n] = x;
            ops[n + 1] = x ^ SIGN;
            n += 2;
        }
    }
    for &a in &ops {
        for &b in &ops {
            check_binary(a, b);
        }
    }
}

/// Ties of the product and the sum, built to be exactly halfway: the
/// rounding must go to the even neighbour.
#[test]
fn halfway_cases_round_to_even() {
    // (1 + 2^-12)^2 = 1 + 2^-11 + 2^-24: halfway between 1 + 2^-11 and its
    // successor; even is down
    let a = 1.0 + 1.0 / 4096.0;
    assert_eq!(mul(a, a), a * a);
    assert_eq!(mul(a, a), 1.0 + 1.0 / 2048.0);
    // 1 + 2^-24 is halfway between 1 and 1 + 2^-23: even is 1
    assert_eq!(add(1.0, 1.0 / 16_777_216.0), 1.0);
    // 1 + 2^-23 + 2^-24: halfway, even is 1 + 2^-22
    let x = 1.0 + 1.0 / 8_388_608.0;
    assert_eq!(add(x, 1.0 / 16_777_216.0), x + 1.0 / 16_777_216.0);
    assert_eq!(add(x, 1.0 / 16_777_216.0), 1.0 + 2.0 / 8_388_608.0);
    // the same ties on the subnormal grid: 3 · 2^-150 is halfway between
    // 2^-149 and 2^-148 (even: 2^-148); 2^-150 is halfway between 0 and
    // 2^-149 (even: 0)
    let tiny = f32::from_bits(3);
    assert_eq!(mul(tiny, 0.5).to_bits(), 2);
    assert_eq!(mul(f32::from_bits(1), 0.5).to_bits(), 0);
    assert_eq!(div(tiny, 2.0).to_bits(), 2);
    for m in 1..2000u32 {
        for sh in [1, 2, 5] {
            let s = f32::from_bits(m);
            let d = f32::from_bits(1 << 23) * (1 << sh) as f32;
            check_binary(s.to_bits(), (1.0 / (1 << sh) as f32).to_bits());
            check_binary(d.to_bits(), s.to_bits());
        }
    }
}

/// The comparisons with zero against the FPU's, and `math`'s comparisons
/// (on the host the operators) with these.
fn check_zero_compares(x: f32) {
    assert_eq!(gt_zero(x), x > 0.0, "{:#010x} > 0", x.to_bits());
    assert_eq!(lt_zero(x), x < 0.0, "{:#010x} < 0", x.to_bits());
    assert_eq!(ge_zero(x), x >= 0.0, "{:#010x} >= 0", x.to_bits());
    assert_eq!(le_zero(x), x <= 0.0, "{:#010x} <= 0", x.to_bits());
    assert_eq!(
        (crate::math::gt_zero(x), crate::math::lt_zero(x)),
        (x > 0.0, x < 0.0)
    );
    assert_eq!(
        (crate::math::ge_zero(x), crate::math::le_zero(x)),
        (x >= 0.0, x <= 0.0)
    );
}

/// Comparisons with zero: every edge operand and its neighbours with
/// either sign (zeros, subnormals, infinities, NaNs of any payload at both
/// ends of the NaN range) and 10⁶ random bit patterns.
#[test]
fn zero_comparisons_match_the_fpu() {
    for e in EDGES.iter().chain(&[0x7f80_0001, 0x7fff_ffff]) {
        for x in [*e, e.wrapping_add(1), e.wrapping_sub(1)] {
            check_zero_compares(f32::from_bits(x));
            check_zero_compares(f32::from_bits(x ^ SIGN));
        }
    }
    let mut rng = Rng(4);
    for _ in 0..1_000_000 {
        check_zero_compares(f32::from_bits(rng.next() as u32));
    }
}

fn check_sqrt(a: u32) {
    let hw = f32::from_bits(a).sqrt().to_bits();
    let soft = sqrt(f32::from_bits(a)).to_bits();
    assert!(
        same(soft, hw),
        "sqrt({a:#010x}) = {soft:#010x}, FPU {hw:#010x}"
    );
}

/// Integer conversions: powers of two and their neighbours, ties at every
/// magnitude, and random integers.
#[test]
fn int_conversions_match_the_fpu() {
    let mut xs = [0u32; 3 * 32 + 2];
    for k in 0..32 {
        xs[3 * k] = 1 << k;
        xs[3 * k + 1] = (1u32 << k).wrapping_sub(1);
        xs[3 * k + 2] = (1u32 << k) | 1 << k.saturating_sub(25);
    }
    xs[96] = u32::MAX;
    xs[97] = 0x8000_0080; // a tie at the top
    let mut rng = Rng(3);
    for i in 0..1_000_000 + xs.len() {
        let x = xs
            .get(i)
            .copied()
            .unwrap_or_else(|| rng.next() as u32 >> (i % 32));
        assert_eq!(from_u32(x).to_bits(), (x as f32).to_bits(), "{x:#x} as f32");
        let y = x as i32;
        assert_eq!(from_i32(y).to_bits(), (y as f32).to_bits(), "{y} as f32");
        let y = y.wrapping_neg();
        assert_eq!(from_i32(y).to_bits(), (y as f32).to_bits(), "{y} as f32");
    }
}

fn random_pairs(n: u64, seed: u64) {
    let mut rng = Rng(seed);
    for _ in 0..n {
        let (a, b) = rng.pair();
        check_binary(a, b);
        check_sqrt(a);
    }
}

/// The square root of every edge operand, and of every float in [1, 4)
/// (each significand at both exponent parities) and of the subnormals
/// below 2¹⁶ ulp.
#[test]
fn sqrt_matches_the_fpu() {
    for e in EDGES {
        for x in [e, e.wrapping_add(1), e.wrapping_sub(1)] {
            check_sqrt(x);
            check_sqrt(x ^ SIGN);
        }
    }
    for x in 0x3f80_0000..0x4080_0000 {
        check_sqrt(x);
    }
    for x in 0..1 << 16 {
        check_sqrt(x);
    }
}

/// 10⁶ random pairs (each checked by add, sub, mul, div and the
/// comparisons; the first operand by sqrt).
#[test]
fn random_operands_match_the_fpu() {
    random_pairs(1_000_000, 1);
}

/// 10⁹ random pairs: `cargo test --release -p micropt --lib soft -- --ignored`.
#[test]
#[ignore]
fn random_operands_match_the_fpu_1e9() {
    random_pairs(1_000_000_000, 2);
}

/// Every 24-bit integer's `n · 2⁻²⁴` from the bits equals the FPU's
/// conversion and product (the samplers' floats on the soft-float targets).
#[test]
fn unit_u24_is_the_conversion_for_every_input() {
    for n in 0..1u32 << 24 {
        let want = n as f32 * (1.0 / 16_777_216.0);
        assert_eq!(unit_u24(n).to_bits(), want.to_bits(), "{n}");
    }
}

/// `op(v)` is the FPU's `factor · v`, NaN-ness aside (a NaN's bits are
/// canonical here), on a million random pairs of every class and on `edges`
/// and their negations.
fn is_the_product_by(op: fn(f32) -> f32, factor: f32, seed: u64, edges: &[f32]) {
    let mut rng = Rng(seed);
    let check = |v: f32| {
        let (got, want) = (op(v), factor * v);
        assert!(
            got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
            "{v:e} times {factor}"
        );
    };
    for _ in 0..1_000_000 {
        let (a, b) = rng.pair();
        check(f32::from_bits(a));
        check(f32::from_bits(b));
    }
    for &v in edges {
        check(v);
        check(-v);
    }
}

/// Doubling on the exponent gives the FPU's product, across every class of
/// input.
#[test]
fn twice_is_the_product() {
    is_the_product_by(
        twice,
        2.0,
        7,
        &[
            0.0,
            1e-45,
            1.175_494_2e-38,
            1.701_411_7e38,
            1.701_411_8e38,
            f32::MAX,
            f32::INFINITY,
        ],
    );
}

/// Halving on the exponent gives the FPU's product by 0.5, across every
/// class of input (subnormal results rounded by the product).
#[test]
fn half_is_the_product() {
    is_the_product_by(
        half,
        0.5,
        11,
        &[
            0.0,
            1e-45,
            3e-45,
            1.175_494_2e-38,
            2.350_988_7e-38,
            f32::MAX,
            f32::INFINITY,
        ],
    );
}
