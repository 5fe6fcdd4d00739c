//! Unbiased path tracing of the rendering equation
//! `L_o = L_e + ∫ L_i f_r cos θ dω`.
//!
//! Materials are seen only through [`Material::scatter`] (crate::material):
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
//! * BSDF sampling: a direction sampled from the BSDF ([`Bsdf::sample`];
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
//! component)`, [`Options::rr_gain`]), which keeps the estimator unbiased. A hard
//! depth cap ([`Options::max_depth`], default 256) exists only as a guard
//! against endless paths in closed scenes of albedo-1 mirrors, where
//! roulette never fires; in any scene with an albedo below 1 its
//! contribution is below 0.999^253 of a throughput that roulette has already
//! reduced — far beyond any measurable effect. In a box of perfect mirrors it
//! drops the light of paths longer than 256 bounces (documented bias).
//!
//! Each path is an unbiased sample of its pixel. A pixel's mean stays
//! unbiased only if the number of samples it gets does not depend on their
//! values: uniform allocation ([`crate::budget::AdaptiveOptions::adaptive`]
//! false, the CLI's `--uniform`). The default adaptive allocation is biased,
//! and consistent: the bias vanishes as the budget grows ([`crate::budget`]).

use crate::geometry::{Color, Hit, ObjectId, Ray, Vec3};
use crate::light::{self, Window};
use crate::material::{Bsdf, Lambert, Lobe, Material, Scatter};
use crate::math;
use crate::sampler::SampleStream;
use crate::scene::SceneView;

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
    /// Use micromath's approximate trigonometry in direction sampling.
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
    /// Guard against endless paths (see the module docs).
    pub max_depth: u32,
    /// Work skipped because the scene cannot need it.
    pub skip: Skip,
    /// Sample the images of small lights in mirror spheres from the light's
    /// side ([`crate::highlight`]; a pinhole camera, feature `highlight`),
    /// not only by film position: the same expectation, less noise where
    /// such an image is a fraction of a pixel.
    pub highlights: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            strategy: Strategy::Mis,
            stratified: true,
            fast_math: false,
            rr_start: 2,
            rr_gain: 1.5,
            max_depth: 256,
            skip: Skip::ALL,
            highlights: true,
        }
    }
}

/// Work counters of a render: paths and rays by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Path samples (one camera ray each).
    pub paths: u64,
    /// Rays traced for closest hits after the camera ray (and the rays of
    /// [`crate::highlight`]'s samples, which have no path of their own).
    pub bounce_rays: u64,
    /// Shadow rays (occlusion tests toward a light).
    pub shadow_rays: u64,
    /// Samples whose radiance was NaN, infinite or above
    /// [`crate::render::SAMPLE_MAX`] (counted, then dropped).
    pub nonfinite: u64,
    /// Rays that escaped a closed scene: numerical leaks (should be 0).
    pub leaks: u64,
}

impl Stats {
    /// All rays: camera + bounce + shadow.
    pub fn rays(&self) -> u64 {
        self.paths + self.bounce_rays + self.shadow_rays
    }

    /// Adds another set of counters to this one.
    pub fn merge(&mut self, o: &Stats) {
        self.paths += o.paths;
        self.bounce_rays += o.bounce_rays;
        self.shadow_rays += o.shadow_rays;
        self.nonfinite += o.nonfinite;
        self.leaks += o.leaks;
    }
}

/// Power heuristic weight of strategy `a` against `b` (β = 2), written as
/// `1 / (1 + (b/a)²)` so that huge pdfs (tiny lights) cannot overflow.
#[inline(always)]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let r = b / a;
    1.0 / (1.0 + r * r)
}

/// The stratified pair whose first number picks the light at a path's first
/// non-delta vertex.
const SELECT_PAIR: u32 = 4;

