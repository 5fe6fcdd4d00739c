//! Next-event estimation: a direction sampled toward the chosen light
//! (uniformly in its cone, or through the window an opaque wall cuts it
//! to), a shadow ray, and the sample's weight against BSDF sampling by
//! multiple importance sampling, written so that no pdf is divided by.

use super::choice::LightChoice;
use super::{Options, Strategy};
use crate::geometry::{Color, Hit, ObjectId, Ray, Vec3, line_misses, line_misses_by_far};
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

/// The factor by which [`whole_light`] grows the radii of the light and
/// of each occluder.
const GROW: f32 = 1.0 + 1.0 / 256.0;

/// The direct light of the one light at a Lambertian point in closed form,
/// where the point provably sees all of it: `sin²α cos β` (`α` the light's
/// angular radius, `β` the angle of its centre from the normal), so that
/// the vertex adds `thr · albedo · Le · sin²α cos β`, the exact integral
/// of `Le (albedo/π) cos θ` over the light's solid angle: a sphere
/// entirely above the tangent plane has the projected solid angle
/// `π sin²α cos β` (the form factor of a sphere seen from a surface
/// element). `None` where that is not certain; next-event estimation
/// samples the light there, as it always did.
///
/// Certain means, with margins far above f32 rounding:
/// * the whole light lies above the horizon, `n · (c − x) > r + d/1024`:
///   every direction toward it leaves the surface by at least 2⁻¹⁰ in
///   cosine, so the sphere the point lies on (if it faces outward) cannot
///   block it, being convex;
/// * every other sphere of the shadow rays' occluder list keeps out of
///   the cone from `x` around the light (half-angle `α'` with
///   `sin α' = r (1 + 2⁻⁸) / d`), by more than its radius grown by 2⁻⁸
///   plus `4e` (`e` the hit point's error bound: the shadow ray's origin
///   offset stays within it): with `h` and `p` the centre's distances
///   across and along the axis, `h cos α' − p sin α' > ρ (1 + 2⁻⁸) + 4e`
///   (the distance from a point to the cone's surface, or less), compared
///   in squares with `2⁻¹⁸ |s − x|²` more for the rounding. Every shadow
///   ray toward the light lies in that cone, so it misses such a sphere
///   by a wide margin. (The cone is not cut at the light: a sphere beyond
///   the light is refused for nothing.) Where the cone refuses a sphere,
///   it still passes if its centre lies farther than `(ρ + r)(1 + 2⁻⁸) +
///   4e` from the line through the light's centre (every shadow ray stays
///   within `r` of it): the sphere test's own line test, which targets
///   without an FPU try first in integer arithmetic (`line_misses_by_far`,
///   which answers only where the float test says the same), so that every
///   target makes the same decision.
///
/// `to_c` is `c − x` and `d2` its squared length (above `r2`). The list
/// holds no emitter ([`SceneView::shadow_lights`] is false: the caller has
/// checked [`OneLight::whole`](super::plan)).
#[inline(always)]
pub(super) fn whole_light(
    scene: &SceneView<'_>,
    hit: &Hit,
    n: Vec3,
    to_c: Vec3,
    d2: f32,
    r: f32,
    r2: f32,
) -> Option<f32> {
    let ndc = n.dot(to_c);
    let d = math::sqrt(d2);
    if !math::gt(ndc, r + d * (1.0 / 1024.0)) {
        return None;
    }
    let inv_d = 1.0 / d;
    let sin = r * GROW * inv_d;
    // at most 0 within the grown light: then no occluder passes the test
    let cos2 = 1.0 - sin * sin;
    let cone = Cone {
        axis: to_c * inv_d,
        sin,
        cos2,
        grow: 4.0 * hit.error,
        hull: r * GROW + 4.0 * hit.error,
    };
    let clear = match hit.object.as_sphere() {
        // the point's own sphere is behind every direction toward the
        // light if the shading normal is the outward one
        Some(_) if math::gt_zero(n.dot(hit.normal)) => cone.clear::<true>(scene.tested_shadow, hit),
        Some(_) => false,
        None => cone.clear::<false>(scene.tested_shadow, hit),
    };
    if !clear {
        return None;
    }
    Some(r2 * ndc * (inv_d * inv_d * inv_d))
}

/// The cone of [`whole_light`]: unit axis, `sin α'`, `cos² α'`, and what
/// an occluder's grown radius gains besides (`4e`).
struct Cone {
    axis: Vec3,
    sin: f32,
    cos2: f32,
    grow: f32,
    /// `r·GROW + grow`: what the line test adds to an occluder's grown
    /// radius.
    hull: f32,
}

