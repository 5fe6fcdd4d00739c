//! smallpt's algorithm (K. Beason's 99-line path tracer) in double precision,
//! on the scene format: the yardstick micropt's efficiency is measured
//! against on `scenes/smallpt.scene`.
//!
//! What is smallpt's and kept as it is:
//! - BSDF sampling only (no light sampling): emission is added at every hit,
//!   after any bounce;
//! - diffuse: cosine-weighted directions built exactly as smallpt builds them,
//!   two-sided (about the normal facing the ray);
//! - mirror: perfect reflection tinted by the material;
//! - glass: at the first two hits of a path both the reflected and the
//!   refracted ray are followed (weighted by the Fresnel terms); deeper, one is
//!   chosen with probability `P = 0.25 + 0.5·Re` and weighted by `Re/P` or
//!   `Tr/(1 − P)`;
//! - Russian roulette from the sixth hit on: the path goes on with
//!   probability `p = min(max(reflectance), 0.999)` and its reflectance is
//!   divided by `p`. smallpt's glass, mirror and walls all have colours of
//!   at most 0.999, so this is its rule; here glass reflects everything
//!   (reflectance 1), and the 0.999 keeps the roulette ending paths in glass
//!   (a ray trapped by total internal reflection inside a sphere stays
//!   trapped, as every chord meets the surface at the same angle) without
//!   changing the expected image;
//! - a hard cap of [`MAX_DEPTH`] hits ([`SmallptOptions::max_depth`]) as a
//!   safety net: with survival at most 0.999 a path reaches it with a
//!   probability below 1e-28, so it never fires unless the roulette is
//!   broken; the paths it ends are counted ([`SmallptOutput::truncated`]);
//! - ray offsets: hits closer than `1e-4` are ignored (no origin offset);
//! - 2×2 stratified pixel samples, `spp / 4` in each quarter of the pixel.
//!
//! What follows the scene format instead: the glass uses the exact
//! (unpolarised) Fresnel equations, not Schlick's approximation; a box pixel
//! filter (uniform within each quarter) instead of smallpt's tent; the camera
//! is the format's pinhole ([`Camera`]); a `light` emits toward the outside
//! only and, like smallpt's black light sphere, reflects nothing; glass does
//! not absorb. With [`SmallptOptions::cutoff`] a path also ends at a surface
//! that reflects nothing (a light, a black wall), where smallpt traces it on
//! with zero weight until the roulette; the image's expectation is the same.
//!
//! Coordinates are parsed from the text as f64 (the walls are spheres of
//! radius 1e5, which f32 cannot intersect accurately); micropt's own parser
//! checks the file first, so every malformed scene gets its error message.

use crate::image::Image;
use crate::render::resolve_threads;
use micropt::Color;
use std::ops::{Add, Mul, Neg, Sub};
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

/// A 3-vector of f64 (position, direction or RGB).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3 {
    /// x or red.
    pub x: f64,
    /// y or green.
    pub y: f64,
    /// z or blue.
    pub z: f64,
}

impl V3 {
    /// (0, 0, 0).
    pub const ZERO: V3 = V3::new(0.0, 0.0, 0.0);
    /// (1, 1, 1).
    pub const ONE: V3 = V3::new(1.0, 1.0, 1.0);

    /// The vector (x, y, z).
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }

    /// Dot product.
    pub fn dot(self, o: V3) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Cross product.
    pub fn cross(self, o: V3) -> V3 {
        V3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// The unit vector along `self`.
    pub fn normalize(self) -> V3 {
        self * (1.0 / self.dot(self).sqrt())
    }

    /// Component-wise product.
    pub fn scale(self, o: V3) -> V3 {
        V3::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }

    /// Largest component.
    pub fn max_component(self) -> f64 {
        self.x.max(self.y).max(self.z)
    }
}