/// The uniform number that chooses a light: stratified at a path's first
/// non-delta vertex (`first`), independent elsewhere.
#[inline(always)]
fn selection_number(first: bool, stream: &mut SampleStream<'_>) -> f32 {
    if first {
        stream.stratified_2d(SELECT_PAIR)[0]
    } else {
        stream.next_f32()
    }
}

/// The weight of the choice by radiance × solid angle in the choice of a
/// light at a glossy vertex ([`Ctx::choose_light_glossy`]): every light
/// keeps at least this fraction of the probability it would have at a
/// Lambertian vertex.
const DEFENSIVE: f32 = 0.25;

/// The probability of choosing a light whose radiance × solid angle is `w`
/// and radiance × lobe share is `g`, of sums `sum` and `gsum`.
#[inline(always)]
fn mixed_selection(w: f32, g: f32, sum: f32, gsum: f32) -> f32 {
    if gsum > 0.0 {
        DEFENSIVE * (w / sum) + (1.0 - DEFENSIVE) * (g / gsum)
    } else {
        w / sum
    }
}

/// A light's share of a glossy lobe (`metal::light_share`; none in a
/// build without metal, which chooses no light by it).
#[inline(always)]
fn light_share(alpha: f32, wo: Vec3, n: Vec3, to_c: Vec3, d2: f32, omc: f32) -> f32 {
    #[cfg(feature = "metal")]
    {
        crate::material::metal::light_share(alpha, wo, n, to_c, d2, omc)
    }
    #[cfg(not(feature = "metal"))]
    {
        let _ = (alpha, wo, n, to_c, d2, omc);
        0.0
    }
}

/// Where the last diffuse vertex was, for weighting an emitter that its
/// BSDF sample hits.
#[derive(Clone, Copy)]
struct PrevVertex {
    point: Vec3,
    normal: Vec3,
    bsdf_pdf: f32,
    /// Sum of light-selection weights at that vertex, negated where a
    /// glossy lobe chose the light ([`GlossyChoice`] holds the rest).
    weight_sum: f32,
    /// With one light: its 1 − cos θ_max seen from that vertex, as
    /// next-event estimation computed it (0: it could not be sampled there),
    /// negated where next-event estimation sampled the light's window.
    light_omc: f32,
    /// Whether the horizon test was done there.
    horizon: bool,
}

/// What a glossy vertex's light choice depended on, for the pdf of an
/// emitter its BSDF sample hits. Kept apart from [`PrevVertex`] and
/// written and read only out of line, so that the loop of a scene without
/// metal does no more with it than set it up once per path.
#[derive(Clone, Copy)]
struct GlossyChoice {
    /// The lobe's width.
    alpha: f32,
    /// The direction back along the ray that reached the vertex.
    wo: Vec3,
    /// The sum of the lights' shares of the lobe (radiance × share).
    share_sum: f32,
}

/// A light's weights at a glossy vertex ([`Ctx::glossy_weights`]).
struct GlossyWeights {
    /// From the vertex to the light's centre, and its squared length.
    to_c: Vec3,
    d2: f32,
    /// The light's `1 − cos θ_max` seen from the vertex.
    omc: f32,
    /// Radiance × solid angle, and radiance × its share of the lobe.
    w: f32,
    g: f32,
}

/// The light chosen for next-event estimation at a vertex.
struct LightChoice {
    sphere: usize,
    /// Selection probability.
    p_sel: f32,
    /// From the vertex to the light's centre, and its squared length.
    to_c: Vec3,
    d2: f32,
}

/// What every path of a render decides the same way, from the scene view
/// and the options alone: made once per render ([`PathPlan::new`]; the
/// renderer keeps it) rather than once per path.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathPlan<'a> {
    /// Emitters that next-event estimation samples.
    lights: &'a [u16],
    /// The several-lights variant of the path tracer (or no light at all,
    /// or the `specialize` skip off).
    many: bool,
    /// Zero weight for lights entirely below the horizon of a point of a
    /// plane (the skip is on and the scene analysis found it can happen).
    horizon_planes: bool,
    /// The same for points of spheres.
    horizon_spheres: bool,
    /// The only light, looked up once (scenes with one light).
    one: Option<OneLight<'a>>,
    /// Windows of lights cut by a wall (empty with that skip off).
    windows: &'a [Window],
}

