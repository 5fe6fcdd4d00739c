//! The fixed-capacity scene, one module per part: [`builder`] checks every
//! value as a scene is built, this module holds the validated storage, the
//! load-time analysis lives in [`crate::analysis`], and [`query`] is how a
//! ray finds its hit (closest hit and occlusion, over the analysis' lists).

pub mod builder;
pub mod bvh;
pub mod query;

pub use crate::error::SceneError;
pub use builder::{MaterialId, SceneBuilder};
pub use query::SceneView;

use crate::analysis::{Analysis, Slabs};
use crate::camera::CameraSpec;
use crate::geometry::{Color, ObjectId, Plane, Sphere, Vec3};
use crate::material::Material;
use bvh::Bvh;
use heapless::Vec;

/// Default capacity: spheres.
pub const MAX_SPHERES: usize = 128;
/// Default capacity: planes.
pub const MAX_PLANES: usize = 16;
/// Default capacity: materials.
pub const MAX_MATERIALS: usize = 32;

/// Largest capacity of each kind (spheres, planes, materials) a scene type
/// may have. An object's id is a 15-bit index with a plane flag (all ones
/// meaning "nothing"), and lights and materials are listed by `u16` index:
/// a larger capacity would give two objects one id. A `Scene` or
/// `SceneBuilder` type with a larger capacity does not compile:
///
/// ```compile_fail,E0080
/// let too_big: micropt::SceneBuilder<40_000, 1, 1> = micropt::SceneBuilder::new();
/// ```
pub const MAX_CAPACITY: usize = 0x7fff;

/// Largest width or height of an image a scene's `resolution` may give
/// (the host's renderer and its `--size` share the limit).
pub const MAX_SIDE: u32 = 16_384;
/// Most pixels in an image a scene's `resolution` may give (8192 × 4096;
/// about 1.2 GB of the host's accumulators and image).
pub const MAX_PIXELS: u32 = 1 << 25;

/// Whether capacities `S`, `P`, `M` fit the ids (see [`MAX_CAPACITY`]).
pub(crate) struct Capacities<const S: usize, const P: usize, const M: usize>;

impl<const S: usize, const P: usize, const M: usize> Capacities<S, P, M> {
    /// Evaluated where a scene type is made: a compile error for a capacity
    /// over [`MAX_CAPACITY`].
    pub(crate) const CHECK: () = assert!(
        S <= MAX_CAPACITY && P <= MAX_CAPACITY && M <= MAX_CAPACITY,
        "a micropt scene capacity exceeds micropt::scene::MAX_CAPACITY (32767)"
    );
}

/// [`Scene::EMPTY`]'s camera: all zeros, which
/// [`Renderer::new`](crate::Renderer::new) refuses.
const NO_CAMERA: CameraSpec = CameraSpec {
    eye: Vec3::ZERO,
    target: Vec3::ZERO,
    up: Vec3::ZERO,
    vfov_deg: 0.0,
    aperture: 0.0,
    focus: 0.0,
};

/// A validated scene with fixed capacities (default 128 spheres, 16 planes,
/// 32 materials; choose others with the const parameters).
///
/// ```
/// use micropt::{Scene, SceneBuilder, Material, Vec3, CameraSpec};
/// let mut b: SceneBuilder = SceneBuilder::new();
/// let grey = b.material(Material::Diffuse(Vec3::splat(0.5)))?;
/// b.sphere(Vec3::ZERO, 1.0, grey)?;
/// b.camera(CameraSpec::pinhole(
///     Vec3::new(0.0, 0.0, 4.0),
///     Vec3::ZERO,
///     Vec3::new(0.0, 1.0, 0.0),
///     40.0,
/// ))?;
/// b.background(Vec3::ONE)?;
/// let scene: Scene = b.build()?;
/// assert_eq!(scene.spheres().len(), 1);
/// # Ok::<(), micropt::SceneError>(())
/// ```
#[derive(Clone, Debug)]
pub struct Scene<
    const S: usize = MAX_SPHERES,
    const P: usize = MAX_PLANES,
    const M: usize = MAX_MATERIALS,
> {
    pub(crate) spheres: Vec<Sphere, S>,
    pub(crate) planes: Vec<Plane, P>,
    pub(crate) materials: Vec<Material, M>,
    pub(crate) analysis: Analysis<S, P>,
    pub(crate) bvh: Bvh<S>,
    pub(crate) background: Color,
    pub(crate) camera: CameraSpec,
    pub(crate) resolution: Option<(u32, u32)>,
}

impl<const S: usize, const P: usize, const M: usize> Scene<S, P, M> {
    /// A scene without objects and without a camera, all zero bits: the
    /// slot that [`SceneBuilder::build_into`] and
    /// [`parse_into`](crate::parse::parse_into) fill in place (a `static`
    /// initialised with it goes to `.bss`). It cannot be rendered:
    /// [`Renderer::new`](crate::Renderer::new) refuses its camera.
    pub const EMPTY: Self = {
        let () = Capacities::<S, P, M>::CHECK;
        Self {
            spheres: Vec::new(),
            planes: Vec::new(),
            materials: Vec::new(),
            analysis: Analysis::EMPTY,
            bvh: Bvh::EMPTY,
            background: Color::ZERO,
            camera: NO_CAMERA,
            resolution: None,
        }
    };

