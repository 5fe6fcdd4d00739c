//! Physics of the version 2 materials, checked in f64 on the host against
//! numerical integration and closed forms: the rough metal's (GGX,
//! visible-normal sampling) pdf, estimator, reciprocity, mirror limit and
//! numerical stability; the checker's radiance under a uniform sky.

use micropt::integrator::Options;
use micropt::material::{Bsdf, Metal};
use micropt::{Camera, Vec3};
use micropt_host::render::{RenderJob, parse_host, render};

/// splitmix64: the tests' own reproducible random numbers.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// On the 2⁻²⁴ grid of [0, 1), as the core's sampler gives.
    fn uniform(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / 16_777_216.0
    }
    fn u2(&mut self) -> [f32; 2] {
        [self.uniform(), self.uniform()]
    }
}

fn metal(alpha: f32) -> Metal {
    Metal {
        tint: Vec3::new(1.0, 0.5, 0.25),
        alpha,
    }
}

/// The unit direction at polar angle `theta` (from +z) in the xz plane.
fn polar(theta: f64) -> Vec3 {
    Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32)
}

fn v64(v: Vec3) -> [f64; 3] {
    [f64::from(v.x), f64::from(v.y), f64::from(v.z)]
}

/// Integrals over the sphere of directions `wi` for a fixed `wo`, by the
/// midpoint rule over the half vector `m` (upper hemisphere), whose GGX
/// peak the substitution `tan θm = α u / (1 − u)` spreads over `u` in
/// [0, 1): `wi = 2 (wo·m) m − wo`, `dωi = 4 (wo·m) dωm`. Returns
/// `(∫ pdf over the sphere, ∫ pdf over the upper hemisphere,
/// ∫ f_red cos θi over the upper hemisphere)`.
fn quadrature(m: &Metal, wo: Vec3, nu: usize, nphi: usize) -> (f64, f64, f64) {
    let a = f64::from(m.alpha);
    let o = v64(wo);
    let (mut all, mut upper, mut albedo) = (0.0, 0.0, 0.0);
    let dphi = 2.0 * std::f64::consts::PI / nphi as f64;
    for i in 0..nu {
        let u = (i as f64 + 0.5) / nu as f64;
        let s = u / (1.0 - u);
        let theta = (a * s).atan();
        let dtheta = a / (1.0 + a * a * s * s) / ((1.0 - u) * (1.0 - u)) / nu as f64;
        let (st, ct) = theta.sin_cos();
        for j in 0..nphi {
            let phi = (j as f64 + 0.5) * dphi;
            let h = [st * phi.cos(), st * phi.sin(), ct];
            let oh = o[0] * h[0] + o[1] * h[1] + o[2] * h[2];
            if oh <= 0.0 {
                // wi's half vector is −m, below the surface: no density
                continue;
            }
            let wi = [
                2.0 * oh * h[0] - o[0],
                2.0 * oh * h[1] - o[1],
                2.0 * oh * h[2] - o[2],
            ];
            let wi32 = Vec3::new(wi[0] as f32, wi[1] as f32, wi[2] as f32);
            let dw = 4.0 * oh * st * dtheta * dphi;
            let p = f64::from(m.pdf(wo, wi32));
            all += p * dw;
            if wi[2] > 0.0 {
                upper += p * dw;
                albedo += f64::from(m.f(wo, wi32).x) * wi[2] * dw;
            }
        }
    }
    (all, upper, albedo)
}

/// Monte Carlo over the core's sampler: the fraction of samples dropped
/// (reflected below the surface) and the mean and standard error of the
/// red weight `f cos / pdf` (0 for a dropped sample).
fn sampled(m: &Metal, wo: Vec3, n: usize, seed: u64) -> (f64, f64, f64) {
    let mut rng = Rng(seed);
    let (mut dropped, mut sum, mut sq) = (0usize, 0.0f64, 0.0f64);
    for _ in 0..n {
        match m.sample_local(wo, rng.u2(), false) {
            Some(s) => {
                let w = f64::from(s.weight.x);
                sum += w;
                sq += w * w;
            }
            None => dropped += 1,
        }
    }
    let k = n as f64;
    let mean = sum / k;
    let se = ((sq / k - mean * mean).max(0.0) / (k - 1.0)).sqrt();
    (dropped as f64 / k, mean, se)
}

const ALPHAS: [f32; 5] = [0.01, 0.05, 0.2, 0.5, 1.0];
const THETAS_DEG: [f64; 5] = [0.0, 30.0, 60.0, 80.0, 89.0];

