//! No NaN, no infinity: property tests of sampling, BSDFs, pdfs and MIS
//! weights over every valid input, including grazing angles, rays parallel
//! to planes, cone sampling with r/d from 1e-6 to 1, shading points inside
//! the light, and indices of refraction far from glass.
//!
//! Beyond finiteness, each test checks the law its function implements
//! against a double-precision reference: the cone sampler returns directions
//! inside the cone that reach the sphere, with the exact solid-angle pdf
//! 1 / (2π (1 − cos θ_max)); the cosine sampler returns unit vectors on the
//! hemisphere; the dielectric obeys Snell's law and energy conservation
//! (0 ≤ R ≤ 1); the power heuristic is a weight in [0, 1].

// `!(x > 0.0)` is deliberate: true for NaN as well
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod common;

use common::*;
use micropt::integrator::{Options, Stats, power_heuristic, radiance};
use micropt::light::{cone_pdf, one_minus_cos_max, sample_cone};
use micropt::material::{fresnel_dielectric, sample_cosine, sample_dielectric};
use micropt::sampler::PixelSampler;
use micropt::{CameraSpec, Material, Scene, SceneBuilder, Vec3};
use proptest::prelude::*;
use proptest::test_runner::TestRunner;
use std::cell::RefCell;

/// ε = 2⁻²⁴.
const EPS: f64 = 1.0 / 16_777_216.0;

/// Largest uniform the samplers ever get: 1 − 2⁻²⁴.
const U_MAX: f32 = 1.0 - 1.0 / 16_777_216.0;

/// A sampler input in [0, 1): the ends with high probability.
fn u01() -> impl Strategy<Value = f32> {
    prop_oneof![
        1 => Just(0.0f32),
        1 => Just(U_MAX),
        1 => 0.0f32..1e-6,
        1 => 1.0f32 - 1e-6..1.0,
        6 => 0.0f32..1.0,
    ]
}

#[derive(Default, Debug)]
struct ConeStats {
    samples: u64,
    inside: u64,
    max_pdf_rel_err: f64,
    max_surface_err: f64,
    max_angle_excess: f64,
    min_ratio: f64,
    max_ratio: f64,
}

