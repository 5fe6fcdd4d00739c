//! The path loop: one path from the camera, vertex by vertex, as a short
//! loop over [`PathState`] whose steps each compute one term of the
//! estimator:
//!
//! 1. [`PathState::closest_hit`]: the next vertex, or
//!    [`PathState::escape`], the background radiance `L_e` of a ray that
//!    leaves the scene;
//! 2. the material's scatter at the vertex, one of
//!    - [`PathState::emission`]: `L_e` of an emitter the path hits,
//!      weighted by multiple importance sampling against next-event
//!      estimation at the vertex before;
//!    - [`PathState::non_delta`]: a Lambertian, checker or rough-metal
//!      vertex: [`PathState::direct_light`] (next-event estimation of
//!      `∫ L_e f_r cos θ dω` over the lights) and [`PathState::bsdf_sample`]
//!      (the direction that continues the path, so the rest of
//!      `∫ L_i f_r cos θ dω`);
//!    - [`PathState::delta`]: a mirror or glass vertex, its one direction
//!      (or both, where a path splits at its first glass vertex);
//! 3. [`PathState::roulette`] and [`PathState::advance`]: Russian roulette
//!    on the throughput and, deep in a path, on the depth;
//! 4. [`PathState::resume_split`]: the other branch of a split path.
//!
//! Every step is `#[inline(always)]` (but [`PathState::direct_many`] on
//! cores without an FPU, where inlining it cost 10 KB of flash): the loop
//! is one function per variant of the tracer (several lights or one, tree
//! or lists), and the compiler keeps [`PathState`] in registers. That holds
//! only while no out-of-line call takes the address of one of its fields:
//! a call given `&self.ray` put the whole state in memory, zeroed on every
//! path (cornell on a Cortex-M4F: 2,692 instructions a path instead of
//! 2,488). So the out-of-line query gets a copy of the ray, and
//! `Sphere::origin_power` its point in registers.

use super::choice::{GlossyChoice, LightChoice};
use super::nee::{direct, direct_window, nee, nee_window, whole_light};
use super::plan::{Ctx, OneLight, PrevVertex, window_of};
#[cfg(feature = "glass")]
use super::split::{Branch, split_at_glass};
use super::{Options, PathSum, Strategy, power_heuristic};
use crate::analysis::Listed;
#[cfg(feature = "highlight")]
use crate::caustic::{self, CausticSample, ROOTS};
use crate::geometry::{Color, Hit, ObjectId, Ray, Vec3};
use crate::material::diffuse::sample_cosine;
use crate::material::{Bsdf, DeltaSample, Lambert, Lobe, Material, Scatter};
use crate::math;
use crate::sampler::SampleStream;
use crate::scene::SceneView;
use crate::stats::Stats;

/// The path tracer, compiled for scenes with several lights (`MANY`) or
/// with one, and for rays that find their spheres through the scene's tree
/// (`TREE`) or its lists: the radiance arriving along the camera ray `ray`,
/// estimated by one path (and, where it splits at glass, its second
/// branch).
#[inline(always)]
pub(super) fn trace<const MANY: bool, const TREE: bool>(
    ctx: &Ctx<'_, '_>,
    ray: Ray,
    stream: &mut SampleStream<'_>,
    opts: &Options,
    stats: &mut Stats,
) -> PathSum {
    let mut path = PathState::new(ctx.scene, ray, opts);
    loop {
        while path.vertex::<MANY, TREE>(ctx, stream, opts, stats) {}
        if !path.resume_split() {
            break;
        }
    }
    path.finish(stats)
}

/// [`PathState::caustic`]: no caustic pair applies.
#[cfg(feature = "highlight")]
const CAUSTIC_NONE: u16 = u16::MAX;
/// [`PathState::caustic`]: the path left its first non-delta vertex, where
/// the caustics were sampled.
#[cfg(feature = "highlight")]
const CAUSTIC_ARMED: u16 = u16::MAX - 1;
/// [`PathState::caustic`]: this bit and a glass sphere's index: the path
/// has refracted into it from the first non-delta vertex.
#[cfg(feature = "highlight")]
const CAUSTIC_INSIDE: u16 = 0x8000;

