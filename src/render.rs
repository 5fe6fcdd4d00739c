//! The render API: a pure function of (scene, camera, options, seed, tile,
//! sample range) that any executor can drive — one core on a board, threads
//! on a host.

use crate::camera::{Camera, CameraError};
use crate::film::Tile;
use crate::geometry::{Color, ObjectId, Ray};
use crate::integrator::{self, Options, PathPlan, PathSum, Stats};
use crate::math;
use crate::sampler::{PixelSampler, SampleStream, pixel_key_of, seed_key};
use crate::scene::bvh::BvhView;
use crate::scene::{Scene, SceneView};
#[cfg(feature = "highlight")]
use crate::{
    camera::LensPoint,
    highlight::{self, Highlights, PixelHighlights},
    sampler::{mix64, sobol_2d, to_unit},
};

/// The stratified pair of a sample's stream that places a lens camera's
/// ray on the lens: the first pair the integrator does not use (0 is the
/// film position, 1 the first bounce, 2 the first light sample), so a lens
/// changes no other draw of a path.
pub const LENS_PAIR: u32 = 3;

/// What the render seed's key is XORed with for the rays that measure
/// the lights a pixel sees ([`Renderer::lights_seen`]): samples
/// independent of the render's.
const COVERAGE_KEY: u64 = 0x6a09_e667_f3bc_c909;
/// What it is XORed with for the rays that measure the mean albedo a
/// pixel's samples see ([`Renderer::texture_rays`]).
#[cfg(feature = "checker")]
const TEXTURE_KEY: u64 = 0x3c6e_f372_fe94_f82b;

/// What a highlight pair's key is XORed with for the lens positions of
/// its estimates ([`crate::highlight::estimate`]).
#[cfg(feature = "highlight")]
const LENS_KEY: u64 = 0xbb67_ae85_84ca_a73b;

/// The largest sample component a render keeps: `f32::MAX / 2^20`, so that
/// the sum of a pixel's samples (at most [`MAX_SPP`] =
/// 2^20) cannot overflow. Larger (and non-finite) samples are counted in
/// [`Stats::nonfinite`](crate::stats::Stats::nonfinite) and dropped.
pub const SAMPLE_MAX: f32 = f32::MAX / MAX_SPP as f32;

/// Most samples per pixel, on average, that a budget
/// ([`crate::budget::Budget`]) may ask for: a pixel's count (a `u32`, at
/// most a tile's samples) never overflows, a pixel's sum of samples below
/// [`SAMPLE_MAX`] stays finite, and a deadline far in the future still
/// ends. Larger budgets are clamped to it.
pub const MAX_SPP: u32 = 1 << 20;

/// Renders pixels of one scene at one image size.
///
/// ```
/// use micropt::{parse::parse, Renderer, Stats, Vec3, film::{tiles, TILE}};
/// let scene = parse(include_str!("../scenes/furnace.scene")).unwrap();
/// let r = Renderer::new(&scene, 32, 32).unwrap().seed(1);
/// let mut stats = Stats::default();
/// let mut px = [Vec3::ZERO; (TILE * TILE) as usize];
/// for tile in tiles(32, 32) {
///     r.render_tile(&tile, 4, &mut px, &mut stats);
/// }
/// assert_eq!(stats.paths, 32 * 32 * 4);
/// // the last tile's top-left pixel is the image centre, on the grey sphere
/// // under a white sky: exactly its albedo (the furnace test)
/// assert_eq!(px[0], Vec3::splat(0.5));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Renderer<'a> {
    scene: SceneView<'a>,
    camera: Camera,
    /// [`seed_key`] of the render seed
    seed_key: u64,
    options: Options,
    /// The scene's tree, whether or not the options use it.
    tree: Option<BvhView<'a>>,
    /// What every path decides the same way: `PathPlan::new(&scene,
    /// &options)`, made again whenever either changes.
    plan: PathPlan<'a>,
    /// The (mirror, light) pairs whose images can be sampled from the
    /// light's side (used when the options allow: [`Renderer::highlights_on`]).
    #[cfg(feature = "highlight")]
    highlights: Highlights,
    /// The spheres whose caustics can be sampled through them (used when
    /// the options allow: [`Renderer::caustics_on`]).
    #[cfg(feature = "highlight")]
    caustics: crate::caustic::Spheres,
}