/// Normalisation of the visible-normal sampling density: the reflection
/// density `D_wo(wm) / (4 |wo·wm|)` integrates to exactly 1 over the sphere
/// of directions, and over the upper hemisphere to 1 minus the probability
/// that the sampler reflects below the surface (counted from the core's
/// sampler: 1M samples, binomial standard error).
#[test]
fn metal_pdf_integrates_to_one_and_matches_the_dropped_samples() {
    for &alpha in &ALPHAS {
        let m = metal(alpha);
        for &deg in &THETAS_DEG {
            let wo = polar(deg.to_radians());
            let (all, upper, _) = quadrature(&m, wo, 1500, 256);
            // the quadrature's own error: measured below 2e-4 at this
            // resolution against 4x the points (f32 directions and the
            // midpoint rule)
            assert!(
                (all - 1.0).abs() < 1e-3,
                "alpha {alpha}, theta {deg}: pdf integrates to {all} over the sphere"
            );
            let n = 1_000_000;
            let (p_drop, _, _) = sampled(&m, wo, n, 7 + deg as u64);
            let se = (p_drop * (1.0 - p_drop) / n as f64).sqrt();
            let expected = all - upper;
            assert!(
                (p_drop - expected).abs() < 4.0 * se + 1e-3,
                "alpha {alpha}, theta {deg}: {p_drop} of the samples dropped, the pdf puts {expected} below (se {se})"
            );
        }
    }
}

/// The estimator is unbiased: the mean of `f cos θi / pdf` over the core's
/// samples equals the directional albedo `∫ f cos θi dωi` computed by
/// quadrature (within 4 standard errors plus the quadrature's error).
#[test]
fn metal_estimator_mean_is_the_directional_albedo() {
    for &alpha in &ALPHAS {
        let m = metal(alpha);
        for &deg in &THETAS_DEG {
            let wo = polar(deg.to_radians());
            let (_, _, albedo) = quadrature(&m, wo, 1500, 256);
            let (_, mean, se) = sampled(&m, wo, 400_000, 99 + deg as u64);
            assert!(
                albedo > 0.0 && albedo <= 1.0 + 1e-3,
                "alpha {alpha}, theta {deg}: albedo {albedo}"
            );
            assert!(
                (mean - albedo).abs() < 4.0 * se + 1e-3,
                "alpha {alpha}, theta {deg}: estimator mean {mean} (se {se}) vs albedo {albedo}"
            );
        }
    }
}

/// Helmholtz reciprocity, f(wo, wi) = f(wi, wo): the formula is symmetric
/// in f32 too, so the values are equal bit for bit.
#[test]
fn metal_is_reciprocal() {
    let mut rng = Rng(3);
    let mut dir = || {
        let z = rng.uniform().max(1e-4);
        let phi = 2.0 * std::f32::consts::PI * rng.uniform();
        let s = (1.0 - z * z).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    };
    for &alpha in &[0.001, 0.02, 0.3, 1.0] {
        let m = metal(alpha);
        for _ in 0..10_000 {
            let (a, b) = (dir(), dir());
            let (fab, fba) = (m.f(a, b), m.f(b, a));
            assert_eq!(fab, fba, "alpha {alpha}: f({a:?}, {b:?})");
            assert!(fab.x.is_finite() && fab.x >= 0.0);
        }
    }
}

/// The mirror limit: at α = 0.001 the metal reflects almost every sample
/// within 0.01 rad of the mirror direction (GGX's tails keep a few
/// percent out: P(tan θm > t) = α² / (α² + t²)), with weight tint × G1(wi)
/// → the tint.
#[test]
fn metal_approaches_the_mirror_as_alpha_vanishes() {
    for &deg in &[0.0, 30.0, 60.0, 80.0] {
        let wo = polar(f64::to_radians(deg));
        let mirror = [-f64::from(wo.x), 0.0, f64::from(wo.z)];
        let mut near = [0usize; 2];
        for (k, &alpha) in [0.001f32, 0.01].iter().enumerate() {
            let m = metal(alpha);
            let mut rng = Rng(11);
            let n = 100_000;
            let mut sum = 0.0;
            for _ in 0..n {
                let Some(s) = m.sample_local(wo, rng.u2(), false) else {
                    continue;
                };
                let d = v64(s.dir);
                let cos: f64 = (0..3).map(|i| d[i] * mirror[i]).sum();
                if cos.clamp(-1.0, 1.0).acos() < 0.01 {
                    near[k] += 1;
                }
                sum += f64::from(s.weight.x);
            }
            if alpha == 0.001 {
                assert!(
                    near[0] as f64 > 0.9 * n as f64,
                    "theta {deg}: only {} of {n} samples near the mirror direction",
                    near[0]
                );
                let mean = sum / n as f64;
                assert!((mean - 1.0).abs() < 2e-3, "theta {deg}: mean weight {mean}");
            }
        }
        assert!(near[0] > near[1], "theta {deg}: {near:?}");
    }
}

