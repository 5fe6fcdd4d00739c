//! Unbiased path tracing of the rendering equation
//! `L_o = L_e + ∫ L_i f_r cos θ dω`.
//!
//! Materials are seen only through [`Material::scatter`](crate::material::Material::scatter):
//! an emitter, a Dirac delta, or a non-delta BSDF. At every non-delta vertex
//! (Lambertian, checker, rough metal) the estimator combines two strategies
//! by multiple importance sampling with the power heuristic (Veach 1997):
//!
//! * next-event estimation: one emitter is chosen (with probability
//!   proportional to its radiance times the solid angle it subtends, zero for
//!   emitters entirely below the surface's horizon; at a glossy vertex mixed
//!   with its radiance times its share of the lobe, so that the light the
//!   lobe sees is sampled most), a direction is sampled uniformly in its
//!   cone, and a shadow ray tests visibility;
//! * BSDF sampling: a direction sampled from the BSDF ([`Bsdf::sample`](crate::material::Bsdf::sample);
//!   the Lambertian's cosine-distributed) continues the path; if it hits an
//!   emitter, the emission is weighted against the light-sampling pdf of
//!   that direction.
//!
//! Mirror and glass vertices are Dirac deltas: emitters seen through them get
//! full weight. A glass vertex chooses reflection or refraction with
//! probability equal to the Fresnel reflectance, except the first glass
//! vertex of a path before any non-delta vertex (the glass the camera sees,
//! through any mirrors): there the path splits and traces both, weighted by
//! the reflectance and the transmittance, the reflection after the
//! refraction's branch ends. That removes the variance of the choice where
//! the two continuations see very different radiance (a small bright light
//! reflected in a glass ball against the scene seen through it), for at
//! most one extra branch per path. The first non-delta vertex of a path (wherever mirrors and
//! glass put it) takes its bounce, its light choice and its light sample
//! from the pixel's stratified pairs; later vertices use independent
//! numbers. Paths end by Russian roulette on the throughput after
//! [`Options::rr_start`] bounces (survival `min(1, rr_gain × max
//! component)`, [`Options::rr_gain`]), which keeps the estimator unbiased.
//! Roulette on the throughput alone never ends a path whose throughput
//! does not fall: one caught in total internal reflection inside glass, or
//! in a closed box of albedo-1 mirrors. So from [`Options::deep_start`]
//! bounces on, a second, independent roulette on the depth alone keeps a
//! path with probability [`Options::deep_survival`] per bounce (and divides
//! the survivors' throughput by it): every path ends with probability 1
//! and the estimate stays unbiased. The hard depth cap
//! ([`Options::max_depth`]) is only a safety net behind it: with the
//! defaults a path reaches it with probability below 1e-13. The
//! paths it still ends are counted ([`Stats::truncated`]).
//!
//! Each path is an unbiased sample of its pixel. A pixel's mean stays
//! unbiased only if the number of samples it gets does not depend on their
//! values: uniform allocation ([`crate::budget::AdaptiveOptions::adaptive`]
//! false, the CLI's `--uniform`). The default adaptive allocation is biased,
//! and consistent: the bias vanishes as the budget grows ([`crate::budget`]).

mod choice;
mod nee;
mod path;
mod plan;
#[cfg(feature = "glass")]
mod split;

pub use crate::stats::Stats;
pub(crate) use plan::PathPlan;

use crate::geometry::{Color, Ray};
use crate::sampler::SampleStream;
use crate::scene::SceneView;
use path::trace;
use plan::Ctx;

/// A path's estimate of the radiance along its camera ray, and the part
/// of it that no non-delta vertex scattered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSum {
    /// The estimate of `L` along the camera ray.
    pub total: Color,
    /// The part of `total` that emitters (and the background) give straight
    /// to the camera or through mirrors and glass only: a light seen
    /// directly, its image in a mirror ball or through a glass ball; and
    /// the focused caustics sampled through a glass ball
    /// ([`crate::caustic::CausticSample::focused`]). A denoiser
    /// keeps it out of its filter (it is sharp, and most of it has little
    /// noise); callers that do not split the estimate ignore it, and the
    /// compiler drops its arithmetic.
    pub direct: Color,
    /// Whether the camera ray itself hit a light's outside (`total` is its
    /// `L_e`): counted by the denoiser ([`crate::denoise::SeenLights`]).
    pub seen: bool,
}

/// Which strategies estimate direct lighting at diffuse vertices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Light sampling and BSDF sampling, combined by MIS (power heuristic).
    Mis,
    /// BSDF sampling only: emitters are found only by hitting them.
    BsdfOnly,
    /// Light sampling only: emitters hit after a diffuse bounce are ignored.
    LightOnly,
}

