//! The fixed-capacity scene: objects, materials, lights, camera, validated
//! on construction, and the two ray queries (closest hit, occlusion).

use crate::analysis::{Analysis, Listed, Slabs, analyse_into};
use crate::camera::{CameraError, CameraSpec};
use crate::geometry::{Color, Hit, ObjectId, Plane, Ray, Sphere, Vec3};
use crate::material::Material;
use crate::math;
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

/// A material handle returned by [`SceneBuilder::material`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialId(pub(crate) u16);

/// What is wrong with a scene built in code (the parser maps these to
/// line-numbered [`crate::parse::ParseError`]s).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneError {
    /// More objects of this kind than the build's fixed capacity.
    Capacity(&'static str),
    /// A value outside its allowed range; names the quantity.
    OutOfRange(&'static str),
    /// A `resolution` that is zero or larger than [`MAX_SIDE`] per side or
    /// [`MAX_PIXELS`] in all.
    Resolution,
    /// A value that is NaN or infinite.
    NotFinite,
    /// A material handle from another scene, or out of range.
    UnknownMaterial,
    /// A plane with a light material (an infinite emitter).
    LightOnPlane,
    /// The scene has no camera.
    NoCamera,
    /// A second camera.
    SecondCamera,
    /// The camera specification is invalid.
    Camera(CameraError),
    /// A material kind (`"mirror"`, `"glass"`) whose code this build left
    /// out (its cargo feature is off).
    MaterialNotBuilt(&'static str),
}

impl core::fmt::Display for SceneError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            // `write_str` pieces rather than `{what}`: a `{}` of a `&str`
            // links the formatter's padding code into the firmware
            // (docs/firmware.md)
            SceneError::Capacity(what) => {
                f.write_str("too many ")?;
                f.write_str(what)?;
                f.write_str(" (fixed capacity of this build)")
            }
            SceneError::OutOfRange(what) => {
                f.write_str(what)?;
                f.write_str(" out of range")
            }
            SceneError::Resolution => f.write_str(RESOLUTION_LIMITS),
            SceneError::NotFinite => f.write_str("value is not finite"),
            SceneError::UnknownMaterial => f.write_str("unknown material"),
            SceneError::LightOnPlane => {
                f.write_str("a plane cannot use a light material (infinite emitter)")
            }
            SceneError::NoCamera => f.write_str("the scene has no camera"),
            SceneError::SecondCamera => f.write_str("a second camera (exactly one is allowed)"),
            SceneError::Camera(CameraError::EyeEqualsTarget) => {
                f.write_str("camera eye equals target")
            }
            SceneError::Camera(CameraError::UpParallelToView) => {
                f.write_str("camera up vector is zero or parallel to the view direction")
            }
            SceneError::Camera(CameraError::FovOutOfRange) => {
                f.write_str("vertical field of view must be in (0, 180) degrees")
            }
            SceneError::Camera(CameraError::NotFinite) => f.write_str("camera value is not finite"),
            SceneError::MaterialNotBuilt(kind) => {
                f.write_str(kind)?;
                f.write_str(" materials are not in this build (enable micropt's `")?;
                f.write_str(kind)?;
                f.write_str("` cargo feature)")
            }
        }
    }
}

/// The message of [`SceneError::Resolution`] (a literal, checked against
/// the constants by a test: formatting the numbers would link the formatter's
/// padding code into a board's flash).
const RESOLUTION_LIMITS: &str =
    "resolution out of range: each side from 1 to 16384, at most 33554432 pixels in all";

/// Whether capacities `S`, `P`, `M` fit the ids (see [`MAX_CAPACITY`]).
struct Capacities<const S: usize, const P: usize, const M: usize>;

impl<const S: usize, const P: usize, const M: usize> Capacities<S, P, M> {
    /// Evaluated where a scene type is made: a compile error for a capacity
    /// over [`MAX_CAPACITY`].
    const CHECK: () = assert!(
        S <= MAX_CAPACITY && P <= MAX_CAPACITY && M <= MAX_CAPACITY,
        "a micropt scene capacity exceeds micropt::scene::MAX_CAPACITY (32767)"
    );
}

