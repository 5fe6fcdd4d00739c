//! Accuracy of the core's math module against double precision: the
//! polynomials replace libm's double-precision sinf/cosf/powf (which would
//! pull soft-double code into the firmware), so they must stay within a few
//! ulps.

use micropt::math;

fn ulps(a: f32, exact: f64) -> f64 {
    let ulp = f64::from(f32::EPSILON) * exact.abs().max(f64::from(f32::MIN_POSITIVE));
    (f64::from(a) - exact).abs() / ulp
}

#[test]
fn sqrt_is_correctly_rounded_and_equals_libm() {
    let mut bits = 1u32;
    while bits < 0x7f80_0000 {
        let x = f32::from_bits(bits);
        assert_eq!(math::sqrt(x), f64::from(x).sqrt() as f32, "sqrt({x:e})");
        assert_eq!(math::sqrt(x).to_bits(), libm::sqrtf(x).to_bits());
        bits += 0x0000_3f1d;
    }
    assert!(math::sqrt(-1.0).is_nan());
}

/// The largest absolute error of f32 `(sin, cos)` pairs against the exact
/// values at angles `a` (radians), in units of ulp(1) (values cross zero).
fn worst_sincos_ulp1(pairs: impl Iterator<Item = ((f32, f32), f64)>) -> f64 {
    let mut worst = 0.0f64;
    for ((s, c), a) in pairs {
        worst = worst
            .max((f64::from(s) - a.sin()).abs())
            .max((f64::from(c) - a.cos()).abs());
    }
    worst / f64::from(f32::EPSILON)
}

#[test]
fn sincos_turns_within_2_ulp_of_one() {
    let worst = worst_sincos_ulp1((0..1_000_000u32).map(|i| {
        let t = i as f32 / 1_000_000.0;
        (math::sincos_turns(t), f64::from(t) * std::f64::consts::TAU)
    }));
    assert!(worst <= 2.0, "worst {worst} ulp(1)");
}

#[test]
fn sincos_quarter_within_2_ulp_of_one() {
    let q = std::f64::consts::FRAC_PI_4;
    let worst = worst_sincos_ulp1((-500_000..=500_000i32).map(|i| {
        let x = (f64::from(i) / 500_000.0 * q) as f32;
        (math::sincos_quarter(x), f64::from(x))
    }));
    assert!(worst <= 2.0, "worst {worst} ulp(1)");
}

#[test]
fn log2_exp2_powf_within_a_few_ulp() {
    let mut worst_log = 0.0f64;
    let mut worst_pow = 0.0f64;
    let mut x = 1.0e-30f32;
    while x < 1.0e30 {
        let e = f64::from(x).log2();
        // near log2 = 0 measure against ulp(1)
        let err =
            (f64::from(math::log2(x)) - e).abs() / (f64::from(f32::EPSILON) * e.abs().max(1.0));
        worst_log = worst_log.max(err);
        // the sRGB curve's domain
        if (0.003..=1.0).contains(&x) {
            worst_pow = worst_pow.max(ulps(math::powf(x, 1.0 / 2.4), f64::from(x).powf(1.0 / 2.4)));
        }
        x *= 1.0123;
    }
    assert!(worst_log < 2.0, "log2 worst {worst_log} ulp");
    assert!(worst_pow < 4.0, "powf worst {worst_pow} ulp on [0.003, 1]");
    let mut worst_exp = 0.0f64;
    for i in -1260..1270 {
        let y = i as f32 * 0.1 + 0.0371;
        worst_exp = worst_exp.max(ulps(math::exp2(y), 2f64.powf(f64::from(y))));
    }
    assert!(worst_exp < 3.0, "exp2 worst {worst_exp} ulp");
}

#[test]
fn micromath_fast_functions_are_approximations() {
    // documented: ~5 % for sqrt; this is why geometry never uses them
    let e = (f64::from(math::fast_sqrt(2.0)) - 2f64.sqrt()).abs() / 2f64.sqrt();
    assert!(e > 1e-4 && e < 0.1, "fast_sqrt rel error {e}");
    let (s, c) = math::fast_sincos_turns(0.1);
    let a = 0.1 * std::f64::consts::TAU;
    assert!((f64::from(s) - a.sin()).abs() < 1e-2 && (f64::from(c) - a.cos()).abs() < 1e-2);
}

