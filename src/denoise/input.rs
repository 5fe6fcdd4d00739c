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
/// them: 36 bytes a pixel.
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
    /// How many samples' camera rays hit a light themselves
    /// ([`PathSum::seen`]).
    pub seen: u32,
}

impl Moments {
    /// No samples.
    pub const ZERO: Self = Self {
        scattered: [0.0; 3],
        direct: [0.0; 3],
        square: 0.0,
        half: 0.0,
        seen: 0,
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
        self.seen += u32::from(s.seen);
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
    /// and whether the surface sees its brightest light and is
    /// [`Guide::blurred`], hashed: two pixels are filtered together only
    /// where it is equal.
    pub key: u32,
    /// How many mirror and glass vertices came before the surface.
    pub deltas: u32,
    /// Whether one of them was glass (the path tracer picks reflection or
    /// refraction there at random; the guide follows the refraction).
    pub glass: bool,
    /// Whether the surface is a plane (its normal the same at every
    /// point: pixels of the same key need no normal test).
    pub flat: bool,
    /// Whether the pixel's samples see more than one albedo of the
    /// surface's texture (a checker's edge inside the pixel, or a checker
    /// out of focus behind a thin lens): `albedo` is then the mean of the
    /// albedos the guide saw, too coarse to divide out, and the filter
    /// smooths the radiance itself, with other blurred pixels only.
    pub blurred: bool,
    /// The surface's object if it is textured (its albedo changes over
    /// it), else [`ObjectId::NONE`].
    pub textured: ObjectId,
}

impl Guide {
    /// The guide of a pixel left as rendered.
    pub const KEEP: Self = Self {
        kind: GuideKind::Keep,
        albedo: Color::ZERO,
        normal: Vec3::ZERO,
        key: 0,
        deltas: 0,
        glass: false,
        flat: false,
        blurred: false,
        textured: ObjectId::NONE,
    };
}

/// The lens points whose rays must agree with the centre's for a thin-lens
/// pixel to be filtered: the rim of the lens disk at four quarters (the
/// concentric map's edge midpoints).
#[cfg(feature = "lens")]
pub(super) const LENS_RIM: [[f32; 2]; 4] =
    [[0.999_999, 0.5], [0.0, 0.5], [0.5, 0.999_999], [0.5, 0.0]];

/// Albedos that differ by more than this (in a channel) are different.
const BLUR_TOLERANCE: f32 = 1.0 / 64.0;
/// What a blurred pixel's key is XORed with: it is filtered with blurred
/// pixels of the same object chain only.
pub(super) const BLURRED_KEY: u32 = 0x5bd1_e995;
/// Where a textured pixel's albedo is looked at besides its centre (film
/// offsets, pixels): near its four corners.
#[cfg(feature = "checker")]
pub(super) const PIXEL_CORNERS: [[f32; 2]; 4] =
    [[-0.45, -0.45], [0.45, -0.45], [-0.45, 0.45], [0.45, 0.45]];

/// Whether two albedos differ (by more than [`BLUR_TOLERANCE`] in a
/// channel).
#[allow(dead_code)] // a build with neither checker nor lens never blurs
#[inline(always)]
fn differ(a: Color, b: Color) -> bool {
    math::gt((a - b).abs().max_component(), BLUR_TOLERANCE)
}

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
///
/// Two more things the samples see that the centre ray alone would miss:
/// whether the surface's point sees its brightest light (a shadow's edge
/// splits the key, as an object's edge does), and, on a textured surface,
/// whether other albedos lie within the pixel (rays near its corners) or
/// across the lens (the rim's rays): then the pixel is
/// [`Guide::blurred`], its albedo the mean of those seen.
pub fn guide(renderer: &Renderer<'_>, x: u32, y: u32) -> Guide {
    let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
    let (mut g, sees) = guide_along(renderer, renderer.camera().ray(fx, fy), true);
    if g.kind != GuideKind::Surface {
        return g;
    }
    // where the pixel's samples see more than one albedo (a texture's
    // edge, a texture out of focus), the centre's is not theirs to divide
    // out: the mean of the albedos seen, and the pixel is blurred
    // (a build with neither lens nor checker never blurs)
    #[cfg_attr(not(any(feature = "lens", feature = "checker")), allow(unused_mut))]
    let (mut albedo, mut seen, mut blurred) = (g.albedo, 1u32, false);
    #[cfg(feature = "lens")]
    if renderer.camera().has_lens() {
        for lens in LENS_RIM {
            let (r, ..) = guide_along(renderer, renderer.camera().lens_ray(fx, fy, lens), false);
            if r.key != g.key {
                return Guide {
                    kind: GuideKind::Keep,
                    ..g
                };
            }
            blurred |= differ(r.albedo, g.albedo);
            albedo += r.albedo;
            seen += 1;
        }
    }
    #[cfg(feature = "checker")]
    if g.textured != ObjectId::NONE {
        let object = g.textured;
        for [dx, dy] in PIXEL_CORNERS {
            let ray = renderer.camera().ray(fx + dx, fy + dy);
            let a = if g.deltas == 0 {
                // seen straight: the texture where the corner's ray meets
                // the same object (whatever stands in front of it there:
                // an object's edge is the key test's), no scene query
                texture_along(renderer, &ray, object)
            } else {
                // behind mirrors and glass: the corner's ray followed as
                // the centre's, where it reaches the same chain
                let (r, ..) = guide_along(renderer, ray, false);
                (r.key == g.key).then_some(r.albedo)
            };
            if let Some(a) = a {
                blurred |= differ(a, g.albedo);
                albedo += a;
                seen += 1;
            }
        }
    }
    if sees {
        g.key ^= SEES_LIGHT_KEY;
    }
    if blurred {
        g = Guide {
            albedo: albedo * (1.0 / seen as f32),
            key: g.key ^ BLURRED_KEY,
            blurred: true,
            ..g
        };
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
/// Also returns, if `light` asks, whether the surface sees its brightest
/// light ([`sees_brightest_light`]).
pub(super) fn guide_along(renderer: &Renderer<'_>, mut ray: Ray, light: bool) -> (Guide, bool) {
    const KEEP: (Guide, bool) = (Guide::KEEP, false);
    let scene = renderer.scene();
    let mut from = ObjectId::NONE;
    let mut tint = Color::ONE;
    #[cfg_attr(not(feature = "glass"), allow(unused_mut))]
    let mut glass = false;
    let mut key: u32 = 0x9e37_79b9;
    for deltas in 0..=GUIDE_DEPTH {
        let Some(hit) = scene.closest_hit(&ray, from) else {
            return KEEP;
        };
        key = key.rotate_left(5) ^ (u32::from(hit.object.0) + 1);
        key = key.wrapping_mul(0x0100_0193);
        let Some(mat) = scene.materials.get(hit.material as usize) else {
            return KEEP;
        };
        let n = if math::lt_zero(ray.dir.dot(hit.normal)) {
            hit.normal
        } else {
            -hit.normal
        };
        let surface = |albedo: Color, textured: bool| {
            let g = Guide {
                kind: GuideKind::Surface,
                albedo: tint * albedo,
                normal: n,
                key,
                deltas,
                glass,
                flat: hit.object.as_plane().is_some(),
                blurred: false,
                textured: if textured { hit.object } else { ObjectId::NONE },
            };
            (g, light && sees_brightest_light(scene, &hit, n))
        };
        let dir = match mat {
            Material::Diffuse(a) => return surface(*a, false),
            #[cfg(feature = "checker")]
            Material::Checker(c) => {
                return surface(c.albedo_at_hit(&hit), true);
            }
            #[cfg(feature = "metal")]
            Material::Metal(m) => {
                if math::lt(m.alpha, SHARP_ALPHA) {
                    return KEEP;
                }
                return surface(m.tint, false);
            }
            #[cfg(feature = "mirror")]
            Material::Mirror(t) => {
                tint *= *t;
                reflect(ray.dir, hit.normal)
            }
            #[cfg(feature = "glass")]
            Material::Glass(ior) => {
                glass = true;
                // the refraction where there is one (u just below 1 picks
                // it unless the reflection carries everything)
                crate::material::sample_dielectric(ray.dir, hit.normal, *ior, 0.999_999).0
            }
            _ => return KEEP,
        };
        ray = hit.spawn(dir);
        from = hit.object;
    }
    KEEP
}

/// Whether a ray's [`guide_along`] key `key` is the chain of objects of
/// guide `g` (whose key may also say that its surface sees its brightest
/// light, and that it is blurred).
#[cfg(feature = "checker")]
pub(super) fn same_chain(g: &Guide, key: u32) -> bool {
    let chain = if g.blurred {
        g.key ^ BLURRED_KEY
    } else {
        g.key
    };
    key == chain || key == chain ^ SEES_LIGHT_KEY
}

/// Where `ray` meets `object` (a plane or a sphere), if it does.
#[cfg(feature = "checker")]
pub(super) fn hit_on(
    renderer: &Renderer<'_>,
    ray: &Ray,
    object: ObjectId,
) -> Option<crate::geometry::Hit> {
    let scene = renderer.scene();
    Some(if let Some(i) = object.as_plane() {
        let p = scene.planes.get(i)?;
        p.hit(ray, p.intersect(ray, f32::INFINITY)?, object)
    } else {
        let s = scene.spheres.get(object.as_sphere()?)?;
        s.hit(ray, s.intersect(ray, f32::INFINITY)?, object)
    })
}

/// The checker's albedo where `ray` meets `object` (a plane or a sphere),
/// if it does and the object is a checker.
#[cfg(feature = "checker")]
pub(super) fn texture_along(renderer: &Renderer<'_>, ray: &Ray, object: ObjectId) -> Option<Color> {
    let hit = hit_on(renderer, ray, object)?;
    match renderer.scene().materials.get(usize::from(hit.material))? {
        Material::Checker(c) => Some(c.albedo_at_hit(&hit)),
        _ => None,
    }
}

/// Lights the visibility guide compares (the first of the scene's list).
const GUIDE_LIGHTS: usize = 16;
/// What the key of a pixel whose surface sees its brightest light is
/// XORed with: a hard shadow's edge separates taps as an object's does.
const SEES_LIGHT_KEY: u32 = 0x2545_f491;

/// Whether the point `hit` (normal `n`, toward the viewer) sees the centre
/// of the light that would give it the most irradiance unoccluded (the
/// largest `L_e r² cos θ / d²` among the first [`GUIDE_LIGHTS`] lights): a
/// noise-free guide of the light's shadows, which no albedo or normal
/// shows (a sphere's shadow on the floor, a contact shadow).
fn sees_brightest_light(
    scene: &crate::scene::SceneView<'_>,
    hit: &crate::geometry::Hit,
    n: Vec3,
) -> bool {
    let mut best = 0.0f32;
    let mut target = None;
    // one light: the brightest if it lights the point at all (no score)
    let alone = scene.lights.len() == 1;
    for &i in scene.lights.iter().take(GUIDE_LIGHTS) {
        let Some((s, le)) = scene.sphere_light(i) else {
            continue;
        };
        let d = s.center - hit.point;
        let d2 = d.dot(d);
        let cos_d = n.dot(d);
        if !(math::gt_zero(cos_d) && math::gt(d2, s.radius * s.radius)) {
            continue;
        }
        if alone {
            if math::gt_zero(le.luminance()) && math::is_finite(d2) {
                target = Some((i, d, d2));
            }
            break;
        }
        // L r² (n·d) / d³ = L r² cos θ / d²
        let e = le.luminance() * s.radius * s.radius * cos_d / (d2 * math::sqrt(d2));
        if math::gt(e, best) && math::is_finite(e) {
            best = e;
            target = Some((i, d, d2));
        }
    }
    let Some((i, d, d2)) = target else {
        return false;
    };
    let dist = math::sqrt(d2);
    let dir = d * (1.0 / dist);
    !scene.occluded(
        &hit.spawn_on(n, dir),
        dist,
        hit.object,
        ObjectId::sphere(usize::from(i)),
    )
}
