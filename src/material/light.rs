//! The emitter: radiance on the outward side of a sphere, no reflection.

use crate::geometry::Color;
use crate::scene::SceneError;
use crate::scene::builder::check_non_negative;

/// Checks an emitter's radiance (each channel ≥ 0).
pub(crate) fn validate(radiance: Color) -> Result<(), SceneError> {
    check_non_negative(radiance, "radiance")
}