/// Which work the integrator skips because the scene analysis
/// ([`crate::analysis`]) proved it unneeded. Every switch is on by default;
/// turning one off exists to measure what it saves and to test that the
/// image does not change: bit for bit, except `specialize`, `horizon` with
/// several lights (the lights below the horizon no longer share the
/// selection probabilities, so one random number picks another light),
/// `unreachable_lights` with an unreachable light, and `windows`, which
/// change the random numbers drawn or the estimator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Skip {
    /// Shadow rays test only objects that can lie between a point and a light.
    pub shadow_occluders: bool,
    /// Camera rays test only spheres that can be in view.
    pub view_culling: bool,
    /// Run the integrator compiled without light selection for a scene with
    /// one light.
    pub specialize: bool,
    /// Lights entirely below a surface's horizon are not sampled there.
    pub horizon: bool,
    /// Lights that no path can reach are never sampled.
    pub unreachable_lights: bool,
    /// A closed scene never looks up the background.
    pub closed: bool,
    /// Walls (opaque axis-aligned planes) are tested one per axis
    /// ([`crate::analysis::Slabs`]).
    pub slabs: bool,
    /// Rays find their spheres through the scene's bounding volume
    /// hierarchy, when the analysis gave it one ([`crate::scene::bvh`]).
    pub bvh: bool,
    /// A light that an opaque wall cuts is sampled through its window
    /// ([`crate::light::Window`]), not over the part the wall hides.
    pub windows: bool,
    /// Where a Lambertian point sees the one light whole (all of it above
    /// the point's horizon, no occluder near the way to it), its direct
    /// light is the closed form: no light sample and no shadow ray (the
    /// same expectation, and no noise from that light there).
    pub whole_light: bool,
}

impl Skip {
    /// Every skip on (the default).
    pub const ALL: Self = Self {
        shadow_occluders: true,
        view_culling: true,
        specialize: true,
        horizon: true,
        unreachable_lights: true,
        closed: true,
        slabs: true,
        bvh: true,
        windows: true,
        whole_light: true,
    };
    /// No skip: the integrator does all the work a general scene needs.
    pub const NONE: Self = Self {
        shadow_occluders: false,
        view_culling: false,
        specialize: false,
        horizon: false,
        unreachable_lights: false,
        closed: false,
        slabs: false,
        bvh: false,
        windows: false,
        whole_light: false,
    };
}

impl Default for Skip {
    fn default() -> Self {
        Self::ALL
    }
}

/// Integrator settings. [`Options::default`] is what every image uses unless
/// a benchmark compares variants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Direct-lighting strategy.
    pub strategy: Strategy,
    /// Stratified (Owen-scrambled Sobol) samples for the pixel position and,
    /// at a path's first non-delta vertex, its bounce, its light choice and
    /// its light sample; independent random numbers otherwise.
    pub stratified: bool,
    /// Use micromath's approximate trigonometry in direction sampling (in a
    /// build with the `fast-math` feature; without it, ignored).
    pub fast_math: bool,
    /// Bounces before Russian roulette starts.
    pub rr_start: u32,
    /// Russian roulette keeps a path with probability
    /// `min(1, rr_gain × max throughput component)` (and divides the
    /// throughput by it). 1 is the textbook choice; with 1.5 a path runs on
    /// surely until its throughput falls below 2/3, which spends fewer
    /// roulette draws on bright paths and gave the best efficiency
    /// 1/(MSE × time) of the settings compared (docs/bench.md, "Russian
    /// roulette").
    pub rr_gain: f32,
    /// Bounces from which a second Russian roulette, on the depth alone,
    /// ends a path with probability `1 − deep_survival` per bounce, whatever
    /// its throughput (see the module docs).
    pub deep_start: u32,
    /// The probability that a path survives the depth roulette at each
    /// bounce from [`Options::deep_start`] on. Close to 1, so that the weight of a long path that finds light
    /// (`1 / deep_survival` per bounce) grows slowly: the estimate's
    /// variance stays finite wherever a path finds light more often than
    /// once in `1 / (1 − deep_survival)` bounces.
    pub deep_survival: f32,
    /// Hard cap on a path's bounces: a safety net behind the depth roulette
    /// that ends, biased, the rare path still alive after it
    /// ([`Stats::truncated`] counts them).
    pub max_depth: u32,
    /// Work skipped because the scene cannot need it.
    pub skip: Skip,
    /// Sample the images of small lights in mirror spheres from the light's
    /// side ([`crate::highlight`]; a pinhole camera, feature `highlight`),
    /// not only by film position: the same expectation, less noise where
    /// such an image is a fraction of a pixel.
    pub highlights: bool,
    /// Sample the light that reaches a path's first non-delta vertex
    /// through one mirror or glass sphere by a sample through the sphere
    /// ([`crate::caustic`]; feature `highlight`), not only by the BSDF
    /// sample: the same expectation, less noise where a small light's
    /// image in a mirror or glass ball lights a surface.
    pub caustics: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            strategy: Strategy::Mis,
            stratified: true,
            fast_math: false,
            rr_start: 2,
            rr_gain: 1.5,
            deep_start: 256,
            deep_survival: 1.0 - 1.0 / 1024.0,
            max_depth: 32768,
            skip: Skip::ALL,
            highlights: true,
            caustics: true,
        }
    }
}

