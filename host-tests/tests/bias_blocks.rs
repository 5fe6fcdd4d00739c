//! Regional bias: a whole-image mean or MSE can hide a region that is a few
//! percent off when brighter regions dominate it. Here the law checked is
//! unbiasedness region by region: the pooled mean of independent renders
//! of every row and every 8×8 block lies within 4 standard errors of an
//! independent reference (smallpt's in double precision, gloss's, dof's and
//! many's from Mitsuba, gloss's and many's also from Blender Cycles, and the
//! horizon rows of gloss and many from an exact integral,
//! `tools/horizon_rows.py`; both sides' errors counted: the renders' from
//! their spread over seeds, the reference's from its per-pixel
//! standard-error map).
//!
//! Each reference judges only the pixels where it has no known
//! departure from the scene format (docs/mitsuba.md, "Regional bias of
//! micropt against the references"); a row or block is compared with each
//! reference that judges any of its pixels, over those pixels.
//!
//! smallpt's scene is the hard case: walls are spheres of radius 1e5 whose
//! centres are not f32 values (the ceiling's lies 0.0016 from the nearest),
//! and the lamp pokes 0.27 units through the ceiling, so a rounding of the
//! ceiling's height moves the lamp's rim by 33 times as much.

mod common;

use common::figure;
use micropt::{Color, Options};
use micropt_host::image::Image;
use micropt_host::metrics::{BiasReport, bias_z, pooled};
use micropt_host::reference::scenes_dir;
use micropt_host::render::{RenderJob, parse_host, render};
use std::path::PathBuf;

fn data_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(name)
}

fn data(name: &str) -> Image {
    Image::load_pfm(&data_path(name)).unwrap()
}

/// One reference of a scene and the pixels it judges.
struct Truth {
    /// What it is, for the figures.
    label: &'static str,
    /// Its image.
    image: Image,
    /// Its per-pixel standard error.
    se: Image,
    /// Whether it judges pixel (x, y).
    judges: Box<dyn Fn(u32, u32) -> bool>,
}

impl Truth {
    /// The reference `file` (.pfm and .se.pfm in host-tests/data), judging
    /// the pixels `judges` accepts.
    fn file(label: &'static str, file: &str, judges: impl Fn(u32, u32) -> bool + 'static) -> Self {
        Self {
            label,
            image: data(&format!("{file}.pfm")),
            se: data(&format!("{file}.se.pfm")),
            judges: Box::new(judges),
        }
    }

    /// The exact values of `name`'s ground-and-sky pixels of its horizon
    /// rows (host-tests/data/NAME.horizon.csv, written by
    /// tools/horizon_rows.py), judging those pixels only. A pixel's error
    /// is its integral's standard error and the bound on what the scene's
    /// other spheres can change in it, added in quadrature (relative to
    /// the value: bounds below 2.4e-6, standard errors below 6e-6; the
    /// renders' errors of those pixels are 2e-4 to 1e-3).
    fn horizon(name: &str, width: u32, height: u32) -> Self {
        let text = std::fs::read_to_string(data_path(&format!("{name}.horizon.csv"))).unwrap();
        let (mut image, mut se) = (Image::new(width, height), Image::new(width, height));
        let mut settled = vec![false; (width * height) as usize];
        for line in text.lines().filter(|l| !l.starts_with('#')).skip(1) {
            let v: Vec<f64> = line.split(',').map(|f| f.parse().unwrap()).collect();
            let (x, y) = (v[0] as u32, v[1] as u32);
            let e = |s: f64| (s * s + v[8] * v[8]).sqrt() as f32;
            image.set(x, y, Color::new(v[2] as f32, v[3] as f32, v[4] as f32));
            se.set(x, y, Color::new(e(v[5]), e(v[6]), e(v[7])));
            settled[(y * width + x) as usize] = true;
        }
        assert!(settled.iter().any(|&s| s), "{name}: no settled pixel");
        Self {
            label: "exact horizon",
            image,
            se,
            judges: Box::new(move |x, y| settled[(y * width + x) as usize]),
        }
    }
}

