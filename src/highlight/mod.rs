//! Highlights: the images of lights in mirror spheres and through glass
//! balls, sampled from the light's side (feature `highlight`).
//!
//! A camera ray that meets a mirror sphere and then a light carries the
//! light's radiance times the mirror's tint; one that passes through a
//! glass ball (in and out) and then meets a light, the radiance times the
//! two Fresnel transmittances. When the light is small and far, its image
//! in a convex mirror is a small fraction of a pixel (a sun in a ball of a
//! tenth of a unit, seen across a field, covers about 1 % of a pixel), and
//! through a ball a few pixels at most, which film sampling finds only by
//! chance: it is most of the error of such a pixel, and it falls as 1/N at
//! best.
//!
//! This module estimates that part of a pixel's integral another way. It
//! samples the direction ω of the ray leaving the sphere uniformly in the
//! cone, around the line from the sphere's centre to the light's, of every
//! direction in which a ray from a point of the sphere can meet the light
//! (half-angle `asin((r_light + r_sphere) / distance)`), and finds the point
//! of the mirror whose reflection of the eye's ray leaves along ω (one
//! root: see [`mirror_point`]), or the one path from the eye through the
//! ball that leaves along ω. The film position of that point is a sample
//! with density `p(ω) · |dω/dx|` (the Jacobian of the film to
//! leaving-direction map, from the derivatives of the camera ray and of the
//! sphere's normal); a sample inside the pixel whose camera ray meets the
//! sphere first and whose leaving ray meets the light first adds
//! `weight · L_e / (p(ω) |dω/dx|)`. With a thin lens the eye is a lens
//! position, one a sample ([`crate::camera::LensPoint`]): for a fixed lens
//! position the film maps to rays as a pinhole's does, and the lens
//! position's density is the path tracer's. The path tracer leaves out the
//! emission that a camera path meets along such a path (`covers`), so each
//! part of the integral is estimated once: the two are unbiased together.
//!
//! A pair (sphere, light) gets this estimator when the light is at least as
//! large as the sphere, so that a sampled direction meets the light with
//! probability at least a quarter (`(r_l / (r_l + r_m))²`), and its cone is
//! narrow (sine of the half-angle at most [`SIN_MAX`]): a large light's
//! image is large, and film sampling finds it.

use crate::camera::{Camera, LensPoint};
use crate::geometry::{Color, ObjectId, Sphere, Vec3};
use crate::light;
use crate::material::Material;
use crate::material::mirror::reflect;
use crate::math;
use crate::scene::SceneView;
use crate::stats::Stats;

mod chain;

use chain::estimate_chain;
pub use chain::{CHAIN_AREA_MAX, CHAIN_SHARE, CHAINS, VIA_INSIDE};

/// Most pairs (a light seen in a mirror, or through a chain: see
/// [`Highlight::via`]) a render estimates this way; further pairs are left
/// to the path tracer. Feature `small-ram` (a board of 16 KiB): 16 and no
/// chains, and a scene with more pairs or with chains renders differently
/// from the default build.
#[cfg(not(feature = "small-ram"))]
pub const CAPACITY: usize = 160;
/// Most pairs (a light seen in a mirror, or through a chain: see
/// [`Highlight::via`]) a render estimates this way; further pairs are left
/// to the path tracer. Feature `small-ram` (a board of 16 KiB): 16 and no
/// chains, and a scene with more pairs or with chains renders differently
/// from the default build.
#[cfg(feature = "small-ram")]
pub const CAPACITY: usize = 16;

/// Largest sine of the half-angle of a pair's direction cone.
pub const SIN_MAX: f32 = 0.25;

/// Directions each sample of a pixel draws for each of its pairs: a
/// Fibonacci lattice of this many points (`(j / 8, 5j / 8 mod 1)`)
/// shifted by the sample's own pair of numbers. A light's image spans a
/// few pixels, and a pixel holding a sliver of it counted one sample's
/// direction or none (many.scene at 16 spp: a ninth of its squared error
/// was the sun's image in the big mirror landing in its two pixels in
/// unequal counts); each term is unbiased, as each shifted point is
/// uniform, and a direction that lands outside the pixel costs a
/// `mirror_point` and no ray.
pub const LATTICE: usize = 8;

/// The lattice's second coordinates, `5j / 8 mod 1` ([`LATTICE`]).
pub const LATTICE_STEPS: [f32; LATTICE] = {
    let mut s = [0.0f32; LATTICE];
    let mut j = 0;
    while j < LATTICE {
        s[j] = ((5 * j) % LATTICE) as f32 / LATTICE as f32;
        j += 1;
    }
    s
};

/// `v` in [0, 2) wrapped into [0, 1) (`v − 1` is exact there).
#[inline(always)]
pub fn wrap(v: f32) -> f32 {
    if v >= 1.0 { v - 1.0 } else { v }
}

