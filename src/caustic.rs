//! Caustics of small lights through mirror and glass spheres, sampled at a
//! path's first non-delta vertex (feature `highlight`).
//!
//! A small light seen from a diffuse point in a mirror ball, or through a
//! glass ball, is a tiny image in the point's hemisphere: its BSDF sample
//! meets it only by chance, with a large weight when it does. Those rare
//! hits are most of the error of a sunlit scene with such balls (the
//! ground around them, and what a mirror or glass shows of it).
//!
//! This module samples that light through the sphere instead. At a path's
//! first non-delta vertex `x` it chooses one (sphere, light) pair, with
//! probability proportional to the light's radiance and solid angle seen
//! from the sphere times the sphere's solid angle at `x` (the pairs of
//! [`pair_weight`]), samples a direction `ω` uniformly in the cone of
//! every direction in which a ray can leave the sphere and meet the light,
//! and finds the paths from `x` that leave the sphere along `ω`:
//!
//! - for a mirror, the point whose reflection of the ray from `x` leaves
//!   along `ω` ([`mirror_point`], one root);
//! - for glass, the rays from `x` that refract in and out of the sphere
//!   and leave along `ω` ([`glass_paths`]: in the plane of `x`, the
//!   centre and `ω`, a root of the exit angle as a function of the impact
//!   parameter; up to three where `x` is near the sphere).
//!
//! Each path's density at `x` is `p_pair · p(ω) · |dω/dω_x|`; its value
//! `f cos θ · tint · L_e` over that (the tint is the mirror's, or the two
//! Fresnel transmittances of the glass), summed over the roots (the change
//! of variables from `ω_x` to `ω` is many-to-one: all its preimages
//! count). The path tracer leaves out the emission its BSDF sample meets
//! along the same kind of path (one reflection in that mirror, or in and
//! out of that glass sphere, from that `x`): [`bsdf_share`]. The two
//! partition the paths, so the sum is unbiased; except near a glass
//! ball's caustic fold (`|dω/dω_x|` below [`GLASS_JAC_MIN`]), where the
//! sample's density falls to 0 and both take the path, weighted by the
//! balance heuristic ([`fold_weight`]).
//!
//! Only a share of the vertices ([`SHARE`]) sample it, weighted by the
//! inverse: the estimate has little noise, and its cost (a search over the
//! spheres, a root, three or four rays) would otherwise be paid at every
//! vertex.

use crate::geometry::{Color, Hit, ObjectId, Ray, Sphere, Vec3};
use crate::highlight::{SIN_MAX, mirror_point, reflection_jacobian};
use crate::light;
use crate::material::Material;
#[cfg(feature = "glass")]
use crate::material::ball::glass_jacobian;
pub use crate::material::ball::{GlassPath, ROOTS, glass_paths};
use crate::math;
use crate::scene::SceneView;

/// The smallest sine of the half-angle a sphere subtends at a point for
/// its caustics to be sampled there: farther spheres are left to the BSDF
/// sample, whose chance of meeting a light through them falls as their
/// solid angle.
pub const SIN_MIN: f32 = 0.05;

/// The share of first non-delta vertices that sample the caustics (their
/// estimate weighted by the inverse).
pub const SHARE: f32 = 0.1;

/// The smallest `|dω/dω_x|` of a path through a glass sphere that the
/// sample through the sphere takes alone: near a caustic's fold the ratio
/// falls to 0 and the sample's value grows without bound (its variance is
/// infinite there), while the light's image seen from `x` grows large and
/// the BSDF sample finds it well. Paths below it (the fold's) are taken
/// by both, weighted by the balance heuristic ([`fold_weight`]).
pub const GLASS_JAC_MIN: f32 = 0.1;

