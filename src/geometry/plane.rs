//! Infinite two-sided planes.

use super::{Hit, ObjectId, Ray, Vec3};
use crate::math;

/// An infinite plane `{x : normal · x = offset}`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal (the side the scene file's normal points to).
    pub normal: Vec3,
    /// Signed distance of the plane from the origin along `normal`.
    pub offset: f32,
    /// Index of the material in the scene.
    pub material: u16,
}

impl Plane {
    /// The plane through `point` with normal `normal` (any non-zero length;
    /// it is normalised here).
    pub fn new(point: Vec3, normal: Vec3, material: u16) -> Self {
        let n = normal.normalize();
        Self {
            normal: n,
            offset: n.dot(point),
            material,
        }
    }

    /// Ray parameter of the intersection in `(0, t_max)`, or `None`. A ray
    /// parallel to the plane never hits it (the quotient is ±∞ or NaN, and
    /// every comparison with NaN is false).
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<f32> {
        let t = (self.offset - self.normal.dot(ray.origin)) / self.normal.dot(ray.dir);
        if math::positive_below(t, t_max) {
            Some(t)
        } else {
            None
        }
    }

    /// The hit record at ray parameter `t`: the point `p = o + t·d` is
    /// re-projected onto the plane, leaving a distance error of at most
    /// γ(10)·(|n|·|p| + |offset|).
    #[inline]
    pub fn hit(&self, ray: &Ray, t: f32, id: ObjectId) -> Hit {
        let n = self.normal;
        let p = ray.at(t);
        let point = p - n * (n.dot(p) - self.offset);
        // the projection's rounding scales with the point before projection,
        // `p`, which lies off the plane by the rounding of o + t·d (large
        // when the origin is far away) while `point` may be near 0: a bound
        // on |point| alone let spawned rays start on the wrong side
        let error = math::gamma(10) * (n.abs().dot(p.abs()) + math::abs(self.offset));
        Hit {
            t,
            point,
            normal: n,
            error,
            object: id,
            material: self.material,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hit_from_both_sides_and_parallel_miss() {
        let p = Plane::new(Vec3::ZERO, Vec3::new(0.0, 2.0, 0.0), 0);
        let down = Ray::new(Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.0, -1.0, 0.0));
        assert_eq!(p.intersect(&down, f32::INFINITY), Some(3.0));
        let up = Ray::new(Vec3::new(0.0, -3.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(p.intersect(&up, f32::INFINITY), Some(3.0));
        let par = Ray::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(p.intersect(&par, f32::INFINITY), None);
        let away = Ray::new(Vec3::new(0.0, 3.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        assert_eq!(p.intersect(&away, f32::INFINITY), None);
    }

    #[test]
    fn far_plane_hit_is_reprojected() {
        let p = Plane::new(Vec3::new(0.0, 1.0e6, 0.0), Vec3::new(0.3, 1.0, -0.2), 0);
        let r = Ray::new(
            Vec3::new(5.0, 0.0, 3.0),
            Vec3::new(0.1, 1.0, 0.05).normalize(),
        );
        let t = p.intersect(&r, f32::INFINITY).unwrap();
        let h = p.hit(&r, t, ObjectId::plane(0));
        assert!(math::abs(p.normal.dot(h.point) - p.offset) <= h.error);
    }
}