impl Add for V3 {
    type Output = V3;
    fn add(self, o: V3) -> V3 {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for V3 {
    type Output = V3;
    fn sub(self, o: V3) -> V3 {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f64> for V3 {
    type Output = V3;
    fn mul(self, s: f64) -> V3 {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}

impl Neg for V3 {
    type Output = V3;
    fn neg(self) -> V3 {
        V3::new(-self.x, -self.y, -self.z)
    }
}

/// A material of the scene format.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    /// Lambertian with this albedo.
    Diffuse(V3),
    /// Perfect mirror with this tint.
    Mirror(V3),
    /// Smooth dielectric with this index of refraction.
    Glass(f64),
    /// Emitter with this radiance (toward the outside); reflects nothing.
    Light(V3),
}

impl Surface {
    /// The reflectance the path weight uses (the roulette its largest
    /// component, at most [`MAX_SURVIVAL`]): the albedo or tint, 1 for
    /// glass, 0 for a light.
    fn reflectance(&self) -> V3 {
        match *self {
            Surface::Diffuse(c) | Surface::Mirror(c) => c,
            Surface::Glass(_) => V3::ONE,
            Surface::Light(_) => V3::ZERO,
        }
    }
}

/// A sphere with a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ball {
    /// Centre.
    pub center: V3,
    /// Radius (> 0).
    pub radius: f64,
    /// Its material.
    pub surface: Surface,
}

impl Ball {
    /// smallpt's intersection: the nearest `t > 1e-4` along the unit
    /// direction `d`, or 0 for none.
    fn intersect(&self, o: V3, d: V3) -> f64 {
        const EPS: f64 = 1e-4;
        let op = self.center - o;
        let b = op.dot(d);
        let det = b * b - op.dot(op) + self.radius * self.radius;
        if det < 0.0 {
            return 0.0;
        }
        let det = det.sqrt();
        if b - det > EPS {
            b - det
        } else if b + det > EPS {
            b + det
        } else {
            0.0
        }
    }
}

/// The camera statement, in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSpec64 {
    /// Eye.
    pub eye: V3,
    /// Point looked at.
    pub target: V3,
    /// Up vector.
    pub up: V3,
    /// Vertical field of view in degrees.
    pub vfov_deg: f64,
}

/// A scene of spheres read in double precision.
#[derive(Clone, Debug, PartialEq)]
pub struct SmallptScene {
    /// The camera.
    pub camera: CameraSpec64,
    /// The scene's `resolution`, if any.
    pub resolution: Option<(u32, u32)>,
    /// Radiance of rays that hit nothing.
    pub background: V3,
    /// The spheres, in file order.
    pub spheres: Vec<Ball>,
}

fn f64s(tokens: &[&str], line: usize) -> Result<Vec<f64>, String> {
    tokens
        .iter()
        .map(|t| match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("line {line}: '{t}' is not a finite number")),
        })
        .collect()
}

fn v3(v: &[f64]) -> V3 {
    V3::new(v[0], v[1], v[2])
}

impl SmallptScene {
    /// Parses a scene file's text. micropt's parser checks it first (every
    /// malformed scene gets that parser's message, naming the line); then
    /// the numbers are read again as f64. Planes are rejected: smallpt's
    /// scenes are spheres only.
    pub fn parse(text: &str) -> Result<Self, String> {
        micropt::parse::parse_bytes(text.as_bytes()).map_err(|e| e.to_string())?;
        let mut camera = None;
        let mut resolution = None;
        let mut background = V3::ZERO;
        let mut materials: Vec<(&str, Surface)> = Vec::new();
        let mut spheres = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let code = raw.split('#').next().unwrap_or("");
            let t: Vec<&str> = code.split_whitespace().collect();
            let Some((&stmt, args)) = t.split_first() else {
                continue;
            };
            let count = |n: usize| {
                if args.len() == n {
                    Ok(())
                } else {
                    Err(format!("line {line}: {stmt} takes {n} values"))
                }
            };
            match stmt {
                "camera" => {
                    count(10)?;
                    let v = f64s(args, line)?;
                    camera = Some(CameraSpec64 {
                        eye: v3(&v[0..3]),
                        target: v3(&v[3..6]),
                        up: v3(&v[6..9]),
                        vfov_deg: v[9],
                    });
                }
                "resolution" => {
                    count(2)?;
                    let n: Vec<u32> = args
                        .iter()
                        .map(|a| a.parse::<u32>())
                        .collect::<Result<_, _>>()
                        .map_err(|_| format!("line {line}: resolution is not two whole numbers"))?;
                    resolution = Some((n[0], n[1]));
                }
                "background" => {
                    count(3)?;
                    background = v3(&f64s(args, line)?);
                }
                "material" => {
                    let (Some(&name), Some(&kind)) = (args.first(), args.get(1)) else {
                        return Err(format!("line {line}: material needs a name and a kind"));
                    };
                    let v = f64s(&args[2..], line)?;
                    let need = if kind == "glass" { 1 } else { 3 };
                    if v.len() != need {
                        return Err(format!("line {line}: {kind} takes {need} values"));
                    }
                    let s = match kind {
                        "diffuse" => Surface::Diffuse(v3(&v)),
                        "mirror" => Surface::Mirror(v3(&v)),
                        "light" => Surface::Light(v3(&v)),
                        "glass" => Surface::Glass(v[0]),
                        _ => return Err(format!("line {line}: unknown material kind '{kind}'")),
                    };
                    materials.push((name, s));
                }
                "sphere" => {
                    count(5)?;
                    let v = f64s(&args[..4], line)?;
                    let name = args[4];
                    let surface = materials
                        .iter()
                        .find(|m| m.0 == name)
                        .map(|m| m.1)
                        .ok_or_else(|| format!("line {line}: unknown material '{name}'"))?;
                    spheres.push(Ball {
                        center: v3(&v[..3]),
                        radius: v[3],
                        surface,
                    });
                }
                "plane" => {
                    return Err(format!(
                        "line {line}: the smallpt renderer takes spheres only, not planes"
                    ));
                }
                other => return Err(format!("line {line}: unknown statement '{other}'")),
            }
        }
        Ok(Self {
            camera: camera.ok_or("the scene has no camera")?,
            resolution,
            background,
            spheres,
        })
    }

    /// Reads and parses a scene file.
    pub fn load(path: &Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read scene {}: {e}", path.display()))?;
        Self::parse(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// The nearest sphere hit by the ray: (t, index).
    fn intersect(&self, o: V3, d: V3) -> Option<(f64, usize)> {
        let mut best: Option<(f64, usize)> = None;
        for (i, s) in self.spheres.iter().enumerate() {
            let t = s.intersect(o, d);
            if t > 0.0 && best.is_none_or(|b| t < b.0) {
                best = Some((t, i));
            }
        }
        best
    }
}

/// micropt's pinhole camera ([`micropt::camera::Camera`]) in f64: the same
/// frame, the same film, film position (fx, fy) in pixel units with (0, 0)
/// the top-left corner.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    eye: V3,
    dx: V3,
    dy: V3,
    corner: V3,
}