/// A validated scene with fixed capacities (default 128 spheres, 16 planes,
/// 32 materials; choose others with the const parameters).
///
/// ```
/// use micropt::{Scene, SceneBuilder, Material, Vec3, CameraSpec};
/// let mut b: SceneBuilder = SceneBuilder::new();
/// let grey = b.material(Material::Diffuse(Vec3::splat(0.5)))?;
/// b.sphere(Vec3::ZERO, 1.0, grey)?;
/// b.camera(CameraSpec {
///     eye: Vec3::new(0.0, 0.0, 4.0),
///     target: Vec3::ZERO,
///     up: Vec3::new(0.0, 1.0, 0.0),
///     vfov_deg: 40.0,
/// })?;
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
    spheres: Vec<Sphere, S>,
    planes: Vec<Plane, P>,
    materials: Vec<Material, M>,
    analysis: Analysis<S, P>,
    background: Color,
    camera: CameraSpec,
    resolution: Option<(u32, u32)>,
}

/// Builds a [`Scene`] in code, checking every value as it is added.
#[derive(Clone, Debug)]
pub struct SceneBuilder<
    const S: usize = MAX_SPHERES,
    const P: usize = MAX_PLANES,
    const M: usize = MAX_MATERIALS,
> {
    spheres: Vec<Sphere, S>,
    planes: Vec<Plane, P>,
    materials: Vec<Material, M>,
    background: Color,
    camera: Option<CameraSpec>,
    resolution: Option<(u32, u32)>,
}

impl<const S: usize, const P: usize, const M: usize> Default for SceneBuilder<S, P, M> {
    fn default() -> Self {
        Self::new()
    }
}

fn check_finite(v: Vec3) -> Result<(), SceneError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SceneError::NotFinite)
    }
}

fn check_unit_range(c: Color, what: &'static str) -> Result<(), SceneError> {
    check_finite(c)?;
    for v in [c.x, c.y, c.z] {
        if !(0.0..=1.0).contains(&v) {
            return Err(SceneError::OutOfRange(what));
        }
    }
    Ok(())
}

fn check_non_negative(c: Color, what: &'static str) -> Result<(), SceneError> {
    check_finite(c)?;
    if c.x >= 0.0 && c.y >= 0.0 && c.z >= 0.0 {
        Ok(())
    } else {
        Err(SceneError::OutOfRange(what))
    }
}

impl<const S: usize, const P: usize, const M: usize> SceneBuilder<S, P, M> {
    /// An empty scene: no objects, black background, no camera yet.
    pub const fn new() -> Self {
        let () = Capacities::<S, P, M>::CHECK;
        Self {
            spheres: Vec::new(),
            planes: Vec::new(),
            materials: Vec::new(),
            background: Vec3::ZERO,
            camera: None,
            resolution: None,
        }
    }

    /// Adds a material after checking its values (albedo and tint in [0, 1],
    /// IOR > 0, radiance ≥ 0). A mirror or glass material in a build without
    /// its cargo feature is [`SceneError::MaterialNotBuilt`]: the renderer
    /// has no code for it.
    pub fn material(&mut self, m: Material) -> Result<MaterialId, SceneError> {
        match m {
            Material::Diffuse(c) => check_unit_range(c, "albedo")?,
            Material::Mirror(_) if !cfg!(feature = "mirror") => {
                return Err(SceneError::MaterialNotBuilt("mirror"));
            }
            Material::Glass(_) if !cfg!(feature = "glass") => {
                return Err(SceneError::MaterialNotBuilt("glass"));
            }
            Material::Mirror(c) => check_unit_range(c, "mirror reflectance")?,
            Material::Glass(ior) => {
                if !ior.is_finite() {
                    return Err(SceneError::NotFinite);
                }
                if !(ior > 0.0) {
                    return Err(SceneError::OutOfRange("index of refraction"));
                }
            }
            Material::Light(c) => check_non_negative(c, "radiance")?,
        }
        let id = self.materials.len() as u16;
        self.materials
            .push(m)
            .map_err(|_| SceneError::Capacity("materials"))?;
        Ok(MaterialId(id))
    }

    fn lookup(&self, m: MaterialId) -> Result<&Material, SceneError> {
        self.materials
            .get(m.0 as usize)
            .ok_or(SceneError::UnknownMaterial)
    }

