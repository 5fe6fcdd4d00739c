//! The denoiser on synthetic images whose truth is known: what each part
//! of the design is for, and that each safeguard, removed, fails a test.

// the tests index their images by pixel coordinates
#![allow(clippy::needless_range_loop)]

use super::*;
use rand_core::{Rng, SeedableRng};
use rand_xorshift::XorShiftRng;

const W: usize = 48;
const H: usize = 48;

/// A flat wall's texel: albedo `a`, scattered radiance `s`, variance `v`.
fn wall(a: Color, s: Color, v: f32, key: u32) -> Texel {
    let g = Guide {
        kind: GuideKind::Surface,
        albedo: a,
        normal: Vec3::new(0.0, 0.0, 1.0),
        key,
        deltas: 0,
        glass: false,
        flat: true,
        blurred: false,
        textured: crate::geometry::ObjectId::NONE,
    };
    // moments of n samples whose mean is s and whose mean's variance is v
    let n = 16u32;
    let nf = n as f32;
    let l = s.luminance();
    let m = Moments {
        scattered: [s.x * nf, s.y * nf, s.z * nf],
        direct: [0.0; 3],
        square: nf * l * l + v * nf * (nf - 1.0),
        // halves whose difference gives v: ((2h − Σ)/n)² = v
        half: 0.5 * (nf * l + nf * math::sqrt(v)),
        ..Moments::ZERO
    };
    Texel::new(&m, n, &g)
}

/// Runs the denoiser over `img` (row-major `W × H`) with `guards`.
fn run(img: &[Texel], guards: Guards) -> [[Color; W]; H] {
    let mut columns = [Column::EMPTY; W];
    let mut out = [[Color::ZERO; W]; H];
    let mut d = Denoiser::new(W as u32, H as u32, &mut columns)
        .unwrap()
        .with_guards(guards);
    d.run(
        |y, x| img[y as usize * W + x as usize],
        |y, x, c| out[y as usize][x as usize] = c,
    );
    out
}

/// The image unfiltered (each texel's raw value).
fn raw_of(img: &[Texel]) -> [[Color; W]; H] {
    let mut raw = [[Color::ZERO; W]; H];
    for y in 0..H {
        for x in 0..W {
            raw[y][x] = img[y * W + x].raw();
        }
    }
    raw
}

/// Gaussian noise from a seeded generator (Box–Muller through the math
/// module).
fn gauss(rng: &mut XorShiftRng) -> f32 {
    let u1 = ((rng.next_u32() >> 8) as f32 + 0.5) / 16_777_216.0;
    let u2 = (rng.next_u32() >> 8) as f32 / 16_777_216.0;
    let r = math::sqrt(-2.0 * core::f32::consts::LN_2 * math::log2(u1));
    r * math::sincos_turns(u2).1
}

#[test]
fn a_noise_free_image_passes_through_unchanged() {
    // every pixel's samples agree (variance 0): "no filter" has SURE 0 and
    // wins every tie, so the output has the input's bits
    let mut img = [Texel::kept(Color::ZERO); W * H];
    for (i, t) in img.iter_mut().enumerate() {
        let v = (i % 7) as f32 * 0.1 + (i / W % 5) as f32 * 0.03;
        *t = wall(Color::splat(0.5), Color::new(v, 0.5 * v, 0.2), 0.0, 1);
    }
    let out = run(&img, Guards::default());
    for y in 0..H {
        for x in 0..W {
            assert_eq!(out[y][x], img[y * W + x].raw(), "pixel ({x}, {y})");
        }
    }
}

/// A flat wall, mean `mu`, each pixel's mean with Gaussian noise of
/// variance `var` (and that variance as its estimate).
fn noisy_wall(mu: f32, var: f32, seed: u64) -> [Texel; W * H] {
    let mut rng = XorShiftRng::seed_from_u64(seed);
    let mut img = [Texel::kept(Color::ZERO); W * H];
    for t in img.iter_mut() {
        let v = mu + math::sqrt(var) * gauss(&mut rng);
        *t = wall(Color::splat(0.5), Color::splat(v), var, 1);
    }
    img
}