/// The caustic sample's multiple-importance weight of a fold's path
/// (`|dω/dω_x|` below [`GLASS_JAC_MIN`]) whose density at `x` is
/// `fold_pdf` in the sample ([`CausticSample::fold_pdf`]) and `bsdf_pdf`
/// in the vertex's BSDF sample: the balance heuristic, the sample counted
/// at its share of the vertices (`SHARE · fold_pdf` against `bsdf_pdf`).
/// The BSDF sample keeps the rest, `1 −` this ([`bsdf_share`]): the sum
/// of the two estimates is bounded by the BSDF sample's alone, where the
/// sample through the sphere alone has infinite variance.
#[inline(always)]
pub fn fold_weight(fold_pdf: f32, bsdf_pdf: f32) -> f32 {
    let a = SHARE * fold_pdf;
    let sum = a + bsdf_pdf;
    if sum > 0.0 { a / sum } else { 0.0 }
}

/// Most mirror and glass spheres whose caustics a render samples; further
/// spheres are left to the path tracer's BSDF samples. Feature
/// `small-ram` (a board of 16 KiB): 64.
#[cfg(not(feature = "small-ram"))]
pub const CAPACITY: usize = 128;
/// Most mirror and glass spheres whose caustics a render samples; further
/// spheres are left to the path tracer's BSDF samples. Feature
/// `small-ram` (a board of 16 KiB): 64.
#[cfg(feature = "small-ram")]
pub const CAPACITY: usize = 64;

/// The mirror and glass spheres of a scene with a caustic pair
/// ([`has_pair`]), in scene order: what [`sample`] and [`bsdf_share`] take.
#[derive(Clone, Copy, Debug)]
pub struct Spheres {
    list: [u16; CAPACITY],
    len: usize,
}

impl Spheres {
    /// None.
    pub const NONE: Self = Self {
        list: [0; CAPACITY],
        len: 0,
    };

    /// The spheres of `scene` with a caustic pair (the first
    /// [`CAPACITY`]).
    #[inline(never)]
    pub fn new(scene: &SceneView<'_>) -> Self {
        let mut out = Self::NONE;
        for i in 0..scene.spheres.len() {
            if has_pair(scene, i) {
                let Some(slot) = out.list.get_mut(out.len) else {
                    break;
                };
                *slot = i as u16;
                out.len += 1;
            }
        }
        out
    }

    /// The spheres' scene indices.
    pub fn as_slice(&self) -> &[u16] {
        self.list.get(..self.len).unwrap_or(&[])
    }
}

/// How light passes a caustic sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// A mirror of this tint.
    Mirror(Color),
    /// Glass of this index.
    #[cfg(feature = "glass")]
    Glass(f32),
}

fn kind(mat: Option<&Material>) -> Option<Kind> {
    match mat? {
        Material::Mirror(tint) => Some(Kind::Mirror(*tint)),
        #[cfg(feature = "glass")]
        Material::Glass(ior) => Some(Kind::Glass(*ior)),
        _ => None,
    }
}

/// Whether sphere `i` is a mirror or glass sphere with a caustic pair: a
/// light at least as large as the sphere (so that a direction of the pair's
/// cone meets it with probability at least a quarter) whose cone is narrow
/// (sine of the half-angle at most [`SIN_MAX`]).
pub fn has_pair(scene: &SceneView<'_>, i: usize) -> bool {
    let Some(m) = scene.spheres.get(i) else {
        return false;
    };
    kind(scene.materials.get(m.material as usize)).is_some()
        && scene.emitters.iter().any(|&li| {
            scene
                .spheres
                .get(usize::from(li))
                .is_some_and(|l| narrow(m, l))
        })
}

/// Whether the light `l` is at least as large as the sphere `m` and its
/// cone seen from `m` is narrow (sine of the half-angle at most
/// [`SIN_MAX`]).
#[inline(always)]
fn narrow(m: &Sphere, l: &Sphere) -> bool {
    let dl2 = (l.center - m.center).length_squared();
    let reach = l.radius + m.radius;
    l.radius >= m.radius && reach * reach <= SIN_MAX * SIN_MAX * dl2
}

