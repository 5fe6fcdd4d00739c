//! What the denoiser reads for one pixel: the moments of the pixel's
//! samples ([`Moments`], accumulated as they are rendered) and the guide
//! ([`Guide`], what the ray through the pixel's centre sees first behind
//! mirrors and glass, recomputed when needed rather than stored).

use crate::geometry::{Color, ObjectId, Ray, Vec3};
use crate::integrator::PathSum;
use crate::material::Material;
#[cfg(any(feature = "mirror", feature = "glass"))]
use crate::material::reflect;
use crate::math;
use crate::render::Renderer;

/// A metal narrower than this (GGX α) shows sharp reflections whose
/// radiance changes from pixel to pixel with the view: its pixels are
/// left unfiltered.
pub const SHARP_ALPHA: f32 = 0.1;

/// Mirror and glass vertices a guide ray follows before it gives up (and
/// leaves the pixel unfiltered).
pub const GUIDE_DEPTH: u32 = 8;

/// The running sums of one pixel's samples, split as the filter needs
/// them: 32 bytes a pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Moments {
    /// Sum of the samples' scattered part (`total − direct`), which the
    /// filter smooths.
    pub scattered: [f32; 3],
    /// Sum of the samples' direct part ([`PathSum::direct`]), which it keeps.
    pub direct: [f32; 3],
    /// Sum of the squared luminance of the scattered parts: with the sum,
    /// the samples' own variance (n − 1 degrees of freedom).
    pub square: f32,
    /// Sum of the scattered parts' luminance over the first half of the
    /// samples (index below `n / 2`): the two halves' difference estimates
    /// the variance of the mean as the samples are stratified.
    pub half: f32,
}

impl Moments {
    /// No samples.
    pub const ZERO: Self = Self {
        scattered: [0.0; 3],
        direct: [0.0; 3],
        square: 0.0,
        half: 0.0,
    };

    /// Adds one sample; `first_half`: its index is below `n / 2` of the
    /// pixel's `n` samples.
    #[inline]
    pub fn add(&mut self, s: PathSum, first_half: bool) {
        let sc = s.total - s.direct;
        self.scattered[0] += sc.x;
        self.scattered[1] += sc.y;
        self.scattered[2] += sc.z;
        self.direct[0] += s.direct.x;
        self.direct[1] += s.direct.y;
        self.direct[2] += s.direct.z;
        let l = sc.luminance();
        self.square += l * l;
        if first_half {
            self.half += l;
        }
    }

    /// The mean of `n` samples' totals (the raw image).
    pub fn mean(&self, n: u32) -> Color {
        let inv = 1.0 / n.max(1) as f32;
        Color::new(
            (self.scattered[0] + self.direct[0]) * inv,
            (self.scattered[1] + self.direct[1]) * inv,
            (self.scattered[2] + self.direct[2]) * inv,
        )
    }
}

/// Pixel (x, y)'s `spp` samples summed into its moments, in sample order:
/// the same sums wherever the pixel is rendered (the host's whole frame, a
/// board's pixel as the denoiser asks for it, the demo's passes).
pub fn pixel_moments(
    renderer: &Renderer<'_>,
    spp: u32,
    x: u32,
    y: u32,
    stats: &mut crate::stats::Stats,
) -> Moments {
    let pixel = renderer.pixel(x, y);
    let mut m = Moments::ZERO;
    for k in 0..spp {
        m.add(
            renderer.sample_parts_in(&pixel, x, y, k, stats),
            k < spp / 2,
        );
    }
    m
}

/// What the filter may do with a pixel, from its guide.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GuideKind {
    /// A non-delta surface that the filter smooths with its like.
    Surface,
    /// Left as rendered, and never a tap: the centre ray sees a light, the
    /// background, a sharp metal, or nothing within [`GUIDE_DEPTH`].
    Keep,
}

/// What the ray through a pixel's centre sees first behind mirrors and
/// glass (the refracted ray at glass, where there is one): the guide of the
/// filter's weights, and the albedo that it divides out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guide {
    /// Surface or keep.
    pub kind: GuideKind,
    /// The surface's albedo (a metal's tint) times the tints of the mirrors
    /// before it, each channel in [0, 1] (OIDN's albedo convention).
    pub albedo: Color,
    /// The unit shading normal, toward the ray (OIDN's world-space normal).
    pub normal: Vec3,
    /// The objects along the way (the mirrors and glass, then the surface),
    /// hashed: two pixels are filtered together only where it is equal.
    pub key: u32,
    /// How many mirror and glass vertices came before the surface.
    pub deltas: u32,
    /// Whether the surface is a plane (its normal the same at every
    /// point: pixels of the same key need no normal test).
    pub flat: bool,
}