/// Error-free transformations: `two_sum`, `two_square` and `two_prod`
/// return the rounded result and its exact error (a sum or product of two
/// f32s is exact in f64), over operands spanning 2⁻⁴⁰..2⁴⁰ of both signs (no error term underflows).
#[test]
fn error_free_transformations_are_exact() {
    let mut z = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        z ^= z << 13;
        z ^= z >> 7;
        z ^= z << 17;
        z
    };
    for _ in 0..200_000 {
        let r = next();
        let e = ((r >> 32) % 80) as i32 - 40;
        let a = f32::from_bits((r as u32 & 0x807f_ffff) | 0x3f80_0000) * 2f32.powi(e);
        let r = next();
        let e = ((r >> 32) % 80) as i32 - 40;
        let b = f32::from_bits((r as u32 & 0x807f_ffff) | 0x3f80_0000) * 2f32.powi(e);
        let (p, pe) = math::two_prod(a, b);
        assert_eq!(p, a * b);
        assert_eq!(
            f64::from(p) + f64::from(pe),
            f64::from(a) * f64::from(b),
            "{a:e} * {b:e}"
        );
        let (q, qe) = math::two_square(a);
        assert_eq!(f64::from(q) + f64::from(qe), f64::from(a) * f64::from(a));
        let (s, se) = math::two_sum(a, b);
        assert_eq!(s, a + b);
        assert_eq!(
            f64::from(s) + f64::from(se),
            f64::from(a) + f64::from(b),
            "{a:e} + {b:e}"
        );
    }
}

/// The sRGB curve's power as a polynomial: within 2 ulp of double precision
/// on a dense sweep of [2⁻⁹, 1) and at the ends of each binade; the general
/// power outside that range.
#[test]
fn srgb_power_within_2_ulp() {
    let mut worst = 0.0f64;
    let mut check = |x: f32| {
        worst = worst.max(ulps(math::srgb_power(x), f64::from(x).powf(1.0 / 2.4)));
    };
    let (lo, hi) = ((2.0f32).powi(-9).to_bits(), 1.0f32.to_bits());
    for b in (lo..hi).step_by(97) {
        check(f32::from_bits(b));
    }
    for e in -9..0 {
        let x = (2.0f32).powi(e);
        check(x);
        check(f32::from_bits(x.to_bits() - 1));
        check(f32::from_bits((2.0 * x).to_bits() - 1));
    }
    assert!(worst <= 2.0, "worst {worst} ulp");
    for x in [0.001f32, 1.0, 3.0] {
        assert_eq!(math::srgb_power(x), math::powf(x, 1.0 / 2.4));
    }
    assert!(math::srgb_power(f32::NAN).is_nan());
}

/// atan2 and asin against double precision: within 4e-7 rad (under two
/// ulps of π; the series alone is within 1.2e-7) over every
/// quadrant, the axes, tiny and huge ratios; asin at ±1 and 0.
#[test]
fn atan2_and_asin_match_double_precision() {
    let mut z = 0x1234_5678_9abc_def1u64;
    let mut worst = 0.0f64;
    for k in 0..200_000u32 {
        z ^= z << 13;
        z ^= z >> 7;
        z ^= z << 17;
        let scale = [1.0f32, 1e-6, 1e6][k as usize % 3];
        let y = ((z >> 40) as f32 / 16_777_216.0 - 0.5) * scale;
        let x = (((z >> 16) & 0xff_ffff) as f32 / 16_777_216.0 - 0.5)
            * [1.0f32, 1e6, 1e-6][k as usize % 3];
        let e = (f64::from(math::atan2(y, x)) - f64::from(y).atan2(f64::from(x))).abs();
        worst = worst.max(e);
    }
    for (y, x) in [
        (0.0f32, 1.0f32),
        (1.0, 0.0),
        (0.0, -1.0),
        (-1.0, 0.0),
        (1.0, 1.0),
        (-1.0, -1.0),
    ] {
        let e = (f64::from(math::atan2(y, x)) - f64::from(y).atan2(f64::from(x))).abs();
        worst = worst.max(e);
    }
    assert!(worst < 4e-7, "atan2: worst error {worst:e} rad");
    for s in [-1.0f32, -0.999, -0.5, 0.0, 1e-8, 0.3, 0.75, 0.99999, 1.0] {
        let e = (f64::from(math::asin(s)) - f64::from(s).asin()).abs();
        assert!(e < 3e-7, "asin({s}): error {e:e}");
    }
}