/// The caustic sample's paths at a first non-delta vertex: the sum of
/// their `f cos θ · tint · L_e / (density · share)` and the rays traced.
/// Out of line and given no field of the path's state: its frame, with
/// room for a glass ball's three paths, is on the stack only where a
/// vertex samples it (inlined into the path loop it overflowed a 16 KiB
/// Cortex-M0's RAM on gloss.scene, which has no caustic sphere), and the
/// path's state stays in registers (see the module docs).
#[cfg(feature = "highlight")]
#[inline(never)]
fn caustic_paths<B: Lobe>(
    ctx: &Ctx<'_, '_>,
    at: &Vertex<'_>,
    lobe: &B,
    u0: f32,
    u: [f32; 2],
) -> (Color, Color, u32) {
    let mut out = [CausticSample::NONE; ROOTS];
    let mut rays = 0;
    let found = caustic::sample(
        ctx.scene,
        ctx.caustics,
        at.hit,
        at.n,
        u0,
        u,
        &mut rays,
        &mut out,
    );
    let (mut sum, mut focused) = (Color::ZERO, Color::ZERO);
    for cs in out.iter().take(found) {
        let cos_i = at.n.dot(cs.wi);
        let (s, pi_pdf) = lobe.eval(at.wo, at.n, cs.wi, cos_i);
        // f cos θ = tint · s · pdf
        let mut c = lobe.tint() * cs.value * (s * pi_pdf * (math::INV_PI / caustic::SHARE));
        // a fold's path, shared with the BSDF sample (balance heuristic)
        if cs.fold_pdf > 0.0 {
            c *= caustic::fold_weight(cs.fold_pdf, pi_pdf * math::INV_PI);
        }
        sum += c;
        if cs.focused {
            focused += c;
        }
    }
    (sum, focused, rays)
}

/// What the last vertex of a path was. Emitters get full weight after the
/// camera (the eye is a delta) and after mirror or glass (`Delta` and up);
/// the first non-delta vertex, wherever mirrors and glass put it, draws its
/// numbers from the pixel's stratified pairs (`Eye`, kept through deltas;
/// a render without stratification starts at `Delta`).
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Last {
    /// A Lambertian, checker or rough-metal vertex.
    NonDelta,
    /// A mirror or glass vertex after a non-delta one (or the camera, in a
    /// render without stratification).
    Delta,
    /// The camera, or mirrors and glass seen from it.
    Eye,
}

/// The last non-delta vertex, read only after one has set it. With metal
/// an `Option`, empty until then: zeroing the larger record at every
/// path's start cost a call to memclr per path on a Cortex-M4. Without
/// metal the record itself: there an `Option` cost 172 bytes of a 64 KiB
/// firmware's flash.
#[cfg(feature = "metal")]
type Prev = Option<PrevVertex>;
#[cfg(not(feature = "metal"))]
type Prev = PrevVertex;

/// A non-delta vertex as its steps see it.
struct Vertex<'h> {
    hit: &'h Hit,
    /// The shading normal: the surface's, turned toward the incoming ray
    /// (every surface is two-sided).
    n: Vec3,
    /// The direction back along the incoming ray.
    wo: Vec3,
    /// Whether lights entirely below the tangent plane are skipped here.
    horizon: bool,
}

/// One path between its vertices.
struct PathState<'a> {
    /// The radiance gathered so far: the estimate of `L` along the camera
    /// ray.
    l: Color,
    /// The part of `l` gathered before the first non-delta vertex (see
    /// [`PathSum::direct`]).
    direct: Color,
    /// Whether the path (this branch of it) has met a non-delta vertex.
    scattered: bool,
    /// The throughput: the product of `f_r cos θ / pdf` (and of roulette's
    /// weights) from the camera to `ray`'s origin.
    thr: Color,
    /// The ray to the next vertex.
    ray: Ray,
    /// The object `ray` leaves (none for a camera ray).
    from: ObjectId,
    /// The sphere the camera ray met if it is a mirror or glass
    /// ([`crate::highlight::NO_VIA`] for none), with
    /// [`crate::highlight::VIA_INSIDE`] once the next ray met it again (a
    /// ball passed through): the start of the chains whose lights the
    /// highlight estimator samples. Set at delta vertices only.
    #[cfg(feature = "highlight")]
    via: u16,
    /// The spheres `ray` tests: the camera ray's list when culling, the
    /// bounce rays' list from the first bounce on.
    spheres: &'a [Listed],
    last: Last,
    /// Undoes the `(η_i/η_t)²` radiance scaling for Russian roulette, so
    /// that paths inside glass are not killed for a factor that cancels on
    /// exit (and a split's weight, `R` or `1 − R`, so that each branch is
    /// killed as the path that chose it would be).
    rr_scale: f32,
    prev: Prev,
    /// What a glossy vertex's light choice keeps for the MIS weight of an
    /// emitter its BSDF sample hits.
    glossy: GlossyChoice,
    depth: u32,
    /// Counted here and added to [`Stats`] once per path (`u64` additions
    /// are four instructions each on a 32-bit core).
    bounces: u32,
    shadows: u32,
    /// Whether the path may no longer split at a glass vertex: it has
    /// split, or met a non-delta vertex.
    #[cfg(feature = "glass")]
    no_split: bool,
    /// Where the path stands toward a caustic sphere ([`crate::caustic`]):
    /// [`CAUSTIC_ARMED`] right after a first non-delta vertex that sampled
    /// the caustics; then a sphere's scene index once the path has
    /// reflected in that mirror, or refracted into ([`CAUSTIC_INSIDE`]) and
    /// out of that glass sphere; else [`CAUSTIC_NONE`].
    #[cfg(feature = "highlight")]
    caustic: u16,
    /// The other branch of a path split at its first glass vertex (see
    /// [`split_at_glass`]), traced after this one ends.
    #[cfg(feature = "glass")]
    pending: Option<Branch>,
}

