//! The camera of the scene format: pixel (and lens position) → primary ray.
//!
//! A pinhole camera, or a thin lens (feature `lens`): a disk of radius
//! `aperture` around the eye, perpendicular to the view direction, focused on
//! the plane perpendicular to the view direction at distance `focus` from
//! the eye. Every ray through one film position meets that plane in the
//! point where the pinhole ray through the same film position does, so
//! points on the plane of focus are sharp and points at distance `z` along
//! the view axis blur into a disk of radius `aperture · |z − focus| / focus`.

use crate::geometry::{Ray, Vec3};
use crate::math;
#[cfg(feature = "lens")]
use crate::sampler;

/// The camera as a scene describes it (`camera` statement).
///
/// Build a pinhole with [`CameraSpec::pinhole`] and give it a lens with
/// [`CameraSpec::lens`]:
///
/// ```
/// use micropt::{CameraSpec, Vec3};
/// let pinhole = CameraSpec::pinhole(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0), 40.0);
/// assert!(!pinhole.has_lens() && pinhole.validate().is_ok());
/// let thin_lens = pinhole.lens(0.1, 4.0);
/// assert!(thin_lens.has_lens() && thin_lens.validate().is_ok());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSpec {
    /// Eye position (the lens' centre).
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up vector (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub vfov_deg: f32,
    /// Radius of the lens in world units, ≥ 0; 0 is the pinhole.
    pub aperture: f32,
    /// Distance from the eye, along the view direction, of the plane in
    /// focus (perpendicular to the view direction); > 0. A pinhole ignores
    /// it.
    pub focus: f32,
}

/// Why a camera specification is unusable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraError {
    /// The eye equals the target (no view direction), or the squared
    /// distance between them is not a normal f32 (a distance below about
    /// 1.1e-19 or above 1.8e19, where normalising the view direction fails).
    EyeEqualsTarget,
    /// The up vector is parallel to the view direction (the sine of the
    /// angle between them at most 1e-6), or its squared length is 0 or not
    /// finite in f32 (a length below about 4e-23, zero included, or above
    /// 1.8e19).
    UpParallelToView,
    /// The vertical field of view is not in (0, 180) degrees.
    FovOutOfRange,
    /// A coordinate is not finite.
    NotFinite,
    /// The lens radius is negative or not finite.
    ApertureOutOfRange,
    /// The focus distance is not positive or not finite.
    FocusOutOfRange,
    /// A lens (aperture > 0) in a build without the `lens` feature.
    LensNotBuilt,
}

impl CameraSpec {
    /// A pinhole camera at `eye` looking at `target`, `up` the image's up
    /// direction, vertical field of view `vfov_deg` degrees (aperture 0,
    /// focus distance 1).
    pub const fn pinhole(eye: Vec3, target: Vec3, up: Vec3, vfov_deg: f32) -> Self {
        Self {
            eye,
            target,
            up,
            vfov_deg,
            aperture: 0.0,
            focus: 1.0,
        }
    }

    /// This camera with a thin lens of radius `aperture` focused at
    /// distance `focus` along the view direction (aperture 0: a pinhole).
    pub const fn lens(self, aperture: f32, focus: f32) -> Self {
        Self {
            aperture,
            focus,
            ..self
        }
    }

    /// Whether the camera has a lens (aperture > 0): its rays start
    /// anywhere on the lens disk, not at the eye.
    pub fn has_lens(&self) -> bool {
        self.aperture > 0.0
    }