/// What all samples of one pixel share: its sampler, and the highlight
/// pairs that can touch it ([`Renderer::pixel`]).
#[derive(Clone, Debug)]
pub struct Pixel {
    sampler: PixelSampler,
    #[cfg(feature = "highlight")]
    key: u64,
    #[cfg(feature = "highlight")]
    highlights: PixelHighlights,
}

impl<'a> Renderer<'a> {
    /// A renderer of `scene` at `width × height` (seed 0, default options).
    pub fn new<const S: usize, const P: usize, const M: usize>(
        scene: &'a Scene<S, P, M>,
        width: u32,
        height: u32,
    ) -> Result<Self, CameraError> {
        let camera = Camera::new(scene.camera(), width, height)?;
        // a little wider than the frustum: culling must never drop a sphere
        // that a ray through the film's edge could graze
        let view_cos = camera.view_cos() - 1e-4;
        let view = scene.view(view_cos);
        let options = Options::default();
        Ok(Self {
            scene: view,
            camera,
            seed_key: seed_key(0),
            options,
            tree: view.bvh,
            plan: PathPlan::new(&view, &options),
            #[cfg(feature = "highlight")]
            highlights: Highlights::new(&view, &camera),
            #[cfg(feature = "highlight")]
            caustics: crate::caustic::Spheres::new(&view),
        })
    }

