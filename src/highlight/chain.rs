//! The chains of the highlight estimator: a light seen through two delta
//! vertices (camera → mirror or glass ball → mirror ball → light), listed
//! with the direct pairs ([`Highlights`]) and estimated by the same change
//! of variables from film position to the last reflected direction
//! (docs/highlights.md, "Chains").

use super::{
    Highlight, Highlights, is_mirror, lens_rect, mirror_point, pair_distance, pixel_rect, rim_rect,
};
use crate::camera::{Camera, LensPoint};
use crate::geometry::{Color, ObjectId, Sphere, Vec3};
use crate::material::Material;
use crate::material::mirror::reflect;
use crate::math;
use crate::scene::SceneView;
use crate::stats::Stats;

impl Highlights {
    /// The chains camera → `via` → `mirror` → light of `scene` whose
    /// images hold most of film sampling's variance, into the room left (at
    /// most [`CHAINS`]). Film sampling finds an image of area `A < 1` pixel
    /// with probability `A` a sample, so its variance is about `L² A`: the
    /// chains are ranked by `L_e²` times their image's area (at most
    /// [`CHAIN_AREA_MAX`]: [`chain_area`], one solve each), and only the
    /// kept ones are bounded on the film ([`chain_rect`], 10 solves).
    #[inline(never)]
    pub(super) fn add_chains(&mut self, scene: &SceneView<'_>, camera: &Camera) {
        if CHAINS == 0 {
            return;
        }
        let (w, h) = (camera.width(), camera.height());
        // every candidate's area, solved at its cone's axis; the largest
        // variances kept: (L_e² area, via, mirror, light)
        let mut best = [(0.0f32, 0u16, 0u16, 0u16); CHAINS];
        let mut best_min = 0;
        for (ai, a) in scene.spheres.iter().enumerate() {
            let Some((kind, flag)) = first(scene, camera, a) else {
                continue;
            };
            if camera.film_of(a.center).is_none() {
                continue;
            }
            let via = ai as u16 | flag;
            for (mi, m) in scene.spheres.iter().enumerate() {
                if mi == ai || !is_mirror(scene, m) {
                    continue;
                }
                let mi = mi as u16;
                for &li in scene.emitters {
                    let Some(l) = scene.spheres.get(li as usize) else {
                        continue;
                    };
                    let Some(d) = pair_distance(m, l) else {
                        continue;
                    };
                    let axis = (l.center - m.center) * (1.0 / d);
                    let Some(area) =
                        chain_area(scene, camera, (kind, via), a, (m, mi), (l, li), axis)
                    else {
                        continue;
                    };
                    // film sampling finds a larger image often enough, and
                    // the thinned estimate's variance grows with it
                    if !(area <= CHAIN_AREA_MAX) {
                        continue;
                    }
                    let le = scene
                        .materials
                        .get(l.material as usize)
                        .and_then(Material::emission)
                        .map_or(0.0, |c| c.luminance());
                    let v = le * le * area;
                    if !(v > best.get(best_min).map_or(0.0, |b| b.0)) {
                        continue;
                    }
                    if let Some(slot) = best.get_mut(best_min) {
                        *slot = (v, via, mi, li);
                    }
                    best_min = smallest(&best);
                }
            }
        }
        // largest first, so that a full list keeps the largest
        loop {
            let mut at = 0;
            for (k, b) in best.iter().enumerate() {
                if b.0 > best.get(at).map_or(0.0, |c| c.0) {
                    at = k;
                }
            }
            let Some(slot) = best.get_mut(at) else {
                break;
            };
            if !(slot.0 > 0.0) {
                break;
            }
            let (_, via, mi, li) = *slot;
            slot.0 = 0.0;
            let sphere = |i: u16| scene.spheres.get(usize::from(i));
            let (Some(a), Some(m), Some(l)) = (sphere(via & !VIA_INSIDE), sphere(mi), sphere(li))
            else {
                continue;
            };
            let (Some((kind, _)), Some(d)) = (first(scene, camera, a), pair_distance(m, l)) else {
                continue;
            };
            if let Some(pixels) =
                chain_rect(camera, kind, a, m, l, d).and_then(|r| pixel_rect(r, w, h))
            {
                self.insert(Highlight {
                    mirror: mi,
                    light: li,
                    via,
                    pixels,
                });
            }
        }
    }
}