/// Renders scene `name` `seeds` times at `spp` (uniform, so each render is
/// unbiased on its own) and compares the pooled image, with its standard
/// error from the renders' spread, with each reference over the pixels it
/// judges, row by row and 8×8 block by block: a pixel it does not judge
/// takes the reference's value and no error on both sides, so that it adds
/// nothing to its row's or block's difference or variance.
fn regions(name: &str, seeds: u64, spp: u32, truths: &[Truth]) -> Vec<BiasReport> {
    // a shipped scene, or one of the tests' own (host-tests/data)
    let own = data_path(&format!("{name}.scene"));
    let path = if own.exists() {
        own
    } else {
        scenes_dir().join(format!("{name}.scene"))
    };
    let text = std::fs::read_to_string(path).unwrap();
    let scene = parse_host(&text).unwrap();
    let (width, height) = (truths[0].image.width, truths[0].image.height);
    let renders: Vec<Image> = (0..seeds)
        .map(|s| {
            let job = RenderJob {
                width,
                height,
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
    let (mean, se) = pooled(&renders).unwrap();
    // MICROPT_BIAS_DUMP=DIR writes the pooled image and its error, for
    // comparisons of one's own (docs/mitsuba.md)
    if let Some(dir) = std::env::var_os("MICROPT_BIAS_DUMP") {
        for (what, img) in [("mean", &mean), ("se", &se)] {
            let file = PathBuf::from(&dir).join(format!("{name}.{seeds}x{spp}.{what}.pfm"));
            img.write_pfm(std::io::BufWriter::new(
                std::fs::File::create(file).unwrap(),
            ))
            .unwrap();
        }
    }
    truths
        .iter()
        .map(|t| {
            let (mut m, mut s, mut rs) = (mean.clone(), se.clone(), t.se.clone());
            for y in 0..height {
                for x in 0..width {
                    if !(t.judges)(x, y) {
                        m.set(x, y, t.image.get(x, y));
                        s.set(x, y, Color::ZERO);
                        rs.set(x, y, Color::ZERO);
                    }
                }
            }
            bias_z(&m, &s, &t.image, &rs, 8).unwrap()
        })
        .collect()
}

/// Asserts that no row and no 8×8 block of `name` at `seeds` × `spp` lies
/// beyond `bound` standard errors of any reference, and prints the
/// figures.
fn check(name: &str, seeds: u64, spp: u32, bound: f64, truths: &[Truth]) {
    let started = std::time::Instant::now();
    let reports = regions(name, seeds, spp, truths);
    let label = format!("{seeds} x {spp} spp");
    for (t, z) in truths.iter().zip(&reports) {
        for (what, g) in [("row", &z.rows), ("8x8 block", &z.blocks)] {
            figure(
                &format!("{name} regions"),
                &format!("{what}s at {label} against {}", t.label),
                format!(
                    "max |z| {:.2} (group {}, channel {}), chi2/dof {:.2}, groups {}",
                    g.max_abs_z, g.worst.0, g.worst.1, g.chi2_per_dof, g.count
                ),
            );
        }
    }
    figure(
        &format!("{name} regions"),
        &format!("seconds at {label}"),
        format!("{:.1}", started.elapsed().as_secs_f64()),
    );
    for (t, z) in truths.iter().zip(&reports) {
        assert!(
            z.rows.max_abs_z <= bound && z.blocks.max_abs_z <= bound,
            "{name}: regional bias against {}: rows {:?}, blocks {:?}",
            t.label,
            z.rows,
            z.blocks
        );
        // where neither side has noise (every render and the reference the
        // same value: the lamp seen directly) any difference is certain,
        // and a row or block with noise elsewhere would dilute it
        assert_eq!(
            z.pixels.exact_mismatches, 0,
            "pixels that differ from {} where neither has noise: {:?}",
            t.label, z.pixels
        );
    }
}

/// The one reference of `name` (host-tests/data/NAME.pfm), judging every
/// pixel.
fn reference(name: &str) -> Vec<Truth> {
    vec![Truth::file("the reference", name, |_, _| true)]
}

/// 32 renders of 64 spp (2,048 spp pooled).
#[test]
fn smallpt_has_no_regional_bias() {
    check("smallpt", 32, 64, 4.0, &reference("smallpt"));
}

/// The budget of the acceptance check, 8 × 1024 spp pooled as 32 × 256:
/// `cargo test -p micropt-host --test bias_blocks -- --ignored`.
#[test]
#[ignore]
fn smallpt_has_no_regional_bias_deep() {
    check("smallpt", 32, 256, 4.0, &reference("smallpt"));
}

/// Regional bias beyond smallpt, against the Mitsuba references
/// (docs/mitsuba.md), where a whole-image mean cannot see a bias confined
/// to a highlight, a window's rim or the lens' blur: dof, 32 × 256 spp
/// (about 15 s).
#[test]
#[ignore = "deep run: cargo test -p micropt-host --test bias_blocks -- --ignored"]
fn dof_has_no_regional_bias() {
    check("dof", 32, 256, 4.0, &reference("dof"));
}

/// A scene no reference of the shipped set has: dof's thin lens and sun
/// over mirror and glass balls at several depths (host-tests/data/
/// lens-balls.scene), where the highlight estimator takes the sun in each
/// mirror and through each glass ball, solved from each sample's lens
/// position, and the caustic sample shares the glass balls' folds with
/// the BSDF sample; against Mitsuba 3 (32,768 spp, its error map), 32 ×
/// 256 spp (about 20 s). Rows 25-27 (the horizon, blurred by the lens)
/// are not judged: Mitsuba's ground is a finite rectangle, and its
/// horizon rows are brighter than an infinite plane's (docs/mitsuba.md;
/// here row 25's pixels are 2.5-3.4 standard errors darker in micropt
/// across the whole width, not only where the balls are).
#[test]
#[ignore = "deep run: cargo test -p micropt-host --test bias_blocks -- --ignored"]
fn lens_balls_have_no_regional_bias() {
    let mitsuba = Truth::file("Mitsuba", "lens-balls", |_, y| !(25..28).contains(&y));
    check("lens-balls", 32, 256, 4.0, &[mitsuba]);
}

/// gloss, 32 × 1,024 spp (about 50-90 s), against three references, each
/// over the pixels where it has no known departure (docs/mitsuba.md):
///
/// - row 20 (the horizon): the exact integral of the infinite checker
///   floor and the sky, over the pixels that show only those (all 96);
///   both renderers' floors are finite and their row too bright there;
/// - Mitsuba: every other row;
/// - Cycles: rows 0-19 and 29-63, less x 0-47, y 16-47. Its floor beyond
///   about 25 units (rows 21-28) is darker than the exact integral's lower
///   bound by up to 1.1 % (z −45; micropt and Mitsuba are above it); and
///   around the two roughest spheres (alpha 0.45 and 0.18: x 0-47,
///   y 16-47) its height-correlated masking-shadowing makes them brighter
///   than the format's separable G1·G1 (1.5-3.4 % in blocks there).
///
/// 1,024 spp per render, not 256: the floor's light through the
/// near-mirror spheres from the small lights comes in rare paths, and at
/// 32 × 256 spp the renders' spread misses them (the bottom rows' error
/// estimate hardly shrinks from 256 to 1,024 spp, and their deficit
/// against Mitsuba, −0.7 % at z −4.4 at 256, halves at 1,024).
#[test]
#[ignore = "deep run: cargo test -p micropt-host --test bias_blocks -- --ignored"]
fn gloss_has_no_regional_bias() {
    let mitsuba = Truth::file("Mitsuba", "gloss", |_, y| y != 20);
    // rows 20-28: finite and too dark far floor; x 0-47 × y 16-47: G2
    let cycles = Truth::file("Cycles", "gloss.cycles", |x, y| {
        let far_floor = (20..29).contains(&y);
        let rough = x < 48 && (16..48).contains(&y);
        !(far_floor || rough)
    });
    let exact = Truth::horizon("gloss", 96, 64);
    check("gloss", 32, 1024, 4.0, &[exact, mitsuba, cycles]);
}

/// many, 32 × 256 spp (about 25-80 s), against three references, each
/// over the pixels where it has no documented departure (docs/mitsuba.md):
///
/// - row 4 (the horizon): the exact integral of the infinite ground under
///   the sky and the sun, over the 78 pixels that show only those (the 18
///   that show a sphere's top are judged by none); Cycles' ground is
///   finite and its row 0.7 % too bright there, Mitsuba's 2.0 %;
/// - Cycles: every other row;
/// - Mitsuba: rows 0-3 (sky) and 16-63. In rows 4-15 (the far ground,
///   beyond ~30 units) it is brighter than Cycles, micropt and the exact
///   integral: by 0.08-0.11 % on the ground-only pixels of rows 5-7 at the
///   top right, beyond the exact integral's bound there (0.02 %), and by
///   up to 0.35 % in blocks further down.
#[test]
#[ignore = "deep run: cargo test -p micropt-host --test bias_blocks -- --ignored"]
fn many_has_no_regional_bias() {
    let cycles = Truth::file("Cycles", "many.cycles", |_, y| y != 4);
    let mitsuba = Truth::file("Mitsuba", "many", |_, y| !(4..16).contains(&y));
    let exact = Truth::horizon("many", 96, 64);
    check("many", 32, 256, 4.0, &[exact, cycles, mitsuba]);
}