    /// Sets the render seed: images are a pure function of it.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed_key = seed_key(seed);
        self
    }

    /// Sets the integrator options (those a build runs with:
    /// [`Options::effective`]).
    pub fn options(mut self, options: Options) -> Self {
        let options = options.effective();
        self.options = options;
        if !cfg!(micropt_no_bvh) {
            self.scene.bvh = if options.skip.bvh { self.tree } else { None };
        }
        self.plan = PathPlan::new(&self.scene, &self.options);
        self
    }

    /// The integrator options.
    pub fn get_options(&self) -> &Options {
        &self.options
    }

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The scene's arrays.
    pub fn scene(&self) -> &SceneView<'a> {
        &self.scene
    }

    /// Image width.
    pub fn width(&self) -> u32 {
        self.camera.width()
    }

    /// Image height.
    pub fn height(&self) -> u32 {
        self.camera.height()
    }

    /// The sampler of pixel (x, y): what all its samples share.
    #[inline]
    pub fn pixel_sampler(&self, x: u32, y: u32) -> PixelSampler {
        PixelSampler::new(pixel_key_of(self.seed_key, x, y))
    }

    /// What all samples of pixel (x, y) share ([`Renderer::sample_in`]).
    #[inline(always)]
    pub fn pixel(&self, x: u32, y: u32) -> Pixel {
        let key = pixel_key_of(self.seed_key, x, y);
        Pixel {
            sampler: PixelSampler::new(key),
            #[cfg(feature = "highlight")]
            key,
            #[cfg(feature = "highlight")]
            highlights: self
                .highlights_on()
                .map_or(PixelHighlights::NONE, |h| h.at(x, y)),
        }
    }

    /// The (mirror, light) pairs whose images can be sampled from the
    /// light's side ([`crate::highlight`]), whatever the options.
    #[cfg(feature = "highlight")]
    pub fn highlights(&self) -> &Highlights {
        &self.highlights
    }

    /// The pairs this render samples from the light's side: none when
    /// [`Options::highlights`] is off, or when paths end before they could
    /// meet a light after a mirror.
    #[cfg(feature = "highlight")]
    #[inline(always)]
    fn highlights_on(&self) -> Option<&Highlights> {
        (self.options.highlights && self.options.max_depth >= 2 && !self.highlights.is_empty())
            .then_some(&self.highlights)
    }

    /// The spheres whose caustics this render samples through them
    /// ([`crate::caustic`]): none when [`Options::caustics`] is off, or
    /// when paths end before they could meet a light through a sphere.
    #[cfg(feature = "highlight")]
    #[inline(always)]
    fn caustics_on(&self) -> &[u16] {
        // (four bounces reach a light through glass from the first
        // non-delta vertex: below that the path tracer could not)
        if self.options.caustics && self.options.max_depth >= 4 {
            self.caustics.as_slice()
        } else {
            &[]
        }
    }

    /// How many (mirror, light) pairs this render samples from the light's
    /// side (0 in a build without the `highlight` feature).
    pub fn highlight_pairs(&self) -> usize {
        #[cfg(feature = "highlight")]
        {
            self.highlights_on().map_or(0, |h| h.as_slice().len())
        }
        #[cfg(not(feature = "highlight"))]
        {
            0
        }
    }

    /// How many mirror and glass spheres this render samples the caustics
    /// of through the sphere (0 in a build without the `highlight`
    /// feature).
    pub fn caustic_spheres(&self) -> usize {
        #[cfg(feature = "highlight")]
        {
            self.caustics_on().len()
        }
        #[cfg(not(feature = "highlight"))]
        {
            0
        }
    }

    /// Sample number `index` of pixel (x, y): one path. A result that is not
    /// finite, or beyond [`SAMPLE_MAX`] (where a pixel's sum of samples
    /// could overflow), is counted in `stats.nonfinite` and returned as
    /// zero.
    #[inline]
    pub fn sample(&self, x: u32, y: u32, index: u32, stats: &mut Stats) -> Color {
        self.sample_in(&self.pixel(x, y), x, y, index, stats)
    }

    /// [`Renderer::sample`] with what the pixel's samples share computed
    /// beforehand ([`Renderer::pixel`]`(x, y)`; the same bits).
    #[inline(always)]
    pub fn sample_in(&self, pixel: &Pixel, x: u32, y: u32, index: u32, stats: &mut Stats) -> Color {
        self.sample_with::<false>(pixel, x, y, index, stats).total
    }

    /// [`Renderer::sample_in`] with the estimate's direct part: the light
    /// that reached the camera through no non-delta vertex (lights seen
    /// directly, in mirrors or through glass, and the highlight
    /// estimator's). `total` has the same bits as [`Renderer::sample_in`]'s
    /// result; a sample counted as non-finite is zero in both parts.
    #[inline(always)]
    pub fn sample_parts_in(
        &self,
        pixel: &Pixel,
        x: u32,
        y: u32,
        index: u32,
        stats: &mut Stats,
    ) -> PathSum {
        self.sample_with::<true>(pixel, x, y, index, stats)
    }

    /// One sample with its direct part (the highlight estimates added to
    /// it only with `PARTS`). [`Renderer::sample_in`] takes the total
    /// alone, and the compiler drops the direct part's arithmetic: its
    /// firmware's path loop costs what it did before the split (measured:
    /// a const-generic path loop that did not track the part at all cost
    /// 1.3 % more instructions a path on spheres, Cortex-M4F, for codegen
    /// reasons).
    #[inline(always)]
    fn sample_with<const PARTS: bool>(
        &self,
        pixel: &Pixel,
        x: u32,
        y: u32,
        index: u32,
        stats: &mut Stats,
    ) -> PathSum {
        let mut s = pixel.sampler.stream(index);
        let ray = self.primary_ray(&mut s, x, y);
        #[allow(unused_mut)]
        let mut c = integrator::radiance_planned(
            &self.scene,
            &self.plan,
            #[cfg(feature = "highlight")]
            self.highlights_on(),
            #[cfg(feature = "highlight")]
            self.caustics_on(),
            ray,
            &mut s,
            &self.options,
            stats,
        );
        // the lights seen in mirrors that the path left out
        #[cfg(feature = "highlight")]
        if !pixel.highlights.is_empty() {
            let h = self.highlights_of(pixel, x, y, index, stats);
            c.total += h;
            if PARTS {
                c.direct += h;
            }
        }
        let kept = |v: f32| crate::math::abs_at_most(v, SAMPLE_MAX);
        if kept(c.total.x) && kept(c.total.y) && kept(c.total.z) {
            c
        } else {
            stats.nonfinite += 1;
            PathSum {
                total: Color::ZERO,
                direct: Color::ZERO,
                seen: false,
            }
        }
    }

    /// The highlight estimates of sample `index` of pixel (x, y) (out of
    /// line: most pixels have none).
    #[cfg(feature = "highlight")]
    #[inline(never)]
    fn highlights_of(&self, pixel: &Pixel, x: u32, y: u32, index: u32, stats: &mut Stats) -> Color {
        let mut c = Color::ZERO;
        pixel.highlights.each(&self.highlights, x, y, |k, p| {
            // a pair's paths reach the light after one bounce, a chain's
            // after two or three: none when paths end sooner (nor does the
            // path tracer meet them)
            if self.options.max_depth <= p.bounces() {
                return;
            }
            // the pair's own scrambled Sobol points over the pixel's
            // samples; independent numbers when the render's are (so that
            // an unstratified render is plain Monte Carlo throughout, its
            // MSE exactly 1/N)
            let key = pixel.key ^ mix64(k as u64 + 1);
            let numbers = |key: u64| {
                if self.options.stratified {
                    sobol_2d(index, key)
                } else {
                    let z = mix64(key ^ mix64(u64::from(index)));
                    [to_unit(z as u32), to_unit((z >> 32) as u32)]
                }
            };
            let mut rnd = numbers(key);
            // a chain's image: estimated at a share of the samples,
            // weighted by its inverse (its first number decides, rescaled)
            let mut weight = 1.0;
            if p.is_chain() {
                if !(rnd[0] < highlight::CHAIN_SHARE) {
                    return;
                }
                rnd[0] *= 1.0 / highlight::CHAIN_SHARE;
                weight = 1.0 / highlight::CHAIN_SHARE;
            }
            // LATTICE directions a sample: the lattice's points shifted by
            // the sample's pair (each uniform in the cone, so each term is
            // unbiased), so that a pixel holding a sliver of the light's
            // image counts many of its directions, not none or one; an
            // image within one pixel gets them all, and one serves
            let [x0, y0, x1, y1] = p.pixels;
            let steps = if x0 == x1 && y0 == y1 {
                &highlight::LATTICE_STEPS[..1]
            } else {
                &highlight::LATTICE_STEPS[..]
            };
            let scale = weight / steps.len() as f32;
            // with a lens, one lens position a sample for the pair's
            // directions: its own Sobol points, keyed apart
            let lp = if self.camera.has_lens() {
                self.camera.lens_point(numbers(key ^ LENS_KEY))
            } else {
                LensPoint::CENTRE
            };
            let mut sum = Color::ZERO;
            for (j, step) in steps.iter().enumerate() {
                let lu = highlight::wrap(rnd[0] + j as f32 * (1.0 / highlight::LATTICE as f32));
                let lv = highlight::wrap(rnd[1] + step);
                if let Some(v) =
                    highlight::estimate(&self.scene, &self.camera, p, x, y, &lp, [lu, lv], stats)
                {
                    sum += v;
                }
            }
            c += sum * scale;
        });
        c
    }

    /// Whether pixel (x, y)'s samples carry the highlight estimator's images
    /// of lights in mirrors (added to every sample, whatever its camera ray
    /// meets).
    pub fn has_highlights(&self, x: u32, y: u32) -> bool {
        #[cfg(feature = "highlight")]
        {
            self.highlights_on().is_some_and(|h| !h.at(x, y).is_empty())
        }
        #[cfg(not(feature = "highlight"))]
        {
            let _ = (x, y);
            false
        }
    }

    /// The camera rays of the render's samples of pixel (x, y), by sample
    /// index: the rays their paths start from (the same film and lens
    /// positions), so that what a sample saw first can be looked at again
    /// without its path.
    #[cfg(feature = "checker")]
    pub fn sample_rays(&self, x: u32, y: u32) -> impl Fn(u32) -> Ray + '_ {
        let sampler = PixelSampler::new(pixel_key_of(self.seed_key, x, y));
        move |index| self.primary_ray(&mut sampler.stream(index), x, y)
    }

    /// The rays that measure the mean albedo pixel (x, y)'s samples see
    /// (`crate::denoise`'s textures), by index: stratified over the pixel
    /// (and the lens, with one), an Owen-scrambled Sobol net keyed apart
    /// from the render's samples and from the lights' measure, so that the
    /// three are independent.
    #[cfg(feature = "checker")]
    pub fn texture_rays(&self, x: u32, y: u32) -> impl Fn(u32) -> Ray + '_ {
        let sampler = PixelSampler::new(pixel_key_of(self.seed_key ^ TEXTURE_KEY, x, y));
        move |index| self.camera_ray_from(&mut sampler.stream(index), x, y, true)
    }

    /// The lights pixel (x, y) sees directly, measured with `count` camera
    /// rays of their own (an Owen-scrambled Sobol net over the pixel, and
    /// over the lens with one, keyed apart from the render's samples so
    /// that the two are independent): the sum of the `L_e` of the lights
    /// whose outside each ray meets first, and how many rays met one. Each
    /// ray asks what the path tracer's camera ray asks of its first hit
    /// ([`PathSum::seen`]). A pinhole's rays test the scene's emitters and
    /// then whether anything blocks the way from the eye (the shadow
    /// rays' lists: an object they leave out cannot lie between the eye and
    /// a light); a lens's rays, which start off the eye, take the camera
    /// ray's full query.
    #[inline(never)]
    pub fn lights_seen(&self, x: u32, y: u32, count: u32) -> (Color, u32) {
        let sampler = PixelSampler::new(pixel_key_of(self.seed_key ^ COVERAGE_KEY, x, y));
        let scene = &self.scene;
        let (mut sum, mut hits) = (Color::ZERO, 0u32);
        for i in 0..count {
            let ray = self.camera_ray_from(&mut sampler.stream(i), x, y, true);
            if self.camera.has_lens() {
                let spheres = scene.camera_spheres(self.options.skip.view_culling);
                let Some(hit) = scene.closest_hit_among(&ray, ObjectId::NONE, spheres) else {
                    continue;
                };
                if let Some(le) = scene
                    .materials
                    .get(usize::from(hit.material))
                    .and_then(|m| m.emission())
                    && math::lt_zero(ray.dir.dot(hit.normal))
                    && math::gt_zero(le.max_component())
                {
                    sum += le;
                    hits += 1;
                }
                continue;
            }
            // the nearest light's outside along the ray
            let mut near: Option<(f32, u16, Color)> = None;
            for &l in scene.emitters {
                let Some((sphere, le)) = scene.sphere_light(l) else {
                    continue;
                };
                let Some(t) = sphere.intersect(&ray, f32::INFINITY) else {
                    continue;
                };
                let outside = math::lt_zero(ray.dir.dot(ray.at(t) - sphere.center));
                if outside && near.is_none_or(|(tn, ..)| math::lt(t, tn)) {
                    near = Some((t, l, le));
                }
            }
            if let Some((t, l, le)) = near
                && !scene.occluded(&ray, t, ObjectId::NONE, ObjectId::sphere(usize::from(l)))
            {
                sum += le;
                hits += 1;
            }
        }
        (sum, hits)
    }

    /// The camera ray of sample `index` of pixel (x, y): the ray that
    /// [`Renderer::sample`] traces first (to test the camera as it renders).
    pub fn camera_ray(&self, x: u32, y: u32, index: u32) -> Ray {
        let pixel = self.pixel_sampler(x, y);
        self.primary_ray(&mut pixel.stream(index), x, y)
    }

    /// The camera ray of a sample from its stream: the film position from
    /// the stream's pixel pair, and with a lens the lens position from
    /// stratified pair [`LENS_PAIR`] (or the next two independent numbers
    /// when unstratified, which only a lens draws). A pinhole draws exactly
    /// what it drew before lenses existed, so its images are unchanged.
    #[inline(always)]
    fn primary_ray(&self, s: &mut SampleStream<'_>, x: u32, y: u32) -> Ray {
        self.camera_ray_from(s, x, y, self.options.stratified)
    }

    /// [`Renderer::primary_ray`], stratified or not as asked (the
    /// measuring rays of [`Renderer::lights_seen`] always are).
    #[inline(always)]
    fn camera_ray_from(&self, s: &mut SampleStream<'_>, x: u32, y: u32, stratified: bool) -> Ray {
        let [u, v] = if stratified {
            s.stratified_2d(0)
        } else {
            s.next_2d()
        };
        let (fx, fy) = (x as f32 + u, y as f32 + v);
        #[cfg(feature = "lens")]
        if self.camera.has_lens() {
            let lens = if stratified {
                s.stratified_2d(LENS_PAIR)
            } else {
                s.next_2d()
            };
            return self.camera.lens_ray(fx, fy, lens);
        }
        self.camera.ray(fx, fy)
    }

    /// Adds samples `first .. first + count` of every pixel of `tile` to
    /// `sums` (row-major within the tile, `tile.len()` entries), each pixel's
    /// samples in increasing order, so that any split of a pixel's samples
    /// into calls gives the same sums bit for bit.
    pub fn accumulate_tile(
        &self,
        tile: &Tile,
        first: u32,
        count: u32,
        sums: &mut [Color],
        stats: &mut Stats,
    ) {
        // a tile of width 0 has no pixels; max(1) only spares the division
        // a zero check (and the firmware a panic path)
        let w = tile.w.max(1);
        for (i, acc) in sums.iter_mut().take(tile.len()).enumerate() {
            let i = i as u32;
            let (x, y) = (tile.x.saturating_add(i % w), tile.y.saturating_add(i / w));
            let pixel = self.pixel(x, y);
            for k in first..first.saturating_add(count) {
                *acc += self.sample_in(&pixel, x, y, k, stats);
            }
        }
    }

    /// Renders `tile` with `spp` samples per pixel and writes each pixel's
    /// mean radiance to `out` (row-major within the tile).
    pub fn render_tile(&self, tile: &Tile, spp: u32, out: &mut [Color], stats: &mut Stats) {
        for c in out.iter_mut().take(tile.len()) {
            *c = Color::ZERO;
        }
        self.accumulate_tile(tile, 0, spp, out, stats);
        let inv = 1.0 / spp.max(1) as f32;
        for c in out.iter_mut().take(tile.len()) {
            *c *= inv;
        }
    }
}