    /// Checks the specification: the scene format's camera rules, and that
    /// this build has the lens code if the camera has a lens.
    pub fn validate(&self) -> Result<(), CameraError> {
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return Err(CameraError::NotFinite);
        }
        if !(self.vfov_deg > 0.0 && self.vfov_deg < 180.0) {
            return Err(CameraError::FovOutOfRange);
        }
        if !(self.aperture >= 0.0 && self.aperture.is_finite()) {
            return Err(CameraError::ApertureOutOfRange);
        }
        if !(self.focus > 0.0 && self.focus.is_finite()) {
            return Err(CameraError::FocusOutOfRange);
        }
        let fwd = self.target - self.eye;
        if fwd.length_squared() == 0.0 || !fwd.length_squared().is_normal() {
            return Err(CameraError::EyeEqualsTarget);
        }
        let fwd = fwd.normalize();
        let up_len = self.up.length();
        if !(up_len > 0.0) || !up_len.is_normal() {
            return Err(CameraError::UpParallelToView);
        }
        // sine of the angle between up and forward
        let s = fwd.cross(self.up * (1.0 / up_len)).length();
        if !(s > 1e-6) {
            return Err(CameraError::UpParallelToView);
        }
        if self.has_lens() && !cfg!(feature = "lens") {
            return Err(CameraError::LensNotBuilt);
        }
        Ok(())
    }
}

/// A pinhole or thin-lens camera for an image of `width` × `height` pixels.
///
/// The image's right-hand direction is `normalize(forward × up)` and its up
/// direction `right × forward` (docs/scene-format.md); pixel (0,0) is the top-left
/// one, and a pixel covers the square `[px, px+1) × [py, py+1)` of the film.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    eye: Vec3,
    forward: Vec3,
    /// right · tan(vfov/2) · aspect · 2 / width
    dx: Vec3,
    /// −up · tan(vfov/2) · 2 / height
    dy: Vec3,
    /// forward − right·tan·aspect + up·tan: the direction through the film's
    /// top-left corner
    corner: Vec3,
    width: u32,
    height: u32,
    /// The lens radius (0: a pinhole).
    #[cfg(feature = "lens")]
    aperture: f32,
    /// aperture / focus: the largest slope of a lens ray against the
    /// pinhole ray through the same film position
    #[cfg(feature = "lens")]
    slope: f32,
    /// right · aperture: the lens disk's first axis
    #[cfg(feature = "lens")]
    lens_u: Vec3,
    /// up · aperture: its second axis
    #[cfg(feature = "lens")]
    lens_v: Vec3,
    /// right · slope: a lens position's turn of the direction, per unit
    /// of its first coordinate
    #[cfg(feature = "lens")]
    turn_u: Vec3,
    /// up · slope: the same for the second
    #[cfg(feature = "lens")]
    turn_v: Vec3,
}

impl Camera {
    /// A camera for `spec` and the given image size (both > 0).
    pub fn new(spec: &CameraSpec, width: u32, height: u32) -> Result<Self, CameraError> {
        spec.validate()?;
        let forward = (spec.target - spec.eye).normalize();
        let right = forward.cross(spec.up).normalize();
        let up = right.cross(forward);
        let (s, c) = math::sincos(spec.vfov_deg * (math::PI / 360.0));
        let tan_half = s / c;
        let w = math::max(width as f32, 1.0);
        let h = math::max(height as f32, 1.0);
        let half_w = tan_half * w / h;
        let half_h = tan_half;
        Ok(Self {
            eye: spec.eye,
            forward,
            dx: right * (2.0 * half_w / w),
            dy: up * (-2.0 * half_h / h),
            corner: forward - right * half_w + up * half_h,
            width,
            height,
            #[cfg(feature = "lens")]
            aperture: spec.aperture,
            #[cfg(feature = "lens")]
            slope: spec.aperture / spec.focus,
            #[cfg(feature = "lens")]
            lens_u: right * spec.aperture,
            #[cfg(feature = "lens")]
            lens_v: up * spec.aperture,
            #[cfg(feature = "lens")]
            turn_u: right * (spec.aperture / spec.focus),
            #[cfg(feature = "lens")]
            turn_v: up * (spec.aperture / spec.focus),
        })
    }

    /// Whether the camera has a lens: its rays need a lens position
    /// ([`Camera::lens_ray`]). Always false in a build without the `lens`
    /// feature.
    #[inline(always)]
    pub fn has_lens(&self) -> bool {
        #[cfg(feature = "lens")]
        {
            self.aperture > 0.0
        }
        #[cfg(not(feature = "lens"))]
        {
            false
        }
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The eye position.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }

