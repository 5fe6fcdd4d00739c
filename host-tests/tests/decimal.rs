//! The core's allocation-free, panic-free decimal parser
//! (`micropt::parse::parse_f32`) against std's `str::parse::<f32>`: both must
//! give the correctly rounded value (IEEE 754 round half to even) bit for bit,
//! and reject the same strings. The hard inputs are exact halfway points
//! between neighbouring floats (printed in full from their exact double
//! value), where only an exact algorithm rounds to even.

use micropt::parse::parse_f32;
use proptest::prelude::*;

fn same(s: &str) -> Result<(), TestCaseError> {
    let ours = parse_f32(s);
    let std = s.parse::<f32>().ok();
    let ok = match (ours, std) {
        (Some(a), Some(b)) => a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
        (None, None) => true,
        _ => false,
    };
    prop_assert!(ok, "{:?}: ours {:?}, std {:?}", s, ours, std);
    Ok(())
}

/// The exact decimal expansion of the midpoint between the float with these
/// bits and the next one up, nudged by `nudge` ulps of the last printed digit
/// (0: the exact tie).
fn midpoint(bits: u32, nudge: i8) -> Option<String> {
    let x = f32::from_bits(bits);
    let next = f32::from_bits(bits.checked_add(1)?);
    if !x.is_finite() || !next.is_finite() || x < 0.0 {
        return None;
    }
    // exact in double precision (one more bit than f32), and at most 113
    // significant digits: 130 digits print it exactly
    let mid = (f64::from(x) + f64::from(next)) * 0.5;
    let s = format!("{mid:.130e}");
    if nudge == 0 {
        return Some(s);
    }
    let (mant, exp) = s.split_once('e')?;
    let mut digits: Vec<u8> = mant.bytes().collect();
    // add or subtract one unit in the last place of the 131-digit mantissa
    let last = digits.len() - 1;
    if nudge > 0 {
        digits.push(b'1');
    } else if digits[last] > b'0' {
        digits[last] -= 1;
    } else {
        return None;
    }
    Some(format!("{}e{exp}", String::from_utf8(digits).ok()?))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn halfway_points_round_like_std(bits in 0u32..0x7f80_0000, nudge in -1i8..=1) {
        if let Some(s) = midpoint(bits, nudge) {
            same(&s)?;
        }
    }

    #[test]
    fn printed_floats_round_like_std(bits: u32, prec in 0usize..60) {
        let x = f32::from_bits(bits);
        same(&format!("{x}"))?;
        same(&format!("{x:.prec$e}"))?;
        same(&format!("{:.prec$}", f64::from(x)))?;
    }

    #[test]
    fn arbitrary_strings_parse_like_std(s in "[+-]?[0-9]{0,30}(\\.[0-9]{0,30})?([eE][+-]?[0-9]{0,4})?") {
        same(&s)?;
    }

    #[test]
    fn arbitrary_bytes_parse_like_std(s in "[0-9.eE+\\-infatyINFATY ]{0,16}") {
        same(&s)?;
    }
}

#[test]
fn subnormal_and_overflow_boundaries() {
    // the smallest subnormal, its half (a tie to even: 0) and 1.5 times it
    // (a tie to even: 2), the largest float and MAX + half an ulp (a tie
    // that rounds to infinity)
    let min = f64::from(f32::from_bits(1));
    let max = f64::from(f32::MAX);
    let ulp = f64::from(f32::MAX) - f64::from(f32::from_bits(f32::MAX.to_bits() - 1));
    for v in [min, min * 0.5, min * 1.5, max, max + ulp * 0.5] {
        for s in [
            format!("{v:.130e}"),
            format!("-{v:.130e}"),
            format!("{v:e}"),
        ] {
            same(&s).unwrap();
        }
    }
    assert_eq!(parse_f32(&format!("{:.130e}", min * 0.5)), Some(0.0));
    assert_eq!(
        parse_f32(&format!("{:.130e}", min * 1.5)),
        Some(f32::from_bits(2))
    );
    assert_eq!(
        parse_f32(&format!("{:.130e}", max + ulp * 0.5)),
        Some(f32::INFINITY)
    );
}

/// `micropt::parse::residual` gives what the f32 lacks: `hi + lo` equals
/// the decimal (as std's f64 reads it, itself within 2⁻⁵³) to 2⁻⁴⁰ of its
/// magnitude, 2¹⁶ times closer than `hi` alone can be in general.
fn residual_is_accurate(s: &str) -> Result<(), TestCaseError> {
    let Some(hi) = parse_f32(s) else {
        prop_assert_eq!(micropt::parse::residual(s, 0.0), 0.0);
        return Ok(());
    };
    let lo = micropt::parse::residual(s, hi);
    let exact: f64 = s.parse().unwrap();
    if !(hi.is_normal() && exact.abs() > 1e-28 && exact.abs() < 1e36) {
        prop_assert!(lo.abs() <= hi.abs(), "{s}: lo {lo}");
        return Ok(());
    }
    let err = (f64::from(hi) + f64::from(lo) - exact).abs();
    prop_assert!(
        err <= exact.abs() * 2f64.powi(-40),
        "{s}: hi {hi} lo {lo}, error {err:e} of {exact:e}"
    );
    Ok(())
}

#[test]
fn residual_of_scene_values() {
    for s in [
        "-99918.4",
        "100001",
        "681.33",
        "0.1",
        "-0.3",
        "1e5",
        "16.5",
        "123456789.123",
        "1.5e-7",
        "3.4e37",
        "0",
        "-0",
    ] {
        residual_is_accurate(s).unwrap();
    }
    // the ceiling of smallpt: −99918.4 is 0.0015625 below its f32
    let lo = micropt::parse::residual("-99918.4", -99_918.4);
    assert!((f64::from(lo) + 0.0015625).abs() < 1e-9, "{lo}");
}

proptest! {
    #[test]
    fn residual_of_random_decimals(int in 0u64..10_000_000_000, frac in 0u32..100_000, exp in -20i32..20, neg: bool) {
        let s = format!("{}{int}.{frac:05}e{exp}", if neg { "-" } else { "" });
        residual_is_accurate(&s)?;
    }
}