    /// Adds a sphere (radius > 0).
    pub fn sphere(
        &mut self,
        center: Vec3,
        radius: f32,
        m: MaterialId,
    ) -> Result<ObjectId, SceneError> {
        self.sphere_precise(center, Vec3::ZERO, radius, 0.0, m)
    }

    /// Adds a sphere of centre `center + center_lo` and radius
    /// `radius + radius_lo`: f32 values and the remainders of exact ones
    /// (see [`Sphere::with_residuals`]; the parser gives them for every
    /// decimal). Only huge spheres, whose centre's rounding is a visible
    /// distance in the scene, need them.
    pub fn sphere_precise(
        &mut self,
        center: Vec3,
        center_lo: Vec3,
        radius: f32,
        radius_lo: f32,
        m: MaterialId,
    ) -> Result<ObjectId, SceneError> {
        check_finite(center)?;
        if !radius.is_finite() {
            return Err(SceneError::NotFinite);
        }
        if !(radius > 0.0) {
            return Err(SceneError::OutOfRange("radius"));
        }
        if !(radius * radius).is_normal() {
            return Err(SceneError::OutOfRange(
                "radius (its square must be a normal f32)",
            ));
        }
        self.lookup(m)?;
        let id = ObjectId::sphere(self.spheres.len());
        self.spheres
            .push(Sphere::with_residuals(
                center, center_lo, radius, radius_lo, m.0,
            ))
            .map_err(|_| SceneError::Capacity("spheres"))?;
        Ok(id)
    }

    /// Adds an infinite two-sided plane through `point` with normal `normal`
    /// (any non-zero length). A light material is rejected.
    pub fn plane(
        &mut self,
        point: Vec3,
        normal: Vec3,
        m: MaterialId,
    ) -> Result<ObjectId, SceneError> {
        check_finite(point)?;
        check_finite(normal)?;
        let len2 = normal.length_squared();
        if !(len2 > 0.0) || !len2.is_normal() {
            // zero, or so small/large that normalising would fail
            let n = normal * (1.0 / normal.abs().max_component());
            if !(n.length_squared() > 0.0) || !n.is_finite() {
                return Err(SceneError::OutOfRange("plane normal (zero)"));
            }
            return self.plane(point, n, m);
        }
        if let Material::Light(_) = self.lookup(m)? {
            return Err(SceneError::LightOnPlane);
        }
        let id = ObjectId::plane(self.planes.len());
        self.planes
            .push(Plane::new(point, normal, m.0))
            .map_err(|_| SceneError::Capacity("planes"))?;
        Ok(id)
    }

    /// Sets the camera (exactly once).
    pub fn camera(&mut self, spec: CameraSpec) -> Result<(), SceneError> {
        if self.camera.is_some() {
            return Err(SceneError::SecondCamera);
        }
        spec.validate().map_err(SceneError::Camera)?;
        self.camera = Some(spec);
        Ok(())
    }

    /// Sets the radiance of rays that hit nothing (default black).
    pub fn background(&mut self, c: Color) -> Result<(), SceneError> {
        check_non_negative(c, "background radiance")?;
        self.background = c;
        Ok(())
    }

    /// Sets the default image size: each side in 1..=[`MAX_SIDE`], at most
    /// [`MAX_PIXELS`] in all (else [`SceneError::Resolution`]).
    pub fn resolution(&mut self, width: u32, height: u32) -> Result<(), SceneError> {
        let pixels = u64::from(width) * u64::from(height);
        if width == 0
            || height == 0
            || width > MAX_SIDE
            || height > MAX_SIDE
            || pixels > u64::from(MAX_PIXELS)
        {
            return Err(SceneError::Resolution);
        }
        self.resolution = Some((width, height));
        Ok(())
    }

    /// Number of spheres added so far.
    pub fn sphere_count(&self) -> usize {
        self.spheres.len()
    }

    /// Finishes the scene: requires a camera, and analyses what work the
    /// scene can never need ([`crate::analysis`]).
    pub fn build(self) -> Result<Scene<S, P, M>, SceneError> {
        let mut scene = Scene::EMPTY;
        self.build_into(&mut scene)?;
        Ok(scene)
    }