impl<'a> PathPlan<'a> {
    /// The plan of every path through `scene` with `opts`.
    pub(crate) fn new(scene: &SceneView<'a>, opts: &Options) -> Self {
        let skip = &opts.skip;
        let lights = if skip.unreachable_lights {
            scene.lights
        } else {
            scene.emitters
        };
        // no light at all: the general variant, which runs fewer
        // instructions there than the one-light variant (docs/bench.md) and
        // draws the same numbers
        let many = lights.len() != 1 || !skip.specialize;
        let windows: &[Window] = if cfg!(feature = "windows") && skip.windows {
            scene.windows
        } else {
            &[]
        };
        Self {
            lights,
            many,
            horizon_planes: skip.horizon && scene.horizon_planes,
            horizon_spheres: skip.horizon && scene.horizon_spheres,
            one: if many {
                None
            } else {
                OneLight::first(scene, lights, windows)
            },
            windows,
        }
    }
}

/// The scene as one path sees it: the view plus the render's plan.
struct Ctx<'v, 'a> {
    scene: &'v SceneView<'a>,
    plan: &'v PathPlan<'a>,
    /// The (mirror, light) pairs whose emission right after the camera's
    /// mirror [`crate::highlight`] estimates instead.
    #[cfg(feature = "highlight")]
    highlights: Option<&'v crate::highlight::Highlights>,
}

/// What next-event estimation needs of a scene's only light.
#[derive(Clone, Copy, Debug)]
struct OneLight<'a> {
    sphere: usize,
    center: Vec3,
    radius: f32,
    radius2: f32,
    le: Color,
    window: Option<&'a Window>,
}

impl<'a> OneLight<'a> {
    /// The first of `lights`, if it is an emitting sphere.
    #[inline(always)]
    fn first(scene: &SceneView<'_>, lights: &[u16], windows: &'a [Window]) -> Option<Self> {
        let i = *lights.first()? as usize;
        let s = scene.spheres.get(i)?;
        let le = scene.materials.get(s.material as usize)?.emission()?;
        Some(Self {
            sphere: i,
            center: s.center,
            radius: s.radius,
            radius2: s.radius2,
            le,
            window: window_of(windows, i),
        })
    }
}

