//! The perfect mirror: a Dirac delta reflector with a tint (feature
//! `mirror`; [`reflect`] is also built for the glass and the metal).

use crate::error::SceneError;
use crate::error::check_unit_range;
use crate::geometry::Color;
#[cfg(any(feature = "mirror", feature = "glass", feature = "metal"))]
use crate::geometry::Vec3;

/// Checks a mirror's tint (each channel in [0, 1]), or refuses the
/// material in a build without the `mirror` feature.
pub(crate) fn validate(tint: Color) -> Result<(), SceneError> {
    if !cfg!(feature = "mirror") {
        return Err(SceneError::MaterialNotBuilt("mirror"));
    }
    check_unit_range(tint, "mirror reflectance")
}

/// Mirror reflection of `d` about the unit normal `n` (features `mirror`,
/// `glass` or `metal`).
#[cfg(any(feature = "mirror", feature = "glass", feature = "metal"))]
#[inline(always)]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - n * (2.0 * d.dot(n))
}
