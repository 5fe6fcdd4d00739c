//! The path loop: camera ray, closest hits, the material's scatter, a
//! non-delta vertex's next-event estimation and BSDF sample, emitters hit
//! weighted by multiple importance sampling, Russian roulette, and the
//! branches of a path split at glass.

use super::choice::GlossyChoice;
use super::choice::LightChoice;
use super::nee::{direct, direct_window, nee, nee_window, whole_light};
use super::plan::{Ctx, PrevVertex, window_of};
#[cfg(feature = "glass")]
use super::split::{Branch, split_at_glass};
use super::{Options, Strategy, power_heuristic};
use crate::geometry::{Color, Hit, ObjectId, Ray, Vec3};
use crate::material::diffuse::sample_cosine;
use crate::material::{Bsdf, Lambert, Lobe, Scatter};
use crate::math;
use crate::sampler::SampleStream;
use crate::stats::Stats;

/// The path tracer, compiled for scenes with several lights (`MANY`) or
/// with one, and for rays that find their spheres through the scene's tree
/// (`TREE`) or its lists.
#[inline(always)]
pub(super) fn trace<const MANY: bool, const TREE: bool>(
    ctx: &Ctx<'_, '_>,
    ray: Ray,
    stream: &mut SampleStream<'_>,
    opts: &Options,
    stats: &mut Stats,
) -> Color {
    let scene = ctx.scene;
    let mut l = Color::ZERO;
    let mut thr = Color::ONE;
    let mut ray = ray;
    let mut from = ObjectId::NONE;
    // what the last vertex was, in one register: emitters get full weight
    // after the camera (the eye is a delta) and after mirror or glass
    // (`DELTA` and up); the first non-delta vertex, wherever mirrors and
    // glass put it, draws its numbers from the pixel's stratified pairs
    // (`EYE`, kept through deltas; a render without stratification starts
    // at `DELTA`)
    const NON_DELTA: u8 = 0;
    const DELTA: u8 = 1;
    const EYE: u8 = 2;
    let mut last = if opts.stratified { EYE } else { DELTA };
    // undoes the (eta_i/eta_t)^2 radiance scaling for Russian roulette, so
    // that paths inside glass are not killed for a factor that cancels on
    // exit (and a split's weight, R or 1 − R, so that each branch is
    // killed as the path that chose it would be)
    let mut rr_scale = 1.0f32;
    // The last non-delta vertex, read only after one has set it. With metal
    // an Option, empty until then: zeroing the larger record at every
    // path's start cost a call to memclr per path on a Cortex-M4 (59
    // instructions of furnace.scene's 1,002, tools/profile.sh). Without
    // metal the record as it always was: there an Option cost 172 bytes of
    // a 64 KiB firmware's flash.
    #[cfg(feature = "metal")]
    let mut prev: Option<PrevVertex> = None;
    #[cfg(not(feature = "metal"))]
    let mut prev = PrevVertex {
        point: Vec3::ZERO,
        normal: Vec3::ZERO,
        bsdf_pdf: 0.0,
        weight_sum: 0.0,
        light_omc: 0.0,
        horizon: false,
    };
    let mut glossy = GlossyChoice {
        alpha: 0.0,
        wo: Vec3::ZERO,
        share_sum: 0.0,
    };
    // counted here and added to `stats` once per path (u64 additions are
    // four instructions each on a 32-bit core)
    let (mut bounces, mut shadows) = (0u32, 0u32);
    let mut depth = 0u32;
    // whether the path may no longer split at a glass vertex: it has split,
    // or met a non-delta vertex
    #[cfg(feature = "glass")]
    let mut no_split = false;
    // the other branch of a path split at its first glass vertex (see
    // `split_at_glass`), traced after this one ends
    #[cfg(feature = "glass")]
    let mut pending: Option<Branch> = None;
    // one inlined query for every ray, with the camera ray's sphere list
    // when culling (a camera ray leaves no object), the bounce rays' list
    // from the first bounce on (a split path's other branch starts later)
    let mut spheres = if opts.skip.view_culling {
        scene.tested_primary
    } else {
        scene.tested
    };
    // one pass per branch: without glass, exactly one
    #[cfg_attr(not(feature = "glass"), allow(clippy::never_loop))]
    loop {
        loop {
            let found = if opts.skip.slabs {
                scene.closest_hit_in::<TREE>(&ray, from, spheres)
            } else {
                // the out-of-line query's record comes back through memory:
                // rebuilt field by field, so that the inlined query's
                // record need not live there too
                scene
                    .closest_hit_any_among(&ray, from, spheres)
                    .map(|h| Hit {
                        t: h.t,
                        point: h.point,
                        normal: h.normal,
                        error: h.error,
                        object: h.object,
                        material: h.material,
                    })
            };
            let Some(hit) = found else {
                if scene.closed && opts.skip.closed {
                    // nothing can escape a closed scene: a numerical leak
                    stats.leaks += 1;
                } else {
                    l += thr * scene.background;
                }
                break;
            };
            // Russian roulette on the throughput with which the path leaves
            // this vertex (its `depth + 1`-th bounce): ends the path, or
            // weights the survivor. Each scattering arm asks it last, but a
            // cosine-sampled vertex before its direction, which a path that
            // roulette ends never needs (the same numbers in the same order:
            // the direction's are drawn before roulette's)
            macro_rules! roulette {
                () => {
                    if depth + 1 >= opts.rr_start {
                        let p = thr.max_component() * rr_scale * opts.rr_gain;
                        if math::lt(p, 1.0) {
                            if !math::lt(stream.next_f32(), p) {
                                break;
                            }
                            thr *= 1.0 / p;
                        }
                    }
                };
            }
            // a non-delta vertex, compiled once per lobe type (static
            // dispatch): next-event estimation and BSDF sampling by MIS
            macro_rules! non_delta {
                ($lobe:expr) => {{
                    let lobe = $lobe;
                    #[cfg(feature = "glass")]
                    {
                        no_split = true;
                    }
                    // two-sided: shade with the normal facing the incoming ray
                    let n = if math::lt_zero(ray.dir.dot(hit.normal)) {
                        hit.normal
                    } else {
                        -hit.normal
                    };
                    let wo = -ray.dir;
                    let mut weight_sum = 0.0;
                    let mut light_omc = 0.0;
                    let horizon = ctx.horizon_at(hit.object);
                    if opts.strategy != Strategy::BsdfOnly && !ctx.plan.lights.is_empty() {
                        // drawn before the light is chosen, so that skipping a
                        // light below the horizon never shifts the random
                        // numbers; with the closed form in use (one light),
                        // only where the light is sampled
                        macro_rules! light_u {
                            () => {
                                if last == EYE {
                                    stream.stratified_2d(2)
                                } else {
                                    stream.next_2d()
                                }
                            };
                        }
                        let early = if ctx.plan.one.is_some_and(|o| o.whole) {
                            None
                        } else {
                            Some(light_u!())
                        };
                        let f = thr * lobe.tint();
                        if MANY {
                            // several lights have no one-light plan, so the
                            // numbers were drawn above (`early` is `Some`)
                            let u = early.unwrap_or([0.0; 2]);
                            let alpha = lobe.selective_alpha();
                            let (choice, sum) = if cfg!(feature = "metal") && alpha > 0.0 {
                                let (c, sum) = ctx.choose_light_glossy(
                                    hit.point,
                                    n,
                                    horizon,
                                    last == EYE,
                                    stream,
                                    alpha,
                                    wo,
                                    &mut glossy,
                                );
                                // negative: the glossy choice's pdf applies
                                (c, -sum)
                            } else {
                                ctx.choose_light(hit.point, n, horizon, last == EYE, stream)
                            };
                            weight_sum = sum;
                            if let Some(c) = choice {
                                let through = match window_of(ctx.windows(), c.sphere) {
                                    Some(w) => direct_window::<TREE, _>(
                                        scene,
                                        &hit,
                                        n,
                                        f,
                                        &lobe,
                                        wo,
                                        &c,
                                        u,
                                        opts,
                                        &mut shadows,
                                        w,
                                    ),
                                    None => None,
                                };
                                l += match through {
                                    Some(e) => e,
                                    None => direct::<TREE, _>(
                                        scene,
                                        &hit,
                                        n,
                                        f,
                                        &lobe,
                                        wo,
                                        &c,
                                        u,
                                        opts,
                                        &mut shadows,
                                    ),
                                };
                            }
                        } else if let Some(one) = &ctx.plan.one {
                            weight_sum = 1.0;
                            let to_c = one.center - hit.point;
                            let d2 = to_c.length_squared();
                            let whole = |d2| {
                                if one.whole && lobe.cosine_weight().is_some() {
                                    whole_light(scene, &hit, n, to_c, d2, one.radius, one.radius2)
                                } else {
                                    None
                                }
                            };
                            if !(math::gt(d2, one.radius2)
                                && !(horizon && math::lt(n.dot(to_c), -one.radius)))
                            {
                                // not sampled here
                            } else if let Some(k) = whole(d2) {
                                light_omc = f32::INFINITY;
                                l += thr * (lobe.tint() * (one.le * k));
                            } else {
                                let u = match early {
                                    Some(u) => u,
                                    None => light_u!(),
                                };
                                let c = LightChoice {
                                    sphere: one.sphere,
                                    p_sel: 1.0,
                                    to_c,
                                    d2,
                                };
                                let through = match Ctx::window_of_one(one) {
                                    Some(w) => nee_window::<MANY, TREE, _>(
                                        scene,
                                        &hit,
                                        n,
                                        f,
                                        &lobe,
                                        wo,
                                        &c,
                                        one.le,
                                        u,
                                        opts,
                                        &mut shadows,
                                        w,
                                    ),
                                    None => None,
                                };
                                if let Some(e) = through {
                                    // negative: the window's pdf applies
                                    light_omc = -1.0;
                                    l += e;
                                } else {
                                    l += nee::<MANY, TREE, _>(
                                        scene,
                                        &hit,
                                        n,
                                        f,
                                        &lobe,
                                        wo,
                                        &c,
                                        one.radius2,
                                        one.le,
                                        u,
                                        opts,
                                        &mut shadows,
                                        &mut light_omc,
                                    );
                                }
                            }
                        }
                    }
                    let u = if last == EYE {
                        stream.stratified_2d(1)
                    } else {
                        stream.next_2d()
                    };
                    // f · cos / pdf (the Lambertian's: its albedo, exactly),
                    // and the π-scaled pdf of the direction
                    let (dir, pi_pdf) = if let Some(w) = lobe.cosine_weight() {
                        thr *= w;
                        roulette!();
                        sample_cosine(n, u[0], u[1], opts.fast_math)
                    } else {
                        let Some(bs) = lobe.sample(wo, n, u, opts.fast_math) else {
                            break;
                        };
                        thr *= bs.weight;
                        roulette!();
                        (bs.dir, bs.pi_pdf)
                    };
                    let vertex = PrevVertex {
                        point: hit.point,
                        normal: n,
                        bsdf_pdf: pi_pdf * math::INV_PI,
                        weight_sum,
                        light_omc,
                        horizon,
                    };
                    #[cfg(feature = "metal")]
                    {
                        prev = Some(vertex);
                    }
                    #[cfg(not(feature = "metal"))]
                    {
                        prev = vertex;
                    }
                    last = NON_DELTA;
                    ray = hit.spawn_on(n, dir);
                }};
            }
            let Some(mat) = scene.materials.get(hit.material as usize) else {
                break;
            };
            match mat.scatter(&hit, ray.dir, stream) {
                Scatter::Emit(le) => {
                    // a light seen in a mirror straight from the camera
                    // (`from`: the camera ray's object) whose image the
                    // highlight estimator samples: left to it
                    #[cfg(feature = "highlight")]
                    if depth == 1
                        && let Some(h) = ctx.highlights
                        && h.covers(from, hit.object)
                    {
                        break;
                    }
                    // emits on the outward side only, reflects nothing
                    if math::lt_zero(ray.dir.dot(hit.normal)) {
                        let w = if last != NON_DELTA {
                            1.0
                        } else {
                            match opts.strategy {
                                Strategy::BsdfOnly => 1.0,
                                Strategy::LightOnly => 0.0,
                                Strategy::Mis => {
                                    let weigh = |prev: &PrevVertex| {
                                        let pl = hit.object.as_sphere().map_or(0.0, |i| {
                                            ctx.light_pdf::<MANY>(prev, &glossy, i, ray.dir)
                                        });
                                        power_heuristic(prev.bsdf_pdf, pl)
                                    };
                                    match &prev {
                                        #[cfg(feature = "metal")]
                                        Some(prev) => weigh(prev),
                                        // not reached: `last` is not NON_DELTA
                                        // before the first non-delta vertex
                                        #[cfg(feature = "metal")]
                                        None => 1.0,
                                        #[cfg(not(feature = "metal"))]
                                        prev => weigh(prev),
                                    }
                                }
                            }
                        };
                        l += thr * le * w;
                    }
                    break;
                }
                Scatter::Bsdf(Bsdf::Lambert(albedo)) => non_delta!(Lambert(albedo)),
                #[cfg(feature = "metal")]
                Scatter::Bsdf(Bsdf::Ggx(m)) => non_delta!(m),
                Scatter::Delta(ds) => {
                    // the first glass vertex seen from the camera (through
                    // any mirrors and glass, before any diffuse or glossy
                    // vertex) continues along both its reflection and its
                    // refraction (the choice just drawn is not used); every
                    // other glass vertex along the one chosen by the Fresnel
                    // reflectance
                    #[cfg(feature = "glass")]
                    let ds = match split_at_glass(mat, &hit, &ray, !no_split) {
                        Some((t, b)) => {
                            no_split = true;
                            pending = Some(Branch {
                                thr: thr * b.thr,
                                rr_scale: rr_scale * b.rr_scale,
                                depth: depth + 1,
                                ..b
                            });
                            t
                        }
                        None => ds,
                    };
                    thr *= ds.weight;
                    rr_scale /= ds.scale;
                    last = last.max(DELTA);
                    ray = hit.spawn(ds.dir);
                    roulette!();
                }
                Scatter::Absorb => break,
            }
            depth += 1;
            spheres = scene.tested;
            // one test per bounce for both the depth roulette and the cap
            if depth >= ctx.plan.deep {
                match deep_roulette(depth, opts, stream, stats) {
                    Some(w) => thr *= w,
                    None => break,
                }
            }
            from = hit.object;
            bounces += 1;
        }
        // the path's other branch, if it split at a glass vertex
        #[cfg(feature = "glass")]
        if let Some(b) = pending.take() {
            ray = b.ray;
            thr = b.thr;
            rr_scale = b.rr_scale;
            depth = b.depth;
            from = b.from;
            last = EYE;
            bounces += 1;
            continue;
        }
        break;
    }
    stats.paths += 1;
    stats.bounce_rays += u64::from(bounces);
    stats.shadow_rays += u64::from(shadows);
    l
}

/// The depth roulette and the cap, for a path at `depth` bounces (at least
/// `deep_start` or `max_depth`): `None` ends the path (counted in
/// `stats.truncated` where the cap ends it), else the survivor's weight
/// `1 / deep_survival`. A path this long may be caught where its
/// throughput never falls (total internal reflection, a mirror box), so it
/// meets a second roulette, independent of the first, on the depth alone.
/// Out of line and cold: almost no path gets here, and one copy serves
/// every variant of the loop.
#[cold]
#[inline(never)]
fn deep_roulette(
    depth: u32,
    opts: &Options,
    stream: &mut SampleStream<'_>,
    stats: &mut Stats,
) -> Option<f32> {
    if depth >= opts.max_depth {
        stats.truncated += 1;
        return None;
    }
    (stream.next_f32() < opts.deep_survival).then_some(1.0 / opts.deep_survival)
}