impl<'a> PathState<'a> {
    /// A path that starts along the camera ray `ray`.
    #[inline(always)]
    fn new(scene: &SceneView<'a>, ray: Ray, opts: &Options) -> Self {
        Self {
            l: Color::ZERO,
            direct: Color::ZERO,
            scattered: false,
            thr: Color::ONE,
            ray,
            from: ObjectId::NONE,
            #[cfg(feature = "highlight")]
            via: crate::highlight::NO_VIA,
            spheres: scene.camera_spheres(opts.skip.view_culling),
            last: if opts.stratified {
                Last::Eye
            } else {
                Last::Delta
            },
            rr_scale: 1.0,
            prev: no_prev(),
            glossy: GlossyChoice {
                alpha: 0.0,
                wo: Vec3::ZERO,
                share_sum: 0.0,
            },
            depth: 0,
            bounces: 0,
            shadows: 0,
            #[cfg(feature = "highlight")]
            caustic: CAUSTIC_NONE,
            #[cfg(feature = "glass")]
            no_split: false,
            #[cfg(feature = "glass")]
            pending: None,
        }
    }

    /// One vertex: the closest hit and what its material does there.
    /// Whether the path goes on.
    #[inline(always)]
    fn vertex<const MANY: bool, const TREE: bool>(
        &mut self,
        ctx: &Ctx<'_, 'a>,
        stream: &mut SampleStream<'_>,
        opts: &Options,
        stats: &mut Stats,
    ) -> bool {
        let scene = ctx.scene;
        let Some(hit) = self.closest_hit::<TREE>(scene, opts) else {
            self.escape(scene, opts, stats);
            return false;
        };
        let Some(mat) = scene.materials.get(hit.material as usize) else {
            return false;
        };
        let goes_on = match mat.scatter(&hit, self.ray.dir, stream) {
            Scatter::Emit(le) => {
                self.emission::<MANY>(ctx, &hit, le, opts);
                false
            }
            Scatter::Bsdf(Bsdf::Lambert(albedo)) => {
                self.non_delta::<MANY, TREE, _>(ctx, &hit, Lambert(albedo), stream, opts)
            }
            #[cfg(feature = "metal")]
            Scatter::Bsdf(Bsdf::Ggx(m)) => {
                self.non_delta::<MANY, TREE, _>(ctx, &hit, m, stream, opts)
            }
            Scatter::Delta(ds) => self.delta(mat, &hit, ds, stream, opts),
            Scatter::Absorb => false,
        };
        goes_on && self.advance(ctx, &hit, stream, opts, stats)
    }

    /// The closest surface along the ray, among the spheres it tests and
    /// the planes.
    #[inline(always)]
    fn closest_hit<const TREE: bool>(&self, scene: &SceneView<'_>, opts: &Options) -> Option<Hit> {
        if opts.skip.slabs {
            scene.closest_hit_in::<TREE>(&self.ray, self.from, self.spheres)
        } else {
            // the out-of-line query takes the ray's address: a copy, so that
            // the path's state need not live in memory
            let ray = self.ray;
            // the out-of-line query's record comes back through memory:
            // rebuilt field by field, so that the inlined query's record
            // need not live there too
            scene
                .closest_hit_any_among(&ray, self.from, self.spheres)
                .map(|h| Hit {
                    t: h.t,
                    point: h.point,
                    normal: h.normal,
                    error: h.error,
                    object: h.object,
                    material: h.material,
                })
        }
    }

    /// The background's `L_e` along a ray that leaves the scene. Nothing
    /// can escape a closed scene: there it is a numerical leak, counted.
    #[inline(always)]
    fn escape(&mut self, scene: &SceneView<'_>, opts: &Options, stats: &mut Stats) {
        if scene.closed && opts.skip.closed {
            stats.leaks += 1;
        } else {
            self.add(self.thr * scene.background);
        }
    }