/// The selection weight at `x` of the caustic pair (sphere `m`, light `l`
/// of emitted luminance `le`): the light's radiance times its solid-angle
/// factor `(r_l / d)²` seen from the sphere's centre, times the sphere's
/// `(r / d)²` seen from `x`; 0 where the pair's caustic is not sampled at
/// `x` (the light smaller than the sphere, its cone wider than [`SIN_MAX`],
/// the sphere's half-angle below [`SIN_MIN`], or `x` inside).
#[inline(always)]
pub fn pair_weight(m: &Sphere, l: &Sphere, le: f32, x: Vec3) -> f32 {
    let d2 = (m.center - x).length_squared();
    let r2 = m.radius * m.radius;
    if !(d2 > r2 && r2 >= SIN_MIN * SIN_MIN * d2) {
        return 0.0;
    }
    if !narrow(m, l) {
        return 0.0;
    }
    let dl2 = (l.center - m.center).length_squared();
    le * (l.radius * l.radius / dl2) * (r2 / d2)
}

/// The luminance of light sphere `l`'s emission (0 if it emits nothing).
#[inline(always)]
fn emitted(scene: &SceneView<'_>, l: &Sphere) -> Option<Color> {
    scene.materials.get(l.material as usize)?.emission()
}

/// The share of the emission of `light` that a path meets after its first
/// non-delta vertex, at `x`, and then one reflection in the mirror sphere
/// `sphere`, or a refraction into and out of the glass sphere `sphere`
/// leaving along `exit`, that the path tracer keeps, where [`sample`]
/// with the spheres `list` samples such paths at `x`: 0 for the paths it
/// takes alone, `1 −` [`fold_weight`] for a fold's (`bsdf_pdf`: the
/// density of the BSDF sample's direction at `x`), 1 for paths it does
/// not sample.
#[inline(never)]
pub fn bsdf_share(
    scene: &SceneView<'_>,
    list: &[u16],
    x: Vec3,
    sphere: usize,
    exit: &Ray,
    light: ObjectId,
    bsdf_pdf: f32,
) -> f32 {
    let Some(li) = light.as_sphere() else {
        return 1.0;
    };
    if !list.iter().any(|&i| usize::from(i) == sphere)
        || !scene.emitters.iter().any(|&e| usize::from(e) == li)
    {
        return 1.0;
    }
    let (Some(m), Some(l)) = (scene.spheres.get(sphere), scene.spheres.get(li)) else {
        return 1.0;
    };
    let le = emitted(scene, l).map_or(0.0, |c| c.luminance());
    let w = pair_weight(m, l, le, x);
    if !(w > 0.0) {
        return 1.0;
    }
    match kind(scene.materials.get(m.material as usize)) {
        #[cfg(feature = "glass")]
        Some(Kind::Glass(ior)) => {
            // the path's impact parameter: the exit line's distance from
            // the centre (the entry's, by symmetry)
            let to_c = m.center - x;
            let d = to_c.length();
            let a = to_c * (1.0 / d);
            let sw = (exit.dir - a * a.dot(exit.dir)).length();
            let b = (m.center - exit.origin).cross(exit.dir).length();
            let jac = glass_jacobian(d, m.radius, ior, b, sw);
            if jac >= GLASS_JAC_MIN {
                return 0.0;
            }
            // a fold's path: its density in the sample, as [`sample`]
            // draws it (the pair's share of the weights at x, the cone's
            // pdf, the Jacobian)
            let reach = l.radius + m.radius;
            let pdf = (w / pair_total(scene, list, x))
                * light::cone_pdf(m.center, l.center, reach * reach)
                * jac;
            1.0 - fold_weight(pdf, bsdf_pdf)
        }
        Some(Kind::Mirror(_)) => {
            let _ = (exit, bsdf_pdf);
            0.0
        }
        None => 1.0,
    }
}

