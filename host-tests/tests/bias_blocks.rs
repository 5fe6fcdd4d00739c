//! Regional bias: a whole-image mean or MSE can hide a region that is a few
//! percent off when brighter regions dominate it. Here the law checked is
//! unbiasedness region by region: the pooled mean of independent renders
//! of every row and every 8×8 block lies within 4 standard errors of an
//! independent reference (smallpt's in double precision, gloss's, dof's and
//! many's from Mitsuba; both sides' errors counted: the
//! renders' from their spread over seeds, the reference's from its
//! per-pixel standard-error map).
//!
//! smallpt's scene is the hard case: walls are spheres of radius 1e5 whose
//! centres are not f32 values (the ceiling's lies 0.0016 from the nearest),
//! and the lamp pokes 0.27 units through the ceiling, so a rounding of the
//! ceiling's height moves the lamp's rim by 33 times as much.

mod common;

use common::figure;
use micropt::Options;
use micropt_host::image::Image;
use micropt_host::metrics::{BiasReport, bias_z, pooled};
use micropt_host::reference::scenes_dir;
use micropt_host::render::{RenderJob, parse_host, render};
use std::path::PathBuf;

fn data(name: &str) -> Image {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    Image::load_pfm(&root.join("data").join(name)).unwrap()
}

/// Renders scene `name` `seeds` times at `spp` (uniform, so each render is
/// unbiased on its own) and compares the pooled image, with its standard
/// error from the renders' spread, with the reference row by row and 8×8
/// block by block.
///
/// `reference_wrong` lists rows where the reference is known to be wrong:
/// the pooled mean takes the reference's values there, so that those rows
/// add nothing to their row's or block's difference.
fn regions(name: &str, seeds: u64, spp: u32, reference_wrong: &[u32]) -> BiasReport {
    let text = std::fs::read_to_string(scenes_dir().join(format!("{name}.scene"))).unwrap();
    let scene = parse_host(&text).unwrap();
    let reference = data(&format!("{name}.pfm"));
    let reference_se = data(&format!("{name}.se.pfm"));
    let renders: Vec<Image> = (0..seeds)
        .map(|s| {
            let job = RenderJob {
                width: reference.width,
                height: reference.height,
                spp,
                seed: 1_000 + s,
                threads: 0,
                options: Options::default(),
            };
            let out = render(&*scene, &job, &|| {}).unwrap();
            assert_eq!(out.stats.nonfinite, 0, "{name}");
            out.image
        })
        .collect();
    let (mut mean, se) = pooled(&renders).unwrap();
    for &y in reference_wrong {
        for x in 0..mean.width {
            let i = (y * mean.width + x) as usize;
            mean.pixels[i] = reference.pixels[i];
        }
    }
    bias_z(&mean, &se, &reference, &reference_se, 8).unwrap()
}

/// Asserts that no row and no 8×8 block of `name` at `seeds` × `spp` lies
/// beyond `bound` standard errors of the reference, and prints the figures.
fn check(name: &str, seeds: u64, spp: u32, bound: f64, reference_wrong: &[u32]) {
    let started = std::time::Instant::now();
    let z = regions(name, seeds, spp, reference_wrong);
    let label = format!("{seeds} x {spp} spp");
    for (what, g) in [("row", &z.rows), ("8x8 block", &z.blocks)] {
        figure(
            &format!("{name} regions"),
            &format!("{what}s at {label}"),
            format!(
                "max |z| {:.2} (group {}, channel {}), chi2/dof {:.2}",
                g.max_abs_z, g.worst.0, g.worst.1, g.chi2_per_dof
            ),
        );
    }
    figure(
        &format!("{name} regions"),
        &format!("seconds at {label}"),
        format!("{:.1}", started.elapsed().as_secs_f64()),
    );
    assert!(
        z.rows.max_abs_z <= bound && z.blocks.max_abs_z <= bound,
        "{name}: regional bias: rows {:?}, blocks {:?}",
        z.rows,
        z.blocks
    );
    // where neither side has noise (every render and the reference the
    // same value: the lamp seen directly) any difference is certain, and a
    // row or block with noise elsewhere would dilute it
    assert_eq!(
        z.pixels.exact_mismatches, 0,
        "pixels that differ from the reference where neither has noise: {:?}",
        z.pixels
    );
}

/// 32 renders of 64 spp (2,048 spp pooled).
#[test]
fn smallpt_has_no_regional_bias() {
    check("smallpt", 32, 64, 4.0, &[]);
}

/// The budget of the acceptance check, 8 × 1024 spp pooled as 32 × 256:
/// `cargo test -p micropt-host --test bias_blocks -- --ignored`.
#[test]
#[ignore]
fn smallpt_has_no_regional_bias_deep() {
    check("smallpt", 32, 256, 4.0, &[]);
}

/// Regional bias beyond smallpt, against the Mitsuba references
/// (docs/mitsuba.md), where a whole-image mean cannot see a bias confined
/// to a highlight, a window's rim or the lens' blur: dof, 32 × 256 spp
/// (about 15 s).
#[test]
#[ignore = "deep run: cargo test -p micropt-host --test bias_blocks -- --ignored"]
fn dof_has_no_regional_bias() {
    check("dof", 32, 256, 4.0, &[]);
}

/// gloss, 32 × 256 spp (about 25 s). Row 20 holds the horizon, where the
/// reference is 1.7 % too bright (docs/mitsuba.md): left out.
#[test]
#[ignore = "deep run; fails against the reference now (docs/mitsuba.md)"]
fn gloss_has_no_regional_bias() {
    check("gloss", 32, 256, 4.0, &[20]);
}

/// many, 32 × 256 spp (about 75 s). Row 4 holds the horizon, where the
/// reference is 1.9 % too bright (docs/mitsuba.md): left out.
#[test]
#[ignore = "deep run; fails against the reference now (docs/mitsuba.md)"]
fn many_has_no_regional_bias() {
    check("many", 32, 256, 4.0, &[4]);
}