/// Most pairs whose film rectangles hold one pixel that a pixel keeps in
/// its own list; a pixel in more tests every pair per sample.
pub const PIXEL_PAIRS: usize = 8;

/// One (mirror or glass sphere, light sphere) pair and the pixels the
/// light's image in it can touch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Highlight {
    /// Scene index of the sphere the path leaves for the light: a mirror,
    /// or a glass ball seen straight from the camera (then `via` is the
    /// same ball with [`VIA_INSIDE`]: [`Highlight::through_glass`]).
    pub mirror: u16,
    /// Scene index of the light sphere.
    pub light: u16,
    /// Scene index of the sphere that the camera sees `mirror` in (a
    /// chain: camera → `via` → `mirror` → light): a mirror, or a glass ball
    /// passed through with [`VIA_INSIDE`] set; [`NO_VIA`] for a light seen
    /// in `mirror` straight from the camera.
    pub via: u16,
    /// Pixels `[x0, y0, x1, y1]` (inclusive) that can hold the light's
    /// image in the mirror (the film rectangle of the pair's cone of
    /// directions).
    pub pixels: [u16; 4],
}

/// [`Highlight::via`] of a light seen in a mirror straight from the camera.
pub const NO_VIA: u16 = u16::MAX;

impl Highlight {
    /// No pair (a light seen straight in mirror 0, on no pixel).
    pub const NONE: Self = Self {
        mirror: 0,
        light: 0,
        via: NO_VIA,
        pixels: [0; 4],
    };

    /// The bounces of the pair's paths before they meet the light: 1 in a
    /// mirror, 2 through a glass ball (in and out) or a chain of two
    /// mirrors, 3 through a glass ball and a mirror.
    #[inline(always)]
    pub fn bounces(&self) -> u32 {
        match self.via {
            NO_VIA => 1,
            v if v & VIA_INSIDE != 0 => 3 - u32::from(self.through_glass()),
            _ => 2,
        }
    }

    /// Whether the pair is a light seen through a glass ball straight from
    /// the camera (`via` is the ball, passed through, and `mirror` the
    /// ball itself).
    #[inline(always)]
    pub fn through_glass(&self) -> bool {
        self.via & VIA_INSIDE != 0 && self.via & !VIA_INSIDE == self.mirror
    }

    /// Whether the pair is a chain of two spheres ([`CHAIN_SHARE`] of the
    /// samples estimate it).
    #[inline(always)]
    pub fn is_chain(&self) -> bool {
        self.via != NO_VIA && !self.through_glass()
    }

    fn holds(&self, x: u32, y: u32) -> bool {
        let [x0, y0, x1, y1] = self.pixels;
        (u32::from(x0)..=u32::from(x1)).contains(&x) && (u32::from(y0)..=u32::from(y1)).contains(&y)
    }
}

/// A render's pairs, ordered by their first row.
#[derive(Clone, Copy, Debug)]
pub struct Highlights {
    list: [Highlight; CAPACITY],
    len: usize,
    /// The most rows a pair's rectangle spans, less one ([`Highlights::at`]).
    tallest: u16,
}

impl Highlights {
    /// No pairs.
    pub const NONE: Self = Self {
        list: [Highlight::NONE; CAPACITY],
        len: 0,
        tallest: 0,
    };

    /// The pairs of `scene` seen by `camera`: first every light seen in a
    /// mirror or through a glass ball straight from the camera, then, in
    /// the room left, the chains (camera → mirror or glass → mirror →
    /// light) whose images are largest on the film ([`CHAINS`] at most).
    /// With a lens, each is bounded on the film over the whole lens
    /// (its rectangles from the lens' centre and rim).
    #[inline(never)]
    pub fn new(scene: &SceneView<'_>, camera: &Camera) -> Self {
        let mut out = Self::NONE;
        let (w, h) = (camera.width(), camera.height());
        for (mi, m) in scene.spheres.iter().enumerate() {
            // a mirror, or a glass ball that one path from the eye leaves
            // along each direction (as a chain's first sphere)
            let kind = if is_mirror(scene, m) {
                None
            } else {
                match chain::first(scene, camera, m) {
                    Some((k, _)) if k != chain::First::Mirror => Some(k),
                    _ => continue,
                }
            };
            for &li in scene.emitters {
                let Some(l) = scene.spheres.get(li as usize) else {
                    continue;
                };
                let Some(d) = pair_distance(m, l) else {
                    continue;
                };
                // a pair whose image is not bounded that way, or lies
                // outside the film, is left to film sampling
                let Some(pixels) =
                    image_rect(camera, kind, m, l, d).and_then(|r| pixel_rect(r, w, h))
                else {
                    continue;
                };
                out.insert(Highlight {
                    mirror: mi as u16,
                    light: li,
                    via: if kind.is_some() {
                        mi as u16 | VIA_INSIDE
                    } else {
                        NO_VIA
                    },
                    pixels,
                });
            }
        }
        out.add_chains(scene, camera);
        out
    }