    /// [`SceneBuilder::build`] into `scene` (all of it replaced; unchanged
    /// on error), in place: the scene is never on the stack, only this
    /// builder. With `scene` in static memory (e.g. a `static` initialised
    /// with [`Scene::EMPTY`]) a board builds a large scene in a stack of
    /// about the builder's size.
    pub fn build_into(self, scene: &mut Scene<S, P, M>) -> Result<(), SceneError> {
        let camera = self.camera.ok_or(SceneError::NoCamera)?;
        scene.spheres = self.spheres;
        scene.planes = self.planes;
        scene.materials = self.materials;
        scene.background = self.background;
        scene.camera = camera;
        scene.resolution = self.resolution;
        analyse_into(
            &mut scene.analysis,
            &scene.spheres,
            &scene.planes,
            &scene.materials,
            &scene.camera,
        );
        Ok(())
    }
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
            background: Color::ZERO,
            camera: CameraSpec {
                eye: Vec3::ZERO,
                target: Vec3::ZERO,
                up: Vec3::ZERO,
                vfov_deg: 0.0,
            },
            resolution: None,
        }
    };

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
        }
    }
}

/// The arrays of a [`Scene`] and its analysis, borrowed; ray queries live
/// here.
#[derive(Clone, Copy, Debug)]
pub struct SceneView<'a> {
    /// The spheres.
    pub spheres: &'a [Sphere],
    /// The planes.
    pub planes: &'a [Plane],
    /// The materials.
    pub materials: &'a [Material],
    /// Indices of reachable emitting spheres.
    pub lights: &'a [u16],
    /// Indices of all emitting spheres.
    pub emitters: &'a [u16],
    /// Spheres that can block a shadow ray.
    pub shadow_spheres: &'a [u16],
    /// Planes that can block a shadow ray.
    pub shadow_planes: &'a [u16],
    /// Spheres a camera ray can hit.
    pub primary_spheres: &'a [u16],
    /// The walls tested one per axis ([`Slabs`]); `None` when the scene has
    /// no opaque axis-aligned plane.
    pub slabs: Option<Slabs>,
    /// The planes that are not in `slabs`.
    pub other_planes: &'a [u16],
    /// The spheres (copies with their ids) that bounce rays test, in the
    /// analysis' view order.
    pub tested: &'a [Listed],
    /// The spheres that camera rays test (`primary_spheres`).
    pub tested_primary: &'a [Listed],
    /// The spheres that shadow rays test (`shadow_spheres`).
    pub tested_shadow: &'a [Listed],
    /// Some sphere of `tested_shadow` is an emitter (a shadow ray's target
    /// must then be skipped by id).
    pub shadow_lights: bool,
    /// One light, and no occluder of the lists reaches into it
    /// ([`crate::analysis::Analysis::light_clear`]).
    pub light_clear: bool,
    /// A light can lie entirely below the horizon of a point of a diffuse
    /// plane ([`crate::analysis::Analysis::horizon_planes`]).
    pub horizon_planes: bool,
    /// The same for diffuse spheres.
    pub horizon_spheres: bool,
    /// Windows of the reachable lights that an opaque wall cuts.
    pub windows: &'a [crate::light::Window],
    /// Background radiance.
    pub background: Color,
    /// No ray can escape (the background is never seen).
    pub closed: bool,
}

/// Records the hit of the slab plane along one axis (origin and direction
/// components `o`, `d`; the axis' planes `c` and `ids` as in [`Slabs`]) if it
/// is nearer than `t_best`. The ray parameter is bit for bit
/// [`Plane::intersect`]'s. The side is the sign bit of `d`, used as an index
/// (a load, not a branch the processor would have to guess): for `d = ±0`
/// either plane gives t = ±∞, never a hit, as in [`Plane::intersect`].
#[inline(always)]
fn slab_axis(
    o: f32,
    d: f32,
    c: &[f32; 2],
    ids: &[ObjectId; 2],
    t_best: &mut f32,
    best: &mut ObjectId,
) {
    let side = (d.to_bits() >> 31) as usize;
    let (Some(&c), Some(&id)) = (c.get(side), ids.get(side)) else {
        return;
    };
    let t = (c - o) / d;
    // t_best > 0: +∞ or an earlier hit
    if math::positive_below_positive(t, *t_best) {
        *t_best = t;
        *best = id;
    }
}

