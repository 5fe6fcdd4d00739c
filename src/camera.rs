//! The pinhole camera of the scene format: pixel → primary ray.

use crate::geometry::{Ray, Vec3};
use crate::math;

/// The camera as a scene describes it (`camera` statement).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSpec {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up vector (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub vfov_deg: f32,
}

/// Why a camera specification is unusable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraError {
    /// The eye equals the target: no view direction.
    EyeEqualsTarget,
    /// The up vector is zero or parallel to the view direction.
    UpParallelToView,
    /// The vertical field of view is not in (0, 180) degrees.
    FovOutOfRange,
    /// A coordinate is not finite.
    NotFinite,
}

impl CameraSpec {
    /// Checks the specification (the scene format's camera rules).
    pub fn validate(&self) -> Result<(), CameraError> {
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return Err(CameraError::NotFinite);
        }
        if !(self.vfov_deg > 0.0 && self.vfov_deg < 180.0) {
            return Err(CameraError::FovOutOfRange);
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
        Ok(())
    }
}

/// A pinhole camera for an image of `width` × `height` pixels.
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
        })
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
    pub fn view_cos(&self) -> f32 {
        // forward is unit and orthogonal to the corner's film offset
        1.0 / self.corner.length()
    }

    /// The primary ray through film position (`fx`, `fy`) in pixel units:
    /// `(px + u, py + v)` for pixel (px, py) and an offset (u, v) in [0,1)².
    #[inline]
    pub fn ray(&self, fx: f32, fy: f32) -> Ray {
        let d = self.corner + self.dx * fx + self.dy * fy;
        Ray::new(self.eye, d.normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> CameraSpec {
        CameraSpec {
            eye: Vec3::ZERO,
            target: Vec3::new(0.0, 0.0, -1.0),
            up: Vec3::new(0.0, 1.0, 0.0),
            vfov_deg: 90.0,
        }
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
    }
}