impl Camera {
    /// The camera of `spec` for a `width` × `height` image.
    pub fn new(spec: &CameraSpec64, width: u32, height: u32) -> Self {
        let forward = (spec.target - spec.eye).normalize();
        let right = forward.cross(spec.up).normalize();
        let up = right.cross(forward);
        let half_h = (spec.vfov_deg.to_radians() * 0.5).tan();
        let (w, h) = (f64::from(width), f64::from(height));
        let half_w = half_h * w / h;
        Self {
            eye: spec.eye,
            dx: right * (2.0 * half_w / w),
            dy: up * (-2.0 * half_h / h),
            corner: forward - right * half_w + up * half_h,
        }
    }

    /// The primary ray (origin, unit direction) through film position
    /// (fx, fy).
    pub fn ray(&self, fx: f64, fy: f64) -> (V3, V3) {
        (
            self.eye,
            (self.corner + self.dx * fx + self.dy * fy).normalize(),
        )
    }
}

/// Fresnel reflectance of unpolarised light at a smooth dielectric
/// boundary (the exact Fresnel equations): `cos_i` the cosine of the angle
/// of incidence, `eta` = n(incident side) / n(other side). 1 under total
/// internal reflection.
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let cos_i = cos_i.abs().min(1.0);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// SplitMix64: a small, fast generator of 64-bit words (passes BigCrush);
/// one per pixel, seeded from (render seed, pixel index).
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// The generator of pixel `pixel` for render seed `seed`.
    pub fn new(seed: u64, pixel: u64) -> Self {
        let mut r = Rng(seed ^ 0x5851_f42d_4c95_7f2d);
        let a = r.next_u64();
        Rng(a ^ pixel.wrapping_mul(0x9e37_79b9_7f4a_7c15).rotate_left(17))
    }

    /// The next 64-bit word.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// The largest survival probability of the roulette: smallpt's glass
/// colour, so that a path trapped in lossless glass still ends (after about
/// a thousand hits on average).
pub const MAX_SURVIVAL: f64 = 0.999;

/// The default hard cap on hits per path. Past the fifth hit a path
/// survives each hit with probability at most [`MAX_SURVIVAL`], so it
/// reaches this cap with probability below `0.999^65531 < 1e-28`: the cap
/// only stops a path whose roulette does not work.
pub const MAX_DEPTH: u32 = 1 << 16;

/// How the smallpt renderer may differ from smallpt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SmallptOptions {
    /// End a path at a surface that reflects nothing (smallpt traces it on
    /// with zero weight until the roulette).
    pub cutoff: bool,
    /// End a path at its `max_depth`-th hit (after adding that hit's
    /// emission), dropping what it would have gathered further on: a bias,
    /// counted in [`SmallptOutput::truncated`]. At least 1.
    pub max_depth: u32,
}

