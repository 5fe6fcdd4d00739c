//! Next-event estimation: a direction sampled toward the chosen light
//! (uniformly in its cone, or through the window an opaque wall cuts it
//! to), a shadow ray, and the sample's weight against BSDF sampling by
//! multiple importance sampling, written so that no pdf is divided by.

use super::choice::LightChoice;
use super::{Options, Strategy};
use crate::geometry::{Color, Hit, ObjectId, Ray, Vec3};
use crate::light::{self, Window};
use crate::material::{Lobe, Material};
use crate::math;
use crate::scene::SceneView;

/// Next-event estimation toward the light that [`Ctx::choose_light`] chose
/// (the several-lights variant), MIS-weighted.
///
/// With `a = p_bsdf / p_light = (π p_bsdf / π) · 2π (1 − cos θ_max) /
/// p_sel`, the estimate `f · Le · cos / p_light · w` with the power
/// heuristic `w = 1 / (1 + a²)` is `(f cos / p_bsdf) · Le · a / (1 + a²)`:
/// no pdf is ever divided by. For the Lambertian `f cos / p_bsdf` is its
/// albedo and `π p_bsdf` the cosine, so with one light `a ≤ 2` and `a²`
/// cannot overflow. `f` is the throughput times the lobe's tint
/// ([`Lobe::tint`]), `wo` the direction back along the incoming ray.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn direct<const TREE: bool, B: Lobe>(
    scene: &SceneView<'_>,
    hit: &Hit,
    n: Vec3,
    f: Color,
    lobe: &B,
    wo: Vec3,
    c: &LightChoice,
    u: [f32; 2],
    opts: &Options,
    shadows: &mut u32,
) -> Color {
    let Some(s) = scene.spheres.get(c.sphere) else {
        return Color::ZERO;
    };
    let Some(le) = scene
        .materials
        .get(s.material as usize)
        .and_then(Material::emission)
    else {
        return Color::ZERO;
    };
    nee::<true, TREE, B>(
        scene, hit, n, f, lobe, wo, c, s.radius2, le, u, opts, shadows, &mut 0.0,
    )
}

/// [`direct`] through the light's window (the several-lights variant).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(super) fn direct_window<const TREE: bool, B: Lobe>(
    scene: &SceneView<'_>,
    hit: &Hit,
    n: Vec3,
    f: Color,
    lobe: &B,
    wo: Vec3,
    c: &LightChoice,
    u: [f32; 2],
    opts: &Options,
    shadows: &mut u32,
    w: &Window,
) -> Option<Color> {
    let le = scene
        .spheres
        .get(c.sphere)
        .and_then(|s| scene.materials.get(s.material as usize))
        .and_then(Material::emission)?;
    nee_window::<true, TREE, B>(scene, hit, n, f, lobe, wo, c, le, u, opts, shadows, w)
}

/// [`direct`] with the light's squared radius and radiance given.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn nee<const MANY: bool, const TREE: bool, B: Lobe>(
    scene: &SceneView<'_>,
    hit: &Hit,
    n: Vec3,
    f: Color,
    lobe: &B,
    wo: Vec3,
    c: &LightChoice,
    r2: f32,
    le: Color,
    u: [f32; 2],
    opts: &Options,
    shadows: &mut u32,
    omc_out: &mut f32,
) -> Color {
    // the occluder lists hold what can block a reachable light: shadow rays
    // toward the others (sampled when that skip is off) test everything
    let lists = opts.skip.shadow_occluders && opts.skip.unreachable_lights;

    let surface = !(lists && scene.light_clear);
    let ls = light::sample_cone_toward(c.to_c, c.d2, r2, u[0], u[1], opts.fast_math, surface);
    *omc_out = ls.omc_max;
    let cos = n.dot(ls.dir);
    if !math::gt_zero(cos) {
        return Color::ZERO;
    }
    *shadows += 1;
    let shadow = hit.spawn_on(n, ls.dir);
    let target = ObjectId::sphere(c.sphere);
    let blocked = if lists && MANY {
        scene.occluded_outlined::<TREE>(&shadow, ls.dist, hit.object, target)
    } else if lists {
        scene.occluded_in::<TREE>(&shadow, ls.dist, hit.object, target)
    } else {
        // a copy for the out-of-line test: a ray whose address a call
        // takes lives in memory, on the inlined test's path too
        let copy = Ray::new(shadow.origin, shadow.dir);
        scene.occluded_by_any(&copy, ls.dist, hit.object, target)
    };
    if blocked {
        return Color::ZERO;
    }
    let (s, pi_pdf) = lobe.eval(wo, n, ls.dir, cos);
    let a = math::twice(pi_pdf) * ls.omc_max;
    let a = if MANY { a / c.p_sel } else { a };
    let w = match opts.strategy {
        // a/(1 + a²) = 1/(a + 1/a): the second form for the huge `a` of a
        // light chosen with a tiny probability
        Strategy::Mis if MANY && a > 1.0e18 => 1.0 / a,
        Strategy::Mis => a / (1.0 + a * a),
        _ => a,
    };
    // s is 1 for the Lambertian: f · le · w, as ever
    f * s * le * w
}