fn check_cone(u: [f64; 8], u1: f32, u2: f32, st: &mut ConeStats) -> Result<(), TestCaseError> {
    let x = scale(
        unit(u[0], u[1]),
        if u[2] < 0.2 {
            0.0
        } else {
            log_uniform(1e-2, 1e6, u[2])
        },
    );
    let d = log_uniform(1e-3, 1e6, u[3]);
    // r/d from 1e-6 to 1, and some shading points inside the light
    let ratio = if u[4] < 0.1 {
        1.0 + u[5] // inside or on the sphere
    } else if u[4] < 0.2 {
        1.0 - log_uniform(1e-7, 1e-2, u[5])
    } else {
        log_uniform(1e-6, 1.0, u[5])
    };
    let c = add(x, scale(unit(u[6], u[7]), d));
    let (x32, c32) = (v3(x), v3(c));
    let r = (d * ratio) as f32;
    if !(r * r).is_normal() {
        return Ok(()); // the scene builder rejects such radii
    }
    let r2 = r * r;
    let (xd, cd, rd) = (d3(x32), d3(c32), f64::from(r));
    let dd = len(sub(cd, xd));
    st.samples += 1;
    for fast in [false, true] {
        let s = sample_cone(x32, c32, r2, u1, u2, fast);
        let pdf = cone_pdf(x32, c32, r2);
        prop_assert!(pdf.is_finite() && pdf >= 0.0, "cone_pdf = {pdf}");
        let Some(s) = s else {
            // only from inside or on the sphere (f32 decides)
            prop_assert!((c32 - x32).length_squared() <= r2);
            prop_assert_eq!(pdf, 0.0);
            if !fast {
                st.inside += 1;
            }
            continue;
        };
        prop_assert!(s.dir.is_finite() && s.dist.is_finite() && s.pdf.is_finite());
        prop_assert!(s.pdf > 0.0 && s.dist >= 0.0, "{:?}", s);
        prop_assert!((s.dir.length() - 1.0).abs() < 1e-3, "{:?}", s);
        prop_assert_eq!(s.pdf, pdf);
        if fast {
            continue;
        }
        prop_assert!((s.dir.length() - 1.0).abs() < 1e-5, "{:?}", s);
        // exact pdf: 1 / (2π (1 − cos θmax)), 1 − cos θmax = s² / (1 + √(1 − s²))
        let s2 = (rd / dd) * (rd / dd);
        let omc = s2 / (1.0 + (1.0 - s2).max(0.0).sqrt());
        let exact = 1.0 / (2.0 * std::f64::consts::PI * omc);
        let rel = (f64::from(s.pdf) / exact - 1.0).abs();
        st.max_pdf_rel_err = st.max_pdf_rel_err.max(rel);
        st.min_ratio = st.min_ratio.min(rd / dd);
        st.max_ratio = st.max_ratio.max(rd / dd);
        // the f32 pdf is exact to a few ulps where d² > r² is clear; next to
        // the surface, 1 − s² itself is only known to ε / (1 − s²)
        let cond = 1.0 + 1.0 / (1.0 - s2).max(1e-300).sqrt();
        prop_assert!(
            rel <= 64.0 * 6e-8 * cond,
            "pdf {} exact {exact}: {rel:e}",
            s.pdf
        );
        // the direction lies in the cone: angle to the centre ≤ θmax
        let w = normalize(sub(cd, xd));
        let dir = d3(s.dir);
        let cos = dot(normalize(dir), w);
        let sin_max = rd / dd;
        let cos_max = (1.0 - sin_max * sin_max).max(0.0).sqrt();
        // compare in angle: θ ≤ θmax (+ f32 direction rounding)
        let theta = cos.clamp(-1.0, 1.0).acos();
        let theta_max = cos_max.clamp(-1.0, 1.0).acos();
        let excess = (theta - theta_max) / (theta_max + 1e-6);
        st.max_angle_excess = st.max_angle_excess.max(excess);
        prop_assert!(
            theta <= theta_max * (1.0 + 1e-3) + 1e-6,
            "direction {theta} outside the cone {theta_max}"
        );
        // x + dist·dir reaches the sphere (relative to d: f32 positions)
        let p = add(xd, scale(dir, f64::from(s.dist)));
        let surf = sphere_dist(p, cd, rd).abs() / (dd + len(xd));
        st.max_surface_err = st.max_surface_err.max(surf);
        // within the rounding of a unit direction over distance d, and of
        // dist = d (cos θ − √(s² − sin²θ)) near the silhouette
        prop_assert!(
            surf <= 2e-3,
            "sample point {surf:e} (relative) off the light"
        );
    }
    Ok(())
}

fn run_cone(mut runner: TestRunner, name: &str) {
    let st = RefCell::new(ConeStats {
        min_ratio: f64::INFINITY,
        ..Default::default()
    });
    runner
        .run(
            &(proptest::array::uniform8(0.0f64..1.0), u01(), u01()),
            |(u, u1, u2)| check_cone(u, u1, u2, &mut st.borrow_mut()),
        )
        .unwrap();
    let st = st.into_inner();
    figure(name, "cases", st.samples);
    figure(
        name,
        "shading points inside/on the light (None, pdf 0)",
        st.inside,
    );
    figure(
        name,
        "r/d range sampled",
        format!("{:.2e} .. {:.9}", st.min_ratio, st.max_ratio),
    );
    figure(
        name,
        "max relative pdf error vs f64",
        format!("{:.2e}", st.max_pdf_rel_err),
    );
    figure(
        name,
        "max (theta - theta_max) / theta_max",
        format!("{:.2e}", st.max_angle_excess),
    );
    figure(
        name,
        "max |x + dist dir - light surface| / (d + |x|)",
        format!("{:.2e}", st.max_surface_err),
    );
}

#[test]
fn cone_sampling_is_finite_and_exact() {
    run_cone(runner(30_000), "cone_sampling");
}

#[test]
#[ignore = "deep run: cargo test -- --ignored"]
fn cone_sampling_is_finite_and_exact_deep() {
    run_cone(random_runner(3_000_000), "cone_sampling_deep");
}

