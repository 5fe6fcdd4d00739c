//! Three-component f32 vectors, also used for linear RGB colours.

use crate::math;
use core::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub};

/// A 3-vector of `f32`: a point, a direction, or a linear RGB colour
/// (`x, y, z` = `r, g, b`; see [`Color`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec3 {
    /// First component (red for colours).
    pub x: f32,
    /// Second component (green for colours).
    pub y: f32,
    /// Third component (blue for colours).
    pub z: f32,
}

/// Linear RGB radiance or reflectance, stored as a [`Vec3`].
pub type Color = Vec3;

impl Vec3 {
    /// The zero vector.
    pub const ZERO: Self = Self::new(0.0, 0.0, 0.0);
    /// All components one (white).
    pub const ONE: Self = Self::new(1.0, 1.0, 1.0);

    /// A vector from its components.
    #[inline(always)]
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        Self { x, y, z }
    }

    /// All three components equal to `v`.
    #[inline(always)]
    pub const fn splat(v: f32) -> Self {
        Self::new(v, v, v)
    }

    /// Dot product.
    #[inline(always)]
    pub fn dot(self, o: Self) -> f32 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Cross product (right-handed).
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// Squared length.
    #[inline(always)]
    pub fn length_squared(self) -> f32 {
        self.dot(self)
    }

    /// Length.
    #[inline(always)]
    pub fn length(self) -> f32 {
        math::sqrt(self.length_squared())
    }

    /// This vector scaled to unit length (NaN components for the zero vector).
    #[inline(always)]
    pub fn normalize(self) -> Self {
        self * (1.0 / self.length())
    }

    /// Component-wise absolute value.
    #[inline(always)]
    pub fn abs(self) -> Self {
        Self::new(math::abs(self.x), math::abs(self.y), math::abs(self.z))
    }

    /// The largest component.
    #[inline(always)]
    pub fn max_component(self) -> f32 {
        math::max(self.x, math::max(self.y, self.z))
    }

    /// Whether all components are finite.
    #[inline(always)]
    pub fn is_finite(self) -> bool {
        math::is_finite(self.x) && math::is_finite(self.y) && math::is_finite(self.z)
    }

    /// Luminance of a linear RGB colour (Rec. 709 weights).
    #[inline(always)]
    pub fn luminance(self) -> f32 {
        0.2126 * self.x + 0.7152 * self.y + 0.0722 * self.z
    }

    /// An orthonormal basis `(t, b)` completing the unit vector `self`
    /// (Duff et al. 2017, branchless, no trigonometry).
    #[inline(always)]
    pub fn basis(self) -> (Self, Self) {
        let n = self;
        let sign = math::copysign(1.0, n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        (
            Self::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            Self::new(b, sign + n.y * n.y * a, -n.y),
        )
    }
}

impl Add for Vec3 {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl AddAssign for Vec3 {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl Sub for Vec3 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Neg for Vec3 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y, -self.z)
    }
}

impl Mul<f32> for Vec3 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, s: f32) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }
}

impl Mul for Vec3 {
    type Output = Self;
    /// Component-wise product (colour filtering).
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        Self::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}

impl MulAssign for Vec3 {
    #[inline(always)]
    fn mul_assign(&mut self, o: Self) {
        *self = *self * o;
    }
}

impl MulAssign<f32> for Vec3 {
    #[inline(always)]
    fn mul_assign(&mut self, s: f32) {
        *self = *self * s;
    }
}

impl Div<f32> for Vec3 {
    type Output = Self;
    #[inline(always)]
    fn div(self, s: f32) -> Self {
        Self::new(self.x / s, self.y / s, self.z / s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_is_right_handed() {
        let x = Vec3::new(1.0, 0.0, 0.0);
        let y = Vec3::new(0.0, 1.0, 0.0);
        assert_eq!(x.cross(y), Vec3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(1.0, 2.0, 3.0).normalize(),
            Vec3::new(-0.3, 0.1, -0.9).normalize(),
        ] {
            let (t, b) = n.basis();
            assert!((t.length() - 1.0).abs() < 1e-6);
            assert!((b.length() - 1.0).abs() < 1e-6);
            assert!(t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6 && t.dot(b).abs() < 1e-6);
            // right-handed: t x b = n
            assert!((t.cross(b) - n).length() < 1e-6);
        }
    }
}