// the test parses scenes that use mirrors and glass
#[cfg(all(test, feature = "parser", feature = "mirror", feature = "glass"))]
mod tests {
    use super::*;
    use crate::integrator::Skip;

    /// The renderer decides once per render (its `PathPlan`) what
    /// `integrator::radiance` decides per path, and makes the plan again
    /// when the options change: every sample has the bits of `radiance`
    /// called on the same camera ray and stream, with every skip on, with
    /// each off and with none. (cornell: one light; smallpt: a light cut
    /// by its walls, so windows; furnace: no light.)
    #[test]
    fn the_per_render_plan_decides_as_each_path_would() {
        let mut skips = [Skip::ALL; 12];
        skips[1] = Skip::NONE;
        let offs: [fn(&mut Skip); 10] = [
            |s| s.shadow_occluders = false,
            |s| s.view_culling = false,
            |s| s.specialize = false,
            |s| s.horizon = false,
            |s| s.unreachable_lights = false,
            |s| s.closed = false,
            |s| s.slabs = false,
            |s| s.bvh = false,
            |s| s.windows = false,
            |s| s.whole_light = false,
        ];
        for (skip, off) in skips.iter_mut().skip(2).zip(offs) {
            off(skip);
        }
        for (text, lights, windows) in [
            (include_str!("../scenes/cornell.scene"), 1, false),
            (include_str!("../scenes/smallpt.scene"), 1, true),
            (include_str!("../scenes/furnace.scene"), 0, false),
        ] {
            let scene: Scene<16, 8, 8> = crate::parse::parse_with_capacity(text).unwrap();
            assert_eq!(scene.lights().len(), lights);
            assert_eq!(!scene.analysis().windows.is_empty(), windows);
            for skip in skips {
                let options = Options {
                    skip,
                    ..Options::default()
                };
                let r = Renderer::new(&scene, 12, 9).unwrap().options(options);
                let mut stats = Stats::default();
                for (x, y, i) in [(0, 0, 0), (5, 4, 3), (11, 8, 7), (6, 2, 15)] {
                    let planned = r.sample(x, y, i, &mut stats);
                    let pixel = r.pixel_sampler(x, y);
                    let mut s = pixel.stream(i);
                    let ray = r.primary_ray(&mut s, x, y);
                    let per_path =
                        integrator::radiance(r.scene(), ray, &mut s, &options, &mut stats);
                    let bits = |c: Color| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()];
                    assert_eq!(bits(planned), bits(per_path), "{skip:?} ({x}, {y}) #{i}");
                }
            }
        }
    }
}