/// The cancellation-free 1 − cos θmax against double precision, r/d from
/// 1e-6 to 1 − 1e-7 (the naive 1 − √(1 − s²) is 100 % wrong below 2.4e-4).
#[test]
fn one_minus_cos_is_accurate_for_tiny_and_huge_cones() {
    let mut worst: f64 = 0.0;
    for i in 0..=1000 {
        let ratio = log_uniform(1e-6, 1.0 - 1e-7, i as f64 / 1000.0);
        let (r, d) = (ratio as f32, 1.0f32);
        let got = f64::from(one_minus_cos_max(r * r, d * d));
        let s2 = f64::from(r) * f64::from(r);
        let exact = s2 / (1.0 + (1.0 - s2).sqrt());
        let cond = 1.0 + 1.0 / (1.0 - s2).sqrt();
        let rel = (got / exact - 1.0).abs() / cond;
        worst = worst.max(rel);
    }
    figure(
        "one_minus_cos",
        "max relative error / conditioning",
        format!("{worst:.2e}"),
    );
    assert!(worst < 1e-6, "{worst:e}");
}

#[test]
fn cosine_sampling_is_finite_and_on_the_hemisphere() {
    let min_cos = std::cell::Cell::new(f32::INFINITY);
    runner(30_000)
        .run(
            &(
                proptest::array::uniform2(0.0f64..1.0),
                u01(),
                u01(),
                any::<bool>(),
            ),
            |(u, u1, u2, fast)| {
                let n = v3(unit(u[0], u[1])).normalize();
                let (d, cos) = sample_cosine(n, u1, u2, fast);
                prop_assert!(d.is_finite() && cos.is_finite());
                prop_assert!(cos > 0.0 && cos <= 1.0, "cos = {cos}");
                let tol = if fast { 2e-3 } else { 1e-5 };
                prop_assert!((d.length() - 1.0).abs() < tol, "{d:?}");
                prop_assert!((d.dot(n) - cos).abs() < tol, "{d:?} {cos}");
                // the MIS weight of this BSDF sample against any light pdf
                let pdf = cos * std::f32::consts::FRAC_1_PI;
                for pl in [0.0, 1e-30, 1.0, 3e11, f32::MAX, f32::INFINITY] {
                    let w = power_heuristic(pdf, pl);
                    prop_assert!(w.is_finite() && (0.0..=1.0).contains(&w), "{pdf} {pl} {w}");
                    let w = power_heuristic(pl, pdf);
                    if pl > 0.0 {
                        prop_assert!(w.is_finite() && (0.0..=1.0).contains(&w), "{pl} {pdf} {w}");
                    }
                }
                min_cos.set(min_cos.get().min(cos));
                Ok(())
            },
        )
        .unwrap();
    figure("cosine_sampling", "min cos theta sampled", min_cos.get());
}

#[derive(Default, Debug)]
struct DielectricStats {
    cases: u64,
    refracted: u64,
    max_snell_err: f64,
}

