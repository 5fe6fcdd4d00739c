//! Textures that a pixel's samples see more than one albedo of (a
//! checker's edge inside the pixel, a checker out of focus behind a thin
//! lens): the pixel's mean albedo, measured.
//!
//! Where a pixel's samples see several albedos, each sample's scattered
//! radiance is about its albedo times the light that reaches the surface,
//! and the pixel's noise is mostly which albedos its `n` samples happened
//! to see. Each sample's first surface behind mirrors is found again (its
//! camera ray, [`Renderer::sample_rays`], followed as the guide follows the
//! centre's), so that the mean albedo `Ā` of exactly those samples is
//! known; behind a thin lens `4n` rays of their own
//! ([`Renderer::texture_rays`]) measure the pixel's mean albedo `A` far
//! more finely (a pinhole's `A` is `Ā`). The pixel's scattered mean `y`
//! becomes the ratio estimate `A · y / Ā` (consistent: `Ā` and `A` both
//! tend to the pixel's mean albedo), and `y / Ā`, the light on the
//! surface without the texture's noise, is what the filter smooths, with
//! the pixels of the same chain that see one albedo.
//!
//! Only where pixels tell the squares apart: a footprint (where the
//! pixel's corners' rays and its lens rim's meet the surface) wider than
//! [`FINE_SQUARES`] squares sees a texture so fine that the image is
//! smooth there, and the pixel is smoothed as it is with the other
//! blurred pixels, which averages the texture's noise over its
//! neighbours at no cost (measured instead, its error would be the
//! measured albedo's, which a flat image's filter beats). The measure is
//! taken up to [`MEASURED_UP_TO`] samples a pixel.

use super::Texel;
#[cfg(feature = "lens")]
use super::input::LENS_RIM;
use super::input::{
    BLURRED_KEY, Guide, GuideKind, Moments, PIXEL_CORNERS, guide_along, hit_on, same_chain,
    texture_along,
};
use crate::geometry::{Color, ObjectId, Ray, Vec3};
use crate::material::Material;
use crate::math;
use crate::render::Renderer;

/// Measuring rays for each of the render's samples of a pixel, behind a
/// thin lens. A pinhole's pixel takes the albedo its own samples saw as
/// its mean: they are a stratified net over the pixel alone, and
/// measured with 1 to 4 rays a sample more, gloss and the room of the
/// denoiser's test scenes came out the same (3.77x and 25.9x without, 3.79x
/// and 26.4x with 4), where behind a lens the measure takes dof from
/// 1.38x to 1.88x.
pub const TEXTURE_RAYS_PER_SAMPLE: u32 = 4;
/// The most samples a pixel for which the measure is taken: beyond, the
/// albedo the samples saw is the mean (their coverage noise is then small
/// beside what else is left, and 4 rays a sample cost about what the path
/// costs: on dof at 256 spp the measure made the denoised render 36 %
/// slower than the raw one for 3 % less MSE).
pub const MEASURED_UP_TO: u32 = 64;
/// A footprint wider than this many of the checker's squares (its pixel's
/// corners and its lens's rim, where they meet the surface) sees a
/// texture too fine to tell apart from pixel to pixel.
pub const FINE_SQUARES: f32 = 2.0;

/// The albedos a textured pixel's samples saw (each half of them) and its
/// mean albedo, measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRatio {
    /// The mean albedo of the first and of the second half of the
    /// render's samples.
    halves: [Color; 2],
    /// The mean albedo of the measuring rays.
    measured: Color,
}

impl TextureRatio {
    /// Pixel (x, y)'s albedos, for its `n` samples and guide `g`: `None`
    /// where the ratio does not apply (glass on the way, whose reflection
    /// or refraction the path tracer draws at random; an odd `n`; no
    /// texture at the centre; a footprint wider than [`FINE_SQUARES`] squares;
    /// behind mirrors, a ray that reaches another chain of objects than
    /// the guide's).
    ///
    /// Seen straight, each ray asks only where it meets the centre's
    /// textured object (no scene query: a ray that meets something in
    /// front of it counts the texture behind, for the samples and the
    /// measure alike, so that the two still estimate the same mean).
    #[inline(never)]
    pub fn measure(renderer: &Renderer<'_>, g: &Guide, x: u32, y: u32, n: u32) -> Option<Self> {
        if g.glass || n < 2 || !n.is_multiple_of(2) {
            return None;
        }
        let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
        let object = g.textured;
        if object == ObjectId::NONE {
            return None;
        }
        if g.deltas == 0 && footprint_is_fine(renderer, object, fx, fy) {
            return None;
        }
        let albedo = |ray: Ray| {
            if g.deltas == 0 {
                return texture_along(renderer, &ray, object);
            }
            let (r, ..) = guide_along(renderer, ray, false);
            (r.kind == GuideKind::Surface && same_chain(g, r.key)).then_some(r.albedo)
        };
        let mut halves = [Color::ZERO; 2];
        let sample = renderer.sample_rays(x, y);
        for k in 0..n {
            let half = halves.get_mut(usize::from(k >= n / 2))?;
            *half += albedo(sample(k))?;
        }
        let per_half = 2.0 / n as f32;
        let halves = [halves[0] * per_half, halves[1] * per_half];
        if !renderer.camera().has_lens() || n > MEASURED_UP_TO {
            return Some(Self {
                halves,
                measured: (halves[0] + halves[1]) * 0.5,
            });
        }
        let count = n.saturating_mul(TEXTURE_RAYS_PER_SAMPLE);
        let mut measured = Color::ZERO;
        let measuring = renderer.texture_rays(x, y);
        for i in 0..count {
            measured += albedo(measuring(i))?;
        }
        Some(Self {
            halves,
            measured: measured * (1.0 / count as f32),
        })
    }

