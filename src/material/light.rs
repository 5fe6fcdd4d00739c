//! The emitter: radiance on the outward side of a sphere, no reflection.

use crate::error::SceneError;
use crate::error::check_non_negative;
use crate::geometry::Color;

/// Checks an emitter's radiance (each channel ≥ 0).
pub(crate) fn validate(radiance: Color) -> Result<(), SceneError> {
    check_non_negative(radiance, "radiance")
}