    /// The unit view direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Cosine of the half-angle of the narrowest cone around the view axis
    /// that contains every camera ray (the one through a film corner).
    ///
    /// With a lens, a ray starts within `aperture` of the eye and aims at a
    /// point of the film's frustum at distance `focus`: the tangent of its
    /// angle to the axis is at most the corner's plus `aperture / focus`.
    /// (Every point of such a ray lies within `aperture` of the ray from the
    /// eye in the same direction, which [`crate::analysis`] allows for.)
    pub fn view_cos(&self) -> f32 {
        #[cfg(feature = "lens")]
        if self.has_lens() {
            let tan = (self.corner - self.forward).length() + self.slope;
            return 1.0 / math::sqrt(1.0 + tan * tan);
        }
        // forward is unit and orthogonal to the corner's film offset
        1.0 / self.corner.length()
    }

    /// The lens radius and its largest slope against the pinhole ray
    /// (`aperture / focus`); zeros for a pinhole.
    pub fn lens(&self) -> (f32, f32) {
        #[cfg(feature = "lens")]
        {
            (self.aperture, self.slope)
        }
        #[cfg(not(feature = "lens"))]
        {
            (0.0, 0.0)
        }
    }

    /// The primary ray through film position (`fx`, `fy`) in pixel units:
    /// `(px + u, py + v)` for pixel (px, py) and an offset (u, v) in [0,1)².
    #[inline]
    pub fn ray(&self, fx: f32, fy: f32) -> Ray {
        let d = self.corner + self.dx * fx + self.dy * fy;
        Ray::new(self.eye, d.normalize())
    }

    /// The film position (in pixel units, as [`Camera::ray`] takes it) of
    /// the pinhole ray through the point `p`, or `None` when `p` is not in
    /// front of the eye.
    pub fn film_of(&self, p: Vec3) -> Option<[f32; 2]> {
        let q = p - self.eye;
        let depth = q.dot(self.forward);
        if !(depth > 0.0) {
            return None;
        }
        // the film direction: forward component exactly 1 (see `ray`)
        let off = q * (1.0 / depth) - self.corner;
        Some([
            off.dot(self.dx) / self.dx.length_squared(),
            off.dot(self.dy) / self.dy.length_squared(),
        ])
    }

    /// The position on the lens that `lens` in [0,1)² maps to (as
    /// [`Camera::lens_ray`] maps it); the eye for a pinhole.
    #[cfg(feature = "highlight")]
    pub fn lens_point(&self, lens: [f32; 2]) -> LensPoint {
        #[cfg(feature = "lens")]
        if self.has_lens() {
            let (a, b, _) = sampler::concentric_disk(lens[0], lens[1], false);
            return self.lens_at(a, b);
        }
        let _ = lens;
        LensPoint::CENTRE
    }

    /// The position (`a`, `b`) on the unit disk scaled to the lens (the
    /// lens' rim for `a² + b² = 1`); the eye for a pinhole.
    #[cfg(feature = "highlight")]
    pub fn lens_at(&self, a: f32, b: f32) -> LensPoint {
        #[cfg(feature = "lens")]
        if self.has_lens() {
            return LensPoint {
                offset: self.lens_u * a + self.lens_v * b,
                turn: self.turn_u * a + self.turn_v * b,
            };
        }
        let _ = (a, b);
        LensPoint::CENTRE
    }

    /// Where the rays from lens position `lp` start.
    #[cfg(feature = "highlight")]
    #[inline(always)]
    pub fn origin(&self, lp: &LensPoint) -> Vec3 {
        self.eye + lp.offset
    }