impl<'a> Ctx<'_, 'a> {
    /// The windows in force. Without the `windows` feature none, as a
    /// constant: such a build has no window code.
    #[inline(always)]
    fn windows(&self) -> &'a [Window] {
        if cfg!(feature = "windows") {
            self.plan.windows
        } else {
            &[]
        }
    }

    /// The only light's window (see [`Ctx::windows`]).
    #[inline(always)]
    fn window_of_one(one: &OneLight<'a>) -> Option<&'a Window> {
        if cfg!(feature = "windows") {
            one.window
        } else {
            None
        }
    }

    fn light_lum(&self, sphere: usize) -> f32 {
        let s = &self.scene;
        s.spheres
            .get(sphere)
            .and_then(|x| s.materials.get(x.material as usize))
            .and_then(Material::emission)
            .map_or(0.0, |le| le.luminance())
    }

    /// Whether the horizon test is worth doing on `object`.
    #[inline(always)]
    fn horizon_at(&self, object: ObjectId) -> bool {
        if object.as_sphere().is_some() {
            self.plan.horizon_spheres
        } else {
            self.plan.horizon_planes
        }
    }

    /// Whether light sphere `i` can be sampled from `x` with normal `n`:
    /// `x` outside it and (with `horizon`) not all of it below the
    /// tangent plane, `n · (c − x) < −r`.
    /// Returns the vector to the centre, its squared length and the
    /// squared radius.
    #[inline(always)]
    fn samplable(&self, x: Vec3, n: Vec3, i: usize, horizon: bool) -> Option<(Vec3, f32, f32)> {
        let s = self.scene.spheres.get(i)?;
        let to_c = s.center - x;
        let d2 = to_c.length_squared();
        if !(d2 > s.radius2) || (horizon && n.dot(to_c) < -s.radius) {
            return None;
        }
        Some((to_c, d2, s.radius2))
    }

    /// Light-selection weight of light `i` at (`x`, `n`): luminance ×
    /// (1 − cos θ_max), i.e. radiance × subtended solid angle; 0 where it
    /// cannot be sampled.
    #[inline]
    fn light_weight(&self, x: Vec3, n: Vec3, i: usize, horizon: bool) -> f32 {
        self.samplable(x, n, i, horizon).map_or(0.0, |(_, d2, r2)| {
            self.light_lum(i) * light::one_minus_cos_max(r2, d2)
        })
    }

    /// Picks a light for next-event estimation at `x` by one uniform number
    /// from `stream` (the several-lights variant; with one light the
    /// integrator uses [`OneLight`] and selects nothing); returns the choice
    /// and the weight sum (needed later for MIS).
    #[inline]
    fn choose_light(
        &self,
        x: Vec3,
        n: Vec3,
        horizon: bool,
        first: bool,
        stream: &mut SampleStream<'_>,
    ) -> (Option<LightChoice>, f32) {
        let u = selection_number(first, stream);
        let mut sum = 0.0;
        for &l in self.plan.lights {
            sum += self.light_weight(x, n, l as usize, horizon);
        }
        if !(sum > 0.0) {
            return (None, 0.0);
        }
        let target = u * sum;
        let mut acc = 0.0;
        let mut chosen = None;
        for &l in self.plan.lights {
            let i = l as usize;
            let Some((to_c, d2, r2)) = self.samplable(x, n, i, horizon) else {
                continue;
            };
            let w = self.light_lum(i) * light::one_minus_cos_max(r2, d2);
            if w > 0.0 {
                acc += w;
                chosen = Some(LightChoice {
                    sphere: i,
                    p_sel: w / sum,
                    to_c,
                    d2,
                });
                if target < acc {
                    break;
                }
            }
        }
        (chosen, sum)
    }

    /// Light `i`'s two weights at a glossy vertex (`x`, `n`, lobe `alpha`
    /// seen from `wo`), or `None` where it cannot be sampled: the one
    /// computation behind both the choice ([`Ctx::choose_light_glossy`])
    /// and its pdf ([`Ctx::glossy_light_pdf`]), so that they agree bit for
    /// bit.
    #[inline(always)]
    fn glossy_weights(
        &self,
        x: Vec3,
        n: Vec3,
        i: usize,
        horizon: bool,
        alpha: f32,
        wo: Vec3,
    ) -> Option<GlossyWeights> {
        let (to_c, d2, r2) = self.samplable(x, n, i, horizon)?;
        let lum = self.light_lum(i);
        let omc = light::one_minus_cos_max(r2, d2);
        Some(GlossyWeights {
            to_c,
            d2,
            omc,
            w: lum * omc,
            g: lum * light_share(alpha, wo, n, to_c, d2, omc),
        })
    }

    /// [`Ctx::choose_light`] at a vertex of a glossy lobe of width `alpha`
    /// ([`Lobe::selective_alpha`]): each light's probability mixes its
    /// share of radiance × solid angle (weight [`DEFENSIVE`]) with its
    /// share of radiance × its part of the lobe (`metal::light_share`), so
    /// that the light in the lobe is sampled most and no light that can
    /// contribute is left out. Returns the choice and the sum of radiance ×
    /// solid angle, and keeps the rest in `glossy` (for [`Ctx::light_pdf`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn choose_light_glossy(
        &self,
        x: Vec3,
        n: Vec3,
        horizon: bool,
        first: bool,
        stream: &mut SampleStream<'_>,
        alpha: f32,
        wo: Vec3,
        glossy: &mut GlossyChoice,
    ) -> (Option<LightChoice>, f32) {
        let u = selection_number(first, stream);
        let (mut sum, mut gsum) = (0.0, 0.0);
        for &l in self.plan.lights {
            if let Some(gw) = self.glossy_weights(x, n, l as usize, horizon, alpha, wo) {
                sum += gw.w;
                gsum += gw.g;
            }
        }
        if !(sum > 0.0) {
            return (None, 0.0);
        }
        *glossy = GlossyChoice {
            alpha,
            wo,
            share_sum: gsum,
        };
        let mut acc = 0.0;
        let mut chosen = None;
        for &l in self.plan.lights {
            let i = l as usize;
            let Some(gw) = self.glossy_weights(x, n, i, horizon, alpha, wo) else {
                continue;
            };
            if gw.w > 0.0 {
                let p_sel = mixed_selection(gw.w, gw.g, sum, gsum);
                acc += p_sel;
                chosen = Some(LightChoice {
                    sphere: i,
                    p_sel,
                    to_c: gw.to_c,
                    d2: gw.d2,
                });
                if u < acc {
                    break;
                }
            }
        }
        (chosen, sum)
    }

    /// [`Ctx::light_pdf`] where [`Ctx::choose_light_glossy`] chose the light
    /// at `prev`: the same operands, the same bits. Out of line, so that the
    /// loop of a scene without metal keeps its registers.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn glossy_light_pdf(
        &self,
        point: Vec3,
        normal: Vec3,
        horizon: bool,
        sum: f32,
        glossy: &GlossyChoice,
        i: usize,
        dir: Vec3,
    ) -> f32 {
        let Some(gw) = self.glossy_weights(point, normal, i, horizon, glossy.alpha, glossy.wo)
        else {
            return 0.0;
        };
        let p_sel = mixed_selection(gw.w, gw.g, sum, glossy.share_sum);
        match window_of(self.windows(), i) {
            Some(win) if win.covers(point) => p_sel * win.pdf(point, dir),
            _ => p_sel / (math::TWO_PI * gw.omc),
        }
    }

    /// Solid-angle pdf with which next-event estimation at `prev` would have
    /// produced a direction toward light sphere `i` (selection included).
    #[inline]
    fn light_pdf<const MANY: bool>(
        &self,
        prev: &PrevVertex,
        glossy: &GlossyChoice,
        i: usize,
        dir: Vec3,
    ) -> f32 {
        if !MANY {
            // bit for bit the pdf from the point and normal: the same
            // one_minus_cos_max of the same operands, or the same window
            return match &self.plan.one {
                Some(one) if one.sphere == i && prev.light_omc > 0.0 => {
                    1.0 / (math::TWO_PI * prev.light_omc)
                }
                Some(one) if one.sphere == i && prev.light_omc < 0.0 => {
                    Self::window_of_one(one).map_or(0.0, |w| w.pdf(prev.point, dir))
                }
                _ => 0.0,
            };
        }
        if !self.plan.lights.contains(&(i as u16)) {
            return 0.0;
        }
        if cfg!(feature = "metal") && prev.weight_sum < 0.0 {
            return self.glossy_light_pdf(
                prev.point,
                prev.normal,
                prev.horizon,
                -prev.weight_sum,
                glossy,
                i,
                dir,
            );
        }
        let Some((_, d2, r2)) = self.samplable(prev.point, prev.normal, i, prev.horizon) else {
            return 0.0;
        };
        if let Some(w) = window_of(self.windows(), i)
            && w.covers(prev.point)
        {
            if !(prev.weight_sum > 0.0) {
                return 0.0;
            }
            let p_sel = self.light_lum(i) * light::one_minus_cos_max(r2, d2) / prev.weight_sum;
            return p_sel * w.pdf(prev.point, dir);
        }
        if prev.weight_sum > 0.0 {
            // p_sel · pdf_cone = (lum · omc / W) · 1 / (2π omc)
            self.light_lum(i) / (math::TWO_PI * prev.weight_sum)
        } else {
            0.0
        }
    }
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
    radiance_planned(
        scene,
        &PathPlan::new(scene, opts),
        #[cfg(feature = "highlight")]
        None,
        ray,
        stream,
        opts,
        stats,
    )
}