/// Most chains (camera → mirror or glass ball → mirror → light) a render
/// estimates: the ones whose images hold most of film sampling's variance,
/// in the room the direct pairs leave.
#[cfg(not(feature = "small-ram"))]
pub const CHAINS: usize = super::CAPACITY;
/// Most chains (camera → mirror or glass ball → mirror → light) a render
/// estimates: none with the feature `small-ram`.
#[cfg(feature = "small-ram")]
pub const CHAINS: usize = 0;

/// The share of a pixel's samples that estimate each chain's image
/// (weighted by its inverse; the rest add nothing for it). A chain's image
/// is a small fraction `A` of a pixel and its estimate has little
/// variance: thinned, it has about `A / CHAIN_SHARE` of film sampling's,
/// at a fraction of the cost of a solve a sample.
pub const CHAIN_SHARE: f32 = 0.125;

/// The largest film area (pixels²) of a chain's image for the estimator
/// (at its cone's axis): film sampling finds a larger one often enough.
pub const CHAIN_AREA_MAX: f32 = 1.0 / 16.0;

/// The index of the smallest first element of `list` (the first of equals).
fn smallest(list: &[(f32, u16, u16, u16)]) -> usize {
    let mut at = 0;
    for (k, b) in list.iter().enumerate() {
        if b.0 < list.get(at).map_or(0.0, |c| c.0) {
            at = k;
        }
    }
    at
}

/// [`Highlight::via`]'s flag of a glass ball passed through (in and out)
/// before the mirror; without it `via` is a mirror reflected in.
pub const VIA_INSIDE: u16 = 0x8000;

/// Most fixed-point steps of a chain's solve ([`chain_points`]).
const CHAIN_STEPS: usize = 32;

/// What the first sphere of a chain does to the camera's ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum First {
    /// Reflects it (a mirror).
    Mirror,
    /// Refracts it in and out (a glass ball of this index).
    #[cfg(feature = "glass")]
    Glass(f32),
}

/// The first sphere `a` of a chain seen by `camera` and its
/// [`VIA_INSIDE`] flag: a mirror; or a glass ball seen from at least
/// `max(2, η / (2(η − 1)))` radii off its centre, with `1 < η < 3.8`,
/// from every point of the lens: there the exit angle of the ray from the
/// eye is monotone in its impact parameter and within (−π, π)
/// ([`crate::material::ball::glass_paths`]), so one path from the eye
/// leaves the ball along each direction, and the chain's solve finds every
/// path.
pub(super) fn first(scene: &SceneView<'_>, camera: &Camera, a: &Sphere) -> Option<(First, u16)> {
    #[cfg(not(feature = "glass"))]
    let _ = camera;
    match scene.materials.get(a.material as usize)? {
        Material::Mirror(_) => Some((First::Mirror, 0)),
        #[cfg(feature = "glass")]
        Material::Glass(ior) => {
            let eta = *ior;
            // the lens' nearest point
            let d = (a.center - camera.eye()).length() - camera.lens().0;
            let single = eta > 1.0
                && eta < 3.8
                && d >= 2.0 * a.radius
                && d * 2.0 * (eta - 1.0) > eta * a.radius;
            single.then_some((First::Glass(eta), VIA_INSIDE))
        }
        _ => None,
    }
}

/// Where the ray from `eye` enters the glass ball `a` (`kind`, from
/// [`first`]) on the one path that leaves it along `w`, or `None` where
/// none does (or `kind` is a mirror).
pub(super) fn glass_entry(eye: Vec3, kind: First, a: &Sphere, w: Vec3) -> Option<Vec3> {
    match kind {
        First::Mirror => {
            let _ = (eye, a, w);
            None
        }
        #[cfg(feature = "glass")]
        First::Glass(eta) => {
            use crate::material::ball::{GlassPath, ROOTS, glass_paths};
            let mut paths = [GlassPath::NONE; ROOTS];
            let found = glass_paths(eye, a.center, a.radius, eta, w, &mut paths);
            paths.first().filter(|_| found == 1).map(|p| p.entry)
        }
    }
}