    /// The emitted radiance `L_e` of the emitter the path hits, on its
    /// outward side, weighted by multiple importance sampling where
    /// next-event estimation at the vertex before could have found it too.
    /// The path ends (emitters reflect nothing).
    #[inline(always)]
    fn emission<const MANY: bool>(
        &mut self,
        ctx: &Ctx<'_, '_>,
        hit: &Hit,
        le: Color,
        opts: &Options,
    ) {
        // a light seen in a mirror straight from the camera (`from`: the
        // camera ray's object) whose image the highlight estimator samples:
        // left to it
        #[cfg(feature = "highlight")]
        if self.depth <= 3
            && opts.highlights
            && let Some(h) = ctx.highlights
            && h.covers(self.depth, self.via, self.from, hit.object)
        {
            return;
        }
        // a light seen through a mirror or glass sphere from the first
        // non-delta vertex, whose caustic the sample through the sphere
        // took there: left to it, or shared with it on a caustic's fold
        #[cfg(feature = "highlight")]
        let mut le = le;
        #[cfg(feature = "highlight")]
        if self.caustic < CAUSTIC_INSIDE
            && let Some((x, bsdf_pdf)) = self.prev_bsdf()
        {
            let share = caustic::bsdf_share(
                ctx.scene,
                ctx.caustics,
                x,
                usize::from(self.caustic),
                &self.ray,
                hit.object,
                bsdf_pdf,
            );
            if !(share > 0.0) {
                return;
            }
            le *= share;
        }
        if math::lt_zero(self.ray.dir.dot(hit.normal)) {
            let w = self.emission_weight::<MANY>(ctx, hit, opts);
            self.add(self.thr * le * w);
            // the camera ray's own light: `finish` reads `from` at depth 0
            if self.depth == 0 {
                self.from = hit.object;
            }
        }
    }

    /// The MIS weight of an emitter hit: 1 after the camera, a mirror or
    /// glass (no light sample could find it); after a non-delta vertex, the
    /// power heuristic of the BSDF sample's pdf against the light
    /// sample's.
    #[inline(always)]
    fn emission_weight<const MANY: bool>(
        &self,
        ctx: &Ctx<'_, '_>,
        hit: &Hit,
        opts: &Options,
    ) -> f32 {
        if self.last != Last::NonDelta {
            return 1.0;
        }
        match opts.strategy {
            Strategy::BsdfOnly => 1.0,
            Strategy::LightOnly => 0.0,
            Strategy::Mis => {
                let weigh = |prev: &PrevVertex| {
                    let pl = hit.object.as_sphere().map_or(0.0, |i| {
                        ctx.light_pdf::<MANY>(prev, &self.glossy, i, self.ray.dir)
                    });
                    power_heuristic(prev.bsdf_pdf, pl)
                };
                match self.prev {
                    #[cfg(feature = "metal")]
                    Some(prev) => weigh(&prev),
                    // not reached: `last` is not `NonDelta` before the
                    // first non-delta vertex
                    #[cfg(feature = "metal")]
                    None => 1.0,
                    #[cfg(not(feature = "metal"))]
                    prev => weigh(&prev),
                }
            }
        }
    }

    /// A non-delta vertex, compiled once per lobe type (static dispatch):
    /// next-event estimation, then the BSDF sample that continues the path.
    /// Whether the path goes on.
    #[inline(always)]
    fn non_delta<const MANY: bool, const TREE: bool, B: Lobe>(
        &mut self,
        ctx: &Ctx<'_, '_>,
        hit: &Hit,
        lobe: B,
        stream: &mut SampleStream<'_>,
        opts: &Options,
    ) -> bool {
        self.forbid_split();
        #[cfg(feature = "highlight")]
        let first = !self.scattered;
        self.scattered = true;
        let at = Vertex {
            hit,
            n: if math::lt_zero(self.ray.dir.dot(hit.normal)) {
                hit.normal
            } else {
                -hit.normal
            },
            wo: -self.ray.dir,
            horizon: ctx.horizon_at(hit.object),
        };
        let (weight_sum, light_omc) =
            self.direct_light::<MANY, TREE, B>(ctx, &at, &lobe, stream, opts);
        #[cfg(feature = "highlight")]
        self.caustic(ctx, &at, &lobe, first, stream);
        let Some((dir, pi_pdf)) = self.bsdf_sample(&at, &lobe, stream, opts) else {
            return false;
        };
        self.set_prev(PrevVertex {
            point: hit.point,
            normal: at.n,
            bsdf_pdf: pi_pdf * math::INV_PI,
            weight_sum,
            light_omc,
            horizon: at.horizon,
        });
        self.last = Last::NonDelta;
        self.ray = hit.spawn_on(at.n, dir);
        true
    }