/// The nearest hit among the `slabs` (if given), `planes` (an index
/// iterator) and `spheres`, skipping the surface the ray leaves. Planes come
/// first, so that spheres beyond the nearest wall are rejected early.
#[inline(always)]
fn nearest<'p>(
    slabs: Option<&Slabs>,
    planes: impl Iterator<Item = (usize, &'p Plane)>,
    spheres: &[Listed],
    all_planes: &[Plane],
    ray: &Ray,
    from: ObjectId,
) -> Option<Hit> {
    let mut t_best = f32::INFINITY;
    let mut best = ObjectId::NONE;
    if let Some(sl) = slabs {
        let (o, d) = (ray.origin, ray.dir);
        let [cx, cy, cz] = &sl.c;
        let [ix, iy, iz] = &sl.id;
        slab_axis(o.x, d.x, cx, ix, &mut t_best, &mut best);
        slab_axis(o.y, d.y, cy, iy, &mut t_best, &mut best);
        slab_axis(o.z, d.z, cz, iz, &mut t_best, &mut best);
    }
    for (i, p) in planes {
        let id = ObjectId::plane(i);
        if id == from {
            continue;
        }
        if let Some(t) = p.intersect(ray, t_best) {
            t_best = t;
            best = id;
        }
    }
    // a sphere at exactly the nearest plane's distance wins the tie
    // (spheres take precedence although planes are tested first): accept
    // t ≤ t_best, i.e. t < the next float above it
    let mut t_max = math::next_up_positive(t_best);
    // two copies of the sphere loop: rays that do not leave a sphere (from
    // the camera or a wall) compare no ids
    let hit_sphere = if from.as_sphere().is_some() {
        nearest_sphere::<true>(spheres, ray, &mut t_max, from)
    } else {
        nearest_sphere::<false>(spheres, ray, &mut t_max, from)
    };
    if let Some(l) = hit_sphere {
        Some(l.sphere.hit(ray, t_max, l.id))
    } else if let Some(i) = best.as_plane() {
        all_planes.get(i).map(|p| p.hit(ray, t_best, best))
    } else {
        None
    }
}

/// The nearest of `spheres` that `ray` hits before `t_max` (which becomes
/// its distance); `from` (if `FROM`) is tested from its surface.
#[inline(always)]
fn nearest_sphere<'l, const FROM: bool>(
    spheres: &'l [Listed],
    ray: &Ray,
    t_max: &mut f32,
    from: ObjectId,
) -> Option<&'l Listed> {
    let mut hit = None;
    for l in spheres {
        let t = if FROM && l.id == from {
            l.sphere.intersect_from_surface(ray, *t_max)
        } else {
            l.sphere.intersect(ray, *t_max)
        };
        if let Some(t) = t {
            *t_max = t;
            hit = Some(l);
        }
    }
    hit
}

/// The objects of `all` named by the index list `ids`.
#[inline(always)]
fn listed<'a, T>(ids: &'a [u16], all: &'a [T]) -> impl Iterator<Item = (usize, &'a T)> + 'a {
    ids.iter()
        .filter_map(move |&i| all.get(i as usize).map(|o| (i as usize, o)))
}