/// The chain camera (`eye`) → `a` (reflected in, or passed through) →
/// mirror `m` whose last reflection leaves `m` along `w`: the point where
/// the camera's ray meets `a` and the point on `m`, or `None` where there
/// is none the eye sees. A fixed point: the ray leaves `a` toward `m`'s
/// point ([`mirror_point`], or [`crate::material::ball::glass_paths`]'s one path
/// from the eye along that direction), and `m`'s point reflects the ray
/// from where it left `a` into `w`; each step moves the first point by
/// about `r_a / (2 D)` (a mirror) or `r_a / D` (a ball) of the second's
/// move, `D` the distance between the spheres. Not converged in
/// [`CHAIN_STEPS`]: `None`. Starts from the direction `start` (a nearby
/// solution's) or the line between the centres; returns the two points
/// and the direction between them.
pub(super) fn chain_points(
    eye: Vec3,
    first: First,
    a: &Sphere,
    m: &Sphere,
    w: Vec3,
    start: Option<Vec3>,
) -> Option<(Vec3, Vec3, Vec3)> {
    // one step of the fixed point: the points and the next direction
    let step = |dir: Vec3| -> Option<(Vec3, Vec3, Vec3)> {
        // where the camera's ray meets `a`, and where it leaves `a` along dir
        let (seen, leaves) = match first {
            First::Mirror => {
                let p = a.center + mirror_point(eye, a.center, a.radius, dir)? * a.radius;
                (p, p)
            }
            #[cfg(feature = "glass")]
            First::Glass(eta) => {
                let mut paths =
                    [crate::material::ball::GlassPath::NONE; crate::material::ball::ROOTS];
                let found = crate::material::ball::glass_paths(
                    eye, a.center, a.radius, eta, dir, &mut paths,
                );
                let p = paths.first().filter(|_| found == 1)?;
                (p.entry, p.exit)
            }
        };
        let pm = m.center + mirror_point(leaves, m.center, m.radius, w)? * m.radius;
        Some((seen, pm, (pm - leaves).normalize()))
    };
    let mut dir = start.unwrap_or_else(|| (m.center - a.center).normalize());
    // two steps, then Aitken's extrapolation of the three directions
    // (Irons and Tuck's vector form): the iteration converges linearly, by
    // a factor that is nearly the same in every direction of the tangent
    // plane, which the extrapolation removes
    for _ in 0..CHAIN_STEPS / 3 {
        let (seen, pm, d1) = step(dir)?;
        let a1 = d1 - dir;
        if !(a1.length_squared() > 1e-13) {
            return Some((seen, pm, d1));
        }
        let (seen, pm, d2) = step(d1)?;
        let a2 = d2 - d1;
        if !(a2.length_squared() > 1e-13) {
            return Some((seen, pm, d2));
        }
        let dd = a2 - a1;
        let den = dd.length_squared();
        dir = if den > 0.0 {
            let x = d2 - a2 * (a2.dot(dd) / den);
            if x.is_finite() { x.normalize() } else { d2 }
        } else {
            d2
        };
    }
    None
}

/// A ray's derivatives along two directions of the film: of its origin
/// and of its direction.
#[derive(Clone, Copy, Debug)]
struct RayDiff {
    dp: [Vec3; 2],
    dw: [Vec3; 2],
}

impl RayDiff {
    /// The derivatives after the ray (unit `w`) travels `t` to a point of a
    /// sphere of radius `r` and outward normal `n` there and reflects
    /// (`eta` `None`) or refracts (`eta` = η_i / η_t): the point moves
    /// with the ray's origin and direction (to the tangent plane), the
    /// normal by `dp / r`, and the new direction with both (Igehy's ray
    /// differentials).
    fn through(self, w: Vec3, t: f32, n: Vec3, r: f32, eta: Option<f32>) -> Self {
        let wn = w.dot(n);
        // the normal facing the ray's origin
        let (nf, sign) = if wn < 0.0 { (n, 1.0) } else { (-n, -1.0) };
        let cos_i = -w.dot(nf);
        let mut out = self;
        for k in 0..2 {
            let (Some(&dp), Some(&dw)) = (self.dp.get(k), self.dw.get(k)) else {
                continue;
            };
            let dq = dp + dw * t;
            let dpn = dq - w * (n.dot(dq) / wn);
            let dnf = dpn * (sign / r);
            let dcos = -(dw.dot(nf) + w.dot(dnf));
            let dwn = match eta {
                None => dw + (nf * dcos + dnf * cos_i) * 2.0,
                Some(eta) => {
                    let cos_t = math::sqrt(math::max(1.0 - eta * eta * (1.0 - cos_i * cos_i), 0.0));
                    let mu = eta * cos_i - cos_t;
                    let dmu = (eta - eta * eta * cos_i / cos_t) * dcos;
                    dw * eta + nf * dmu + dnf * mu
                }
            };
            if let (Some(p), Some(d)) = (out.dp.get_mut(k), out.dw.get_mut(k)) {
                *p = dpn;
                *d = dwn;
            }
        }
        out
    }