impl Default for SmallptOptions {
    /// smallpt as written, capped at [`MAX_DEPTH`] hits.
    fn default() -> Self {
        Self {
            cutoff: false,
            max_depth: MAX_DEPTH,
        }
    }
}

/// Path counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Counts {
    rays: u64,
    truncated: u64,
}

/// smallpt's radiance estimate along the ray (o, d): `depth` hits so far.
fn radiance(
    scene: &SmallptScene,
    opts: SmallptOptions,
    mut o: V3,
    mut d: V3,
    mut depth: u32,
    rng: &mut Rng,
    n: &mut Counts,
) -> V3 {
    let mut sum = V3::ZERO;
    let mut weight = V3::ONE;
    loop {
        n.rays += 1;
        let Some((t, i)) = scene.intersect(o, d) else {
            return sum + weight.scale(scene.background);
        };
        let ball = &scene.spheres[i];
        let x = o + d * t;
        let normal = (x - ball.center).normalize();
        let into = normal.dot(d) < 0.0;
        let nl = if into { normal } else { -normal };
        if let Surface::Light(e) = ball.surface
            && into
        {
            sum = sum + weight.scale(e);
        }
        let mut f = ball.surface.reflectance();
        let p = f.max_component();
        depth += 1;
        if depth >= opts.max_depth {
            n.truncated += 1;
            return sum;
        }
        if depth > 5 {
            let q = p.min(MAX_SURVIVAL);
            if rng.uniform() < q {
                f = f * (1.0 / q);
            } else {
                return sum;
            }
        }
        if opts.cutoff && p == 0.0 {
            return sum;
        }
        weight = weight.scale(f);
        o = x;
        match ball.surface {
            Surface::Diffuse(_) | Surface::Light(_) => {
                let r1 = 2.0 * std::f64::consts::PI * rng.uniform();
                let r2 = rng.uniform();
                let r2s = r2.sqrt();
                let w = nl;
                let a = if w.x.abs() > 0.1 {
                    V3::new(0.0, 1.0, 0.0)
                } else {
                    V3::new(1.0, 0.0, 0.0)
                };
                let u = a.cross(w).normalize();
                let v = w.cross(u);
                d = (u * (r1.cos() * r2s) + v * (r1.sin() * r2s) + w * (1.0 - r2).sqrt())
                    .normalize();
            }
            Surface::Mirror(_) => {
                d = d - normal * (2.0 * normal.dot(d));
            }
            Surface::Glass(ior) => {
                let refl = d - normal * (2.0 * normal.dot(d));
                let nnt = if into { 1.0 / ior } else { ior };
                let ddn = d.dot(nl);
                let cos2t = 1.0 - nnt * nnt * (1.0 - ddn * ddn);
                if cos2t < 0.0 {
                    d = refl;
                    continue;
                }
                let sign = if into { 1.0 } else { -1.0 };
                let tdir = (d * nnt - normal * (sign * (ddn * nnt + cos2t.sqrt()))).normalize();
                let re = fresnel_dielectric(ddn, nnt);
                let tr = 1.0 - re;
                if depth > 2 {
                    let pr = 0.25 + 0.5 * re;
                    if rng.uniform() < pr {
                        weight = weight * (re / pr);
                        d = refl;
                    } else {
                        weight = weight * (tr / (1.0 - pr));
                        d = tdir;
                    }
                } else {
                    let lr = radiance(scene, opts, x, refl, depth, rng, n);
                    let lt = radiance(scene, opts, x, tdir, depth, rng, n);
                    return sum + weight.scale(lr * re + lt * tr);
                }
            }
        }
    }
}

/// What to render.
#[derive(Clone, Copy, Debug)]
pub struct SmallptJob {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel: a positive multiple of 4 (2×2 strata).
    pub spp: u32,
    /// Render seed.
    pub seed: u64,
    /// Worker threads (0: all cores); the image does not depend on it.
    pub threads: usize,
    /// Departures from smallpt.
    pub options: SmallptOptions,
}