impl SceneView<'_> {
    /// The closest intersection of `ray` in `(0, ∞)`, for a ray that starts
    /// where a path can be (on the camera's side of every opaque plane: every
    /// ray the integrator traces); the walls are tested as [`Slabs`]. `from`
    /// is the object the ray leaves (or [`ObjectId::NONE`]): a plane is never
    /// hit again by a ray leaving it, and a sphere only on its far side if
    /// the ray enters it.
    #[inline(always)]
    pub fn closest_hit(&self, ray: &Ray, from: ObjectId) -> Option<Hit> {
        self.closest_hit_among(ray, from, self.tested)
    }

    /// [`SceneView::closest_hit`] among the spheres `spheres` only (a
    /// sub-list of [`SceneView::tested`], e.g. [`SceneView::tested_primary`]
    /// for a camera ray). The integrator calls this one query for every ray,
    /// choosing the list, so that its code is inlined once.
    #[inline(always)]
    pub fn closest_hit_among(&self, ray: &Ray, from: ObjectId, spheres: &[Listed]) -> Option<Hit> {
        nearest(
            self.slabs.as_ref(),
            listed(self.other_planes, self.planes),
            spheres,
            self.planes,
            ray,
            from,
        )
    }

    /// [`SceneView::closest_hit`] for any ray: every plane is tested on its
    /// own (no slabs). Not inlined: the integrator uses it only when
    /// [`crate::Skip::slabs`] is off.
    #[inline(never)]
    pub fn closest_hit_any(&self, ray: &Ray, from: ObjectId) -> Option<Hit> {
        self.closest_hit_any_among(ray, from, self.tested)
    }

    /// [`SceneView::closest_hit_any`] among the spheres `spheres` only.
    ///
    /// Planes at the same ray parameter (in f32, planes far apart tie at a
    /// great distance: two parallel walls a unit apart seen from 1e7 away)
    /// are resolved as [`SceneView::closest_hit_among`] resolves them, so
    /// that the slab skip changes no bit: the slab planes the ray moves
    /// toward first (axes x, y, z), then every other plane in index order.
    #[inline(never)]
    pub fn closest_hit_any_among(
        &self,
        ray: &Ray,
        from: ObjectId,
        spheres: &[Listed],
    ) -> Option<Hit> {
        let mut first = [ObjectId::NONE; 3];
        if let Some(sl) = &self.slabs {
            let d = [ray.dir.x, ray.dir.y, ray.dir.z];
            for ((f, ids), dk) in first.iter_mut().zip(&sl.id).zip(d) {
                if let Some(&id) = ids.get((dk.to_bits() >> 31) as usize) {
                    *f = id;
                }
            }
        }
        let slab_planes = first.into_iter().filter_map(|id| id.as_plane());
        let rest = (0..self.planes.len()).filter(move |&i| !first.contains(&ObjectId::plane(i)));
        nearest(
            None,
            slab_planes
                .chain(rest)
                .filter_map(|i| self.planes.get(i).map(|p| (i, p))),
            spheres,
            self.planes,
            ray,
            from,
        )
    }

    /// Whether anything but the objects `from` (where the ray starts) and
    /// `target` (the light it aims at) blocks `ray` before `t_max`. Only the
    /// objects that the analysis found able to block a shadow ray toward a
    /// reachable light are tested.
    #[inline(always)]
    pub fn occluded(&self, ray: &Ray, t_max: f32, from: ObjectId, target: ObjectId) -> bool {
        blocked(
            self.tested_shadow,
            listed(self.shadow_planes, self.planes),
            ray,
            t_max,
            from,
            target,
            self.shadow_lights,
        )
    }

    /// [`SceneView::occluded`], not inlined: for the integrator's
    /// several-lights variant, where a second inlined copy of the test costs
    /// flash and, on the board, time (docs/bench.md).
    #[inline(never)]
    pub fn occluded_outlined(
        &self,
        ray: &Ray,
        t_max: f32,
        from: ObjectId,
        target: ObjectId,
    ) -> bool {
        self.occluded(ray, t_max, from, target)
    }

    /// [`SceneView::occluded`] testing every object (no analysis). Not
    /// inlined: the integrator uses it only with skips off.
    #[inline(never)]
    pub fn occluded_by_any(&self, ray: &Ray, t_max: f32, from: ObjectId, target: ObjectId) -> bool {
        blocked(
            self.tested,
            self.planes.iter().enumerate(),
            ray,
            t_max,
            from,
            target,
            true,
        )
    }
}

/// Whether any of `spheres` and `planes` but `from` and `target` blocks
/// `ray` before `t_max`.
#[inline(always)]
fn blocked<'p>(
    spheres: &[Listed],
    planes: impl Iterator<Item = (usize, &'p Plane)>,
    ray: &Ray,
    t_max: f32,
    from: ObjectId,
    target: ObjectId,
    check_target: bool,
) -> bool {
    // copies of the sphere loop, so that the common cases (no light in the
    // list; leaving a wall) compare fewer ids
    let hit = match (from.as_sphere().is_some(), check_target) {
        (false, false) => spheres_block::<false, false>(spheres, ray, t_max, from, target),
        (true, false) => spheres_block::<true, false>(spheres, ray, t_max, from, target),
        _ => spheres_block::<true, true>(spheres, ray, t_max, from, target),
    };
    if hit {
        return true;
    }
    for (i, p) in planes {
        if ObjectId::plane(i) != from && p.intersect(ray, t_max).is_some() {
            return true;
        }
    }
    false
}