    /// The pixel's texel from its moments `m` (`n` samples, guide `g`):
    /// its scattered mean the ratio estimate, its albedo the measured
    /// one, filtered with the pixels of its chain that are not blurred.
    /// `None` where the samples' albedo is too dark in a channel to divide
    /// by.
    pub fn texel(&self, m: &Moments, n: u32, g: &Guide) -> Option<Texel> {
        let seen = (self.halves[0] + self.halves[1]) * 0.5;
        let (la, lb) = (self.halves[0].luminance(), self.halves[1].luminance());
        if math::lt(
            math::min(math::min(seen.x, seen.y), seen.z),
            super::MIN_ALBEDO,
        ) || math::lt(math::min(la, lb), super::MIN_ALBEDO)
        {
            return None;
        }
        let base = Guide {
            albedo: self.measured,
            key: g.key ^ BLURRED_KEY,
            blurred: false,
            ..*g
        };
        let mut t = Texel::new(m, n, &base);
        if !t.filtered {
            return Some(t);
        }
        let ratio = Color::new(
            self.measured.x / seen.x,
            self.measured.y / seen.y,
            self.measured.z / seen.z,
        );
        t.scattered *= ratio;
        // the halves' difference, each half's light on the surface
        // (its scattered luminance over its albedo's), times the measured
        // albedo: the variance of the ratio estimate as it is sampled
        let inv = 2.0 / n as f32;
        let sum = Color::new(m.scattered[0], m.scattered[1], m.scattered[2]).luminance();
        let (first, second) = (m.half * inv, (sum - m.half) * inv);
        let lm = self.measured.luminance();
        let d = lm * (first / la - second / lb) * 0.5;
        t.variance = d * d;
        let s = lm / seen.luminance();
        t.spread *= s * s;
        (t.scattered.is_finite() && math::is_finite(t.variance) && math::is_finite(t.spread))
            .then_some(t)
    }
}

/// Whether the footprint of the pixel centred at film position (fx, fy)
/// on `object` (where the rays through its corners and, with a lens, its
/// lens's rim meet it) spans more than [`FINE_SQUARES`] of its checker's squares
/// (a ray that misses it: the footprint is unbounded).
fn footprint_is_fine(renderer: &Renderer<'_>, object: ObjectId, fx: f32, fy: f32) -> bool {
    let camera = renderer.camera();
    let scene = renderer.scene();
    // the object's checker (every ray below meets that one object)
    let material = match (object.as_plane(), object.as_sphere()) {
        (Some(i), _) => scene.planes.get(i).map(|p| p.material),
        (_, Some(i)) => scene.spheres.get(i).map(|s| s.material),
        _ => None,
    };
    let Some(Material::Checker(c)) = material.and_then(|m| scene.materials.get(usize::from(m)))
    else {
        return false;
    };
    let size = c.size;
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let mut add = |ray: Ray| {
        let Some(h) = hit_on(renderer, &ray, object) else {
            return false;
        };
        let p = h.point;
        lo = Vec3::new(
            math::min(lo.x, p.x),
            math::min(lo.y, p.y),
            math::min(lo.z, p.z),
        );
        hi = Vec3::new(
            math::max(hi.x, p.x),
            math::max(hi.y, p.y),
            math::max(hi.z, p.z),
        );
        true
    };
    for [dx, dy] in PIXEL_CORNERS {
        if !add(camera.ray(fx + dx, fy + dy)) {
            return true;
        }
    }
    #[cfg(feature = "lens")]
    if camera.has_lens() {
        for lens in LENS_RIM {
            if !add(camera.lens_ray(fx, fy, lens)) {
                return true;
            }
        }
    }
    math::gt((hi - lo).length(), FINE_SQUARES * size)
}