    /// The caustics at a path's first non-delta vertex: `∫ L_e f_r cos θ dω`
    /// over the directions that meet a light through one mirror or glass
    /// sphere ([`crate::caustic`]), by one sample through a sphere at a
    /// share of the vertices. The emission that the BSDF sample finds along
    /// such a path is then left out ([`PathState::emission`]): the two
    /// partition the paths, so the sum stays unbiased, and the sample finds
    /// what the BSDF sample finds only by the chance of hitting the light's
    /// tiny image in the sphere.
    #[cfg(feature = "highlight")]
    #[inline(always)]
    fn caustic<B: Lobe>(
        &mut self,
        ctx: &Ctx<'_, '_>,
        at: &Vertex<'_>,
        lobe: &B,
        first: bool,
        stream: &mut SampleStream<'_>,
    ) {
        self.caustic = CAUSTIC_NONE;
        let list = ctx.caustics;
        if !first || list.is_empty() {
            return;
        }
        self.caustic = CAUSTIC_ARMED;
        // sampled at a share of the vertices, weighted by its inverse (the
        // BSDF sample's hits of the same paths are left out at every
        // vertex): unbiased, at a fraction of the cost. Independent
        // numbers: a stratified pair beyond the cached ones costs a hash
        // per path, and this estimate has little noise to stratify
        let u0 = stream.next_f32();
        if u0 >= caustic::SHARE {
            return;
        }
        let u = stream.next_2d();
        let (c, focused, rays) = caustic_paths(ctx, at, lobe, u0 * (1.0 / caustic::SHARE), u);
        // a focused caustic is kept with the direct part, out of a
        // denoiser's filter (it is sharp); a broad one varies as smoothly
        // as the light scattered there, and is filtered with it
        self.l += self.thr * c;
        self.direct += self.thr * focused;
        self.shadows += rays;
    }

    /// The point of the last non-delta vertex, once there is one, and the
    /// density of its BSDF sample's direction.
    #[cfg(feature = "highlight")]
    #[inline(always)]
    fn prev_bsdf(&self) -> Option<(Vec3, f32)> {
        #[cfg(feature = "metal")]
        {
            self.prev.map(|p| (p.point, p.bsdf_pdf))
        }
        #[cfg(not(feature = "metal"))]
        {
            Some((self.prev.point, self.prev.bsdf_pdf))
        }
    }

    /// Next-event estimation at a non-delta vertex: `∫ L_e f_r cos θ dω`
    /// over the lights, by one light sample (or, for a scene's one light
    /// seen whole from a Lambertian point, in closed form), added to the
    /// path's radiance. Returns what the MIS weight of an emitter that the
    /// BSDF sample hits needs: the light-selection weights' sum and, with
    /// one light, its `1 − cos θ_max` (see [`PrevVertex`]).
    #[inline(always)]
    fn direct_light<const MANY: bool, const TREE: bool, B: Lobe>(
        &mut self,
        ctx: &Ctx<'_, '_>,
        at: &Vertex<'_>,
        lobe: &B,
        stream: &mut SampleStream<'_>,
        opts: &Options,
    ) -> (f32, f32) {
        if opts.strategy == Strategy::BsdfOnly || ctx.plan.lights.is_empty() {
            return (0.0, 0.0);
        }
        // drawn before the light is chosen, so that skipping a light below
        // the horizon never shifts the random numbers; with the closed form
        // in use (one light), only where the light is sampled
        let early = if ctx.plan.one.is_some_and(|o| o.whole) {
            None
        } else {
            Some(self.pair(stream, 2))
        };
        let f = self.thr * lobe.tint();
        if MANY {
            // several lights have no one-light plan, so the numbers were
            // drawn above (`early` is `Some`)
            let u = early.unwrap_or([0.0; 2]);
            (
                self.direct_many::<TREE, B>(ctx, at, f, lobe, u, stream, opts),
                0.0,
            )
        } else if let Some(one) = &ctx.plan.one {
            let omc = self.direct_one::<MANY, TREE, B>(ctx, one, at, f, lobe, early, stream, opts);
            (1.0, omc)
        } else {
            (0.0, 0.0)
        }
    }