    /// `|dw₁ × dw₂ · w|`: the solid angle of directions per unit film area.
    fn jacobian(&self, w: Vec3) -> f32 {
        math::abs(self.dw[0].cross(self.dw[1]).dot(w))
    }
}

/// The path of the camera ray through film position (`fx`, `fy`) from
/// lens position `lp` along the chain camera → `via` ([`Highlight::via`])
/// → mirror `mirror` (none: straight on) → light `light`, traced as the
/// path tracer traces it: the weight of the chain's vertices (the first
/// mirror's tint, or the glass ball's two Fresnel transmittances, times
/// `mirror`'s tint) and `|dω/dx|` of the direction leaving the last
/// sphere; `None` where the ray leaves the chain or meets something else
/// first. The rays it traces are counted in `stats`.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn trace_chain(
    scene: &SceneView<'_>,
    camera: &Camera,
    lp: &LensPoint,
    via: u16,
    mirror: Option<u16>,
    light: u16,
    fx: f32,
    fy: f32,
    stats: &mut Stats,
) -> Option<(Color, f32)> {
    let ai = usize::from(via & !VIA_INSIDE);
    let a = scene.spheres.get(ai)?;
    let ray = camera.ray_at(fx, fy, lp);
    let (a1, a2) = camera.dir_derivatives_at(fx, fy, lp);
    let mut diff = RayDiff {
        dp: [Vec3::ZERO; 2],
        dw: [a1, a2],
    };
    stats.bounce_rays += 1;
    let ha = scene.closest_hit_any(&ray, ObjectId::NONE)?;
    if ha.object != ObjectId::sphere(ai) || !(ray.dir.dot(ha.normal) < 0.0) {
        return None;
    }
    let (weight, out, w) = match (
        scene.materials.get(a.material as usize)?,
        via & VIA_INSIDE != 0,
    ) {
        (Material::Mirror(tint), false) => {
            let w = reflect(ray.dir, ha.normal);
            diff = diff.through(ray.dir, ha.t, ha.normal, a.radius, None);
            (*tint, ha, w)
        }
        #[cfg(feature = "glass")]
        (Material::Glass(ior), true) => {
            use crate::material::{fresnel_dielectric, sample_dielectric};
            // the refraction in, as the path tracer's split refracts
            let cos_in = -ray.dir.dot(ha.normal);
            let (r_in, _) = fresnel_dielectric(cos_in, 1.0 / *ior);
            let (inner, _) = sample_dielectric(ray.dir, ha.normal, *ior, 1.0);
            diff = diff.through(ray.dir, ha.t, ha.normal, a.radius, Some(1.0 / *ior));
            stats.bounce_rays += 1;
            let hb = scene.closest_hit_any(&ha.spawn(inner), ha.object)?;
            let cos_out = inner.dot(hb.normal);
            if hb.object != ha.object || !(cos_out > 0.0) {
                return None;
            }
            // and out (a ball gives no total internal reflection to a ray
            // that entered it)
            let (r_out, _) = fresnel_dielectric(cos_out, *ior);
            if !(r_out < 1.0) {
                return None;
            }
            let (w, _) = sample_dielectric(inner, hb.normal, *ior, 1.0);
            diff = diff.through(inner, hb.t, hb.normal, a.radius, Some(*ior));
            (Color::splat((1.0 - r_in) * (1.0 - r_out)), hb, w)
        }
        _ => return None,
    };
    // the mirror, if any, then the light
    let (weight, last, wm) = match mirror {
        None => (weight, out, w),
        Some(mirror) => {
            let m = scene.spheres.get(usize::from(mirror))?;
            let Some(Material::Mirror(tint_m)) = scene.materials.get(m.material as usize) else {
                return None;
            };
            stats.bounce_rays += 1;
            let hm = scene.closest_hit_any(&out.spawn(w), out.object)?;
            if hm.object != ObjectId::sphere(usize::from(mirror)) || !(w.dot(hm.normal) < 0.0) {
                return None;
            }
            let wm = reflect(w, hm.normal);
            diff = diff.through(w, hm.t, hm.normal, m.radius, None);
            (weight * *tint_m, hm, wm)
        }
    };
    stats.bounce_rays += 1;
    let on = scene.closest_hit_any(&last.spawn(wm), last.object)?;
    if on.object != ObjectId::sphere(usize::from(light)) || !(wm.dot(on.normal) < 0.0) {
        return None;
    }
    let jac = diff.jacobian(wm);
    (jac > 0.0).then_some((weight, jac))
}

