//! What can be wrong with a scene, and the checks of values that every
//! part of a scene shares: below the scene, its materials and the parser,
//! which all report through [`SceneError`].

use crate::camera::CameraError;
use crate::geometry::{Color, Vec3};

/// What is wrong with a scene built in code (the parser maps these to
/// line-numbered [`crate::parse::ParseError`]s).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneError {
    /// More objects of this kind than the build's fixed capacity.
    Capacity(&'static str),
    /// A value outside its allowed range; names the quantity.
    OutOfRange(&'static str),
    /// A `resolution` that is zero or larger than [`MAX_SIDE`](crate::scene::MAX_SIDE) per side or
    /// [`MAX_PIXELS`](crate::scene::MAX_PIXELS) in all.
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
                f.write_str("camera eye to target: distance squared is not a normal f32")
            }
            SceneError::Camera(CameraError::UpParallelToView) => f.write_str(
                "camera up vector: length squared is 0 or not finite, or sine of its angle to the view under 1e-6",
            ),
            SceneError::Camera(CameraError::FovOutOfRange) => {
                f.write_str("vertical field of view must be in (0, 180) degrees")
            }
            SceneError::Camera(CameraError::NotFinite) => f.write_str("camera value is not finite"),
            SceneError::Camera(CameraError::ApertureOutOfRange) => {
                f.write_str("camera aperture (lens radius) must be >= 0")
            }
            SceneError::Camera(CameraError::FocusOutOfRange) => {
                f.write_str("camera focus distance must be > 0")
            }
            SceneError::Camera(CameraError::LensNotBuilt) => f.write_str(
                "lens cameras (aperture > 0) are not in this build (enable micropt's `lens` cargo feature)",
            ),
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
pub(crate) const RESOLUTION_LIMITS: &str =
    "resolution out of range: each side from 1 to 16384, at most 33554432 pixels in all";

pub(crate) fn check_finite(v: Vec3) -> Result<(), SceneError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SceneError::NotFinite)
    }
}

pub(crate) fn check_unit_range(c: Color, what: &'static str) -> Result<(), SceneError> {
    check_finite(c)?;
    for v in [c.x, c.y, c.z] {
        if !(0.0..=1.0).contains(&v) {
            return Err(SceneError::OutOfRange(what));
        }
    }
    Ok(())
}

pub(crate) fn check_non_negative(c: Color, what: &'static str) -> Result<(), SceneError> {
    check_finite(c)?;
    if c.x >= 0.0 && c.y >= 0.0 && c.z >= 0.0 {
        Ok(())
    } else {
        Err(SceneError::OutOfRange(what))
    }
}
