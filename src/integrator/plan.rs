//! What every path of a render decides the same way ([`PathPlan`]: the
//! lights to sample, the one-light variant, the horizon tests, the
//! windows), the scene as one path sees it ([`Ctx`]) and what a path keeps
//! of its last non-delta vertex ([`PrevVertex`]).

use super::Options;
use crate::geometry::{Color, ObjectId, Vec3};
use crate::light::Window;
use crate::material::Material;
use crate::scene::SceneView;

/// Where the last diffuse vertex was, for weighting an emitter that its
/// BSDF sample hits.
#[derive(Clone, Copy)]
pub(super) struct PrevVertex {
    pub(super) point: Vec3,
    pub(super) normal: Vec3,
    pub(super) bsdf_pdf: f32,
    /// Sum of light-selection weights at that vertex, negated where a
    /// glossy lobe chose the light ([`GlossyChoice`] holds the rest).
    pub(super) weight_sum: f32,
    /// With one light: its 1 − cos θ_max seen from that vertex, as
    /// next-event estimation computed it (0: it could not be sampled there),
    /// negated where next-event estimation sampled the light's window,
    /// +∞ where the closed form gave its direct light
    /// ([`super::nee::whole_light`]: a BSDF sample that hits it there adds
    /// nothing).
    pub(super) light_omc: f32,
    /// Whether the horizon test was done there.
    pub(super) horizon: bool,
}

/// What every path of a render decides the same way, from the scene view
/// and the options alone: made once per render ([`PathPlan::new`]; the
/// renderer keeps it) rather than once per path.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PathPlan<'a> {
    /// Emitters that next-event estimation samples.
    pub(super) lights: &'a [u16],
    /// The several-lights variant of the path tracer (or no light at all,
    /// or the `specialize` skip off).
    pub(super) many: bool,
    /// Zero weight for lights entirely below the horizon of a point of a
    /// sphere (bit 0) or of a plane (bit 1): the skip is on and the scene
    /// analysis found it can happen there.
    pub(super) horizon: u16,
    /// The only light, looked up once (scenes with one light).
    pub(super) one: Option<OneLight<'a>>,
    /// Windows of lights cut by a wall (empty with that skip off).
    pub(super) windows: &'a [Window],
    /// The depth from which the depth roulette, or else the cap, acts:
    /// the smaller of [`Options::deep_start`] and [`Options::max_depth`].
    pub(super) deep: u32,
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
        // draws the same numbers. A firmware built for a scene of one light
        // at most (`micropt_one_light`) has only the one-light variant: with
        // no light it draws the same numbers there, and should the scene
        // have several lights after all, it samples none of them (`one` is
        // empty): BSDF sampling alone, unbiased but noisier
        let many = !cfg!(micropt_one_light) && (lights.len() != 1 || !skip.specialize);
        let windows: &[Window] = if cfg!(feature = "windows") && skip.windows {
            scene.windows
        } else {
            &[]
        };
        Self {
            lights,
            many,
            horizon: u16::from(skip.horizon && scene.horizon_spheres)
                | u16::from(skip.horizon && scene.horizon_planes) << 1,
            one: if many || lights.len() != 1 {
                None
            } else {
                OneLight::first(scene, lights, windows).map(|mut one| {
                    // the closed form's occluders are the shadow rays' lists
                    // (spheres only, no tree); a light cut by a wall keeps
                    // its window
                    one.whole = skip.whole_light
                        && skip.shadow_occluders
                        && skip.unreachable_lights
                        && scene.shadow_planes.is_empty()
                        && !scene.shadow_lights
                        && scene.bvh.is_none()
                        && one.window.is_none();
                    one
                })
            },
            windows,
            deep: if opts.deep_start < opts.max_depth {
                opts.deep_start
            } else {
                opts.max_depth
            },
        }
    }
}