/// The sum of the caustic pairs' weights at `x` ([`pair_weight`], in
/// [`sample`]'s order, so that its choice's probabilities are these).
#[cfg(feature = "glass")]
fn pair_total(scene: &SceneView<'_>, list: &[u16], x: Vec3) -> f32 {
    let mut total = 0.0f32;
    each_pair(scene, list, x, |_, _, w| total += w);
    total
}

/// Calls `f` with the scene indices of the sphere and the light and the
/// weight ([`pair_weight`], positive) of every caustic pair of the spheres
/// `list` at `x`, in scene order; a sphere whose half-angle at `x` is below
/// [`SIN_MIN`] is passed over before its lights are.
#[inline(always)]
fn each_pair(scene: &SceneView<'_>, list: &[u16], x: Vec3, mut f: impl FnMut(usize, usize, f32)) {
    for &i in list {
        let Some(m) = scene.spheres.get(usize::from(i)) else {
            continue;
        };
        let d2 = (m.center - x).length_squared();
        let r2 = m.radius * m.radius;
        if !(d2 > r2 && r2 >= SIN_MIN * SIN_MIN * d2) {
            continue;
        }
        for &li in scene.emitters {
            let Some(l) = scene.spheres.get(usize::from(li)) else {
                continue;
            };
            let le = emitted(scene, l).map_or(0.0, |c| c.luminance());
            let w = pair_weight(m, l, le, x);
            if w > 0.0 {
                f(usize::from(i), usize::from(li), w);
            }
        }
    }
}

/// One path of a caustic sample.
#[derive(Clone, Copy, Debug)]
pub struct CausticSample {
    /// Unit direction from `x` into the sphere.
    pub wi: Vec3,
    /// `tint · L_e / pdf(wi)`: the radiance arriving along `wi` over the
    /// path's solid-angle density at `x` (the tint is the mirror's, or the
    /// glass's two Fresnel transmittances).
    pub value: Color,
    /// Whether the path concentrates the light (`|dω/dω_x|` below
    /// [`FOCUSED_JAC`]): a focused caustic, sharp at the film's scale,
    /// where a broad one varies smoothly.
    pub focused: bool,
    /// For a path of a caustic's fold (`|dω/dω_x|` below
    /// [`GLASS_JAC_MIN`]), its density at `x` (`value`'s pdf), which the
    /// BSDF sample's is weighed against ([`fold_weight`]); 0 for a path
    /// the sample takes alone.
    pub fold_pdf: f32,
}

impl CausticSample {
    /// No path.
    pub const NONE: Self = Self {
        wi: Vec3::ZERO,
        value: Color::ZERO,
        focused: false,
        fold_pdf: 0.0,
    };
}

/// A caustic path whose `|dω/dω_x|` is below this brings the light to `x`
/// concentrated (`1 / |dω/dω_x|` times what the light itself, seen over
/// the same directions, would give): [`CausticSample::focused`]. A convex
/// mirror never does (its paths spread the light: `|dω/dω_x| > 1`); a
/// glass ball does near its axis.
pub const FOCUSED_JAC: f32 = 1.0;