/// Numerical stability in f32 at both ends of α and at grazing angles:
/// every sample and evaluation, through the integrator's interface (world
/// directions about random normals), is finite and non-negative, samples
/// are unit directions above the surface, and no weight exceeds the tint.
#[test]
fn metal_is_stable_in_f32() {
    let mut rng = Rng(5);
    let grazing = [0.0f32, 1e-30, 1e-8, 1e-6, 1e-4, 1e-2];
    let edges = [0.0f32, 1.0 - 1.0 / 16_777_216.0, 0.5];
    for &alpha in &[0.001f32, 0.0011, 0.003, 0.5, 0.999, 1.0] {
        let m = metal(alpha);
        let bsdf = Bsdf::Ggx(m);
        for i in 0..200_000 {
            let n = {
                let v = Vec3::new(
                    rng.uniform() - 0.5,
                    rng.uniform() - 0.5,
                    rng.uniform() - 0.5,
                );
                if v.length() < 1e-3 {
                    continue;
                }
                v.normalize()
            };
            let (t, b) = n.basis();
            // a direction above the surface, often grazing
            let z = if i % 4 == 0 {
                grazing[i / 4 % grazing.len()]
            } else {
                rng.uniform()
            };
            let phi = 2.0 * std::f32::consts::PI * rng.uniform();
            let s = (1.0 - z * z).max(0.0).sqrt();
            let wo = (t * (s * phi.cos()) + b * (s * phi.sin()) + n * z).normalize();
            let u = if i % 7 == 0 {
                [edges[i % 3], edges[(i / 3) % 3]]
            } else {
                rng.u2()
            };
            if let Some(smp) = bsdf.sample(wo, n, u, i % 2 == 0) {
                let w = smp.weight;
                assert!(
                    w.is_finite() && w.x >= 0.0 && w.x <= 1.0 && w.y <= 0.5 && w.z <= 0.25,
                    "alpha {alpha}: weight {w:?} for wo {wo:?}, n {n:?}, u {u:?}"
                );
                assert!(
                    smp.pi_pdf.is_finite() && smp.pi_pdf > 0.0,
                    "alpha {alpha}: pdf {} for wo {wo:?}, n {n:?}, u {u:?}",
                    smp.pi_pdf
                );
                assert!((smp.dir.length() - 1.0).abs() < 1e-5 && smp.dir.dot(n) > -1e-6);
                // the same direction evaluated as a light sample
                let cos = smp.dir.dot(n);
                if cos > 0.0 {
                    let (ew, ep) = bsdf.eval(wo, n, smp.dir, cos);
                    assert!(ew.is_finite() && ew.x >= 0.0 && ep.is_finite() && ep >= 0.0);
                }
            }
            // a random light direction above the surface
            let zl = rng.uniform();
            let pl = 2.0 * std::f32::consts::PI * rng.uniform();
            let sl = (1.0 - zl * zl).max(0.0).sqrt();
            let wi = (t * (sl * pl.cos()) + b * (sl * pl.sin()) + n * zl).normalize();
            let cos = wi.dot(n);
            if cos > 0.0 {
                let (ew, ep) = bsdf.eval(wo, n, wi, cos);
                assert!(
                    ew.is_finite() && ew.x >= 0.0 && ew.x <= 1.0 && ep.is_finite() && ep >= 0.0,
                    "alpha {alpha}: eval ({ew:?}, {ep}) for wo {wo:?}, wi {wi:?}"
                );
            }
            // and the local functions directly, at the horizon too
            let lo = Vec3::new(s * phi.cos(), s * phi.sin(), z);
            let li = Vec3::new(sl * pl.cos(), sl * pl.sin(), zl);
            let (f, p) = (m.f(lo, li), m.pdf(lo, li));
            assert!(f.is_finite() && f.x >= 0.0 && p.is_finite() && p >= 0.0);
        }
    }
}