impl Cone {
    /// Whether every sphere of `list` (but the hit's own, if `SKIP_OWN`)
    /// keeps out of the cone from the hit point by the margins of
    /// [`whole_light`], or else away from the line through the light's
    /// centre: `h² cos²α' > R² + 2⁻¹⁸ |v|²` with `R = ρ·GROW +
    /// grow + p sin α'`, `v` from the point to the centre, `p = v · axis`
    /// and `h² = |v|² − p²`. (That difference cancels where the centre is
    /// near the axis, by at most `6ε |v|²`, well inside the `2⁻¹⁸ |v|²`;
    /// and where `R < 0`, which the cone's distance would pass outright,
    /// the squares only refuse some spheres behind the point for nothing.)
    #[inline(always)]
    fn clear<const SKIP_OWN: bool>(&self, list: &[crate::analysis::Listed], hit: &Hit) -> bool {
        for l in list {
            if SKIP_OWN && l.id == hit.object {
                continue;
            }
            // first the line through the light's centre: a centre farther
            // than `ρ·GROW + r·GROW + grow` from it keeps every shadow ray
            // (which stays within `r` of that line) at a distance. The
            // sphere test's line test (`line_misses`, on `f = x − s`:
            // `b = −f·axis = p`, `|f|² = |v|²`); without an FPU, where each
            // float operation is a call, first its integer version, which
            // answers only where the float test would say the same
            let line2 = || {
                let line = l.sphere.radius * GROW + self.hull;
                line * line
            };
            if math::SOFT_FLOAT
                && line_misses_by_far(hit.point, l.sphere.center, self.axis, line2())
            {
                continue;
            }
            let v = l.sphere.center - hit.point;
            let vv = v.dot(v);
            let p = v.dot(self.axis);
            // then the cone, and the line in float where the cone refuses
            let reach = l.sphere.radius * GROW + self.grow + p * self.sin;
            if !math::gt(
                (vv - p * p) * self.cos2,
                reach * reach + vv * (1.0 / 262_144.0),
            ) && !line_misses(p, vv - line2(), vv, self.axis.dot(self.axis))
            {
                return false;
            }
        }
        true
    }
}

#[cfg(all(test, feature = "parser"))]
mod tests {
    use super::*;
    use crate::light::sample_cone_toward;
    use crate::scene::Scene;
    use core::fmt::Write;
    use rand_core::{Rng, SeedableRng};
    use rand_xorshift::XorShiftRng;