    /// Next-event estimation among several lights: one chosen by its
    /// expected contribution (at a glossy vertex, mixed with its share of
    /// the lobe), sampled in its cone or through its window, a shadow ray.
    /// Returns the selection weights' sum, negated where the glossy choice
    /// applies.
    #[allow(clippy::too_many_arguments)]
    // inlined, except on cores without an FPU: there every float operation
    // is a call, and inlined into each variant of the loop this step made a
    // firmware of the several-lights scenes 10 KB larger (Cortex-M0,
    // spheres.scene)
    #[cfg_attr(
        any(
            all(target_arch = "arm", not(target_abi = "eabihf")),
            all(target_arch = "riscv32", not(target_feature = "f"))
        ),
        inline(never)
    )]
    #[cfg_attr(
        not(any(
            all(target_arch = "arm", not(target_abi = "eabihf")),
            all(target_arch = "riscv32", not(target_feature = "f"))
        )),
        inline(always)
    )]
    fn direct_many<const TREE: bool, B: Lobe>(
        &mut self,
        ctx: &Ctx<'_, '_>,
        at: &Vertex<'_>,
        f: Color,
        lobe: &B,
        u: [f32; 2],
        stream: &mut SampleStream<'_>,
        opts: &Options,
    ) -> f32 {
        let (hit, n, wo) = (at.hit, at.n, at.wo);
        let first = self.last == Last::Eye;
        let alpha = lobe.selective_alpha();
        let (choice, sum) = if cfg!(feature = "metal") && alpha > 0.0 {
            let (c, sum) = ctx.choose_light_glossy(
                hit.point,
                n,
                at.horizon,
                first,
                stream,
                alpha,
                wo,
                &mut self.glossy,
            );
            (c, -sum)
        } else {
            ctx.choose_light(hit.point, n, at.horizon, first, stream)
        };
        if let Some(c) = choice {
            let scene = ctx.scene;
            let shadows = &mut self.shadows;
            let through = match window_of(ctx.windows(), c.sphere) {
                Some(w) => {
                    direct_window::<TREE, _>(scene, hit, n, f, lobe, wo, &c, u, opts, shadows, w)
                }
                None => None,
            };
            self.l += match through {
                Some(e) => e,
                None => direct::<TREE, _>(scene, hit, n, f, lobe, wo, &c, u, opts, shadows),
            };
        }
        sum
    }

    /// Next-event estimation of a scene's one light: nothing where it is
    /// inside the light or all of the light is below the horizon; the
    /// closed form where a Lambertian point provably sees all of it
    /// ([`whole_light`]); else a sample in its cone (or through its
    /// window) and a shadow ray. Returns its `1 − cos θ_max` as
    /// [`PrevVertex::light_omc`] records it.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn direct_one<const MANY: bool, const TREE: bool, B: Lobe>(
        &mut self,
        ctx: &Ctx<'_, '_>,
        one: &OneLight<'_>,
        at: &Vertex<'_>,
        f: Color,
        lobe: &B,
        early: Option<[f32; 2]>,
        stream: &mut SampleStream<'_>,
        opts: &Options,
    ) -> f32 {
        let (scene, hit, n, wo) = (ctx.scene, at.hit, at.n, at.wo);
        let to_c = one.center - hit.point;
        let d2 = to_c.length_squared();
        if !(math::gt(d2, one.radius2) && !(at.horizon && math::lt(n.dot(to_c), -one.radius))) {
            return 0.0;
        }
        if one.whole
            && lobe.cosine_weight().is_some()
            && let Some(k) = whole_light(scene, hit, n, to_c, d2, one.radius, one.radius2)
        {
            self.l += self.thr * (lobe.tint() * (one.le * k));
            return f32::INFINITY;
        }
        let u = match early {
            Some(u) => u,
            None => self.pair(stream, 2),
        };
        let c = LightChoice {
            sphere: one.sphere,
            p_sel: 1.0,
            to_c,
            d2,
        };
        let shadows = &mut self.shadows;
        let through = match Ctx::window_of_one(one) {
            Some(w) => nee_window::<MANY, TREE, _>(
                scene, hit, n, f, lobe, wo, &c, one.le, u, opts, shadows, w,
            ),
            None => None,
        };
        if let Some(e) = through {
            // negative: the window's pdf applies
            self.l += e;
            return -1.0;
        }
        let mut omc = 0.0;
        self.l += nee::<MANY, TREE, _>(
            scene,
            hit,
            n,
            f,
            lobe,
            wo,
            &c,
            one.radius2,
            one.le,
            u,
            opts,
            shadows,
            &mut omc,
        );
        omc
    }

    /// The BSDF sample that continues the path from a non-delta vertex:
    /// its direction and π times its pdf, the throughput times
    /// `f_r cos θ / pdf` (the Lambertian's: its albedo, exactly). `None`
    /// where the lobe has no direction to give or Russian roulette ends the
    /// path. A cosine-sampled vertex asks roulette before its direction,
    /// which a path that roulette ends never needs (the same numbers in the
    /// same order: the direction's are drawn before roulette's).
    #[inline(always)]
    fn bsdf_sample<B: Lobe>(
        &mut self,
        at: &Vertex<'_>,
        lobe: &B,
        stream: &mut SampleStream<'_>,
        opts: &Options,
    ) -> Option<(Vec3, f32)> {
        let u = self.pair(stream, 1);
        if let Some(w) = lobe.cosine_weight() {
            self.thr *= w;
            if !self.roulette(stream, opts) {
                return None;
            }
            Some(sample_cosine(at.n, u[0], u[1], opts.fast_math))
        } else {
            let bs = lobe.sample(at.wo, at.n, u, opts.fast_math)?;
            self.thr *= bs.weight;
            if !self.roulette(stream, opts) {
                return None;
            }
            Some((bs.dir, bs.pi_pdf))
        }
    }

    /// A mirror or glass vertex: its sampled direction (the refraction,
    /// where the path splits here, with the reflection kept for later),
    /// its weight, then roulette. Whether the path goes on.
    #[inline(always)]
    fn delta(
        &mut self,
        mat: &Material,
        hit: &Hit,
        ds: DeltaSample,
        stream: &mut SampleStream<'_>,
        opts: &Options,
    ) -> bool {
        #[cfg(feature = "highlight")]
        {
            self.caustic_step(mat, hit, &ds);
            // the chains' start: the camera ray's sphere, and whether the
            // next ray meets it again (only delta vertices make a chain)
            if self.depth == 0 {
                self.via = hit
                    .object
                    .as_sphere()
                    .map_or(crate::highlight::NO_VIA, |i| i as u16);
            } else if self.depth == 1 && hit.object.as_sphere() == Some(usize::from(self.via)) {
                self.via |= crate::highlight::VIA_INSIDE;
            }
        }
        let ds = self.split(mat, hit, ds);
        self.thr *= ds.weight;
        self.rr_scale /= ds.scale;
        self.last = self.last.max(Last::Delta);
        self.ray = hit.spawn(ds.dir);
        self.roulette(stream, opts)
    }

    /// Where a delta vertex leaves the path toward a caustic sphere (see
    /// [`PathState::caustic`]): a reflection in a mirror sphere right after
    /// the first non-delta vertex, or a refraction into a glass sphere
    /// there and then out of the same sphere, keeps the sphere's index.
    #[cfg(feature = "highlight")]
    #[inline(always)]
    fn caustic_step(&mut self, mat: &Material, hit: &Hit, ds: &DeltaSample) {
        if self.caustic == CAUSTIC_NONE {
            return;
        }
        // a refraction continues to the far side of the surface
        let refracted = !math::lt_zero(self.ray.dir.dot(hit.normal) * ds.dir.dot(hit.normal));
        self.caustic = match (hit.object.as_sphere(), mat) {
            (Some(i), Material::Mirror(_))
                if self.caustic == CAUSTIC_ARMED && i < usize::from(CAUSTIC_INSIDE) =>
            {
                i as u16
            }
            (Some(i), Material::Glass(_))
                if refracted
                    && self.caustic == CAUSTIC_ARMED
                    && i < usize::from(CAUSTIC_INSIDE) =>
            {
                i as u16 | CAUSTIC_INSIDE
            }
            (Some(i), Material::Glass(_))
                if refracted && usize::from(self.caustic) == (i | usize::from(CAUSTIC_INSIDE)) =>
            {
                i as u16
            }
            _ => CAUSTIC_NONE,
        };
    }

    /// The first glass vertex seen from the camera (through any mirrors and
    /// glass, before any diffuse or glossy vertex) continues along both its
    /// reflection and its refraction (the choice `ds` just drawn is not
    /// used); every other glass vertex along the one chosen by the Fresnel
    /// reflectance.
    #[inline(always)]
    fn split(&mut self, mat: &Material, hit: &Hit, ds: DeltaSample) -> DeltaSample {
        #[cfg(feature = "glass")]
        if let Some((t, b)) = split_at_glass(mat, hit, &self.ray, !self.no_split) {
            self.no_split = true;
            self.pending = Some(Branch {
                thr: self.thr * b.thr,
                rr_scale: self.rr_scale * b.rr_scale,
                depth: self.depth + 1,
                ..b
            });
            return t;
        }
        #[cfg(not(feature = "glass"))]
        let _ = (mat, hit);
        ds
    }

    /// A non-delta vertex ends the part of a path that may split at glass.
    #[inline(always)]
    fn forbid_split(&mut self) {
        #[cfg(feature = "glass")]
        {
            self.no_split = true;
        }
    }

    /// Russian roulette on the throughput with which the path leaves this
    /// vertex (its `depth + 1`-th bounce): ends the path (`false`), or
    /// weights the survivor by `1 / p`.
    #[inline(always)]
    fn roulette(&mut self, stream: &mut SampleStream<'_>, opts: &Options) -> bool {
        if self.depth + 1 >= opts.rr_start {
            let p = self.thr.max_component() * self.rr_scale * opts.rr_gain;
            if math::lt(p, 1.0) {
                if !math::lt(stream.next_f32(), p) {
                    return false;
                }
                self.thr *= 1.0 / p;
            }
        }
        true
    }

    /// After a vertex that continues the path: the depth, and from
    /// [`super::PathPlan`]'s `deep` on, the depth roulette (or the cap).
    /// Whether the path goes on.
    #[inline(always)]
    fn advance(
        &mut self,
        ctx: &Ctx<'_, 'a>,
        hit: &Hit,
        stream: &mut SampleStream<'_>,
        opts: &Options,
        stats: &mut Stats,
    ) -> bool {
        self.depth += 1;
        self.spheres = ctx.scene.tested;
        // one test per bounce for both the depth roulette and the cap
        if self.depth >= ctx.plan.deep {
            match super::plan::deep_roulette(self.depth, opts, stream, stats) {
                Some(w) => self.thr *= w,
                None => return false,
            }
        }
        self.from = hit.object;
        self.bounces += 1;
        true
    }

    /// The path's other branch, if it split at a glass vertex: whether
    /// there was one to trace.
    #[inline(always)]
    fn resume_split(&mut self) -> bool {
        #[cfg(feature = "glass")]
        if let Some(b) = self.pending.take() {
            self.ray = b.ray;
            self.thr = b.thr;
            self.rr_scale = b.rr_scale;
            self.depth = b.depth;
            self.from = b.from;
            self.last = Last::Eye;
            // a path splits only before its first non-delta vertex
            self.scattered = false;
            #[cfg(feature = "highlight")]
            {
                self.caustic = CAUSTIC_NONE;
                // the branch reflected off the ball the other passed through
                if self.via != crate::highlight::NO_VIA {
                    self.via &= !crate::highlight::VIA_INSIDE;
                }
            }
            self.bounces += 1;
            return true;
        }
        false
    }

    /// Two numbers for a vertex's choice `k` (1: the bounce, 2: the light
    /// sample): from the pixel's stratified pairs at its first non-delta
    /// vertex, independent after.
    #[inline(always)]
    fn pair(&self, stream: &mut SampleStream<'_>, k: u32) -> [f32; 2] {
        if self.last == Last::Eye {
            stream.stratified_2d(k)
        } else {
            stream.next_2d()
        }
    }

    /// Records the non-delta vertex the path leaves.
    #[inline(always)]
    fn set_prev(&mut self, v: PrevVertex) {
        #[cfg(feature = "metal")]
        {
            self.prev = Some(v);
        }
        #[cfg(not(feature = "metal"))]
        {
            self.prev = v;
        }
    }

    /// Emitted radiance `c` that reaches the camera along the path: to the
    /// estimate, and to its direct part before the first non-delta vertex.
    #[inline(always)]
    fn add(&mut self, c: Color) {
        self.l += c;
        if !self.scattered {
            self.direct += c;
        }
    }

    /// The path's estimate; its counts go to `stats`.
    #[inline(always)]
    fn finish(self, stats: &mut Stats) -> PathSum {
        stats.paths += 1;
        stats.bounce_rays += u64::from(self.bounces);
        stats.shadow_rays += u64::from(self.shadows);
        PathSum {
            total: self.l,
            direct: self.direct,
            // ended at the camera ray's own light (see `emission`)
            seen: self.depth == 0 && self.from != ObjectId::NONE,
        }
    }
}

/// No non-delta vertex yet (see [`Prev`]).
#[inline(always)]
fn no_prev() -> Prev {
    #[cfg(feature = "metal")]
    {
        None
    }
    #[cfg(not(feature = "metal"))]
    {
        PrevVertex {
            point: Vec3::ZERO,
            normal: Vec3::ZERO,
            bsdf_pdf: 0.0,
            weight_sum: 0.0,
            light_omc: 0.0,
            horizon: false,
        }
    }
}