/// Filter `k`'s predicted error variance in the interior of a flat wall:
/// `σ² Σw² / (Σw)²` of its weights, the product of the row pass's and the
/// column pass's Gaussians.
fn predicted(var: f32, k: usize) -> f32 {
    let (mut s, mut s2) = (0.0f32, 0.0f32);
    let reach = if k == 0 { NARROW as i32 } else { RADIUS as i32 };
    for d in -reach..=reach {
        let w =
            math::exp2(-core::f32::consts::LOG2_E * (d * d) as f32 / (2.0 * WIDTHS[k] * WIDTHS[k]));
        s += w;
        s2 += w * w;
    }
    let one = s2 / (s * s);
    var * one * one
}

/// The MSE over the interior of `noisy_wall(0.4, var, seed)` denoised,
/// and the raw image's.
fn wall_mse(var: f32, seed: u64) -> (f32, f32) {
    let img = noisy_wall(0.4, var, seed);
    let out = run(&img, Guards::default());
    let (mut se, mut raw, mut n) = (0.0f32, 0.0f32, 0.0f32);
    for y in RADIUS..H - RADIUS {
        for x in RADIUS..W - RADIUS {
            let d = out[y][x].luminance() - 0.4;
            let r = img[y * W + x].raw().luminance() - 0.4;
            se += d * d;
            raw += r * r;
            n += 1.0;
        }
    }
    (se / n, raw / n)
}

#[test]
fn a_flat_wall_converges_to_its_mean_at_the_rate_the_filter_predicts() {
    // a linear filter of a flat wall has no bias: its error variance is
    // σ² Σw²/(Σw)², the widest's about σ²/69 here, the narrowest's σ²/12.
    // SURE picks among them (mostly the widest), so the measured MSE lies
    // between the two predictions (the widest's with a 3σ margin for the
    // ~40 independent values the correlated outputs make)
    let (mse, raw) = wall_mse(0.01, 1);
    let (widest, narrowest) = (predicted(0.01, WIDTHS.len() - 1), predicted(0.01, 0));
    assert!(
        mse > 0.5 * widest && mse < narrowest,
        "MSE {mse}, predicted {widest} (widest) .. {narrowest} (narrowest), raw {raw}"
    );
    // and it falls with the samples as the input's variance does (1/N): the
    // same noise pattern at a hundredth of the variance makes the same
    // choices and a hundredth of the MSE (but for a few pixels: the choice
    // weighs each pixel by its brightness, which the noise moves)
    let (small, _) = wall_mse(1e-4, 1);
    let ratio = (mse / 0.01) / (small / 1e-4);
    assert!(
        math::abs(ratio - 1.0) < 0.02,
        "MSE/σ² at two σ: ratio {ratio}"
    );
}

#[test]
fn a_step_between_two_albedos_does_not_leak() {
    // the left half has albedo 0.8, the right 0.2, under the same light
    // (shade 0.5): the filter averages the shade and multiplies each
    // pixel's own albedo back, so the edge stays where it is
    let mut rng = XorShiftRng::seed_from_u64(3);
    let mut img = [Texel::kept(Color::ZERO); W * H];
    for (i, t) in img.iter_mut().enumerate() {
        let a = if i % W < W / 2 { 0.8 } else { 0.2 };
        let v = a * 0.5 * (1.0 + 0.2 * gauss(&mut rng));
        *t = wall(
            Color::splat(a),
            Color::splat(v),
            (a * 0.5 * 0.2) * (a * 0.5 * 0.2),
            1,
        );
    }
    let out = run(&img, Guards::default());
    for x in [W / 2 - 1, W / 2] {
        let want = if x < W / 2 { 0.4 } else { 0.1 };
        let mut mean = 0.0;
        for row in out.iter() {
            mean += row[x].luminance();
        }
        mean /= H as f32;
        // each pixel's noise is 20 %, at most 3 % in a column's mean (3σ);
        // a leak across the edge would move it by up to 0.15
        assert!(
            math::abs(mean - want) < 0.05 * want,
            "column {x}: mean {mean}, want {want}"
        );
    }
}

