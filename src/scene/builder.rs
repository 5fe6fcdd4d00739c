//! Building a scene in code: every value is checked as it is added, and
//! [`SceneBuilder::build`] runs the load-time analysis.

use super::{Capacities, MAX_MATERIALS, MAX_PIXELS, MAX_PLANES, MAX_SIDE, MAX_SPHERES, Scene};
use crate::camera::CameraSpec;
use crate::error::{SceneError, check_finite, check_non_negative};
use crate::geometry::{Color, ObjectId, Plane, Sphere, Vec3};
use crate::material::Material;
use heapless::Vec;

/// A material handle returned by [`SceneBuilder::material`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialId(pub(crate) u16);

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
    settings: Settings,
}

impl<const S: usize, const P: usize, const M: usize> Default for SceneBuilder<S, P, M> {
    fn default() -> Self {
        Self::new()
    }
}

/// The object lists of a scene being built, borrowed: a [`SceneBuilder`]'s
/// own, or a [`Scene`]'s when the scene is built in place (the parser, whose
/// stack then holds no list: its use does not grow with the capacities).
/// Every object is checked as it is added.
pub(crate) struct Lists<'a, const S: usize, const P: usize, const M: usize> {
    spheres: &'a mut Vec<Sphere, S>,
    planes: &'a mut Vec<Plane, P>,
    materials: &'a mut Vec<Material, M>,
}

impl<const S: usize, const P: usize, const M: usize> Lists<'_, S, P, M> {
    /// [`SceneBuilder::material`].
    pub(crate) fn material(&mut self, m: Material) -> Result<MaterialId, SceneError> {
        m.validate()?;
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

    /// [`SceneBuilder::sphere_precise`].
    pub(crate) fn sphere_precise(
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

    /// [`SceneBuilder::plane`].
    pub(crate) fn plane(
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
                return Err(SceneError::OutOfRange(
                    "plane normal (largest component under 2.9e-39)",
                ));
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
}

impl<const S: usize, const P: usize, const M: usize> Scene<S, P, M> {
    /// The scene's object lists emptied, to be filled in place.
    #[cfg(feature = "parser")]
    pub(crate) fn lists_to_fill(&mut self) -> Lists<'_, S, P, M> {
        self.spheres.clear();
        self.planes.clear();
        self.materials.clear();
        Lists {
            spheres: &mut self.spheres,
            planes: &mut self.planes,
            materials: &mut self.materials,
        }
    }
}

/// The scene-wide values of a scene being built: camera, background and
/// image size, each checked as it is set.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Settings {
    background: Color,
    camera: Option<CameraSpec>,
    resolution: Option<(u32, u32)>,
}

impl Settings {
    /// Black background, no camera, no image size.
    pub(crate) const NEW: Self = Self {
        background: Vec3::ZERO,
        camera: None,
        resolution: None,
    };

    /// [`SceneBuilder::camera`].
    pub(crate) fn camera(&mut self, spec: CameraSpec) -> Result<(), SceneError> {
        if self.camera.is_some() {
            return Err(SceneError::SecondCamera);
        }
        spec.validate().map_err(SceneError::Camera)?;
        self.camera = Some(spec);
        Ok(())
    }

    /// [`SceneBuilder::background`].
    pub(crate) fn background(&mut self, c: Color) -> Result<(), SceneError> {
        check_non_negative(c, "background radiance")?;
        self.background = c;
        Ok(())
    }

    /// [`SceneBuilder::resolution`].
    pub(crate) fn resolution(&mut self, width: u32, height: u32) -> Result<(), SceneError> {
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

    /// Finishes `scene`, whose object lists are filled: sets these values
    /// and runs the load-time analysis (and builds the tree if it pays).
    /// Without a camera it is [`SceneError::NoCamera`], and `scene` is left
    /// as it was.
    pub(crate) fn finish<const S: usize, const P: usize, const M: usize>(
        self,
        scene: &mut Scene<S, P, M>,
    ) -> Result<(), SceneError> {
        let camera = self.camera.ok_or(SceneError::NoCamera)?;
        scene.background = self.background;
        scene.camera = camera;
        scene.resolution = self.resolution;
        scene.analyse();
        Ok(())
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
            settings: Settings::NEW,
        }
    }