    /// `hl` into the list by first row (stable: insertion order among
    /// equals; no slice method that can panic, for the firmware's
    /// panic-free link), if there is room.
    fn insert(&mut self, hl: Highlight) {
        if self.len >= CAPACITY {
            return;
        }
        let mut at = self.len;
        while at > 0
            && self
                .list
                .get(at - 1)
                .is_some_and(|p| p.pixels[1] > hl.pixels[1])
        {
            if let Some([a, b]) = self.list.get_mut(at - 1..=at) {
                *b = *a;
            }
            at -= 1;
        }
        if let Some(slot) = self.list.get_mut(at) {
            *slot = hl;
        }
        self.len += 1;
        self.tallest = self.tallest.max(hl.pixels[3].saturating_sub(hl.pixels[1]));
    }

    /// The pairs.
    pub fn as_slice(&self) -> &[Highlight] {
        self.list.get(..self.len).unwrap_or(&[])
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether the emission of `light` that a camera path meets after
    /// `depth` bounces, the last of them at the sphere `from`, having met
    /// first the sphere `first` ([`NO_VIA`] for none; with [`VIA_INSIDE`]
    /// if it met that sphere again right after), is estimated here (the
    /// path tracer then leaves it out). The pairs' paths: camera → mirror
    /// → light at depth 1, camera → glass → glass → light and camera →
    /// mirror → mirror → light at 2, camera → glass → glass → mirror →
    /// light at 3.
    #[inline]
    pub fn covers(&self, depth: u32, first: u16, from: ObjectId, light: ObjectId) -> bool {
        let (Some(m), Some(l)) = (from.as_sphere(), light.as_sphere()) else {
            return false;
        };
        let via = if depth == 1 { NO_VIA } else { first };
        self.as_slice().iter().any(|p| {
            usize::from(p.mirror) == m
                && usize::from(p.light) == l
                && p.via == via
                && p.bounces() == depth
        })
    }

    /// The pairs whose rectangles hold pixel (x, y).
    #[inline(never)]
    pub fn at(&self, x: u32, y: u32) -> PixelHighlights {
        let mut out = PixelHighlights::NONE;
        let list = self.as_slice();
        // the first pair whose rectangle can reach row y: its first row at
        // least y − tallest (the list is ordered by first row)
        let from = y.saturating_sub(u32::from(self.tallest));
        let (mut lo, mut hi) = (0usize, list.len());
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if list.get(mid).is_some_and(|p| u32::from(p.pixels[1]) < from) {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        for (i, p) in list.iter().enumerate().skip(lo) {
            if u32::from(p.pixels[1]) > y {
                break;
            }
            if p.holds(x, y) {
                if let Some(slot) = out.idx.get_mut(usize::from(out.len)) {
                    *slot = i as u8;
                    out.len += 1;
                } else {
                    out.all = true;
                }
            }
        }
        out
    }
}

/// The pairs that can touch one pixel ([`Highlights::at`]).
#[derive(Clone, Copy, Debug)]
pub struct PixelHighlights {
    idx: [u8; PIXEL_PAIRS],
    len: u8,
    /// More than [`PIXEL_PAIRS`]: test every pair.
    all: bool,
}

impl PixelHighlights {
    /// None.
    pub const NONE: Self = Self {
        idx: [0; PIXEL_PAIRS],
        len: 0,
        all: false,
    };

    /// Whether no pair touches the pixel.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Calls `f` with the index and the pair of every pair that can touch
    /// pixel (x, y) of `all`.
    #[inline]
    pub fn each(&self, all: &Highlights, x: u32, y: u32, mut f: impl FnMut(usize, &Highlight)) {
        if self.all {
            for (i, p) in all.as_slice().iter().enumerate() {
                if p.holds(x, y) {
                    f(i, p);
                }
            }
        } else {
            for &i in self.idx.get(..usize::from(self.len)).unwrap_or(&[]) {
                if let Some(p) = all.as_slice().get(usize::from(i)) {
                    f(usize::from(i), p);
                }
            }
        }
    }
}

/// `|dw₁ × dw₂ · w|` for the reflection `w` of a ray (unit `wi`) in a
/// mirror sphere of radius `r`, met at distance `dist` where the normal is
/// `nh` (`nc = nh · wi < 0`), as the ray turns by `a₁` and `a₂`: a turn
/// moves the ray's point on the sphere (along the ray's new direction to
/// the tangent plane) and so the normal (`dP / r`), and the reflection
/// moves with both. With the camera ray's film derivatives, `|dω/dx|` (the
/// highlight estimator); with a unit basis across `wi`, `|dω/dω_x|` (the
/// caustics through a mirror, [`crate::caustic`]).
#[inline(always)]
pub fn reflection_jacobian(
    turns: [Vec3; 2],
    wi: Vec3,
    nh: Vec3,
    nc: f32,
    dist: f32,
    r: f32,
    w: Vec3,
) -> f32 {
    let dw = |a: Vec3| {
        let dp = (a - wi * (nh.dot(a) / nc)) * dist;
        let dn = dp * (1.0 / r);
        a - (nh * (a.dot(nh) + wi.dot(dn)) + dn * nc) * 2.0
    };
    let [a1, a2] = turns;
    math::abs(dw(a1).cross(dw(a2)).dot(w))
}

/// Whether sphere `m` is a mirror.
fn is_mirror(scene: &SceneView<'_>, m: &Sphere) -> bool {
    matches!(
        scene.materials.get(m.material as usize),
        Some(Material::Mirror(_))
    )
}

/// The distance between the centres of mirror `m` and light `l` when the
/// pair gets the estimator: the light at least as large as the mirror and
/// its cone narrow (sine of the half-angle at most [`SIN_MAX`]).
fn pair_distance(m: &Sphere, l: &Sphere) -> Option<f32> {
    let d = (l.center - m.center).length();
    let reach = l.radius + m.radius;
    (l.radius >= m.radius && reach <= SIN_MAX * d).then_some(d)
}

/// Directions sampled on the rim of a pair's cone to bound its image.
const RIM: usize = 32;
/// cos and sin of 2π / [`RIM`].
const STEP_COS: f32 = 0.980_785_3;
const STEP_SIN: f32 = 0.195_090_32;

/// The film rectangle of the image of the light `l` in the mirror `m`, or
/// through the glass ball `m` (`glass`: its kind) (centres `d` apart): the
/// image of the pair's cone of directions is bounded by the image of the
/// cone's rim, whose bounding box of [`RIM`] points is widened by twice
/// the largest step between neighbours (the curve between two of them
/// stays within that), over the lens ([`lens_rect`]). `None` when a rim
/// direction has no point on the sphere's visible side (the cone reaches
/// the part the sphere hides from the eye) or its point is not in front of
/// the eye.
fn image_rect(
    camera: &Camera,
    glass: Option<chain::First>,
    m: &Sphere,
    l: &Sphere,
    d: f32,
) -> Option<[f32; 4]> {
    lens_rect(camera, |lp| {
        let eye = camera.origin(&lp);
        rim_rect(m, l, d, RIM, |w| {
            let seen = match glass {
                None => m.center + mirror_point(eye, m.center, m.radius, w)? * m.radius,
                Some(kind) => chain::glass_entry(eye, kind, m, w)?,
            };
            camera.film_at(seen, &lp)
        })
    })
}

/// Positions on a lens' rim at which a pair's image is bounded
/// ([`lens_rect`]).
const LENS_RIM: usize = 8;

/// The film rectangle that `rect_at` gives from every position of the
/// camera's lens (for a pinhole, from the eye): the union of its
/// rectangles from the lens' centre and [`LENS_RIM`] points of its rim,
/// widened by twice the largest step of a side between rim neighbours. An
/// image moves on the film nearly in proportion to the lens offset (its
/// defocus), so the rim's images bound the disk's. `None` when any of
/// them is `None`.
fn lens_rect(camera: &Camera, rect_at: impl Fn(LensPoint) -> Option<[f32; 4]>) -> Option<[f32; 4]> {
    let mut r = rect_at(LensPoint::CENTRE)?;
    if !camera.has_lens() {
        return Some(r);
    }
    let mut gap = 0.0f32;
    let mut prev: Option<[f32; 4]> = None;
    // (cos, sin) of k · 2π / LENS_RIM: k = 0 again at the end, to close
    // the rim
    let (step_cos, step_sin) = (
        core::f32::consts::FRAC_1_SQRT_2,
        core::f32::consts::FRAC_1_SQRT_2,
    );
    let (mut c, mut s) = (1.0f32, 0.0f32);
    for _ in 0..=LENS_RIM {
        let q = rect_at(camera.lens_at(c, s))?;
        if let Some(p) = prev {
            for (a, b) in q.iter().zip(p.iter()) {
                gap = math::max(gap, math::abs(a - b));
            }
        }
        prev = Some(q);
        r = [
            math::min(r[0], q[0]),
            math::min(r[1], q[1]),
            math::max(r[2], q[2]),
            math::max(r[3], q[3]),
        ];
        (c, s) = (c * step_cos - s * step_sin, s * step_cos + c * step_sin);
    }
    let pad = 2.0 * gap;
    Some([r[0] - pad, r[1] - pad, r[2] + pad, r[3] + pad])
}

/// The film rectangle of the cone of directions from mirror `m` to light
/// `l` (centres `d` apart) under the map `film` from a direction to its
/// film position, as [`image_rect`] bounds it.
fn rim_rect(
    m: &Sphere,
    l: &Sphere,
    d: f32,
    rim: usize,
    film: impl Fn(Vec3) -> Option<[f32; 2]>,
) -> Option<[f32; 4]> {
    // a step of 2π / rim: cos and sin of 2π / 32, doubled while the
    // angle is smaller than the rim's step
    let (mut step_cos, mut step_sin) = (STEP_COS, STEP_SIN);
    let mut n = RIM;
    while n > rim && n > 4 {
        (step_cos, step_sin) = (
            step_cos * step_cos - step_sin * step_sin,
            2.0 * step_sin * step_cos,
        );
        n /= 2;
    }
    let axis = (l.center - m.center) * (1.0 / d);
    let sin = (l.radius + m.radius) / d;
    let cos = math::sqrt(1.0 - sin * sin);
    let (b1, b2) = axis.basis();
    let [mut x0, mut y0] = film(axis)?;
    let (mut x1, mut y1) = (x0, y0);
    let mut gap = 0.0f32;
    let mut prev: Option<[f32; 2]> = None;
    let mut first = [0.0f32; 2];
    // (cos, sin) of k · 2π / RIM, turned by a step each time
    let (mut c, mut s) = (1.0f32, 0.0f32);
    for k in 0..=n {
        let [fx, fy] = if k == n {
            first
        } else {
            film((axis * cos + (b1 * c + b2 * s) * sin).normalize())?
        };
        if let Some([px, py]) = prev {
            gap = math::max(gap, math::max(math::abs(fx - px), math::abs(fy - py)));
        } else {
            first = [fx, fy];
        }
        prev = Some([fx, fy]);
        (c, s) = (c * step_cos - s * step_sin, s * step_cos + c * step_sin);
        (x0, y0) = (math::min(x0, fx), math::min(y0, fy));
        (x1, y1) = (math::max(x1, fx), math::max(y1, fy));
    }
    let pad = 2.0 * gap + 1.0 / 64.0;
    Some([x0 - pad, y0 - pad, x1 + pad, y1 + pad])
}

/// The pixels (inclusive) of the film rectangle `r` within the image, or
/// `None` if there are none.
fn pixel_rect(r: [f32; 4], w: u32, h: u32) -> Option<[u16; 4]> {
    let x0 = math::max(r[0], 0.0);
    let y0 = math::max(r[1], 0.0);
    let x1 = math::min(r[2], w as f32 - 1.0 / 1024.0);
    let y1 = math::min(r[3], h as f32 - 1.0 / 1024.0);
    if !(x0 <= x1 && y0 <= y1) {
        return None;
    }
    Some([
        math::floor(x0) as u16,
        math::floor(y0) as u16,
        math::floor(x1) as u16,
        math::floor(y1) as u16,
    ])
}

/// The unit normal of the point of the sphere (centre `c`, radius `r`)
/// seen from the eye `e` whose mirror reflection of the eye's ray leaves
/// along the unit direction `w`, or `None` when no visible point reflects
/// into `w` (it lies in the cone the sphere hides from the eye).
///
/// In the plane of `e − c` and `w`, with the normal at angle φ from the
/// direction `u` to the eye (at distance `D`) and `w` at angle β:
/// `h(φ) = n·w − n·e(φ)`, the difference of the cosines of the angles of
/// reflection and of incidence, is negative at φ = 0 and has the sign of
/// `2φ + atan2(r sin φ, D − r cos φ) − β`, which increases up to the
/// horizon `cos φ = r / D`: one root, where `h ≥ 0` at the horizon. It is
/// found by Newton's method on `t = tan(φ / 2)`, kept in the bracket of a
/// sign change.
#[inline(never)]
pub fn mirror_point(e: Vec3, c: Vec3, r: f32, w: Vec3) -> Option<Vec3> {
    let to_eye = e - c;
    let dist = to_eye.length();
    if !(dist > r) {
        return None;
    }
    let u = to_eye * (1.0 / dist);
    let cb = w.dot(u);
    let perp = w - u * cb;
    let sb = perp.length();
    if !(sb > 1e-7) {
        // reflected straight back (or away): the point facing the eye
        return (cb > 0.0).then_some(u);
    }
    let v = perp * (1.0 / sb);
    // h and its derivative in t (dφ/dt = 2 / (1 + t²))
    let h = |t: f32| {
        let t2 = t * t;
        let k = 1.0 / (1.0 + t2);
        let (cos, sin) = ((1.0 - t2) * k, 2.0 * t * k);
        let l2 = dist * dist - 2.0 * dist * r * cos + r * r;
        let inv_l = 1.0 / math::sqrt(l2);
        let near = dist * cos - r;
        let val = cos * cb + sin * sb - near * inv_l;
        let dphi = -sin * cb
            + cos * sb
            + dist * sin * inv_l
            + near * dist * r * sin * inv_l * inv_l * inv_l;
        (val, dphi * 2.0 * k)
    };
    let (mut a, mut b) = (0.0f32, math::sqrt((dist - r) / (dist + r)));
    if !(h(b).0 >= 0.0) {
        return None;
    }
    // Newton, kept in the bracket [a, b] of a sign change (bisection when
    // it would leave it), from one step of the fixed point
    // n = (e(n) + w) / |e(n) + w| taken from the bisector of u and w (the
    // root for a distant eye)
    let n0 = (u + w).normalize();
    let n1 = ((to_eye - n0 * r).normalize() + w).normalize();
    let (c1, s1) = (n1.dot(u), n1.dot(v));
    let mut t = math::clamp(s1 / (1.0 + c1), a, b);
    for _ in 0..64 {
        let (ht, dt) = h(t);
        if ht < 0.0 {
            a = t;
        } else {
            b = t;
        }
        let newton = t - ht / dt;
        // quadratic convergence: after a Newton step of 1e-5 t the error is
        // far below an f32 ulp of t (and at the noise of h's rounding the
        // step may leave the bracket by an ulp)
        if !(math::abs(newton - t) > 1e-5 * t) {
            t = math::clamp(newton, a, b);
            break;
        }
        t = if newton > a && newton < b {
            newton
        } else {
            0.5 * (a + b)
        };
        if !(b - a > 4e-7 * b) {
            break;
        }
    }
    let t2 = t * t;
    let k = 1.0 / (1.0 + t2);
    Some(u * ((1.0 - t2) * k) + v * (2.0 * t * k))
}

/// The highlight estimate of pair `p` for pixel (`px`, `py`) from the
/// lens position `lp` (the eye for a pinhole) and the numbers `rnd` in
/// [0,1)²: `weight · L_e / (p(ω) |dω/dx|)` when the sampled film position
/// lies in the pixel and its camera ray from `lp` meets the pair's spheres
/// and then the light first, else `None` (zero); the weight is the
/// mirror's tint, or the ball's two Fresnel transmittances. The rays it
/// traces are counted in `stats.bounce_rays`.
#[allow(clippy::too_many_arguments)]
pub fn estimate(
    scene: &SceneView<'_>,
    camera: &Camera,
    p: &Highlight,
    px: u32,
    py: u32,
    lp: &LensPoint,
    rnd: [f32; 2],
    stats: &mut Stats,
) -> Option<Color> {
    let m = scene.spheres.get(usize::from(p.mirror))?;
    let l = scene.spheres.get(usize::from(p.light))?;
    let le = scene.materials.get(l.material as usize)?.emission()?;
    let reach = l.radius + m.radius;
    let cone = light::sample_cone(m.center, l.center, reach * reach, rnd[0], rnd[1], false)?;
    if p.via != NO_VIA {
        let value = estimate_chain(scene, camera, p, m, cone.dir, [px, py], lp, stats)?;
        return Some(le * value * (1.0 / cone.pdf));
    }
    let Some(Material::Mirror(tint)) = scene.materials.get(m.material as usize) else {
        return None;
    };
    let n = mirror_point(camera.origin(lp), m.center, m.radius, cone.dir)?;
    let [fx, fy] = camera.film_at(m.center + n * m.radius, lp)?;
    let (x0, y0) = (px as f32, py as f32);
    if !(fx >= x0 && fx < x0 + 1.0 && fy >= y0 && fy < y0 + 1.0) {
        return None;
    }
    // the camera ray of that film position, as the path tracer traces it
    // (the query out of line, which gives the same hits as the inlined one
    // the path tracer uses)
    let ray = camera.ray_at(fx, fy, lp);
    stats.bounce_rays += 1;
    let hit = scene.closest_hit_any(&ray, ObjectId::NONE)?;
    if hit.object != ObjectId::sphere(usize::from(p.mirror)) {
        return None;
    }
    let wc = ray.dir;
    let n = hit.normal;
    let w = reflect(wc, n);
    stats.bounce_rays += 1;
    let on = scene.closest_hit_any(&hit.spawn(w), hit.object)?;
    if on.object != ObjectId::sphere(usize::from(p.light)) || !(w.dot(on.normal) < 0.0) {
        return None;
    }
    // |dω/dx|: from the camera ray's derivatives on the film
    let (a1, a2) = camera.dir_derivatives_at(fx, fy, lp);
    let nc = n.dot(wc);
    if !(nc < 0.0) {
        return None;
    }
    let jac = reflection_jacobian([a1, a2], wc, n, nc, hit.t, m.radius, w);
    if !(jac > 0.0) {
        return None;
    }
    Some(*tint * le * (1.0 / (cone.pdf * jac)))
}

#[cfg(test)]
mod tests {
    use super::chain::{chain_points, first};
    use super::*;
    use crate::camera::CameraSpec;

    /// A xorshift stream of numbers in [0, 1).
    fn numbers() -> impl FnMut() -> f32 {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// Law checked: the law of reflection. The point `mirror_point` finds
    /// reflects the ray from the eye into the asked direction (angle of
    /// incidence = angle of reflection, in the plane of incidence), on the
    /// side the eye sees; and a direction it finds no point for lies in
    /// the cone behind the sphere that no visible point reflects into
    /// (angle to the eye's direction beyond 90° plus the horizon angle).
    #[test]
    fn mirror_point_obeys_the_law_of_reflection() {
        let mut next = numbers();
        for (d, r) in [
            (13.0f32, 0.2f32),
            (13.0, 1.0),
            (3.0, 1.0),
            (1.2, 1.0),
            (1e4, 0.5),
        ] {
            let (mut found, mut hidden) = (0, 0);
            for _ in 0..4000 {
                let w = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
                let e = Vec3::new(d, 0.0, 0.0);
                let horizon = math::sqrt(1.0 - (r / d) * (r / d)); // sin of the horizon angle
                match mirror_point(e, Vec3::ZERO, r, w) {
                    Some(n) => {
                        let i = (n * r - e).normalize();
                        assert!(i.dot(n) < 0.0, "the eye sees the point");
                        let out = reflect(i, n);
                        // f32: the root's rounding, a few ulps of the
                        // angle, grows as the eye nears the sphere
                        let tol = 2e-5 * d / (d - r);
                        assert!((out - w).length() < tol, "d {d} r {r} w {w:?}: {out:?}");
                        found += 1;
                    }
                    None => {
                        // beyond β = π/2 + φ_h: cos β < −sin φ_h
                        let cb = w.dot(Vec3::new(1.0, 0.0, 0.0));
                        assert!(cb < -horizon * 0.999 + 1e-3, "d {d} r {r} w {w:?}");
                        hidden += 1;
                    }
                }
            }
            // (a distant eye sees almost all of the sphere: its hidden cone is
            // too narrow for random directions to fall in)
            assert!(
                found > 2000 && (hidden > 0 || r / d < 0.3),
                "{found} {hidden}"
            );
        }
    }

    /// A camera looking down −z at a field of mirror balls under one sun.
    fn field() -> (crate::Scene<64, 4, 8>, Camera) {
        let mut b = crate::SceneBuilder::<64, 4, 8>::new();
        let mirror = b.material(Material::Mirror(Color::splat(0.8))).unwrap();
        let sun = b.material(Material::Light(Color::splat(500.0))).unwrap();
        let spec = CameraSpec::pinhole(
            Vec3::new(0.0, 1.0, 6.0),
            Vec3::ZERO,
            Vec3::new(0.0, 1.0, 0.0),
            40.0,
        );
        b.camera(spec).unwrap();
        for i in 0..5 {
            for j in 0..3 {
                let c = Vec3::new(i as f32 - 2.0, 0.0, -(j as f32) * 1.5);
                b.sphere(c, 0.05 + 0.1 * (i + j) as f32 / 6.0, mirror)
                    .unwrap();
            }
        }
        b.sphere(Vec3::new(300.0, 800.0, 200.0), 30.0, sun).unwrap();
        let scene = b.build().unwrap();
        let camera = Camera::new(&spec, 48, 32).unwrap();
        (scene, camera)
    }

    /// Every film position the estimator can sample for a pair, or for a
    /// chain through two balls, lies in the pair's pixel rectangle (only
    /// those pixels run it, while the path tracer leaves the pair's
    /// emission out everywhere).
    #[test]
    fn sampled_film_positions_lie_in_the_pairs_rectangle() {
        let (scene, camera) = field();
        let view = scene.view(camera.view_cos() - 1e-4);
        let pairs = Highlights::new(&view, &camera);
        let direct = pairs.as_slice().iter().filter(|p| p.via == NO_VIA).count();
        assert_eq!(direct, 15, "every ball's highlight is in view");
        assert!(
            pairs.as_slice().len() > direct + 10,
            "chains fill the room left"
        );
        landed_in_rectangles(&view, &camera, pairs.as_slice());
    }

    /// Samples 2,000 directions (and, with a lens, lens positions) for
    /// each pair of `list`, solves each as the estimator does, and asserts
    /// that every film position on the film lies in its pair's rectangle;
    /// returns how many landed on the film.
    fn landed_in_rectangles(view: &SceneView<'_>, camera: &Camera, list: &[Highlight]) -> usize {
        let mut next = numbers();
        let mut landed = 0;
        for p in list {
            let m = view.spheres[p.mirror as usize];
            let l = view.spheres[p.light as usize];
            let reach = l.radius + m.radius;
            let [x0, y0, x1, y1] = p.pixels;
            for _ in 0..2000 {
                let lp = camera.lens_point([next(), next()]);
                let eye = camera.origin(&lp);
                let Some(cone) =
                    light::sample_cone(m.center, l.center, reach * reach, next(), next(), false)
                else {
                    continue;
                };
                let seen = if p.via == NO_VIA {
                    let Some(n) = mirror_point(eye, m.center, m.radius, cone.dir) else {
                        continue;
                    };
                    m.center + n * m.radius
                } else {
                    let a = view.spheres[usize::from(p.via & !VIA_INSIDE)];
                    let (kind, _) = first(view, camera, &a).unwrap();
                    let found = if p.through_glass() {
                        chain::glass_entry(eye, kind, &a, cone.dir)
                    } else {
                        chain_points(eye, kind, &a, &m, cone.dir, None).map(|(s, _, _)| s)
                    };
                    let Some(seen) = found else {
                        continue;
                    };
                    seen
                };
                let [fx, fy] = camera.film_at(seen, &lp).unwrap();
                let (px, py) = (math::floor(fx), math::floor(fy));
                let (w, h) = (camera.width() as f32, camera.height() as f32);
                if px < 0.0 || py < 0.0 || px >= w || py >= h {
                    continue;
                }
                landed += 1;
                assert!(
                    px >= f32::from(x0)
                        && px <= f32::from(x1)
                        && py >= f32::from(y0)
                        && py <= f32::from(y1),
                    "({fx}, {fy}) outside {:?} (via {}, sphere {})",
                    p.pixels,
                    p.via,
                    p.mirror
                );
            }
        }
        landed
    }

    /// The same through a thin lens, for mirror pairs, glass pairs and
    /// chains: every film position sampled from any lens position (the
    /// solve from that position, projected through it) lies in the pair's
    /// rectangle, which bounds the pair over the lens' centre and rim
    /// (bounded from the lens' centre alone, a mirror's image lands a
    /// pixel outside: the test fails).
    #[test]
    fn sampled_film_positions_through_a_lens_lie_in_the_pairs_rectangle() {
        let mut b = crate::SceneBuilder::<64, 4, 8>::new();
        let mirror = b.material(Material::Mirror(Color::splat(0.8))).unwrap();
        let glass = b.material(Material::Glass(1.5)).unwrap();
        let sun = b.material(Material::Light(Color::splat(500.0))).unwrap();
        // focused at 4: the near balls blur over several pixels
        let spec = CameraSpec::pinhole(
            Vec3::new(0.0, 1.0, 6.0),
            Vec3::ZERO,
            Vec3::new(0.0, 1.0, 0.0),
            40.0,
        )
        .lens(0.15, 4.0);
        b.camera(spec).unwrap();
        for i in 0..5 {
            for j in 0..3 {
                let c = Vec3::new(i as f32 - 2.0, 0.0, 2.0 - (j as f32) * 2.0);
                let mat = if (i + j) % 2 == 0 { mirror } else { glass };
                b.sphere(c, 0.1 + 0.1 * (i + j) as f32 / 6.0, mat).unwrap();
            }
        }
        // a sun ahead (seen through the glass balls) and one behind (in
        // the mirrors)
        b.sphere(Vec3::new(-300.0, 500.0, -800.0), 40.0, sun)
            .unwrap();
        b.sphere(Vec3::new(300.0, 800.0, 200.0), 30.0, sun).unwrap();
        let scene = b.build().unwrap();
        let camera = Camera::new(&spec, 48, 32).unwrap();
        let view = scene.view(camera.view_cos() - 1e-4);
        let pairs = Highlights::new(&view, &camera);
        let list = pairs.as_slice();
        let glass_pairs = list.iter().filter(|p| p.through_glass()).count();
        let mirror_pairs = list.iter().filter(|p| p.via == NO_VIA).count();
        let chains = list.iter().filter(|p| p.is_chain()).count();
        assert!(
            glass_pairs >= 3 && mirror_pairs >= 3 && chains >= 3,
            "{glass_pairs} glass pairs, {mirror_pairs} mirror pairs, {chains} chains"
        );
        let landed = landed_in_rectangles(&view, &camera, list);
        assert!(landed > 1000, "{landed} samples landed on the film");
    }
}
