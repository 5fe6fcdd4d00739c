//! Rays, hit records, and spawning rays from a surface without self-hits.

use super::Vec3;

/// A ray: an origin and a unit-length direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
}

impl Ray {
    /// A ray from `origin` along the unit vector `dir`.
    #[inline(always)]
    pub const fn new(origin: Vec3, dir: Vec3) -> Self {
        Self { origin, dir }
    }

    /// The point at parameter `t`.
    #[inline(always)]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Identifies one object of a scene: a sphere or a plane by index, or none.
///
/// Packed into 16 bits: planes have the top bit set, so a sphere index and a
/// plane index never compare equal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ObjectId(pub(crate) u16);

impl ObjectId {
    /// No object (camera rays start on none).
    pub const NONE: Self = Self(u16::MAX);
    const PLANE_BIT: u16 = 0x8000;

    /// The sphere with index `i`.
    #[inline(always)]
    pub const fn sphere(i: usize) -> Self {
        Self(i as u16 & !Self::PLANE_BIT)
    }

    /// The plane with index `i`.
    #[inline(always)]
    pub const fn plane(i: usize) -> Self {
        Self(i as u16 | Self::PLANE_BIT)
    }

    /// The sphere index, if this is a sphere.
    #[inline(always)]
    pub const fn as_sphere(self) -> Option<usize> {
        if self.0 & Self::PLANE_BIT == 0 {
            Some(self.0 as usize)
        } else {
            None
        }
    }

    /// The index bits without the plane bit: the plane index of a plane,
    /// and `0x7fff` for [`ObjectId::NONE`], beyond every plane index a
    /// scene can have (`get` of it on a plane array is `None`). For an id
    /// known to be a plane or none: a lookup without [`ObjectId::as_plane`]'s
    /// test.
    #[inline(always)]
    pub(crate) const fn plane_slot(self) -> usize {
        (self.0 & !Self::PLANE_BIT) as usize
    }

    /// The plane index, if this is a plane.
    #[inline(always)]
    pub const fn as_plane(self) -> Option<usize> {
        if self.0 != u16::MAX && self.0 & Self::PLANE_BIT != 0 {
            Some((self.0 & !Self::PLANE_BIT) as usize)
        } else {
            None
        }
    }
}

/// A ray-surface intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// The hit point, re-projected onto the surface.
    pub point: Vec3,
    /// Unit geometric normal: outward for spheres, the plane's own normal for
    /// planes (not flipped toward the ray).
    pub normal: Vec3,
    /// Bound on the distance between `point` and the true surface along the
    /// normal (pbrt's error analysis): rays leaving the surface start this far
    /// off it.
    pub error: f32,
    /// The object that was hit.
    pub object: ObjectId,
    /// Index of the object's material in the scene.
    pub material: u16,
}

impl Hit {
    /// A ray leaving the hit point along the unit vector `dir`, its origin
    /// offset to `dir`'s side of the surface by a margin over its error bound, so that it
    /// cannot start behind the surface it leaves, at any scale.
    #[inline]
    pub fn spawn(&self, dir: Vec3) -> Ray {
        Ray::new(offset_origin(self.point, self.normal, self.error, dir), dir)
    }

    /// [`Hit::spawn`] when the caller knows the side: `side` is the normal
    /// or its negation, whichever points to the side `dir` leaves into (the
    /// shading normal of a diffuse vertex, for its BSDF and light samples).
    #[inline(always)]
    pub fn spawn_on(&self, side: Vec3, dir: Vec3) -> Ray {
        Ray::new(offset_along(self.point, side, self.error), dir)
    }
}

/// `p` moved off the surface with unit normal `n` by 1.25 times the error
/// bound `err`, to the side that `dir` points into.
///
/// pbrt-v4 offsets by `err` and rounds each coordinate of the sum away from
/// the surface. Here a margin in the factor covers that rounding instead,
/// without per-coordinate directed rounding (three branches per
/// coordinate). With `s = ±n`, `e = 1.25·err` and every rounding `≤ u = 2⁻²⁴`
/// relative, the rounded origin `o` satisfies
/// `s·(o − p) ≥ e (1 − 7u) − u (|n|·|p|)`. Both shapes' bounds hold at least
/// five roundings of the point's coordinates, `err ≥ 5u (|n|·|p|)`, so
/// `s·(o − p) ≥ err (1.25 (1 − 7u) − 0.2) > err`: the origin lies beyond the
/// true surface, on `dir`'s side, at any scale. (Twice the bound, which
/// needs no such condition, made smallpt's light rim, where a cap 0.27
/// units high meets walls whose bound is 0.03, measurably brighter.)
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3, err: f32, dir: Vec3) -> Vec3 {
    let side = if n.dot(dir) < 0.0 { -n } else { n };
    offset_along(p, side, err)
}

/// `p + side · 1.25·err` (see [`offset_origin`]).
#[inline(always)]
fn offset_along(p: Vec3, side: Vec3, err: f32) -> Vec3 {
    p + side * (1.25 * err)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn object_ids_do_not_collide() {
        assert_ne!(ObjectId::sphere(3), ObjectId::plane(3));
        assert_eq!(ObjectId::sphere(3).as_sphere(), Some(3));
        assert_eq!(ObjectId::plane(3).as_plane(), Some(3));
        assert_eq!(ObjectId::plane(3).as_sphere(), None);
        assert_eq!(ObjectId::NONE.as_plane(), None);
        assert_eq!(ObjectId::NONE.as_sphere(), None);
    }

    #[test]
    fn offset_goes_to_the_side_of_the_direction() {
        let n = Vec3::new(0.0, 1.0, 0.0);
        let p = Vec3::new(1.0e5, 0.0, -3.0);
        let up = offset_origin(p, n, 1e-3, Vec3::new(0.0, 1.0, 0.0));
        let down = offset_origin(p, n, 1e-3, Vec3::new(0.6, -0.8, 0.0));
        assert!(up.y > 0.0 && down.y < 0.0);
        assert_eq!(up.x, p.x);
    }
}