/// [`nee`] through the light's window ([`Window::sample`]) where the window
/// shows all of the light's cap to the point ([`Window::covers`]; `None`
/// elsewhere): the direction through a uniform point of the disk, tested
/// to the cap's surface.
/// `a = p_bsdf / p_light = (π p_bsdf / π) · (A |n·ω| / |y − x|²) / p_sel`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn nee_window<const MANY: bool, const TREE: bool, B: Lobe>(
    scene: &SceneView<'_>,
    hit: &Hit,
    n: Vec3,
    f: Color,
    lobe: &B,
    wo: Vec3,
    c: &LightChoice,
    le: Color,
    u: [f32; 2],
    opts: &Options,
    shadows: &mut u32,
    w: &Window,
) -> Option<Color> {
    let (dir, cos, inv_pdf) = match window_sample::<TREE>(scene, hit, n, c, u, opts, shadows, w)? {
        Some(s) => s,
        None => return Some(Color::ZERO),
    };
    let (s, pi_pdf) = lobe.eval(wo, n, dir, cos);
    let a = pi_pdf * inv_pdf * math::INV_PI;
    let a = if MANY { a / c.p_sel } else { a };
    Some(f * s * le * mis_weight(a, opts))
}

/// The lobe-independent part of [`nee_window`]: `None` where the window
/// does not show all of the cap, `Some(None)` for a sample that adds
/// nothing (below the surface, missing the cap, blocked), else the
/// direction, its cosine and `1 / pdf`. Out of line: one copy serves every
/// light plan and lobe type.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(super) fn window_sample<const TREE: bool>(
    scene: &SceneView<'_>,
    hit: &Hit,
    n: Vec3,
    c: &LightChoice,
    u: [f32; 2],
    opts: &Options,
    shadows: &mut u32,
    w: &Window,
) -> Option<Option<(Vec3, f32, f32)>> {
    if !w.covers(hit.point) {
        return None;
    }
    let lists = opts.skip.shadow_occluders && opts.skip.unreachable_lights;
    let (dir, inv_pdf) = w.sample(hit.point, u[0], u[1], opts.fast_math);
    let cos = n.dot(dir);
    if !(cos > 0.0 && inv_pdf > 0.0) {
        return Some(None);
    }
    let Some(light) = scene.spheres.get(c.sphere) else {
        return Some(None);
    };
    // the cap lies between the point and the disk: the near intersection
    let Some(dist) = light.intersect(&Ray::new(hit.point, dir), f32::INFINITY) else {
        return Some(None);
    };
    *shadows += 1;
    let shadow = hit.spawn_on(n, dir);
    let target = ObjectId::sphere(c.sphere);
    let blocked = if lists {
        scene.occluded_outlined::<TREE>(&shadow, dist, hit.object, target)
    } else {
        scene.occluded_by_any(&shadow, dist, hit.object, target)
    };
    Some((!blocked).then_some((dir, cos, inv_pdf)))
}

/// The weight `a / (1 + a²)` (MIS, power heuristic) or `a` (light
/// sampling only) of a light sample whose BSDF-to-light pdf ratio is `a`.
#[inline(always)]
pub(super) fn mis_weight(a: f32, opts: &Options) -> f32 {
    match opts.strategy {
        // a/(1 + a²) = 1/(a + 1/a): the second form where a² would overflow
        Strategy::Mis if a > 1.0e18 => 1.0 / a,
        Strategy::Mis => a / (1.0 + a * a),
        _ => a,
    }
}