/// The scene as one path sees it: the view plus the render's plan.
pub(super) struct Ctx<'v, 'a> {
    pub(super) scene: &'v SceneView<'a>,
    pub(super) plan: &'v PathPlan<'a>,
    /// The (mirror, light) pairs whose emission right after the camera's
    /// mirror [`crate::highlight`] estimates instead.
    #[cfg(feature = "highlight")]
    pub(super) highlights: Option<&'v crate::highlight::Highlights>,
    /// The spheres whose caustics the first non-delta vertex samples
    /// ([`crate::caustic`]; empty when off).
    #[cfg(feature = "highlight")]
    pub(super) caustics: &'v [u16],
}

/// What next-event estimation needs of a scene's only light.
#[derive(Clone, Copy, Debug)]
pub(super) struct OneLight<'a> {
    pub(super) sphere: usize,
    pub(super) center: Vec3,
    pub(super) radius: f32,
    pub(super) radius2: f32,
    pub(super) le: Color,
    pub(super) window: Option<&'a Window>,
    /// Whether the closed form of [`super::nee::whole_light`] may replace
    /// the light sample ([`super::Skip::whole_light`]): the shadow rays'
    /// occluders are the spheres of [`SceneView::tested_shadow`] alone, and
    /// none of them emits.
    pub(super) whole: bool,
}

impl<'a> OneLight<'a> {
    /// The first of `lights`, if it is an emitting sphere.
    #[inline(always)]
    pub(super) fn first(
        scene: &SceneView<'_>,
        lights: &[u16],
        windows: &'a [Window],
    ) -> Option<Self> {
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
            whole: false,
        })
    }
}

impl<'a> Ctx<'_, 'a> {
    /// The windows in force. Without the `windows` feature none, as a
    /// constant: such a build has no window code.
    #[inline(always)]
    pub(super) fn windows(&self) -> &'a [Window] {
        if cfg!(feature = "windows") {
            self.plan.windows
        } else {
            &[]
        }
    }

    /// The only light's window (see [`Ctx::windows`]).
    #[inline(always)]
    pub(super) fn window_of_one(one: &OneLight<'a>) -> Option<&'a Window> {
        if cfg!(feature = "windows") {
            one.window
        } else {
            None
        }
    }

    pub(super) fn light_lum(&self, sphere: usize) -> f32 {
        let s = &self.scene;
        s.spheres
            .get(sphere)
            .and_then(|x| s.materials.get(x.material as usize))
            .and_then(Material::emission)
            .map_or(0.0, |le| le.luminance())
    }

    /// Whether the horizon test is worth doing on `object`.
    #[inline(always)]
    pub(super) fn horizon_at(&self, object: ObjectId) -> bool {
        // one bit per kind of surface: no branch on the id
        (self.plan.horizon >> (object.0 >> 15)) & 1 != 0
    }

    /// Whether light sphere `i` can be sampled from `x` with normal `n`:
    /// `x` outside it and (with `horizon`) not all of it below the
    /// tangent plane, `n · (c − x) < −r`.
    /// Returns the vector to the centre, its squared length and the
    /// squared radius.
    #[inline(always)]
    pub(super) fn samplable(
        &self,
        x: Vec3,
        n: Vec3,
        i: usize,
        horizon: bool,
    ) -> Option<(Vec3, f32, f32)> {
        let s = self.scene.spheres.get(i)?;
        let to_c = s.center - x;
        let d2 = to_c.length_squared();
        if !(d2 > s.radius2) || (horizon && n.dot(to_c) < -s.radius) {
            return None;
        }
        Some((to_c, d2, s.radius2))
    }
}

/// The window of light sphere `i`, if a wall cuts it.
#[inline(always)]
pub(super) fn window_of(windows: &[Window], i: usize) -> Option<&Window> {
    windows.iter().find(|w| w.light as usize == i)
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
pub(super) fn deep_roulette(
    depth: u32,
    opts: &Options,
    stream: &mut crate::sampler::SampleStream<'_>,
    stats: &mut crate::stats::Stats,
) -> Option<f32> {
    if depth >= opts.max_depth {
        stats.truncated += 1;
        return None;
    }
    (stream.next_f32() < opts.deep_survival).then_some(1.0 / opts.deep_survival)
}