/// Samples the light of the caustic spheres `list` that reaches `x`
/// (shading normal `n`) through one of them: a (sphere, light) pair chosen
/// by [`pair_weight`] (from `u0`), a direction `ω` uniform in the pair's
/// cone (from `u`), and every path from `x` that leaves the sphere along
/// `ω` and meets the light unblocked, written to `out`. Returns how many.
/// The rays it traces are counted in `rays`.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub fn sample(
    scene: &SceneView<'_>,
    list: &[u16],
    x: &Hit,
    n: Vec3,
    u0: f32,
    u: [f32; 2],
    rays: &mut u32,
    out: &mut [CausticSample; ROOTS],
) -> usize {
    // one pass, one number: the running choice keeps a pair with
    // probability w / (sum so far), and u0 rescaled stays uniform
    let mut total = 0.0f32;
    let mut chosen: Option<(usize, usize, f32)> = None;
    let mut v = u0;
    each_pair(scene, list, x.point, |mi, li, w| {
        total += w;
        let keep = w / total;
        if v < keep {
            chosen = Some((mi, li, w));
            v /= keep;
        } else {
            v = (v - keep) / (1.0 - keep);
        }
        v = math::min(v, 0.999_999_94);
    });
    let Some((mi, li, w)) = chosen else {
        return 0;
    };
    let (Some(m), Some(l)) = (scene.spheres.get(mi), scene.spheres.get(li)) else {
        return 0;
    };
    let (Some(k), Some(le)) = (
        kind(scene.materials.get(m.material as usize)),
        emitted(scene, l),
    ) else {
        return 0;
    };
    let reach = l.radius + m.radius;
    let Some(cone) = light::sample_cone(m.center, l.center, reach * reach, u[0], u[1], false)
    else {
        return 0;
    };
    let scale = 1.0 / ((w / total) * cone.pdf);
    let (sphere, lamp) = (ObjectId::sphere(mi), ObjectId::sphere(li));
    // the ray from the sphere's last point along ω meets the light
    // unblocked: its distance to the light
    let to_light = |p: Vec3, rays: &mut u32| -> bool {
        let oc = p - l.center;
        let b = oc.dot(cone.dir);
        let disc = b * b - (oc.length_squared() - l.radius * l.radius);
        if !(disc > 0.0) {
            return false;
        }
        let t = -b - math::sqrt(disc);
        if !(t > 0.0) {
            return false;
        }
        *rays += 1;
        !scene.occluded_by_any(&Ray::new(p, cone.dir), t, sphere, lamp)
    };
    match k {
        Kind::Mirror(tint) => {
            let Some(nh) = mirror_point(x.point, m.center, m.radius, cone.dir) else {
                return 0;
            };
            let p = m.center + nh * m.radius;
            let to_p = p - x.point;
            let dist = to_p.length();
            let wi = to_p * (1.0 / dist);
            let nc = nh.dot(wi);
            if !(n.dot(wi) > 0.0 && nc < 0.0 && to_light(p, rays)) {
                return 0;
            }
            *rays += 1;
            if scene.occluded_by_any(&x.spawn_on(n, wi), dist, x.object, sphere) {
                return 0;
            }
            let (a1, a2) = wi.basis();
            let jac = reflection_jacobian([a1, a2], wi, nh, nc, dist, m.radius, cone.dir);
            if !(jac > 0.0) {
                return 0;
            }
            if let Some(slot) = out.first_mut() {
                *slot = CausticSample {
                    wi,
                    value: tint * le * (scale / jac),
                    focused: jac < FOCUSED_JAC,
                    fold_pdf: 0.0,
                };
            }
            1
        }
        #[cfg(feature = "glass")]
        Kind::Glass(ior) => {
            let mut paths = [GlassPath::NONE; ROOTS];
            let found = glass_paths(x.point, m.center, m.radius, ior, cone.dir, &mut paths);
            let mut kept = 0;
            for p in paths.iter().take(found) {
                if !(n.dot(p.wi) > 0.0 && p.jac > 0.0 && to_light(p.exit, rays)) {
                    continue;
                }
                *rays += 2;
                if scene.occluded_by_any(&x.spawn_on(n, p.wi), p.t_entry, x.object, sphere)
                    || scene.occluded_by_any(&Ray::new(p.entry, p.inner), p.chord, sphere, sphere)
                {
                    continue;
                }
                if let Some(slot) = out.get_mut(kept) {
                    *slot = CausticSample {
                        wi: p.wi,
                        value: le * (p.transmit * scale / p.jac),
                        focused: p.jac < FOCUSED_JAC,
                        fold_pdf: if p.jac < GLASS_JAC_MIN {
                            p.jac / scale
                        } else {
                            0.0
                        },
                    };
                    kept += 1;
                }
            }
            kept
        }
    }
}