    fn unit(rng: &mut XorShiftRng) -> f32 {
        (rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    fn range(rng: &mut XorShiftRng, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * unit(rng)
    }

    /// A floor, a light above it (near, or a far sun) and three spheres
    /// between, at random.
    fn random_scene(rng: &mut XorShiftRng) -> (Scene<8, 2, 4>, Vec3, f32) {
        let mut c = Vec3::new(
            range(rng, -1.0, 1.0),
            range(rng, 1.5, 3.0),
            range(rng, -1.0, 1.0),
        );
        let mut r = range(rng, 0.02, 0.5);
        if unit(rng) < 0.25 {
            // a sun: far, and large
            let far = range(rng, 20.0, 500.0);
            c = Vec3::new(c.x * far, far, c.z * far);
            r = far * range(rng, 0.01, 0.1);
        }
        let mut text: heapless::String<1024> = heapless::String::new();
        writeln!(text, "camera 0 1 5  0 1 0  0 1 0  60").unwrap();
        writeln!(text, "material w diffuse 0.5 0.5 0.5").unwrap();
        writeln!(text, "material l light 1 1 1").unwrap();
        writeln!(text, "plane 0 0 0  0 1 0  w").unwrap();
        writeln!(text, "sphere {} {} {}  {}  l", c.x, c.y, c.z, r).unwrap();
        let mut placed = 0;
        while placed < 3 {
            let rho = range(rng, 0.05, 0.5);
            let s = Vec3::new(
                range(rng, -1.5, 1.5),
                range(rng, rho, 1.6),
                range(rng, -1.5, 1.5),
            );
            if (s - c).length() > r + rho + 0.01 {
                writeln!(text, "sphere {} {} {}  {}  w", s.x, s.y, s.z, rho).unwrap();
                placed += 1;
            }
        }
        let scene = crate::parse::parse_with_capacity(&text).unwrap();
        (scene, c, r)
    }

    /// Soundness of the closed form's visibility test: wherever
    /// [`whole_light`] answers, no shadow ray toward the light (a 16×16
    /// grid over its cone, rim included) is blocked, at hit points of the
    /// floor and of the spheres' outer and inner surfaces.
    #[test]
    fn whole_light_only_where_no_shadow_ray_is_blocked() {
        let mut rng = XorShiftRng::seed_from_u64(11);
        let (mut answered, mut refused) = (0, 0);
        for _ in 0..200 {
            let (scene, c, r) = random_scene(&mut rng);
            let view = scene.view(-1.0);
            assert!(view.shadow_planes.is_empty() && !view.shadow_lights);
            let target = ObjectId::sphere(0);
            for k in 0..64 {
                // from above, or from inside a sphere (inward normals)
                let origin = match view.spheres.get(1 + k % 8) {
                    Some(s) if k % 3 == 0 => s.center,
                    _ => Vec3::new(range(&mut rng, -2.0, 2.0), 1.8, range(&mut rng, -2.0, 2.0)),
                };
                let dir = Vec3::new(
                    range(&mut rng, -1.0, 1.0),
                    range(&mut rng, -1.0, 0.2),
                    range(&mut rng, -1.0, 1.0),
                )
                .normalize();
                let Some(hit) = view.closest_hit(&Ray::new(origin, dir), ObjectId::NONE) else {
                    continue;
                };
                if hit.object == target {
                    continue;
                }
                let n = if dir.dot(hit.normal) < 0.0 {
                    hit.normal
                } else {
                    -hit.normal
                };
                let to_c = c - hit.point;
                let d2 = to_c.length_squared();
                let Some(f) = whole_light(&view, &hit, n, to_c, d2, r, r * r) else {
                    refused += 1;
                    continue;
                };
                answered += 1;
                assert!(f > 0.0 && f.is_finite());
                for i in 0..16 {
                    for j in 0..16 {
                        let (u1, u2) = (i as f32 / 15.0 * 0.999_999, j as f32 / 16.0);
                        let ls = sample_cone_toward(to_c, d2, r * r, u1, u2, false, true);
                        let shadow = hit.spawn_on(n, ls.dir);
                        assert!(
                            !view.occluded_in::<false>(&shadow, ls.dist, hit.object, target),
                            "blocked: {hit:?} toward {c:?} r {r}"
                        );
                    }
                }
            }
        }
        // both answers are common: the test is not vacuous
        assert!(answered > 2000 && refused > 2000, "{answered} {refused}");
    }

    /// The projected solid angle of a sphere wholly above a surface
    /// element is `π sin²α cos β` (the form factor of a sphere): the
    /// closed form against the cone's cosine integrated on a fine grid of
    /// its uniform samples, `(Ω/π) mean(cos θ)`.
    #[test]
    fn whole_light_is_the_form_factor_of_a_sphere() {
        let mut rng = XorShiftRng::seed_from_u64(5);
        let text = "camera 0 1 5  0 1 0  0 1 0  60\nmaterial w diffuse 0.5 0.5 0.5\nmaterial l light 1 1 1\n\
                    plane 0 0 0  0 1 0  w\nsphere 0 1 0  0.1  l\n";
        let scene: Scene<2, 1, 2> = crate::parse::parse_with_capacity(text).unwrap();
        let view = scene.view(-1.0);
        let mut checked = 0;
        for _ in 0..100 {
            let (c, r) = (
                Vec3::new(range(&mut rng, -2.0, 2.0), range(&mut rng, 0.3, 2.0), 0.0),
                range(&mut rng, 0.01, 0.29),
            );
            let hit = view
                .closest_hit(
                    &Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, -1.0, 0.0)),
                    ObjectId::NONE,
                )
                .unwrap();
            let n = hit.normal;
            let to_c = c - hit.point;
            let d2 = to_c.length_squared();
            // the scene's own light is not an occluder: any sphere will do
            let Some(f) = whole_light(&view, &hit, n, to_c, d2, r, r * r) else {
                continue;
            };
            // compensated (Kahan) summation of the 128² cosines
            let (mut sum, mut carry, m) = (0.0f32, 0.0f32, 128u32);
            for i in 0..m {
                for j in 0..m {
                    let u1 = (i as f32 + 0.5) / m as f32;
                    let u2 = (j as f32 + 0.5) / m as f32;
                    let ls = sample_cone_toward(to_c, d2, r * r, u1, u2, false, true);
                    let y = n.dot(ls.dir) - carry;
                    let t = sum + y;
                    carry = (t - sum) - y;
                    sum = t;
                }
            }
            // Ω/π = 2 (1 − cos θmax)
            let omc = crate::light::one_minus_cos_max(r * r, d2);
            let integral = 2.0 * omc * sum / (m * m) as f32;
            let rel = math::abs(f / integral - 1.0);
            assert!(rel < 1e-4, "{c:?} r {r}: {f} against {integral}");
            checked += 1;
        }
        assert!(checked > 30, "{checked}");
    }
}