/// Whether a sphere of `spheres` but `target` (if `TARGET`) blocks `ray`
/// before `t_max`; `from` is tested from its surface (if `FROM`: otherwise
/// the ray does not leave a sphere).
#[inline(always)]
fn spheres_block<const FROM: bool, const TARGET: bool>(
    spheres: &[Listed],
    ray: &Ray,
    t_max: f32,
    from: ObjectId,
    target: ObjectId,
) -> bool {
    for l in spheres {
        if TARGET && l.id == target {
            continue;
        }
        let t = if FROM && l.id == from {
            l.sphere.intersect_from_surface(ray, t_max)
        } else {
            l.sphere.intersect(ray, t_max)
        };
        if t.is_some() {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> CameraSpec {
        CameraSpec {
            eye: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::new(0.0, 1.0, 0.0),
            vfov_deg: 45.0,
        }
    }

    #[test]
    fn resolution_is_bounded_and_the_message_names_the_bounds() {
        use core::fmt::Write;
        let mut b: SceneBuilder<1, 1, 1> = SceneBuilder::new();
        assert_eq!(b.resolution(MAX_SIDE, MAX_PIXELS / MAX_SIDE), Ok(()));
        assert_eq!(b.resolution(1, MAX_SIDE), Ok(()));
        for (w, h) in [
            (0, 1),
            (1, 0),
            (MAX_SIDE + 1, 1),
            (1, MAX_SIDE + 1),
            (MAX_SIDE, MAX_PIXELS / MAX_SIDE + 1),
            (60_000, 60_000),
            (u32::MAX, u32::MAX),
        ] {
            assert_eq!(b.resolution(w, h), Err(SceneError::Resolution), "{w}x{h}");
        }
        let (mut got, mut want) = (
            heapless::String::<128>::new(),
            heapless::String::<128>::new(),
        );
        write!(got, "{}", SceneError::Resolution).unwrap();
        write!(
            want,
            "each side from 1 to {MAX_SIDE}, at most {MAX_PIXELS} pixels"
        )
        .unwrap();
        assert!(got.contains(want.as_str()), "{got}");
    }

    #[test]
    fn the_largest_capacity_fits_the_ids() {
        // the check behind `MAX_CAPACITY` (a larger one fails to compile, see
        // its doc test) and what it protects: the last sphere and plane keep
        // ids of their own, neither of them "nothing"
        let () = Capacities::<MAX_CAPACITY, MAX_CAPACITY, MAX_CAPACITY>::CHECK;
        let (s, p) = (
            ObjectId::sphere(MAX_CAPACITY - 1),
            ObjectId::plane(MAX_CAPACITY - 1),
        );
        assert!(s != p && s != ObjectId::NONE && p != ObjectId::NONE);
        assert!(ObjectId::plane(MAX_CAPACITY) == ObjectId::NONE);
    }

    #[test]
    fn capacity_is_enforced() {
        let mut b: SceneBuilder<2, 1, 1> = SceneBuilder::new();
        let m = b.material(Material::Diffuse(Vec3::splat(0.5))).unwrap();
        assert_eq!(
            b.material(Material::Light(Vec3::ONE)),
            Err(SceneError::Capacity("materials"))
        );
        b.sphere(Vec3::ZERO, 1.0, m).unwrap();
        b.sphere(Vec3::ONE, 1.0, m).unwrap();
        assert_eq!(
            b.sphere(Vec3::ONE, 1.0, m),
            Err(SceneError::Capacity("spheres"))
        );
        b.plane(Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0), m).unwrap();
        assert_eq!(
            b.plane(Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0), m),
            Err(SceneError::Capacity("planes"))
        );
    }

    #[test]
    fn values_are_validated() {
        let mut b: SceneBuilder = SceneBuilder::new();
        assert_eq!(
            b.material(Material::Diffuse(Vec3::new(0.5, 1.5, 0.0))),
            Err(SceneError::OutOfRange("albedo"))
        );
        #[cfg(feature = "glass")]
        assert_eq!(
            b.material(Material::Glass(0.0)),
            Err(SceneError::OutOfRange("index of refraction"))
        );
        assert_eq!(
            b.material(Material::Light(Vec3::new(1.0, -1.0, 0.0))),
            Err(SceneError::OutOfRange("radiance"))
        );
        let lamp = b.material(Material::Light(Vec3::ONE)).unwrap();
        assert_eq!(
            b.sphere(Vec3::ZERO, 0.0, lamp),
            Err(SceneError::OutOfRange("radius"))
        );
        assert_eq!(
            b.plane(Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0), lamp),
            Err(SceneError::LightOnPlane)
        );
        assert_eq!(
            b.plane(Vec3::ZERO, Vec3::ZERO, lamp),
            Err(SceneError::OutOfRange("plane normal (zero)"))
        );
        assert_eq!(
            b.sphere(Vec3::ZERO, 1.0, MaterialId(7)),
            Err(SceneError::UnknownMaterial)
        );
        assert_eq!(b.clone().build().err(), Some(SceneError::NoCamera));
        b.camera(cam()).unwrap();
        assert_eq!(b.camera(cam()), Err(SceneError::SecondCamera));
    }

    /// A build without a material's code refuses the material instead of
    /// rendering it as something else (`cargo test -p micropt --lib
    /// --no-default-features --features parser` runs these).
    #[test]
    fn materials_left_out_of_the_build_are_refused() {
        let mut b: SceneBuilder = SceneBuilder::new();
        let mirror = b.material(Material::Mirror(Vec3::ONE));
        let glass = b.material(Material::Glass(1.5));
        if cfg!(feature = "mirror") {
            assert!(mirror.is_ok());
        } else {
            assert_eq!(mirror, Err(SceneError::MaterialNotBuilt("mirror")));
        }
        if cfg!(feature = "glass") {
            assert!(glass.is_ok());
        } else {
            let e = SceneError::MaterialNotBuilt("glass");
            assert_eq!(glass, Err(e));
            let mut msg: heapless::String<96> = heapless::String::new();
            core::fmt::Write::write_fmt(&mut msg, format_args!("{e}")).unwrap();
            assert_eq!(
                msg,
                "glass materials are not in this build (enable micropt's `glass` cargo feature)"
            );
        }
    }

    #[test]
    fn tiny_plane_normals_are_accepted() {
        let mut b: SceneBuilder = SceneBuilder::new();
        let m = b.material(Material::Diffuse(Vec3::splat(0.5))).unwrap();
        b.plane(Vec3::ZERO, Vec3::new(0.0, 1e-30, 0.0), m).unwrap();
        b.camera(cam()).unwrap();
        let s: Scene = b.build().unwrap();
        assert_eq!(s.planes()[0].normal, Vec3::new(0.0, 1.0, 0.0));
    }

    #[test]
    fn queries_skip_the_surface_a_ray_leaves() {
        let mut b: SceneBuilder = SceneBuilder::new();
        let m = b.material(Material::Diffuse(Vec3::splat(0.5))).unwrap();
        let s = b.sphere(Vec3::ZERO, 1.0, m).unwrap();
        let p = b
            .plane(Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0), m)
            .unwrap();
        b.camera(cam()).unwrap();
        let scene: Scene = b.build().unwrap();
        let v = scene.view(-1.0);
        // from the sphere's top, going up: nothing
        let up = Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        assert!(v.closest_hit(&up, s).is_none());
        // from the sphere's top, going down: far side of the sphere at t = 2
        let down = Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, -1.0, 0.0));
        let h = v.closest_hit(&down, s).unwrap();
        assert_eq!((h.object, h.t), (s, 2.0));
        // from the plane, going down: nothing
        let below = Ray::new(Vec3::new(3.0, -1.0, 0.0), Vec3::new(0.0, -1.0, 0.0));
        assert!(v.closest_hit(&below, p).is_none());
        assert!(!v.occluded(&below, 10.0, p, ObjectId::NONE));
        assert!(v.occluded(&down, 10.0, ObjectId::NONE, ObjectId::NONE));
    }
}