#[test]
fn an_emitters_pixels_are_untouched_and_never_a_tap() {
    let mut img = noisy_wall(0.4, 0.01, 4);
    let light = Color::new(40.0, 30.0, 20.0);
    for y in 20..28 {
        for x in 20..28 {
            img[y * W + x] = Texel::kept(light);
        }
    }
    let out = run(&img, Guards::default());
    let mut before = img;
    for y in 20..28 {
        for x in 20..28 {
            assert_eq!(out[y][x], light);
            // its value does not reach the wall around it
            before[y * W + x] = Texel::kept(Color::ZERO);
        }
    }
    let other = run(&before, Guards::default());
    for y in 0..H {
        for x in 0..W {
            if !(20..28).contains(&x) || !(20..28).contains(&y) {
                assert_eq!(out[y][x], other[y][x], "({x}, {y})");
            }
        }
    }
}

#[test]
fn a_light_seen_directly_is_kept_and_the_rest_filtered() {
    // a pixel whose samples also saw a light (a light's edge) is kept
    // whole, whatever its centre sees; so is a surface seen straight with
    // a direct part (a focused caustic, whose scattered part holds the
    // broad paths' spikes near the focal spot, or the background at a
    // silhouette); behind a mirror, a pixel whose samples saw no light
    // keeps its direct part (the mirror's images) and filters the rest
    let g = |deltas| Guide {
        kind: GuideKind::Surface,
        albedo: Color::splat(0.5),
        normal: Vec3::new(0.0, 0.0, 1.0),
        key: 1,
        deltas,
        glass: false,
        flat: true,
        blurred: false,
        textured: crate::geometry::ObjectId::NONE,
    };
    let m = Moments {
        scattered: [4.0; 3],
        direct: [16.0, 0.0, 0.0],
        square: 4.0,
        half: 2.0,
        seen: 1,
    };
    assert!(!Texel::new(&m, 16, &g(0)).filtered);
    assert!(!Texel::new(&m, 16, &g(1)).filtered);
    let unseen = Moments { seen: 0, ..m };
    assert!(!Texel::new(&unseen, 16, &g(0)).filtered);
    let t = Texel::new(&unseen, 16, &g(1));
    assert!(t.filtered);
    assert_eq!(t.direct, Color::new(1.0, 0.0, 0.0));
}

/// A wall whose true value has a ramp the filter blurs (bias), and noise
/// whose variance varies: the regime where the choice matters.
fn ramp_wall(seed: u64) -> ([Texel; W * H], [f32; W * H]) {
    let mut rng = XorShiftRng::seed_from_u64(seed);
    let mut img = [Texel::kept(Color::ZERO); W * H];
    let mut truth = [0.0; W * H];
    for (i, t) in img.iter_mut().enumerate() {
        let x = (i % W) as f32;
        // a sharp lighting ridge every 12 pixels, on a smooth field
        let mu = 0.2 + if (i % W) % 12 < 2 { 0.6 } else { 0.0 } + 0.002 * x;
        let var = 0.0004;
        truth[i] = mu;
        let v = mu + math::sqrt(var) * gauss(&mut rng);
        *t = wall(Color::splat(1.0), Color::splat(v), var, 1);
    }
    (img, truth)
}

fn mse(out: &[[Color; W]; H], truth: &[f32]) -> f32 {
    let mut s = 0.0;
    for y in 0..H {
        for x in 0..W {
            let d = out[y][x].luminance() - truth[y * W + x];
            s += d * d;
        }
    }
    s / (W * H) as f32
}

#[test]
fn without_no_filter_as_a_choice_the_error_rises_above_the_raw_image() {
    // sharp ridges with little noise: every filter's bias exceeds the noise
    // it removes, so the choice must be able to say "no filter"
    let (img, truth) = ramp_wall(5);
    let raw = raw_of(&img);
    let raw = mse(&raw, &truth);
    let with = mse(&run(&img, Guards::default()), &truth);
    let without = mse(
        &run(
            &img,
            Guards {
                no_filter: false,
                ..Guards::default()
            },
        ),
        &truth,
    );
    assert!(with <= raw, "with the guard: {with} > raw {raw}");
    assert!(without > raw, "without it: {without} <= raw {raw}");
}

