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
    /// The axis (0, 1, 2) that the normal lies along, exactly (its other
    /// components ±0), or 3: [`Plane::hit`]'s arithmetic on that axis alone.
    axis: u8,
}

impl Plane {
    /// The plane through `point` with normal `normal` (any non-zero length;
    /// it is normalised here).
    pub fn new(point: Vec3, normal: Vec3, material: u16) -> Self {
        let n = normal.normalize();
        let axis = match (n.x != 0.0, n.y != 0.0, n.z != 0.0) {
            (true, false, false) => 0,
            (false, true, false) => 1,
            (false, false, true) => 2,
            _ => 3,
        };
        Self {
            normal: n,
            offset: n.dot(point),
            material,
            axis,
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
    ///
    /// For a plane along an axis (the walls of a box) only that axis'
    /// coordinate is computed: with the normal's other components ±0 and
    /// this one ±1 (a unit vector with two zero components), `n·p` is that
    /// coordinate times ±1 exactly, and the other coordinates are
    /// unchanged, so the record is the general one's (but for the sign of
    /// a zero coordinate, which no later operation distinguishes).
    #[inline]
    pub fn hit(&self, ray: &Ray, t: f32, id: ObjectId) -> Hit {
        let n = self.normal;
        let p = ray.at(t);
        let off = self.offset;
        // the projection's rounding scales with the point before projection,
        // `p`, which lies off the plane by the rounding of o + t·d (large
        // when the origin is far away) while `point` may be near 0: a bound
        // on |point| alone let spawned rays start on the wrong side
        let (point, along) = match self.axis {
            0 => (
                Vec3::new(p.x - n.x * (n.x * p.x - off), p.y, p.z),
                math::abs(p.x),
            ),
            1 => (
                Vec3::new(p.x, p.y - n.y * (n.y * p.y - off), p.z),
                math::abs(p.y),
            ),
            2 => (
                Vec3::new(p.x, p.y, p.z - n.z * (n.z * p.z - off)),
                math::abs(p.z),
            ),
            _ => (p - n * (n.dot(p) - off), n.abs().dot(p.abs())),
        };
        let error = math::gamma(10) * (along + math::abs(off));
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

    /// The hit record of a plane along an axis is the general formula's
    /// (both signs of the normal, points near and far, both sides).
    #[test]
    fn axis_plane_hit_is_the_general_one() {
        let mut x = 0x9e37_79b9u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 8) as f32 / 16_777_216.0 - 0.5
        };
        for axis in 0..3 {
            for sign in [1.0f32, -1.0] {
                let mut nv = [0.0f32; 3];
                nv[axis] = sign * 3.0;
                let normal = Vec3::new(nv[0], nv[1], nv[2]);
                for scale in [1.0f32, 1e-3, 1e4] {
                    let point = Vec3::new(next(), next(), next()) * scale;
                    let p = Plane::new(point, normal, 0);
                    assert_eq!(p.axis, axis as u8);
                    let general = Plane { axis: 3, ..p };
                    for _ in 0..200 {
                        let o = Vec3::new(next(), next(), next()) * (4.0 * scale);
                        let d = Vec3::new(next(), next(), next()).normalize();
                        let r = Ray::new(o, d);
                        let Some(t) = p.intersect(&r, f32::INFINITY) else {
                            continue;
                        };
                        let (a, b) = (
                            p.hit(&r, t, ObjectId::plane(0)),
                            general.hit(&r, t, ObjectId::plane(0)),
                        );
                        assert_eq!(a, b, "axis {axis}, sign {sign}, scale {scale}");
                    }
                }
            }
        }
        let tilted = Plane::new(Vec3::ZERO, Vec3::new(0.0, 1.0, 1e-3), 0);
        assert_eq!(tilted.axis, 3);
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