/// [`radiance`] with the decisions of `plan`, which must be
/// `PathPlan::new(scene, opts)`, leaving out the emission that a camera ray
/// meets right after a mirror for the pairs of `highlights`.
#[inline(always)]
pub(crate) fn radiance_planned(
    scene: &SceneView<'_>,
    plan: &PathPlan<'_>,
    #[cfg(feature = "highlight")] highlights: Option<&crate::highlight::Highlights>,
    ray: Ray,
    stream: &mut SampleStream<'_>,
    opts: &Options,
    stats: &mut Stats,
) -> Color {
    let ctx = Ctx {
        scene,
        plan,
        #[cfg(feature = "highlight")]
        highlights,
    };
    // the queries are compiled with and without the tree, so that a scene
    // without one (a firmware for a small scene has no tree code at all)
    // tests nothing about it per ray. (Tested here on the view, not kept in
    // the plan: so the tree's variants know that the view has a tree, and
    // hold no list query for the case without one.)
    let tree = !cfg!(micropt_no_bvh) && scene.bvh.is_some();
    match (plan.many, tree) {
        (true, false) => trace::<true, false>(&ctx, ray, stream, opts, stats),
        (false, false) => trace::<false, false>(&ctx, ray, stream, opts, stats),
        (true, true) => trace::<true, true>(&ctx, ray, stream, opts, stats),
        (false, true) => trace::<false, true>(&ctx, ray, stream, opts, stats),
    }
}

