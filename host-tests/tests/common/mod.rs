//! Shared helpers of the stress tests: double-precision ground truth,
//! proptest runners (a quick deterministic mode for `cargo test`, a deep
//! randomly seeded mode for `cargo test -- --ignored`), and a figure log.
#![allow(dead_code)]

use micropt::Vec3;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// A point or vector in double precision.
pub type D3 = [f64; 3];

/// The exact value of an f32 vector.
pub fn d3(v: Vec3) -> D3 {
    [f64::from(v.x), f64::from(v.y), f64::from(v.z)]
}

/// The f32 vector nearest to `v`.
pub fn v3(v: D3) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

pub fn sub(a: D3, b: D3) -> D3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn add(a: D3, b: D3) -> D3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn scale(a: D3, s: f64) -> D3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn len(a: D3) -> f64 {
    dot(a, a).sqrt()
}

pub fn normalize(a: D3) -> D3 {
    scale(a, 1.0 / len(a))
}

pub fn cross(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A unit vector from two numbers in [0, 1) (uniform on the sphere).
pub fn unit(u: f64, v: f64) -> D3 {
    let z = 1.0 - 2.0 * u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f64::consts::PI * v;
    [r * phi.cos(), r * phi.sin(), z]
}

/// `lo * (hi/lo)^u`: log-uniform in [lo, hi] for u in [0, 1].
pub fn log_uniform(lo: f64, hi: f64, u: f64) -> f64 {
    lo * (hi / lo).powf(u)
}

/// Two unit vectors completing the unit vector `n` to an orthonormal basis.
pub fn basis(n: D3) -> (D3, D3) {
    let a = if n[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let t = normalize(cross(n, a));
    (t, cross(n, t))
}

/// Signed distance of `p` from the sphere (centre `c`, radius `r`):
/// positive outside.
pub fn sphere_dist(p: D3, c: D3, r: f64) -> f64 {
    len(sub(p, c)) - r
}

/// Ray parameters of the two intersections of `o + t d` (d of any length)
/// with the sphere, exactly enough in f64 for f32 inputs: `None` if the line
/// misses. Also returns the perpendicular distance of the centre from the
/// line.
pub fn sphere_roots(o: D3, d: D3, c: D3, r: f64) -> (Option<(f64, f64)>, f64) {
    let f = sub(o, c);
    let a = dot(d, d);
    let tc = -dot(f, d) / a;
    let l = add(f, scale(d, tc));
    let perp = len(l);
    let h2 = (r - perp) * (r + perp);
    if h2 < 0.0 {
        return (None, perp);
    }
    let h = (h2 / a).sqrt();
    (Some((tc - h, tc + h)), perp)
}

/// A proptest runner: `quick` cases, deterministic, for `cargo test`, or
/// `deep` cases from a fresh random seed for the `--ignored` long run.
pub fn runner(cases: u32) -> TestRunner {
    let config = Config {
        cases,
        failure_persistence: None,
        max_shrink_iters: 2048,
        ..Config::default()
    };
    TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha))
}

/// A randomly seeded runner (deep mode): every run explores new cases.
pub fn random_runner(cases: u32) -> TestRunner {
    TestRunner::new(Config {
        cases,
        failure_persistence: None,
        max_shrink_iters: 2048,
        ..Config::default()
    })
}

/// Prints a measured figure in a fixed form that `docs/stability.md` quotes
/// (run the tests with `--nocapture` to see them).
pub fn figure(test: &str, name: &str, value: impl std::fmt::Display) {
    println!("FIGURE {test}: {name} = {value}");
}
