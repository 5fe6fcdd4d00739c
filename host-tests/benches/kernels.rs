//! Criterion benchmarks of the hot kernels: ray-sphere, ray-plane, scene
//! closest hit on cornell, cone sampling, BSDF sampling, the sample stream,
//! and one full path.
//!
//! `cargo bench -p micropt-host --bench kernels`; under `cargo test --benches`
//! criterion runs each once as a smoke test. Plain `cargo test` does not build
//! them.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use micropt::sampler::{PixelSampler, pixel_key};
use micropt::{ObjectId, Plane, Ray, Renderer, Scene, Sphere, Stats, Vec3, light, material};
use std::hint::black_box;

const N: usize = 1024;

/// Deterministic uniform numbers in [0, 1) (splitmix64), independent of the
/// code under test.
struct Uniform(u64);

impl Uniform {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 * (1.0 / 16_777_216.0)
    }

    fn dir(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                2.0 * self.next() - 1.0,
                2.0 * self.next() - 1.0,
                2.0 * self.next() - 1.0,
            );
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v.normalize();
            }
        }
    }

    fn point_in_box(&mut self) -> Vec3 {
        Vec3::new(
            0.05 + 0.9 * self.next(),
            0.05 + 0.9 * self.next(),
            0.05 + 0.9 * self.next(),
        )
    }
}

fn cornell() -> Scene {
    micropt::parse::parse(include_str!("../../scenes/cornell.scene")).expect("cornell parses")
}

/// Rays from random points inside the cornell box in random directions.
fn rays(seed: u64) -> Vec<Ray> {
    let mut u = Uniform(seed);
    (0..N)
        .map(|_| Ray::new(u.point_in_box(), u.dir()))
        .collect()
}

fn intersection(c: &mut Criterion) {
    let rays = rays(1);
    let sphere = Sphere::new(Vec3::new(0.3, 0.2, 0.35), 0.2, 0);
    let plane = Plane::new(Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0), 0);
    let mut g = c.benchmark_group("intersect");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("ray-sphere", |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for r in black_box(&rays) {
                hits += u32::from(sphere.intersect(r, f32::INFINITY).is_some());
            }
            hits
        })
    });
    g.bench_function("ray-plane", |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for r in black_box(&rays) {
                hits += u32::from(plane.intersect(r, f32::INFINITY).is_some());
            }
            hits
        })
    });
    let scene = cornell();
    let view = scene.view(-1.0);
    g.bench_function("cornell closest_hit", |b| {
        b.iter(|| {
            let mut t = 0.0f32;
            for r in black_box(&rays) {
                if let Some(h) = view.closest_hit(r, ObjectId::NONE) {
                    t += h.t;
                }
            }
            t
        })
    });
    g.bench_function("cornell occluded", |b| {
        let lamp = ObjectId::sphere(0);
        b.iter(|| {
            let mut n = 0u32;
            for r in black_box(&rays) {
                n += u32::from(view.occluded(r, 0.5, ObjectId::NONE, lamp));
            }
            n
        })
    });
    g.finish();
}

fn sampling(c: &mut Criterion) {
    let mut u = Uniform(2);
    let pts: Vec<(Vec3, [f32; 2])> = (0..N)
        .map(|_| (u.point_in_box(), [u.next(), u.next()]))
        .collect();
    let normals: Vec<(Vec3, [f32; 3])> = (0..N)
        .map(|_| (u.dir(), [u.next(), u.next(), u.next()]))
        .collect();
    let lamp = Vec3::new(0.5, 0.85, 0.4);
    let mut g = c.benchmark_group("sample");
    g.throughput(Throughput::Elements(N as u64));
    for fast in [false, true] {
        let name = if fast { "cone (fast math)" } else { "cone" };
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (x, [u1, u2]) in black_box(&pts) {
                    if let Some(s) = light::sample_cone(*x, lamp, 0.0064, *u1, *u2, fast) {
                        acc += s.pdf + s.dir.x;
                    }
                }
                acc
            })
        });
        let name = if fast { "cosine (fast math)" } else { "cosine" };
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (n, [u1, u2, _]) in black_box(&normals) {
                    let (d, c) = material::sample_cosine(*n, *u1, *u2, fast);
                    acc += d.x + c;
                }
                acc
            })
        });
    }
    g.bench_function("dielectric", |b| {
        let n = Vec3::new(0.0, 1.0, 0.0);
        b.iter(|| {
            let mut acc = 0.0f32;
            for (d, [u1, _, _]) in black_box(&normals) {
                let (o, f) = material::sample_dielectric(*d, n, 1.5, *u1);
                acc += o.y + f;
            }
            acc
        })
    });
    g.finish();

    let mut g = c.benchmark_group("rng");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function(
        "pixel sampler + stream + 3 stratified pairs + 8 floats",
        |b| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for i in 0..N as u32 {
                    let pixel = PixelSampler::new(pixel_key(7, i & 63, i >> 6));
                    let mut s = pixel.stream(black_box(i));
                    for pair in 0..3 {
                        let [a, b] = s.stratified_2d(pair);
                        acc += a + b;
                    }
                    for _ in 0..8 {
                        acc += s.next_f32();
                    }
                }
                acc
            })
        },
    );
    g.bench_function("xorshift next_f32", |b| {
        let pixel = PixelSampler::new(pixel_key(7, 1, 2));
        let mut s = pixel.stream(3);
        b.iter(|| {
            let mut acc = 0.0f32;
            for _ in 0..N {
                acc += s.next_f32();
            }
            acc
        })
    });
    g.finish();
}

fn full_path(c: &mut Criterion) {
    let scene = cornell();
    let r = Renderer::new(&scene, 64, 64).expect("camera").seed(1);
    let mut g = c.benchmark_group("path");
    g.throughput(Throughput::Elements(4096));
    g.bench_function("cornell Renderer::sample (64x64 pixels, 1 spp)", |b| {
        let mut k = 0u32;
        b.iter(|| {
            let mut stats = Stats::default();
            let mut acc = Vec3::ZERO;
            for y in 0..64 {
                for x in 0..64 {
                    acc += r.sample(x, y, k, &mut stats);
                }
            }
            k = k.wrapping_add(1);
            (acc, stats.rays())
        })
    });
    g.finish();
}

criterion_group!(benches, intersection, sampling, full_path);
criterion_main!(benches);