/// The path tracer, compiled for scenes with several lights (`MANY`) or
/// with one, and for rays that find their spheres through the scene's tree
/// (`TREE`) or its lists.
#[inline(always)]
fn trace<const MANY: bool, const TREE: bool>(
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
    // one pass per branch: without glass, exactly one
    #[cfg_attr(not(feature = "glass"), allow(clippy::never_loop))]
    loop {
        loop {
            // one inlined query for every ray, with the camera ray's sphere
            // list when culling (a camera ray leaves no object)
            let spheres = if depth == 0 && opts.skip.view_culling {
                scene.tested_primary
            } else {
                scene.tested
            };
            let found = if opts.skip.slabs {
                scene.closest_hit_in::<TREE>(&ray, from, spheres)
            } else {
                scene.closest_hit_any_among(&ray, from, spheres)
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
                    let n = if ray.dir.dot(hit.normal) < 0.0 {
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
                        // light below the horizon never shifts the random numbers
                        let u = if last == EYE {
                            stream.stratified_2d(2)
                        } else {
                            stream.next_2d()
                        };
                        let f = thr * lobe.tint();
                        if MANY {
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
                            if d2 > one.radius2 && !(horizon && n.dot(to_c) < -one.radius) {
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
                    let Some(bs) = lobe.sample(wo, n, u, opts.fast_math) else {
                        break;
                    };
                    let vertex = PrevVertex {
                        point: hit.point,
                        normal: n,
                        bsdf_pdf: bs.pi_pdf * math::INV_PI,
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
                    // f · cos / pdf (the Lambertian's: its albedo, exactly)
                    thr *= bs.weight;
                    last = NON_DELTA;
                    ray = hit.spawn_on(n, bs.dir);
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
                    if ray.dir.dot(hit.normal) < 0.0 {
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
                }
                Scatter::Absorb => break,
            }
            depth += 1;
            if depth >= opts.rr_start {
                let p = thr.max_component() * rr_scale * opts.rr_gain;
                if p < 1.0 {
                    if !(stream.next_f32() < p) {
                        break;
                    }
                    thr *= 1.0 / p;
                }
            }
            if depth >= opts.max_depth {
                break;
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

/// The branch of a path that waits while the other is traced: its ray,
/// throughput, roulette scale, depth and the object it leaves.
#[cfg(feature = "glass")]
struct Branch {
    ray: Ray,
    thr: Color,
    rr_scale: f32,
    depth: u32,
    from: ObjectId,
}

/// Splitting at a glass vertex (`split`: the path may split here): the
/// refraction, weighted by `1 − R`, for the path to continue with, and the
/// reflection, weighted by `R` (in `thr`, a factor of the path's
/// throughput; `rr_scale`, a factor of its roulette scale, undoes it), for
/// it to trace after. Russian roulette leaves both weights out, so each
/// branch survives as the unsplit path would have. `None` where the path may not split,
/// the material is not glass, or one continuation carries everything.
///
/// Choosing one of the two by the reflectance is what a glass vertex does
/// elsewhere; it adds variance where the two see very different radiance
/// (the sun reflected in a glass ball against the scene seen through it).
/// Tracing both once per path removes that variance at the vertex the
/// camera sees, for at most one extra branch per path.
#[cfg(feature = "glass")]
#[inline(always)]
fn split_at_glass(
    mat: &Material,
    hit: &Hit,
    ray: &Ray,
    split: bool,
) -> Option<(crate::material::DeltaSample, Branch)> {
    if !split {
        return None;
    }
    let Material::Glass(ior) = *mat else {
        return None;
    };
    split_glass(ior, hit, ray)
}

/// The two continuations of [`split_at_glass`]. Out of line on a board
/// (no OS): it runs at most once per path, and each path variant of the
/// tracer held a copy of it in the flash.
#[cfg(feature = "glass")]
#[cfg_attr(target_os = "none", inline(never))]
#[cfg_attr(not(target_os = "none"), inline(always))]
fn split_glass(ior: f32, hit: &Hit, ray: &Ray) -> Option<(crate::material::DeltaSample, Branch)> {
    let (r_dir, r, t_dir, scale) = crate::material::split_dielectric(ray.dir, hit.normal, ior)?;
    Some((
        crate::material::DeltaSample {
            dir: t_dir,
            weight: Color::splat((1.0 - r) * scale),
            // roulette leaves the split's weight out with the scaling, so
            // that it treats each branch as the path that chose it
            scale: (1.0 - r) * scale,
        },
        Branch {
            ray: hit.spawn(r_dir),
            thr: Color::splat(r),
            rr_scale: 1.0 / r,
            depth: 0,
            from: hit.object,
        },
    ))
}

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
fn direct<const TREE: bool, B: Lobe>(
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
fn direct_window<const TREE: bool, B: Lobe>(
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
fn nee<const MANY: bool, const TREE: bool, B: Lobe>(
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
    if !(cos > 0.0) {
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
        scene.occluded_by_any(&shadow, ls.dist, hit.object, target)
    };
    if blocked {
        return Color::ZERO;
    }
    let (s, pi_pdf) = lobe.eval(wo, n, ls.dir, cos);
    let a = 2.0 * pi_pdf * ls.omc_max;
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
fn nee_window<const MANY: bool, const TREE: bool, B: Lobe>(
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
fn window_sample<const TREE: bool>(
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
fn mis_weight(a: f32, opts: &Options) -> f32 {
    match opts.strategy {
        // a/(1 + a²) = 1/(a + 1/a): the second form where a² would overflow
        Strategy::Mis if a > 1.0e18 => 1.0 / a,
        Strategy::Mis => a / (1.0 + a * a),
        _ => a,
    }
}

/// The window of light sphere `i`, if a wall cuts it.
#[inline(always)]
fn window_of(windows: &[Window], i: usize) -> Option<&Window> {
    windows.iter().find(|w| w.light as usize == i)
}