    /// The primary ray through film position (`fx`, `fy`) from lens
    /// position `lp`: [`Camera::lens_ray`]'s ray (for a pinhole, whose
    /// only position is the eye, [`Camera::ray`]'s, bit for bit).
    #[cfg(feature = "highlight")]
    #[inline]
    pub fn ray_at(&self, fx: f32, fy: f32, lp: &LensPoint) -> Ray {
        let d = self.corner + self.dx * fx + self.dy * fy;
        Ray::new(self.eye + lp.offset, (d - lp.turn).normalize())
    }

    /// The film position of the ray from lens position `lp` through the
    /// point `p` ([`Camera::ray_at`]'s inverse), or `None` when `p` is not
    /// in front of the lens. For a pinhole, [`Camera::film_of`].
    #[cfg(feature = "highlight")]
    pub fn film_at(&self, p: Vec3, lp: &LensPoint) -> Option<[f32; 2]> {
        let q = p - (self.eye + lp.offset);
        let depth = q.dot(self.forward);
        if !(depth > 0.0) {
            return None;
        }
        // the lens ray's direction is that of `d − turn`, `d` the film
        // direction (forward component 1) and `turn` across the view
        let off = q * (1.0 / depth) + lp.turn - self.corner;
        Some([
            off.dot(self.dx) / self.dx.length_squared(),
            off.dot(self.dy) / self.dy.length_squared(),
        ])
    }

    /// The derivatives of [`Camera::ray_at`]'s unit direction along the two
    /// film axes (per pixel); its origin does not move.
    #[cfg(feature = "highlight")]
    pub fn dir_derivatives_at(&self, fx: f32, fy: f32, lp: &LensPoint) -> (Vec3, Vec3) {
        let d = self.corner + self.dx * fx + self.dy * fy - lp.turn;
        let inv = 1.0 / d.length();
        let w = d * inv;
        (
            (self.dx - w * self.dx.dot(w)) * inv,
            (self.dy - w * self.dy.dot(w)) * inv,
        )
    }

    /// The primary ray through film position (`fx`, `fy`) (as
    /// [`Camera::ray`]) from the lens position that `lens` in [0,1)² maps
    /// to, uniformly over the lens disk ([`crate::sampler::concentric_disk`]).
    /// It aims at the point where the pinhole ray through (`fx`, `fy`) meets
    /// the plane of focus: the film direction `d` has a forward component of
    /// exactly 1, so that point is `eye + focus · d`, and the direction from
    /// the lens position `eye + offset` is that of `d − offset / focus`
    /// (scaled by `aperture / focus` rather than multiplied by the focus, so
    /// that neither a distant nor a near focus overflows: the direction is
    /// finite whenever that ratio is moderate).
    #[cfg(feature = "lens")]
    #[inline]
    pub fn lens_ray(&self, fx: f32, fy: f32, lens: [f32; 2]) -> Ray {
        let d = self.corner + self.dx * fx + self.dy * fy;
        let (a, b, _) = sampler::concentric_disk(lens[0], lens[1], false);
        let offset = self.lens_u * a + self.lens_v * b;
        let turn = self.turn_u * a + self.turn_v * b;
        Ray::new(self.eye + offset, (d - turn).normalize())
    }
}

/// A position on a camera's lens ([`Camera::lens_point`]): the rays from
/// it start at `eye + offset` and turn by `turn` (across the view, per unit
/// of the film direction's forward component) to meet the plane of focus
/// where the pinhole's rays do.
#[cfg(feature = "highlight")]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LensPoint {
    offset: Vec3,
    turn: Vec3,
}

#[cfg(feature = "highlight")]
impl LensPoint {
    /// The lens' centre: the eye (a pinhole's only position).
    pub const CENTRE: Self = Self {
        offset: Vec3::ZERO,
        turn: Vec3::ZERO,
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> CameraSpec {
        CameraSpec::pinhole(
            Vec3::ZERO,
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 1.0, 0.0),
            90.0,
        )
    }

