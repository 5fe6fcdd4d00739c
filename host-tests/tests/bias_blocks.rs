//! Regional bias: a whole-image mean or MSE can hide a region that is a few
//! percent off when brighter regions dominate it. Here the law checked is
//! unbiasedness region by region: the pooled mean of independent renders
//! of every row and every 8×8 block lies within 4 standard errors of an
//! independent double-precision reference (both sides' errors counted: the
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
use micropt::parse::parse;
use micropt_host::image::Image;
use micropt_host::metrics::{BiasReport, bias_z, pooled};
use micropt_host::render::{RenderJob, render};
use std::path::PathBuf;

fn data(name: &str) -> Image {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    Image::load_pfm(&root.join("data").join(name)).unwrap()
}

/// Renders smallpt `seeds` times at `spp` (uniform, so each render is
/// unbiased on its own) and compares the pooled image, with its standard
/// error from the renders' spread, with the reference row by row and 8×8
/// block by block.
fn smallpt_regions(seeds: u64, spp: u32) -> BiasReport {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let text = std::fs::read_to_string(root.join("scenes/smallpt.scene")).unwrap();
    let scene = parse(&text).unwrap();
    let reference = data("smallpt.pfm");
    let reference_se = data("smallpt.se.pfm");
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
            let out = render(&scene, &job, &|| {}).unwrap();
            assert_eq!(out.stats.nonfinite, 0);
            out.image
        })
        .collect();
    let (mean, se) = pooled(&renders).unwrap();
    bias_z(&mean, &se, &reference, &reference_se, 8).unwrap()
}

fn check(seeds: u64, spp: u32) {
    let z = smallpt_regions(seeds, spp);
    let label = format!("{seeds} x {spp} spp");
    for (what, g) in [("row", &z.rows), ("8x8 block", &z.blocks)] {
        figure(
            "smallpt regions",
            &format!("{what}s at {label}"),
            format!(
                "max |z| {:.2} (group {}, channel {}), chi2/dof {:.2}",
                g.max_abs_z, g.worst.0, g.worst.1, g.chi2_per_dof
            ),
        );
    }
    // 48 rows and 48 blocks, three channels each: an unbiased renderer
    // exceeds 4 standard errors in any of them with a probability of about
    // 2 % (each standard error estimated from 32 renders per pixel, summed
    // over 64 pixels: nearly normal); the f32-rounded ceiling gave z = +11
    // at the lamp's rim at this budget, the walls' 0.04-unit spawn offsets
    // z = −6 on the floor
    assert!(
        z.rows.max_abs_z <= 4.0 && z.blocks.max_abs_z <= 4.0,
        "regional bias: rows {:?}, blocks {:?}",
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
    check(32, 64);
}

/// The budget of the acceptance check, 8 × 1024 spp pooled as 32 × 256:
/// `cargo test -p micropt-host --test bias_blocks -- --ignored`.
#[test]
#[ignore]
fn smallpt_has_no_regional_bias_deep() {
    check(32, 256);
}