/// A finished render.
#[derive(Clone, Debug)]
pub struct SmallptOutput {
    /// Mean radiance per pixel (rounded to f32).
    pub image: Image,
    /// Standard error of each pixel's mean, from the spread of the samples
    /// within each of its four strata; zero where a stratum has fewer than
    /// two samples (spp < 8).
    pub standard_error: Image,
    /// Camera samples (paths, counting a glass split as one).
    pub paths: u64,
    /// Rays traced.
    pub rays: u64,
    /// Path ends at the depth cap ([`SmallptOptions::max_depth`]); the two
    /// branches of a glass split at the first two hits end separately. Not
    /// zero means the image lacks light and is biased.
    pub truncated: u64,
    /// Wall-clock seconds of the render.
    pub seconds: f64,
    /// Threads used.
    pub threads: usize,
}

impl SmallptOutput {
    /// Paths per wall-clock second.
    pub fn paths_per_second(&self) -> f64 {
        self.paths as f64 / self.seconds.max(1e-12)
    }
}

/// One row of pixels: (means, standard errors, counters).
fn render_row(
    scene: &SmallptScene,
    cam: &Camera,
    job: &SmallptJob,
    y: u32,
) -> (Vec<Color>, Vec<Color>, Counts) {
    let per = job.spp / 4;
    let mut n = Counts::default();
    let mut means = Vec::with_capacity(job.width as usize);
    let mut errs = Vec::with_capacity(job.width as usize);
    for x in 0..job.width {
        let mut rng = Rng::new(job.seed, u64::from(y) * u64::from(job.width) + u64::from(x));
        let mut mean = V3::ZERO;
        let mut var_of_mean = V3::ZERO;
        for s in 0..4u32 {
            let (sx, sy) = (f64::from(s % 2), f64::from(s / 2));
            let (mut sum, mut sq) = (V3::ZERO, V3::ZERO);
            for _ in 0..per {
                let fx = f64::from(x) + 0.5 * (sx + rng.uniform());
                let fy = f64::from(y) + 0.5 * (sy + rng.uniform());
                let (o, d) = cam.ray(fx, fy);
                let l = radiance(scene, job.options, o, d, 0, &mut rng, &mut n);
                sum = sum + l;
                sq = sq + l.scale(l);
            }
            let k = f64::from(per);
            let m = sum * (1.0 / k);
            mean = mean + m * 0.25;
            if per >= 2 {
                // sample variance of the stratum, over its count, / 4²
                let var = (sq - m.scale(sum)) * (1.0 / (k - 1.0));
                let var = V3::new(var.x.max(0.0), var.y.max(0.0), var.z.max(0.0));
                var_of_mean = var_of_mean + var * (1.0 / (16.0 * k));
            }
        }
        let c = |v: V3| Color::new(v.x as f32, v.y as f32, v.z as f32);
        means.push(c(mean));
        errs.push(c(V3::new(
            var_of_mean.x.sqrt(),
            var_of_mean.y.sqrt(),
            var_of_mean.z.sqrt(),
        )));
    }
    (means, errs, n)
}