/// A checker plane or sphere alone under a uniform sky: every point of a
/// convex Lambertian lit by radiance `sky` from its whole hemisphere
/// reflects `albedo × sky` (the cosine-weighted hemisphere integral of
/// `albedo/π` is the albedo). So every pixel whose footprint lies inside
/// one cell has exactly that radiance, with the cell's colour given by the
/// scene format's rule (floor(a/size) summed over the kept axes; even: the
/// first colour).
#[test]
fn checker_under_a_uniform_sky_reflects_albedo_times_sky() {
    let sky = [0.8f64, 0.9, 1.0];
    let even = [0.7f64, 0.5, 0.3];
    let odd = [0.1f64, 0.2, 0.6];
    let cases = [
        // a tilted plane whose normal is nearest y: x and z count
        (
            "camera 0.3 3 4  0 0 0  0 1 0  50\nplane 0 0 0  0.2 1 0.1  c\n",
            0.45f64,
        ),
        // a sphere: all three axes (a solid checker)
        (
            "camera 0.2 0.7 4  0 0 0  0 1 0  35\nsphere 0 0 0  1  c\n",
            0.3f64,
        ),
    ];
    for (geometry, size) in cases {
        let text = format!(
            "background {} {} {}\nmaterial c checker {} {} {}  {} {} {}  {size}\n{geometry}",
            sky[0], sky[1], sky[2], even[0], even[1], even[2], odd[0], odd[1], odd[2]
        );
        let scene = parse_host(&text).unwrap();
        let (w, h) = (64u32, 48u32);
        let job = RenderJob {
            width: w,
            height: h,
            spp: 8,
            seed: 1,
            threads: 0,
            options: Options::default(),
        };
        let out = render(&scene, &job, &|| {}).unwrap();
        assert_eq!(out.stats.nonfinite, 0);
        let cam = Camera::new(scene.camera(), w, h).unwrap();
        let eye = v64(scene.camera().eye);
        let plane = scene.planes().first().copied();
        // the hit point of the camera ray through film position (fx, fy)
        let hit = |fx: f32, fy: f32| -> Option<[f64; 3]> {
            let d = v64(cam.ray(fx, fy).dir);
            let t = match plane {
                Some(p) => {
                    let n = v64(p.normal);
                    let dn: f64 = (0..3).map(|i| d[i] * n[i]).sum();
                    let en: f64 = (0..3).map(|i| eye[i] * n[i]).sum();
                    let t = (f64::from(p.offset) - en) / dn;
                    (t > 0.0).then_some(t)?
                }
                None => {
                    let b: f64 = (0..3).map(|i| d[i] * eye[i]).sum();
                    let c: f64 = eye.iter().map(|v| v * v).sum::<f64>() - 1.0;
                    let disc = b * b - c;
                    (disc > 0.0).then_some(-b - disc.sqrt())?
                }
            };
            Some([eye[0] + t * d[0], eye[1] + t * d[1], eye[2] + t * d[2]])
        };
        // the kept coordinates: drop the axis most aligned with the plane's
        // normal (y here), or none on the sphere
        let coords = |p: [f64; 3]| -> Vec<f64> {
            if plane.is_some() {
                vec![p[0], p[2]]
            } else {
                p.to_vec()
            }
        };
        let (mut inside, mut counts) = (0, [0usize; 2]);
        const G: usize = 8;
        for y in 0..h {
            'pixel: for x in 0..w {
                // a grid over the pixel, edges included
                let mut pts = Vec::with_capacity((G + 1) * (G + 1));
                for j in 0..=G {
                    for i in 0..=G {
                        match hit(
                            x as f32 + i as f32 / G as f32,
                            y as f32 + j as f32 / G as f32,
                        ) {
                            Some(p) => pts.push(p),
                            None => continue 'pixel,
                        }
                    }
                }
                // the largest gap between neighbouring grid points bounds how
                // far any point of the footprint is from one of them
                let mut gap = 0.0f64;
                for j in 0..=G {
                    for i in 0..=G {
                        let p = pts[j * (G + 1) + i];
                        for q in [(i + 1, j), (i, j + 1)] {
                            if q.0 <= G && q.1 <= G {
                                let r = pts[q.1 * (G + 1) + q.0];
                                let d: f64 =
                                    (0..3).map(|k| (p[k] - r[k]).powi(2)).sum::<f64>().sqrt();
                                gap = gap.max(d);
                            }
                        }
                    }
                }
                let cell = |p: [f64; 3]| -> Option<Vec<i64>> {
                    coords(p)
                        .iter()
                        .map(|&a| {
                            let q = a / size;
                            let k = q.floor();
                            // at least a gap from every boundary
                            (q - k > gap / size && k + 1.0 - q > gap / size).then_some(k as i64)
                        })
                        .collect()
                };
                let Some(c0) = cell(pts[0]) else { continue };
                if !pts.iter().all(|&p| cell(p).as_ref() == Some(&c0)) {
                    continue;
                }
                let parity = c0.iter().sum::<i64>().rem_euclid(2) as usize;
                let albedo = if parity == 0 { even } else { odd };
                let got = out.image.get(x, y);
                for (c, g) in [f64::from(got.x), f64::from(got.y), f64::from(got.z)]
                    .iter()
                    .enumerate()
                {
                    let want = albedo[c] * sky[c];
                    // every path gives albedo × sky in f32: only roundings
                    assert!(
                        (g - want).abs() <= 1e-5 * want,
                        "{geometry}: pixel ({x},{y}) channel {c} = {g}, expected {want}"
                    );
                }
                inside += 1;
                counts[parity] += 1;
            }
        }
        assert!(
            counts[0] > 30 && counts[1] > 30,
            "{geometry}: pixels checked per colour {counts:?} of {inside}"
        );
    }
}