#[test]
fn without_the_divergence_term_sure_prefers_filters_that_keep_the_noise() {
    // without 2σ²w_pp/W, SURE of a filter is |F − y|² − σ²: a filter that
    // barely moves y (all weight on the pixel itself: here the narrow one
    // on isolated pixels) looks better than it is. On a flat noisy wall
    // the full estimate picks the widest filter; without the term the
    // output keeps more of the noise
    let img = noisy_wall(0.4, 0.01, 6);
    let truth = [0.4f32; W * H];
    let with = mse(&run(&img, Guards::default()), &truth);
    let without = mse(
        &run(
            &img,
            Guards {
                divergence: false,
                ..Guards::default()
            },
        ),
        &truth,
    );
    assert!(without > 1.2 * with, "without: {without}, with: {with}");
}

#[test]
fn the_workspace_is_checked_and_sized() {
    let mut columns = [Column::EMPTY; 4];
    assert!(Denoiser::new(4, 4, &mut columns).is_ok());
    assert_eq!(
        Denoiser::new(5, 4, &mut columns).err(),
        Some(DenoiseError::Workspace)
    );
    assert_eq!(
        Denoiser::new(0, 4, &mut columns).err(),
        Some(DenoiseError::Size)
    );
    // the budget the boards' figures are made of (docs/denoise.md): a
    // column's rings, at most 800 bytes
    assert_eq!(workspace_bytes(240), 240 * core::mem::size_of::<Column>());
    assert!(core::mem::size_of::<Column>() <= 800);
}

#[test]
fn without_the_consistency_guard_a_noisy_neighbourhood_chooses_a_blur_for_a_quiet_pixel() {
    // a thin line (one pixel wide, 0.5) lit without noise across a noisy
    // wall (0.4, σ² = 0.01): every choice window holds 7 pixels of the
    // line and 42 of the wall, whose SURE (relative and absolute alike)
    // favours the widest filter. Taken on the line, it would blur the line
    // into the wall; the guard refuses a filter that moves a pixel by more
    // than its own noise allows
    let mut rng = XorShiftRng::seed_from_u64(8);
    let mut img = [Texel::kept(Color::ZERO); W * H];
    for (i, t) in img.iter_mut().enumerate() {
        let line = i % W == W / 2;
        let (mu, var) = if line { (0.5, 1e-8) } else { (0.4, 0.01) };
        let v = mu + math::sqrt(var) * gauss(&mut rng);
        *t = wall(Color::splat(1.0), Color::splat(v), var, 1);
    }
    let line = |out: &[[Color; W]; H]| {
        let mut s = 0.0;
        for row in out.iter() {
            let d = row[W / 2].luminance() - 0.5;
            s += d * d;
        }
        s
    };
    let with = line(&run(&img, Guards::default()));
    let without = line(&run(
        &img,
        Guards {
            consistency: false,
            ..Guards::default()
        },
    ));
    let raw = raw_of(&img);
    let raw = line(&raw);
    assert!(
        with <= 2.0 * raw + 1e-9,
        "with the guard: {with}, raw {raw}"
    );
    assert!(
        without > 100.0 * (raw + 1e-9),
        "without: {without}, raw {raw}"
    );
}

#[test]
fn a_firefly_is_no_tap_of_its_neighbours() {
    // one pixel of a noisy wall (σ = 0.1) holds a rare bright path: one
    // sample of 57 among 16, a mean of 4 whose spread (σ ≈ 3.7) is 37
    // times its neighbours'. As a tap it would lift each of them by a few
    // hundredths, within their own noise, so that only this rule keeps
    // it out
    let mut img = noisy_wall(0.4, 0.01, 7);
    img[24 * W + 24] = wall(Color::splat(0.5), Color::splat(4.0), 13.5, 1);
    let clean = run(&noisy_wall(0.4, 0.01, 7), Guards::default());
    let moved = |out: &[[Color; W]; H]| {
        let mut s = 0.0;
        for y in 20..29 {
            for x in 20..29 {
                if (x, y) != (24, 24) {
                    let d = out[y][x].luminance() - clean[y][x].luminance();
                    s += d * d;
                }
            }
        }
        s
    };
    let with = moved(&run(&img, Guards::default()));
    let without = moved(&run(
        &img,
        Guards {
            outlier: false,
            ..Guards::default()
        },
    ));
    assert!(
        without > 10.0 * with,
        "without the rule: {without}, with: {with}"
    );
}