impl Options {
    /// The options a render runs with: these, in a build with the
    /// `tunable` feature; without it, [`Options::default`]'s strategy,
    /// stratification, fast math and skips, with these roulette settings,
    /// depth cap and `highlights` (a lean build's integrator has those
    /// choices compiled in as constants). [`Renderer::options`] keeps the
    /// effective options, so [`Renderer::get_options`] tells what a render
    /// uses.
    ///
    /// [`Renderer::options`]: crate::Renderer::options
    /// [`Renderer::get_options`]: crate::Renderer::get_options
    pub fn effective(self) -> Self {
        if cfg!(feature = "tunable") {
            self
        } else {
            let d = Self::default();
            Self {
                strategy: d.strategy,
                stratified: d.stratified,
                fast_math: d.fast_math,
                skip: d.skip,
                ..self
            }
        }
    }
}

/// Power heuristic weight of strategy `a` against `b` (β = 2), written as
/// `1 / (1 + (b/a)²)` so that huge pdfs (tiny lights) cannot overflow.
#[inline(always)]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let r = b / a;
    1.0 / (1.0 + r * r)
}

/// Estimates the radiance arriving along the camera ray `ray` with one path.
///
/// Pure function of its inputs: the same stream gives the same bits. The
/// integrator is compiled in two variants, for one light (no light
/// selection) or several, and with and without the tree's queries, chosen
/// once per path. Every variant holds every material this build has: a
/// scene without mirrors, glass or metal never enters their code, and one
/// copy of the loop per variant keeps the firmware small. (A renderer makes
/// what this decides from `scene` and `opts` once per render, not once per
/// path.)
#[inline(always)]
pub fn radiance(
    scene: &SceneView<'_>,
    ray: Ray,
    stream: &mut SampleStream<'_>,
    opts: &Options,
    stats: &mut Stats,
) -> Color {
    let opts = &opts.effective();
    radiance_planned(
        scene,
        &PathPlan::new(scene, opts),
        #[cfg(feature = "highlight")]
        None,
        #[cfg(feature = "highlight")]
        &[],
        ray,
        stream,
        opts,
        stats,
    )
    .total
}

/// [`radiance`] with the decisions of `plan`, which must be
/// `PathPlan::new(scene, opts)`, leaving out the emission that a camera ray
/// meets right after a mirror for the pairs of `highlights`; the estimate
/// with its direct part ([`PathSum`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn radiance_planned(
    scene: &SceneView<'_>,
    plan: &PathPlan<'_>,
    #[cfg(feature = "highlight")] highlights: Option<&crate::highlight::Highlights>,
    #[cfg(feature = "highlight")] caustics: &[u16],
    ray: Ray,
    stream: &mut SampleStream<'_>,
    opts: &Options,
    stats: &mut Stats,
) -> PathSum {
    let ctx = Ctx {
        scene,
        plan,
        #[cfg(feature = "highlight")]
        highlights,
        #[cfg(feature = "highlight")]
        caustics,
    };
    // the queries are compiled with and without the tree, so that a scene
    // without one (a firmware for a small scene has no tree code at all)
    // tests nothing about it per ray. (Tested here on the view, not kept in
    // the plan: so the tree's variants know that the view has a tree, and
    // hold no list query for the case without one.)
    let tree = !cfg!(micropt_no_bvh) && scene.bvh.is_some();
    // a firmware for one light has no several-lights variant
    let many = !cfg!(micropt_one_light) && plan.many;
    // without run-time variants, the switches as constants: the integrator
    // then holds no code for the others
    #[cfg(not(feature = "tunable"))]
    let fixed = opts.effective();
    #[cfg(not(feature = "tunable"))]
    let opts = &fixed;
    match (many, tree) {
        (true, false) => trace::<true, false>(&ctx, ray, stream, opts, stats),
        (false, false) => trace::<false, false>(&ctx, ray, stream, opts, stats),
        (true, true) => trace::<true, true>(&ctx, ray, stream, opts, stats),
        (false, true) => trace::<false, true>(&ctx, ray, stream, opts, stats),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effective_options_keep_the_switches_only_when_tunable() {
        let asked = Options {
            strategy: Strategy::BsdfOnly,
            stratified: false,
            fast_math: true,
            skip: Skip::NONE,
            rr_gain: 2.0,
            max_depth: 7,
            highlights: false,
            ..Options::default()
        };
        let got = asked.effective();
        if cfg!(feature = "tunable") {
            assert_eq!(got, asked);
        } else {
            let d = Options::default();
            assert_eq!(
                (got.strategy, got.stratified, got.fast_math, got.skip),
                (d.strategy, d.stratified, d.fast_math, d.skip)
            );
            // the rest as asked
            assert_eq!(
                (got.rr_gain, got.max_depth, got.highlights),
                (2.0, 7, false)
            );
        }
    }
}