fn check_dielectric(
    u: [f64; 6],
    ior: f32,
    uc: f32,
    st: &mut DielectricStats,
) -> Result<(), TestCaseError> {
    let n = v3(unit(u[0], u[1])).normalize();
    let nd = d3(n);
    let (t, b) = basis(nd);
    let a = 2.0 * std::f64::consts::PI * u[2];
    let tang = add(scale(t, a.cos()), scale(b, a.sin()));
    let side = if u[3] < 0.5 { -1.0 } else { 1.0 };
    // incidence: any, normal (exactly -n), grazing, tangent
    let d = match (u[4] * 4.0) as u32 {
        0 => v3(unit(u[5], u[2])).normalize(),
        1 => n * -side as f32,
        2 => v3(normalize(add(
            tang,
            scale(nd, side * log_uniform(1e-9, 1e-1, u[5])),
        )))
        .normalize(),
        _ => v3(tang).normalize(),
    };
    st.cases += 1;
    let cos_i = d.dot(n).abs().min(1.0);
    for eta in [ior, 1.0 / ior] {
        let (r, ct) = fresnel_dielectric(cos_i, eta);
        prop_assert!(
            r.is_finite() && (0.0..=1.0).contains(&r),
            "R = {r} (cos {cos_i}, eta {eta})"
        );
        prop_assert!(ct.is_finite() && (0.0..=1.0).contains(&ct), "cos_t = {ct}");
    }
    let (dir, f) = sample_dielectric(d, n, ior, uc);
    prop_assert!(
        dir.is_finite() && f.is_finite() && f >= 0.0,
        "{dir:?} {f} (ior {ior}, d {d:?}, n {n:?})"
    );
    prop_assert!(
        (dir.length() - 1.0).abs() < 1e-5,
        "{dir:?} (ior {ior}, d {d:?}, n {n:?})"
    );
    // refraction (throughput eta² ≠ 1) crosses the surface and obeys Snell:
    // eta_i sin_i = eta_t sin_t
    if f != 1.0 {
        st.refracted += 1;
        prop_assert!(
            dir.dot(n) * d.dot(n) >= 0.0,
            "refraction must cross the surface"
        );
        let eta = if d.dot(n) < 0.0 {
            1.0 / f64::from(ior)
        } else {
            f64::from(ior)
        };
        let sin_i = len(cross(d3(d), nd)) / len(d3(d));
        let sin_t = len(cross(d3(dir), nd)) / len(d3(dir));
        // f32 rounding: a few ulps, amplified by eta² through
        // sin²t = eta² (1 − cos²i), whose 1 − cos²i is known to ε absolute
        let err = (eta * sin_i - sin_t).abs() / (16.0 * EPS * (1.0 + eta) * (1.0 + eta));
        st.max_snell_err = st.max_snell_err.max(err);
        prop_assert!(err <= 1.0, "Snell: {} vs {sin_t}", eta * sin_i);
    }
    Ok(())
}

fn ior_strategy() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => 1.0001f32..3.0,
        2 => (0.0f64..1.0).prop_map(|u| log_uniform(1e-6, 1e6, u) as f32),
        1 => (0.0f64..1.0).prop_map(|u| log_uniform(1e-30, 1e30, u) as f32),
        1 => Just(1.0f32),
        1 => prop_oneof![Just(f32::MIN_POSITIVE), Just(f32::MAX), Just(1e-38f32), Just(3e38f32)],
    ]
}

fn run_dielectric(mut runner: TestRunner, name: &str) {
    let st = RefCell::new(DielectricStats::default());
    runner
        .run(
            &(
                proptest::array::uniform6(0.0f64..1.0),
                ior_strategy(),
                u01(),
            ),
            |(u, ior, uc)| check_dielectric(u, ior, uc, &mut st.borrow_mut()),
        )
        .unwrap();
    let st = st.into_inner();
    figure(name, "cases", st.cases);
    figure(name, "refractions checked against Snell", st.refracted);
    figure(
        name,
        "max |eta sin_i - sin_t| / (16 eps (1 + eta)^2)",
        format!("{:.3}", st.max_snell_err),
    );
}

#[test]
fn dielectric_is_finite_and_obeys_snell() {
    run_dielectric(runner(30_000), "dielectric");
}

#[test]
#[ignore = "deep run: cargo test -- --ignored"]
fn dielectric_is_finite_and_obeys_snell_deep() {
    run_dielectric(random_runner(3_000_000), "dielectric_deep");
}

// ---------------------------------------------------------------------------
// Whole paths through random scenes

