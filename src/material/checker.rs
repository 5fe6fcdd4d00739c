//! The checkered Lambertian: an albedo that alternates between two colours
//! over squares (on a plane) or cubes (on a sphere) of side `size` in world
//! coordinates (feature `checker`).
//!
//! On a plane the squares span the two world axes other than the one most
//! aligned with the plane's normal (on a tie the earlier of x, y, z is the
//! one dropped); on a sphere all three axes count (a solid checker). The
//! cell of a coordinate `a` is `floor(a / size)`, so a point on a boundary
//! belongs to the cell above it; where the cells' indices sum to an even
//! number the albedo is `even`, where odd `odd`.

use crate::error::SceneError;
use crate::error::check_unit_range;
use crate::geometry::Color;
#[cfg(feature = "checker")]
use crate::geometry::Vec3;
#[cfg(feature = "checker")]
use crate::math;

/// A checkerboard of two Lambertian albedos.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checker {
    /// Albedo where the cell indices sum to an even number, each channel in
    /// [0, 1].
    pub even: Color,
    /// Albedo where they sum to an odd number, each channel in [0, 1].
    pub odd: Color,
    /// Side of a square (> 0), world units.
    pub size: f32,
}

/// Checks a checker's albedos and size, or refuses the material in a build
/// without the `checker` feature.
pub(crate) fn validate(c: &Checker) -> Result<(), SceneError> {
    if !cfg!(feature = "checker") {
        return Err(SceneError::MaterialNotBuilt("checker"));
    }
    check_unit_range(c.even, "albedo")?;
    check_unit_range(c.odd, "albedo")?;
    if !c.size.is_finite() {
        return Err(SceneError::NotFinite);
    }
    if !(c.size > 0.0) {
        return Err(SceneError::OutOfRange("checker size"));
    }
    Ok(())
}

/// 1 if `floor(a / size)` is odd, else 0. Beyond 2²⁴ every f32 is an even
/// integer; a quotient that overflows (a tiny `size`) counts as even.
#[cfg(feature = "checker")]
#[inline(always)]
fn cell_parity(a: f32, size: f32) -> u32 {
    let q = a / size;
    if math::abs(q) < 16_777_216.0 {
        (math::floor(q) as i32 & 1) as u32
    } else {
        0
    }
}

#[cfg(feature = "checker")]
impl Checker {
    /// The albedo where `hit` lies: on its plane, or on its sphere (the
    /// solid checker).
    #[inline]
    pub fn albedo_at_hit(&self, hit: &crate::geometry::Hit) -> Color {
        self.albedo_at(hit.point, hit.object.as_plane().map(|_| hit.normal))
    }

    /// The albedo at point `p` of a plane with unit normal `plane_normal`,
    /// or of a sphere (`None`: the solid checker).
    #[inline]
    pub fn albedo_at(&self, p: Vec3, plane_normal: Option<Vec3>) -> Color {
        let s = self.size;
        let parity = match plane_normal {
            Some(n) => {
                let a = n.abs();
                // the two coordinates that remain when the most aligned
                // axis is dropped (the earlier one on a tie)
                let (u, v) = if a.x >= a.y && a.x >= a.z {
                    (p.y, p.z)
                } else if a.y >= a.z {
                    (p.x, p.z)
                } else {
                    (p.x, p.y)
                };
                cell_parity(u, s) + cell_parity(v, s)
            }
            None => cell_parity(p.x, s) + cell_parity(p.y, s) + cell_parity(p.z, s),
        };
        if parity & 1 == 0 { self.even } else { self.odd }
    }
}

#[cfg(all(test, feature = "checker"))]
mod tests {
    use super::*;

    const C: Checker = Checker {
        even: Color::new(1.0, 1.0, 1.0),
        odd: Color::new(0.0, 0.0, 0.0),
        size: 0.5,
    };

    /// The cell rule of the scene format: floor(a/size) per kept axis, the
    /// sum's parity; boundaries belong to the cell above.
    #[test]
    fn cells_follow_the_floor_rule() {
        let up = Some(Vec3::new(0.0, 1.0, 0.0));
        // y dropped: x and z count
        assert_eq!(C.albedo_at(Vec3::new(0.1, 7.0, 0.1), up), C.even);
        assert_eq!(C.albedo_at(Vec3::new(0.6, 7.0, 0.1), up), C.odd);
        assert_eq!(C.albedo_at(Vec3::new(-0.1, 7.0, 0.1), up), C.odd);
        assert_eq!(C.albedo_at(Vec3::new(-0.1, 7.0, -0.1), up), C.even);
        // on a boundary: x = 0.5 is in cell 1
        assert_eq!(C.albedo_at(Vec3::new(0.5, 0.0, 0.0), up), C.odd);
        assert_eq!(C.albedo_at(Vec3::new(0.0, 0.0, 0.0), up), C.even);
        // a tie between x and y drops x: y and z count
        let diag = Some(Vec3::new(1.0, -1.0, 0.0).normalize());
        assert_eq!(C.albedo_at(Vec3::new(0.0, 0.6, 0.1), diag), C.odd);
        assert_eq!(C.albedo_at(Vec3::new(0.6, 0.1, 0.1), diag), C.even);
        // a sphere: all three
        assert_eq!(C.albedo_at(Vec3::new(0.6, 0.6, 0.6), None), C.odd);
        assert_eq!(C.albedo_at(Vec3::new(0.6, 0.6, 0.1), None), C.even);
        // huge coordinates are even integers of cells; overflow is even
        assert_eq!(C.albedo_at(Vec3::new(1.0e30, 7.0, 0.1), up), C.even);
        let tiny = Checker { size: 1.0e-45, ..C };
        assert_eq!(tiny.albedo_at(Vec3::new(1.0, 7.0, 1.0), up), C.even);
    }
}