/// The film area (pixels²) of the image of light `li` through the chain
/// camera → `via` → mirror `mi` (`a`, `m` those spheres), from its Jacobian
/// along the cone's axis `axis` (the cone's solid angle over `|dω/dx|`),
/// or `None` where the axis has no chain the camera sees unblocked.
#[allow(clippy::too_many_arguments)]
fn chain_area(
    scene: &SceneView<'_>,
    camera: &Camera,
    (first, via): (First, u16),
    a: &Sphere,
    (m, mi): (&Sphere, u16),
    (l, li): (&Sphere, u16),
    axis: Vec3,
) -> Option<f32> {
    let (seen, _, _) = chain_points(camera.eye(), first, a, m, axis, None)?;
    let lp = LensPoint::CENTRE;
    let [fx, fy] = camera.film_at(seen, &lp)?;
    if !(fx >= 0.0 && fy >= 0.0 && fx < camera.width() as f32 && fy < camera.height() as f32) {
        return None;
    }
    let (_, jac) = trace_chain(
        scene,
        camera,
        &lp,
        via,
        Some(mi),
        li,
        fx,
        fy,
        &mut Stats::default(),
    )?;
    let d2 = (l.center - m.center).length_squared();
    let reach = l.radius + m.radius;
    // the cone's solid angle, 2π (1 − cos θ) ≈ π sin² θ for a narrow cone
    Some(core::f32::consts::PI * reach * reach / (d2 * jac))
}

/// [`image_rect`] of the chain camera → `a` → `m` → light `l`.
fn chain_rect(
    camera: &Camera,
    first: First,
    a: &Sphere,
    m: &Sphere,
    l: &Sphere,
    d: f32,
) -> Option<[f32; 4]> {
    lens_rect(camera, |lp| {
        let eye = camera.origin(&lp);
        // the rim's solves start from the axis's
        let axis = (l.center - m.center) * (1.0 / d);
        let (_, _, start) = chain_points(eye, first, a, m, axis, None)?;
        rim_rect(m, l, d, CHAIN_RIM, |w| {
            let (seen, _, _) = chain_points(eye, first, a, m, w, Some(start))?;
            camera.film_at(seen, &lp)
        })
    })
}

/// Directions on the rim of a chain's cone to bound its image: its image
/// is a small fraction of a pixel, and the bound's margin (twice the
/// largest step between neighbours) is most of the rectangle.
const CHAIN_RIM: usize = 8;
/// The part of [`estimate`] for pair `p` through a glass ball or a chain
/// (camera → `p.via` → mirror `m`, or the ball `m` itself, → light) from
/// lens position `lp` and the sampled direction `w` leaving `m`: the
/// path's weight over `|dω/dx|` ([`trace_chain`]) when its film position
/// lies in pixel `px`, else `None`.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(super) fn estimate_chain(
    scene: &SceneView<'_>,
    camera: &Camera,
    p: &Highlight,
    m: &Sphere,
    w: Vec3,
    px: [u32; 2],
    lp: &LensPoint,
    stats: &mut Stats,
) -> Option<Color> {
    let a = scene.spheres.get(usize::from(p.via & !VIA_INSIDE))?;
    let (kind, _) = first(scene, camera, a)?;
    let eye = camera.origin(lp);
    let (seen, mirror) = if p.through_glass() {
        (glass_entry(eye, kind, a, w)?, None)
    } else {
        (chain_points(eye, kind, a, m, w, None)?.0, Some(p.mirror))
    };
    let [fx, fy] = camera.film_at(seen, lp)?;
    let (x0, y0) = (px[0] as f32, px[1] as f32);
    if !(fx >= x0 && fx < x0 + 1.0 && fy >= y0 && fy < y0 + 1.0) {
        return None;
    }
    let (weight, jac) = trace_chain(scene, camera, lp, p.via, mirror, p.light, fx, fy, stats)?;
    Some(weight * (1.0 / jac))
}