/// A random legal scene: 1–6 spheres (radius 1e-3 .. 1e3, any material,
/// including lights of tiny and huge radiance, glass of any IOR, lights inside
/// glass), 0–3 planes, a camera somewhere.
fn random_scene(u: &[f64]) -> Option<Scene> {
    let mut it = u.iter().copied();
    let mut next = move || it.next().unwrap_or(0.5);
    let mut b: SceneBuilder = SceneBuilder::new();
    let scale_all = log_uniform(1e-3, 1e3, next());
    let mut mats = Vec::new();
    for _ in 0..4 {
        let c = Vec3::new(next() as f32, next() as f32, next() as f32);
        let k = next();
        let m = if k < 0.35 {
            Material::Diffuse(c)
        } else if k < 0.5 {
            Material::Mirror(c)
        } else if k < 0.7 {
            Material::Glass(log_uniform(1e-6, 1e6, next()) as f32)
        } else {
            Material::Light(c * log_uniform(1e-3, 1e6, next()) as f32)
        };
        mats.push(b.material(m).ok()?);
    }
    let grey = b.material(Material::Diffuse(Vec3::splat(0.5))).ok()?;
    let nspheres = 1 + (next() * 6.0) as usize;
    let mut last = Vec3::ZERO;
    for i in 0..nspheres {
        let r = (scale_all * log_uniform(1e-2, 10.0, next())) as f32;
        // sometimes concentric with the previous one (a light inside glass)
        let c = if i > 0 && next() < 0.3 {
            last
        } else {
            v3(scale(unit(next(), next()), scale_all * 3.0 * next()))
        };
        last = c;
        let m = mats[(next() * 4.0) as usize % 4];
        b.sphere(c, r, m).ok()?;
    }
    for _ in 0..(next() * 4.0) as usize {
        let n = v3(unit(next(), next()));
        let p = v3(scale(unit(next(), next()), scale_all * 5.0 * next()));
        // planes cannot be lights: fall back to grey
        let m = mats[(next() * 4.0) as usize % 4];
        if b.plane(p, n, m).is_err() {
            b.plane(p, n, grey).ok()?;
        }
    }
    let eye = v3(scale(
        unit(next(), next()),
        scale_all * 4.0 * (0.1 + next()),
    ));
    let target = v3(scale(unit(next(), next()), scale_all * next()));
    b.camera(CameraSpec::pinhole(
        eye,
        target,
        Vec3::new(0.0, 1.0, 0.0),
        10.0 + 150.0 * next() as f32,
    ))
    .ok()?;
    if next() < 0.5 {
        b.background(v3([next(), next(), next()])).ok()?;
    }
    b.build().ok()
}

fn run_random_scenes(mut runner: TestRunner, name: &str) {
    let scenes = std::cell::Cell::new(0u64);
    let paths = std::cell::Cell::new(0u64);
    runner
        .run(&proptest::collection::vec(0.0f64..1.0, 96), |u| {
            let Some(scene) = random_scene(&u) else {
                return Ok(());
            };
            scenes.set(scenes.get() + 1);
            let renderer = micropt::Renderer::new(&scene, 6, 6).unwrap();
            let mut stats = Stats::default();
            for y in 0..6 {
                for x in 0..6 {
                    for k in 0..2 {
                        // the film zeroes a non-finite sample (and counts
                        // it, checked below); what it passes on must be a
                        // radiance: no channel negative
                        let c = renderer.sample(x, y, k, &mut stats);
                        prop_assert!(c.x >= 0.0 && c.y >= 0.0 && c.z >= 0.0, "{c:?}");
                    }
                }
            }
            // the raw estimator, before the film's guard
            let view = scene.view(-1.0);
            let opts = Options::default();
            for k in 0..16 {
                let ray = renderer.camera().ray(3.0, 3.0);
                let pixel = PixelSampler::new(k);
                let mut s = pixel.stream(0);
                let l = radiance(&view, ray, &mut s, &opts, &mut stats);
                prop_assert!(l.is_finite(), "{l:?}");
                prop_assert!(l.x >= 0.0 && l.y >= 0.0 && l.z >= 0.0, "{l:?}");
            }
            paths.set(paths.get() + stats.paths);
            prop_assert_eq!(stats.nonfinite, 0, "non-finite samples in {:?}", scene);
            Ok(())
        })
        .unwrap();
    figure(name, "scenes rendered", scenes.get());
    figure(name, "paths traced", paths.get());
    figure(name, "non-finite samples", 0);
}

#[test]
fn random_scenes_give_finite_radiance() {
    run_random_scenes(runner(2_000), "random_scenes");
}

#[test]
#[ignore = "deep run: cargo test -- --ignored"]
fn random_scenes_give_finite_radiance_deep() {
    run_random_scenes(random_runner(100_000), "random_scenes_deep");
}