/// Renders `scene` with smallpt's algorithm. Every pixel has its own random
/// stream, so the image is the same for any number of threads.
pub fn render(scene: &SmallptScene, job: &SmallptJob) -> Result<SmallptOutput, String> {
    if job.width == 0 || job.height == 0 {
        return Err("image size must be at least 1x1".into());
    }
    if job.spp == 0 || !job.spp.is_multiple_of(4) {
        return Err(format!(
            "spp {} is not a positive multiple of 4 (smallpt samples 2x2 strata)",
            job.spp
        ));
    }
    if job.options.max_depth == 0 {
        return Err("the depth cap must be at least 1 hit".into());
    }
    let cam = Camera::new(&scene.camera, job.width, job.height);
    let threads = resolve_threads(job.threads).min(job.height as usize).max(1);
    let (w, h) = (job.width as usize, job.height as usize);
    let image = Mutex::new(Image::new(job.width, job.height));
    let errors = Mutex::new(Image::new(job.width, job.height));
    let counts = Mutex::new(Counts::default());
    let next = AtomicU32::new(0);
    let work = || {
        let mut local = Counts::default();
        loop {
            let y = next.fetch_add(1, Ordering::Relaxed);
            if y >= job.height {
                break;
            }
            let (m, e, r) = render_row(scene, &cam, job, y);
            local.rays += r.rays;
            local.truncated += r.truncated;
            let row = y as usize * w;
            image.lock().unwrap_or_else(|p| p.into_inner()).pixels[row..row + w]
                .copy_from_slice(&m);
            errors.lock().unwrap_or_else(|p| p.into_inner()).pixels[row..row + w]
                .copy_from_slice(&e);
        }
        let mut c = counts.lock().unwrap_or_else(|p| p.into_inner());
        c.rays += local.rays;
        c.truncated += local.truncated;
    };
    let start = Instant::now();
    if threads == 1 {
        work();
    } else {
        std::thread::scope(|s| {
            for _ in 0..threads {
                s.spawn(work);
            }
        });
    }
    let seconds = start.elapsed().as_secs_f64();
    let counts = counts.into_inner().unwrap_or_else(|p| p.into_inner());
    Ok(SmallptOutput {
        image: image.into_inner().unwrap_or_else(|p| p.into_inner()),
        standard_error: errors.into_inner().unwrap_or_else(|p| p.into_inner()),
        paths: (w * h) as u64 * u64::from(job.spp),
        rays: counts.rays,
        truncated: counts.truncated,
        seconds,
        threads,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::bias_z;
    use crate::reference::{Reference, scenes_dir, standard_error_map};

    fn smallpt_scene() -> SmallptScene {
        SmallptScene::load(&scenes_dir().join("smallpt.scene")).unwrap()
    }

    #[test]
    fn parses_the_walls_in_double_precision() {
        let s = smallpt_scene();
        assert_eq!(s.resolution, Some((64, 48)));
        assert_eq!(s.spheres.len(), 9);
        // the floor: f32 would keep -99918.4 only to about 0.004
        assert_eq!(s.spheres[5].center, V3::new(50.0, -99918.4, 81.6));
        assert_eq!(s.spheres[5].radius, 1e5);
        assert_eq!(s.spheres[7].surface, Surface::Glass(1.5));
        assert_eq!(
            s.spheres[8].surface,
            Surface::Light(V3::new(12.0, 12.0, 12.0))
        );
        assert_eq!(s.camera.vfov_deg, 48.7);
    }

    #[test]
    fn bad_scenes_name_the_line() {
        let e = SmallptScene::parse("camera 0 0 0  0 0 -1  0 1 0  60\nsphere 0 0 -3 1 nope\n")
            .unwrap_err();
        assert!(e.contains("line 2"), "{e}");
        let e = SmallptScene::parse(
            "camera 0 0 0  0 0 -1  0 1 0  60\nmaterial m diffuse 1 1 1\nplane 0 -1 0 0 1 0 m\n",
        )
        .unwrap_err();
        assert!(e.contains("line 3") && e.contains("planes"), "{e}");
    }

    #[test]
    fn camera_is_micropts() {
        // the same pixel -> ray mapping as the core's f32 camera
        let s = smallpt_scene();
        let c = s.camera;
        let f = |v: V3| micropt::Vec3::new(v.x as f32, v.y as f32, v.z as f32);
        let spec =
            micropt::camera::CameraSpec::pinhole(f(c.eye), f(c.target), f(c.up), c.vfov_deg as f32);
        let ours = Camera::new(&c, 64, 48);
        let theirs = micropt::camera::Camera::new(&spec, 64, 48).unwrap();
        for (fx, fy) in [
            (0.0, 0.0),
            (64.0, 0.0),
            (0.0, 48.0),
            (32.0, 24.0),
            (7.3, 41.9),
        ] {
            let (_, d) = ours.ray(fx, fy);
            let r = theirs.ray(fx as f32, fy as f32).dir;
            let diff = d - V3::new(r.x.into(), r.y.into(), r.z.into());
            let e = diff.dot(diff).sqrt();
            assert!(e < 1e-6, "({fx}, {fy}): {e}");
        }
        // y = 0 is the top row: its rays point higher than the bottom row's
        assert!(ours.ray(32.0, 0.0).1.y > ours.ray(32.0, 48.0).1.y);
    }

    #[test]
    fn fresnel_is_exact() {
        // Fresnel equations: normal incidence gives ((n1-n2)/(n1+n2))^2, the
        // same from either side; total internal reflection beyond the
        // critical angle; grazing incidence reflects everything
        let r0 = (0.5f64 / 2.5).powi(2);
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - r0).abs() < 1e-15);
        assert!((fresnel_dielectric(1.0, 1.5) - r0).abs() < 1e-15);
        let crit = (1.0f64 / 1.5).asin();
        assert_eq!(fresnel_dielectric((crit + 1e-6).cos(), 1.5), 1.0);
        assert!(fresnel_dielectric((crit - 1e-3).cos(), 1.5) < 1.0);
        assert!(fresnel_dielectric(1e-9, 1.0 / 1.5) > 0.999_999);
        // Brewster's angle (tan i = n2/n1): the p-polarised part vanishes and
        // R = rs^2 / 2 with rs = -sin(i - t) / sin(i + t)
        let b = 1.5f64.atan();
        let t = (b.sin() / 1.5).asin();
        let rs = (b - t).sin() / (b + t).sin();
        assert!((fresnel_dielectric(b.cos(), 1.0 / 1.5) - 0.5 * rs * rs).abs() < 1e-14);
        // reciprocity: same R for the reversed ray
        let i = 0.7f64;
        let t = (i.sin() / 1.5).asin();
        assert!(
            (fresnel_dielectric(i.cos(), 1.0 / 1.5) - fresnel_dielectric(t.cos(), 1.5)).abs()
                < 1e-14
        );
    }

    #[test]
    fn image_does_not_depend_on_threads() {
        let s = smallpt_scene();
        let job = |threads| SmallptJob {
            width: 16,
            height: 12,
            spp: 8,
            seed: 3,
            threads,
            options: SmallptOptions::default(),
        };
        let a = render(&s, &job(1)).unwrap();
        let b = render(&s, &job(2)).unwrap();
        assert_eq!(a.image, b.image);
        assert_eq!(a.standard_error, b.standard_error);
        assert_eq!(a.rays, b.rays);
        assert!(render(&s, &SmallptJob { spp: 6, ..job(1) }).is_err());
    }

    #[test]
    fn converges_to_the_reference() {
        // no bias against the independent double-precision reference: the
        // means of rows and of 8x8 blocks differ from it by what the two
        // renders' standard errors allow. Measured over 8 seeds at 64 spp:
        // chi-square per value 0.65-1.24 (rows), 0.75-1.36 (blocks), MSE over
        // its noise expectation 0.94-1.05, image-mean |z| up to 2.4; the
        // three channels share their paths, so 48 groups give a chi-square
        // spread of about sqrt(2/48) = 0.2. Measured failures: the image
        // upside down gives row chi-square 9,700; a field of view 0.5 degree
        // wider gives 11. The 4096-spp check is in docs/smallpt-efficiency.md.
        let s = smallpt_scene();
        let r = Reference::load("smallpt").unwrap();
        let ref_se = standard_error_map("smallpt").unwrap().unwrap();
        let out = render(
            &s,
            &SmallptJob {
                width: 64,
                height: 48,
                spp: 64,
                seed: 1,
                threads: 0,
                options: SmallptOptions::default(),
            },
        )
        .unwrap();
        assert_eq!(out.truncated, 0);
        let z = bias_z(&out.image, &out.standard_error, &r.image, &ref_se, 8).unwrap();
        assert!(z.rows.chi2_per_dof < 1.8, "{z:?}");
        assert!(z.blocks.chi2_per_dof < 1.8, "{z:?}");
        assert!((z.mse / z.expected_mse - 1.0).abs() < 0.2, "{z:?}");
        for c in z.image_z {
            assert!(c.abs() < 4.0, "{z:?}");
        }
    }

    #[test]
    fn cutoff_changes_the_work_not_the_image() {
        // ending paths at surfaces that reflect nothing drops only terms
        // multiplied by zero: same mean up to noise, fewer rays
        let s = smallpt_scene();
        let job = |cutoff| SmallptJob {
            width: 64,
            height: 48,
            spp: 16,
            seed: 5,
            threads: 0,
            options: SmallptOptions {
                cutoff,
                ..SmallptOptions::default()
            },
        };
        let (a, b) = (
            render(&s, &job(false)).unwrap(),
            render(&s, &job(true)).unwrap(),
        );
        assert!(b.rays < a.rays, "{} {}", b.rays, a.rays);
        let z = bias_z(&a.image, &a.standard_error, &b.image, &b.standard_error, 8).unwrap();
        assert!(z.blocks.chi2_per_dof < 1.8, "{z:?}");
        for c in z.image_z {
            assert!(c.abs() < 4.0, "{z:?}");
        }
    }

    /// A small job on all cores with the default options.
    fn small(width: u32, height: u32, spp: u32, seed: u64) -> SmallptJob {
        SmallptJob {
            width,
            height,
            spp,
            seed,
            threads: 0,
            options: SmallptOptions::default(),
        }
    }

    #[test]
    fn glass_resting_on_the_ground_ends() {
        // A glass ball resting on a ground sphere, seen from the gap under
        // it, where paths get caught inside the ball in chords beyond the
        // critical angle, which total internal reflection keeps for ever
        // (most likely a diffuse bounce on the ground within 1e-4 of the
        // glass skips the glass's near surface and starts inside the ball). With glass surviving the roulette always, 9-14
        // paths per seed here never ended (stopped at a cap of 2,000 hits);
        // with survival 0.999 every path ends by the roulette.
        let s = SmallptScene::parse(
            "camera 0.02 0.0002 0   0 0 0   0 1 0   20\n\
             material ground diffuse 0.6 0.6 0.6\n\
             material glass glass 1.5\n\
             material lamp light 8 8 8\n\
             sphere 0 -1000 0 1000 ground\n\
             sphere 0 0.8 0 0.8 glass\n\
             sphere 1.5 3 0 0.5 lamp\n",
        )
        .unwrap();
        for seed in 1..=6 {
            let out = render(&s, &small(8, 8, 16, seed)).unwrap();
            assert_eq!(out.truncated, 0, "seed {seed}");
            assert!(out.image.pixels.iter().all(|c| c.x.is_finite()));
        }
    }

    /// A glass ball of radius 1 in a uniform surround of radiance 1, seen
    /// from (0, 0.9, 0) along `dir` through a field of view of 0.0001
    /// degree, so that every ray of the image follows one line.
    fn inside_glass(dir: (f64, f64)) -> SmallptScene {
        let (x, y) = dir;
        SmallptScene::parse(&format!(
            "camera 0 0.9 0   {x} {} 0   0 0 1   0.0001\n\
             background 1 1 1\n\
             material glass glass 1.5\n\
             sphere 0 0 0 1 glass\n",
            0.9 + y
        ))
        .unwrap()
    }

    #[test]
    fn a_camera_inside_glass_ends() {
        // A chord of a sphere meets the surface at the same angle at each
        // end, so a ray whose line passes the centre at more than 1/1.5 of
        // the radius is reflected totally for ever. Along +x from
        // (0, 0.9, 0) it passes at 0.9: no light ever arrives (image
        // exactly 0), and every path ends by the roulette: 5 hits, then a
        // geometric number with survival 0.999, 1,005 hits on average
        // (standard deviation 1,000 per path).
        let out = render(&inside_glass((1.0, 0.0)), &small(4, 4, 64, 2)).unwrap();
        assert_eq!(out.truncated, 0);
        assert!(out.image.pixels.iter().all(|c| *c == Color::ZERO));
        let hits = out.rays as f64 / out.paths as f64;
        let sigma = 1000.0 / (out.paths as f64).sqrt();
        assert!((hits - 1005.0).abs() < 4.0 * sigma, "{hits} hits per path");
        // Passing the centre at 0.666 (just inside the critical 0.6667,
        // Fresnel reflectance 0.77 at each hit, a quarter of the paths past
        // the fifth hit) the ray escapes: glass that absorbs nothing in a
        // surround of radiance 1 shows it exactly (over 12 seeds |z| <= 1.2).
        let (s, c) = (0.666f64 / 0.9, (1.0 - (0.666f64 / 0.9).powi(2)).sqrt());
        let out = render(&inside_glass((s, c)), &small(2, 2, 1024, 3)).unwrap();
        assert_eq!(out.truncated, 0);
        let mean = out.image.mean()[1];
        let se = (out
            .standard_error
            .pixels
            .iter()
            .map(|e| f64::from(e.y).powi(2))
            .sum::<f64>()
            .sqrt())
            / 4.0;
        assert!((mean - 1.0).abs() < 4.0 * se, "{mean} +- {se}");
    }

    #[test]
    fn the_depth_cap_ends_and_counts_paths() {
        // The camera inside a closed grey sphere: no path leaves, and before
        // the roulette starts (sixth hit) none ends by chance, so a cap of 3
        // hits ends every path at exactly its third hit.
        let s = SmallptScene::parse(
            "camera 0 0 0   0 0 -1   0 1 0   60\n\
             material grey diffuse 0.5 0.5 0.5\n\
             sphere 0 0 0 1 grey\n",
        )
        .unwrap();
        let mut job = small(4, 4, 8, 1);
        job.options.max_depth = 3;
        let out = render(&s, &job).unwrap();
        assert_eq!(out.truncated, out.paths);
        assert_eq!(out.rays, 3 * out.paths);
        // the default cap is never reached: the roulette ends every path
        let out = render(&s, &small(4, 4, 8, 1)).unwrap();
        assert_eq!(out.truncated, 0);
        assert!(out.rays > 5 * out.paths);
        job.options.max_depth = 0;
        assert!(render(&s, &job).unwrap_err().contains("at least 1"));
    }
}