    /// Back to [`Scene::EMPTY`], field by field (no temporary of the whole
    /// scene on the stack): what a failed [`parse_into`] leaves.
    ///
    /// [`parse_into`]: crate::parse::parse_into
    #[cfg(feature = "parser")]
    pub(crate) fn clear(&mut self) {
        let Self {
            spheres,
            planes,
            materials,
            analysis,
            bvh,
            background,
            camera,
            resolution,
        } = self;
        spheres.clear();
        planes.clear();
        materials.clear();
        analysis.clear();
        bvh.clear();
        *background = Color::ZERO;
        *camera = NO_CAMERA;
        *resolution = None;
    }

    /// The spheres.
    pub fn spheres(&self) -> &[Sphere] {
        &self.spheres
    }

    /// The planes.
    pub fn planes(&self) -> &[Plane] {
        &self.planes
    }

    /// The materials.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// Indices (into [`Scene::spheres`]) of the emitting spheres that a
    /// path can reach (see [`crate::analysis`]).
    pub fn lights(&self) -> &[u16] {
        &self.analysis.lights
    }

    /// The bounding volume hierarchy over the spheres (empty when the
    /// analysis found that the scene does not need one:
    /// [`crate::analysis::tree_pays`]).
    pub fn bvh(&self) -> &Bvh<S> {
        &self.bvh
    }

    /// Builds the bounding volume hierarchy (`on`) or drops it, whatever
    /// the analysis decided: to measure what the tree costs or saves, and
    /// to test that it changes no hit.
    pub fn set_bvh(&mut self, on: bool) {
        let a = &self.analysis;
        // a firmware for a scene below the threshold has no tree code
        if on && !cfg!(micropt_no_bvh) {
            self.bvh.build(&a.listed_view, &a.shadow_spheres);
        } else {
            self.bvh.clear();
        }
    }

    /// What the load-time analysis found.
    pub fn analysis(&self) -> &Analysis<S, P> {
        &self.analysis
    }

    /// Radiance of rays that hit nothing.
    pub fn background(&self) -> Color {
        self.background
    }

    /// The camera.
    pub fn camera(&self) -> &CameraSpec {
        &self.camera
    }

    /// Moves the camera (a demo's orbit) and makes the load-time analysis
    /// again, since what it proves depends on where the camera is (which
    /// lights face it, whether it is inside a sphere). An invalid camera is
    /// refused and the scene left as it was.
    pub fn set_camera(&mut self, spec: CameraSpec) -> Result<(), crate::camera::CameraError> {
        spec.validate()?;
        self.camera = spec;
        self.analyse();
        Ok(())
    }

    /// The load-time analysis of the scene as it stands (objects and
    /// camera), and the tree if it pays: what finishing a scene and moving
    /// its camera both run.
    pub(crate) fn analyse(&mut self) {
        crate::analysis::analyse_into(
            &mut self.analysis,
            &self.spheres,
            &self.planes,
            &self.materials,
            &self.camera,
        );
        // (a firmware built without the tree's code keeps the empty tree of
        // Scene::EMPTY)
        if !cfg!(micropt_no_bvh) {
            self.set_bvh(crate::analysis::tree_pays(self.analysis.listed_view.len()));
        }
    }

    /// The default image size, if the scene sets one.
    pub fn resolution(&self) -> Option<(u32, u32)> {
        self.resolution
    }

    /// A borrowed view of the scene's arrays, independent of the capacities:
    /// what the integrator works on. `view_cos` is the cosine of the
    /// half-angle of a cone around the view axis that contains every camera
    /// ray (−1: no culling); spheres outside it are left out of primary-ray
    /// tests.
    pub fn view(&self, view_cos: f32) -> SceneView<'_> {
        let a = &self.analysis;
        let visible = a.view_keys.partition_point(|&k| k >= view_cos);
        SceneView {
            spheres: &self.spheres,
            planes: &self.planes,
            materials: &self.materials,
            lights: &a.lights,
            emitters: &a.emitters,
            shadow_spheres: &a.shadow_spheres,
            shadow_planes: &a.shadow_planes,
            primary_spheres: a.view_order.get(..visible).unwrap_or(&a.view_order),
            // no wall at all: no slab test (three divisions a ray)
            slabs: (a.slabs != Slabs::EMPTY).then_some(a.slabs),
            other_planes: &a.other_planes,
            tested: &a.listed_view,
            tested_primary: a.listed_view.get(..visible).unwrap_or(&a.listed_view),
            tested_shadow: &a.listed_shadow,
            light_clear: a.light_clear,
            horizon_planes: a.horizon_planes,
            horizon_spheres: a.horizon_spheres,
            windows: &a.windows,
            shadow_lights: a.listed_shadow.iter().any(|l| {
                a.emitters
                    .iter()
                    .any(|&e| l.id == ObjectId::sphere(e as usize))
            }),
            background: self.background,
            closed: a.closed,
            bvh: self.bvh.view(),
        }
    }
}