    #[test]
    fn orientation_matches_the_format() {
        // looking down -z with +y up: +x is right, pixel (0,0) top-left
        let cam = Camera::new(&spec(), 4, 2).unwrap();
        let centre = cam.ray(2.0, 1.0);
        assert!((centre.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        let top_left = cam.ray(0.0, 0.0).dir;
        assert!(top_left.x < 0.0 && top_left.y > 0.0);
        // vfov 90: the top edge is at 45 degrees
        let top = cam.ray(2.0, 0.0).dir;
        assert!((top.y - top.z.abs()).abs() < 1e-6);
        // aspect 2: the right edge is at atan(2)
        let right = cam.ray(4.0, 1.0).dir;
        assert!((right.x / -right.z - 2.0).abs() < 1e-5);
    }

    #[test]
    fn rejects_bad_specs() {
        let mut s = spec();
        s.target = s.eye;
        assert_eq!(s.validate(), Err(CameraError::EyeEqualsTarget));
        let mut s = spec();
        s.up = Vec3::new(0.0, 0.0, 3.0);
        assert_eq!(s.validate(), Err(CameraError::UpParallelToView));
        let mut s = spec();
        s.vfov_deg = 180.0;
        assert_eq!(s.validate(), Err(CameraError::FovOutOfRange));
        for (aperture, focus, want) in [
            (-0.1, 1.0, Err(CameraError::ApertureOutOfRange)),
            (f32::NAN, 1.0, Err(CameraError::ApertureOutOfRange)),
            (f32::INFINITY, 1.0, Err(CameraError::ApertureOutOfRange)),
            (0.1, 0.0, Err(CameraError::FocusOutOfRange)),
            (0.1, -2.0, Err(CameraError::FocusOutOfRange)),
            (0.0, 0.0, Err(CameraError::FocusOutOfRange)),
            (0.1, f32::INFINITY, Err(CameraError::FocusOutOfRange)),
            (0.0, 1.0, Ok(())),
            (-0.0, 1.0, Ok(())),
        ] {
            assert_eq!(
                spec().lens(aperture, focus).validate(),
                want,
                "{aperture} {focus}"
            );
        }
    }

    /// Thin-lens law: every ray through one film position, whatever its
    /// lens position, meets the plane of focus (perpendicular to the view
    /// direction at distance `focus`) where the pinhole ray through that
    /// film position does, and starts on the lens disk (in the plane
    /// through the eye perpendicular to the view direction, within the
    /// aperture of the eye).
    #[cfg(feature = "lens")]
    #[test]
    fn lens_rays_meet_on_the_plane_of_focus() {
        let (aperture, focus) = (0.2, 3.0);
        let cam = Camera::new(&spec().lens(aperture, focus), 8, 6).unwrap();
        let pin = Camera::new(&spec(), 8, 6).unwrap();
        assert!(cam.has_lens() && !pin.has_lens());
        // the view is down -z: the plane of focus is z = -3
        let on_focus = |r: Ray| r.at((-focus - r.origin.z) / r.dir.z);
        for (fx, fy) in [(0.0, 0.0), (4.0, 3.0), (7.5, 1.25), (8.0, 6.0)] {
            let q = on_focus(pin.ray(fx, fy));
            for lens in [
                [0.0, 0.0],
                [0.999, 0.5],
                [0.25, 0.75],
                [0.5, 0.5],
                [0.0, 0.999],
            ] {
                let r = cam.lens_ray(fx, fy, lens);
                assert_eq!(r.origin.z, 0.0);
                assert!(r.origin.length() <= aperture * (1.0 + 1e-6));
                assert!((r.dir.length() - 1.0).abs() < 1e-6);
                let miss = (on_focus(r) - q).length();
                assert!(miss < 1e-5, "({fx}, {fy}) {lens:?}: {miss}");
            }
        }
        // the lens widens the cone of camera rays by aperture / focus
        let tan = |c: f32| crate::math::sqrt(1.0 / (c * c) - 1.0);
        let widened = tan(cam.view_cos()) - tan(pin.view_cos());
        assert!((widened - aperture / focus).abs() < 1e-5, "{widened}");
    }
}