impl Guide {
    /// The guide of a pixel left as rendered.
    pub const KEEP: Self = Self {
        kind: GuideKind::Keep,
        albedo: Color::ZERO,
        normal: Vec3::ZERO,
        key: 0,
        deltas: 0,
        flat: false,
    };
}

/// The lens points whose rays must agree with the centre's for a thin-lens
/// pixel to be filtered: the rim of the lens disk at four quarters (the
/// concentric map's edge midpoints).
#[cfg(feature = "lens")]
const LENS_RIM: [[f32; 2]; 4] = [[0.999_999, 0.5], [0.0, 0.5], [0.5, 0.999_999], [0.5, 0.0]];

/// The guide of pixel (x, y): the centre ray (through the lens's centre,
/// for a thin lens) followed through up to [`GUIDE_DEPTH`] mirror and glass
/// vertices to its first non-delta surface. Deterministic: no random
/// numbers.
///
/// With a thin lens the pixel's samples come from the whole lens, and out
/// of focus they see more than the centre ray does: a pixel where the rays
/// from the lens's rim reach another object chain than the centre's (the
/// blurred edge of a defocused object) is left unfiltered, its guide's
/// albedo and normal kept for the guide images.
pub fn guide(renderer: &Renderer<'_>, x: u32, y: u32) -> Guide {
    let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
    let g = guide_along(renderer, renderer.camera().ray(fx, fy));
    #[cfg(feature = "lens")]
    if g.kind == GuideKind::Surface && renderer.camera().has_lens() {
        for lens in LENS_RIM {
            if guide_along(renderer, renderer.camera().lens_ray(fx, fy, lens)).key != g.key {
                return Guide {
                    kind: GuideKind::Keep,
                    ..g
                };
            }
        }
    }
    g
}

/// [`guide`] along one camera ray.
// a build without mirror and glass has no delta vertex: the loop's first
// vertex always returns
#[cfg_attr(
    not(any(feature = "mirror", feature = "glass")),
    allow(unreachable_code, unused_mut, unused_variables)
)]
fn guide_along(renderer: &Renderer<'_>, mut ray: Ray) -> Guide {
    let scene = renderer.scene();
    let mut from = ObjectId::NONE;
    let mut tint = Color::ONE;
    let mut key: u32 = 0x9e37_79b9;
    for deltas in 0..=GUIDE_DEPTH {
        let Some(hit) = scene.closest_hit(&ray, from) else {
            return Guide::KEEP;
        };
        key = key.rotate_left(5) ^ (u32::from(hit.object.0) + 1);
        key = key.wrapping_mul(0x0100_0193);
        let Some(mat) = scene.materials.get(hit.material as usize) else {
            return Guide::KEEP;
        };
        let n = if math::lt_zero(ray.dir.dot(hit.normal)) {
            hit.normal
        } else {
            -hit.normal
        };
        let surface = |albedo: Color| Guide {
            kind: GuideKind::Surface,
            albedo: tint * albedo,
            normal: n,
            key,
            deltas,
            flat: hit.object.as_plane().is_some(),
        };
        let dir = match mat {
            Material::Diffuse(a) => return surface(*a),
            #[cfg(feature = "checker")]
            Material::Checker(c) => {
                return surface(c.albedo_at(hit.point, hit.object.as_plane().map(|_| hit.normal)));
            }
            #[cfg(feature = "metal")]
            Material::Metal(m) => {
                if math::lt(m.alpha, SHARP_ALPHA) {
                    return Guide::KEEP;
                }
                return surface(m.tint);
            }
            #[cfg(feature = "mirror")]
            Material::Mirror(t) => {
                tint *= *t;
                reflect(ray.dir, hit.normal)
            }
            #[cfg(feature = "glass")]
            Material::Glass(ior) => {
                // the refraction where there is one (u just below 1 picks
                // it unless the reflection carries everything)
                crate::material::sample_dielectric(ray.dir, hit.normal, *ior, 0.999_999).0
            }
            _ => return Guide::KEEP,
        };
        ray = hit.spawn(dir);
        from = hit.object;
    }
    Guide::KEEP
}