    fn lists(&mut self) -> Lists<'_, S, P, M> {
        Lists {
            spheres: &mut self.spheres,
            planes: &mut self.planes,
            materials: &mut self.materials,
        }
    }

    /// Adds a material after checking its values ([`Material::validate`]:
    /// albedo and tint in [0, 1], IOR > 0, metal width in [0.001, 1],
    /// checker size > 0, radiance ≥ 0). A mirror, glass, metal or checker
    /// material in a build without its cargo feature is
    /// [`SceneError::MaterialNotBuilt`]: the renderer has no code for it.
    pub fn material(&mut self, m: Material) -> Result<MaterialId, SceneError> {
        self.lists().material(m)
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
        self.lists()
            .sphere_precise(center, center_lo, radius, radius_lo, m)
    }

    /// Adds an infinite two-sided plane through `point` with normal `normal`
    /// (any non-zero length). A light material is rejected.
    pub fn plane(
        &mut self,
        point: Vec3,
        normal: Vec3,
        m: MaterialId,
    ) -> Result<ObjectId, SceneError> {
        self.lists().plane(point, normal, m)
    }

    /// Sets the camera (exactly once). A camera with a lens in a build
    /// without the `lens` feature is refused
    /// ([`CameraError::LensNotBuilt`](crate::camera::CameraError::LensNotBuilt)).
    pub fn camera(&mut self, spec: CameraSpec) -> Result<(), SceneError> {
        self.settings.camera(spec)
    }

    /// Sets the radiance of rays that hit nothing (default black).
    pub fn background(&mut self, c: Color) -> Result<(), SceneError> {
        self.settings.background(c)
    }

    /// Sets the default image size: each side in 1..=[`MAX_SIDE`], at most
    /// [`MAX_PIXELS`] in all (else [`SceneError::Resolution`]).
    pub fn resolution(&mut self, width: u32, height: u32) -> Result<(), SceneError> {
        self.settings.resolution(width, height)
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
    /// on error): the scene is never on the stack, only this builder. With
    /// `scene` in static memory (e.g. a `static` initialised with
    /// [`Scene::EMPTY`]) a board builds a large scene in a stack of about
    /// the builder's size. (The parser builds in place without a builder:
    /// [`crate::parse::parse_into`].)
    pub fn build_into(self, scene: &mut Scene<S, P, M>) -> Result<(), SceneError> {
        if self.settings.camera.is_none() {
            return Err(SceneError::NoCamera);
        }
        scene.spheres = self.spheres;
        scene.planes = self.planes;
        scene.materials = self.materials;
        self.settings.finish(scene)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::CameraError;

    fn cam() -> CameraSpec {
        CameraSpec::pinhole(
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::ZERO,
            Vec3::new(0.0, 1.0, 0.0),
            45.0,
        )
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
        use crate::scene::MAX_CAPACITY;
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
            Err(SceneError::OutOfRange(
                "plane normal (largest component under 2.9e-39)"
            ))
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

    /// A lens camera in a build without the lens code is refused, never
    /// rendered as a pinhole; aperture 0 is a pinhole in every build.
    #[test]
    fn lens_cameras_need_the_lens_feature() {
        let mut b: SceneBuilder = SceneBuilder::new();
        let lens = b.camera(cam().lens(0.1, 5.0));
        if cfg!(feature = "lens") {
            assert!(lens.is_ok());
        } else {
            let e = SceneError::Camera(CameraError::LensNotBuilt);
            assert_eq!(lens, Err(e));
            let mut msg: heapless::String<128> = heapless::String::new();
            core::fmt::Write::write_fmt(&mut msg, format_args!("{e}")).unwrap();
            assert!(msg.contains("`lens` cargo feature"), "{msg}");
        }
        let mut b: SceneBuilder = SceneBuilder::new();
        assert!(b.camera(cam().lens(0.0, 5.0)).is_ok());
        let mut b: SceneBuilder = SceneBuilder::new();
        assert_eq!(
            b.camera(cam().lens(-0.1, 5.0)),
            Err(SceneError::Camera(CameraError::ApertureOutOfRange))
        );
        assert_eq!(
            b.camera(cam().lens(0.1, 0.0)),
            Err(SceneError::Camera(CameraError::FocusOutOfRange))
        );
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
}
