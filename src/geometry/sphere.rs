//! Spheres: Ray Tracing Gems ch. 7 intersection and re-projected hit points.

use super::{Hit, ObjectId, Ray, Vec3};
use crate::math;

/// A sphere. Construct with [`Sphere::new`], which caches the squared radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f32,
    /// `radius * radius`, cached.
    pub(crate) radius2: f32,
    /// What the radius lacks, below its f32 rounding, for the surface to
    /// pass where the scene put it ([`Sphere::with_residuals`]); 0 for a
    /// sphere whose centre and radius are exact f32 values.
    pub(crate) radius_lo: f32,
    /// Index of the material in the scene.
    pub material: u16,
}

impl Sphere {
    /// A sphere with the given centre, radius and material index.
    pub fn new(center: Vec3, radius: f32, material: u16) -> Self {
        Self {
            center,
            radius,
            radius2: radius * radius,
            radius_lo: 0.0,
            material,
        }
    }

    /// A sphere whose centre and radius are `center + center_lo` and
    /// `radius + radius_lo`, each given as an f32 and the rest of its exact
    /// value (a decimal such as smallpt's −99918.4 lies 0.0016 from the
    /// nearest f32; [`crate::parse`] passes both parts).
    ///
    /// The rounding of a huge sphere's centre moves its surface by up to
    /// half an ulp of the centre's coordinates (1/256 at 1e5): for smallpt's
    /// ceiling, 0.0016 units, which grew the rim where the lamp, a sphere of
    /// radius 600, pokes 0.27 units through it by 0.05 units, a visible
    /// fraction of the rim's pixels. The remainders cannot be kept at f32
    /// precision in the centre itself, so they go into the radius: the
    /// sphere about the f32 centre whose radius is `radius + δ`, with
    /// `δ = radius_lo + n·center_lo` and `n` the unit direction from the
    /// centre toward the world origin, passes through the exact surface
    /// point in that direction and lies within `|center_lo|·|m − n|` of the
    /// exact sphere in any other direction `m`: negligible across a scene
    /// (under 1e-5 units for smallpt's walls, where `|m − n| < 2e-3`), but
    /// up to twice the centre's rounding on the side away from the origin
    /// (`m = −n`), where the sphere without `δ` is off by once it: the
    /// correction is for the side that faces the origin. `δ` enters where the
    /// surface's exact position counts: the power of ray origins near the
    /// surface and the refined hit points of huge spheres.
    pub fn with_residuals(
        center: Vec3,
        center_lo: Vec3,
        radius: f32,
        radius_lo: f32,
        material: u16,
    ) -> Self {
        let len = center.length();
        let toward_origin = if len > 0.0 {
            center * (-1.0 / len)
        } else {
            Vec3::ZERO
        };
        let delta = radius_lo + toward_origin.dot(center_lo);
        Self {
            radius_lo: if math::is_finite(delta) { delta } else { 0.0 },
            ..Self::new(center, radius, material)
        }
    }

    /// Ray parameter of the first intersection in `(0, t_max)`, or `None`.
    ///
    /// The robust form of Ray Tracing Gems ch. 7 (Haines et al.): the
    /// discriminant comes from the perpendicular distance `l` of the centre to
    /// the ray (no cancellation of two large squares), and the near root is
    /// `c / q`, so neither root suffers catastrophic cancellation. It holds for
    /// smallpt's walls of radius 1e5. `ray.dir` must be unit length.
    ///
    /// Most rays miss most spheres, so a cheap test comes first: the line
    /// misses the sphere iff `(f·d)² − c |d|² < 0` (`f = o − centre`,
    /// `c = |f|² − r²`), which cancels for distant spheres but has an error
    /// below `2⁻¹⁸ |f|²` (about twenty roundings of terms up to `|f|²`, for
    /// any length of `d`); only a line that misses by more than that is
    /// rejected before the robust form, which decides everything else. (The
    /// robust discriminant's own rounding is of the same order, so no hit it
    /// would find is lost.)
    ///
    /// On targets without an FPU, where each of those float operations is
    /// a call of some 60 instructions, a pre-test in integer arithmetic
    /// first rejects the lines that miss by a wide margin; it only rejects
    /// lines the float test rejects too, so the result is the same.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<f32> {
        if math::SOFT_FLOAT && line_misses_by_far(ray.origin, self.center, ray.dir, self.radius2) {
            return None;
        }
        let f = ray.origin - self.center;
        let b = -f.dot(ray.dir); // ray parameter of the closest approach
        let ff = f.dot(f);
        let c = ff - self.radius2; // > 0: origin outside
        if line_misses(b, c, ff, ray.dir.dot(ray.dir)) {
            return None;
        }
        self.intersect_robust(ray, t_max, f, b, c)
    }

    /// The robust part of [`Sphere::intersect`], from `f = o − centre`,
    /// `b = −f·d` and `c = |f|² − r²`.
    #[inline(always)]
    fn intersect_robust(&self, ray: &Ray, t_max: f32, f: Vec3, b: f32, c: f32) -> Option<f32> {
        let mut c = c;
        if math::gt_zero(c) && (math::le_zero(b) || b - self.radius >= t_max) {
            // outside, and the sphere lies behind the origin or beyond t_max
            return None;
        }
        let l = f + ray.dir * b;
        let disc = self.radius2 - l.dot(l);
        if math::lt_zero(disc) {
            return None;
        }
        let sq = math::sqrt(disc);
        // roots are q and c/q with q = b ± √disc (the sign of b: no
        // cancellation); outside (c > 0, b > 0) the near root is c/q; inside
        // (c ≤ 0) the positive root is q if b ≥ 0, else c/q
        let q = if math::ge_zero(b) { b + sq } else { b - sq };
        // origin within 3 % of r from the surface: |f|² − r² cancels, and its
        // f32 rounding (up to ~3ε|f|², over 1000 for smallpt's r = 1e5
        // walls) moves the near root by ~1.5εr = 0.01, which shifts the rim
        // where smallpt's lamp meets the ceiling by a fifth of a pixel
        // (docs/stability.md). Recompute it where it is used (c/q), or where
        // its sign, which picks the root, is within its rounding.
        if math::abs(c) < self.radius2 * 0.0625
            && (math::gt_zero(c)
                || math::lt_zero(b)
                || -c <= math::gamma(8) * (c + 2.0 * self.radius2))
        {
            // the recomputation costs some 60 operations: first a bound on
            // the rounded c, |c − c_exact| ≤ γ(8)(|f|² + r²) + 2r|δ| (three
            // roundings of f, three of |f|², one of the difference, and the
            // radius' residual); where |c| − slack ≥ t_max |q|, the exact c
            // has the same sign and its root lies beyond t_max too: the same
            // answer, for most walls a ray heads toward once a nearer hit is
            // known
            let slack = math::gamma(8) * (c + 2.0 * self.radius2)
                + 2.0 * self.radius * math::abs(self.radius_lo);
            if math::abs(c) - slack >= t_max * math::abs(q) {
                return None;
            }
            c = self.origin_power(ray.origin);
        }
        let t = if math::gt_zero(c) || math::lt_zero(b) {
            c / q
        } else {
            q
        };
        if math::positive_below(t, t_max) {
            Some(t)
        } else {
            None
        }
    }

    /// `|o − c|² − (r + δ)²` (the power of the point `o`, with the radius's
    /// residual δ of [`Sphere::with_residuals`]) to a few ulps of the
    /// result, in double-f32 arithmetic: the difference, the squares and
    /// the sum are split into exact high and low parts
    /// ([`math::two_sum`], [`math::two_square`]).
    #[inline(always)]
    pub(crate) fn origin_power(&self, o: Vec3) -> f32 {
        self.power_at(o.x, o.y, o.z)
    }

    /// [`Sphere::origin_power`] of the point `(x, y, z)`. Out of line, and
    /// its point in registers: a `Vec3` argument would be passed by
    /// reference, and whatever holds the point (a path's state) would have
    /// to live in memory.
    #[inline(never)]
    fn power_at(&self, x: f32, y: f32, z: f32) -> f32 {
        let (fx, ex) = math::two_sum(x, -self.center.x);
        let (fy, ey) = math::two_sum(y, -self.center.y);
        let (fz, ez) = math::two_sum(z, -self.center.z);
        let (px, qx) = math::two_square(fx);
        let (py, qy) = math::two_square(fy);
        let (pz, qz) = math::two_square(fz);
        let (pr, qr) = math::two_square(self.radius);
        let (s1, e1) = math::two_sum(px, py);
        let (s2, e2) = math::two_sum(s1, pz);
        let (s3, e3) = math::two_sum(s2, -pr);
        // (r + δ)² = r² + 2rδ + δ²: δ is below r's rounding, so 2rδ is of
        // the size of the low parts, and δ² is negligible
        let lo = (e1 + e2 + e3)
            + ((qx + qy + qz) - qr - 2.0 * self.radius * self.radius_lo)
            + 2.0 * (fx * ex + fy * ey + fz * ez)
            + (ex * ex + ey * ey + ez * ez);
        s3 + lo
    }

    /// Ray parameter of the far intersection of a ray that starts on this
    /// sphere's surface and enters it, or `None` if it leaves the sphere.
    ///
    /// This is how a ray spawned from the sphere treats its own surface:
    /// leaving outward it cannot hit a convex surface again; entering, it hits
    /// only the far side. No epsilon is involved.
    #[inline(always)]
    pub fn intersect_from_surface(&self, ray: &Ray, t_max: f32) -> Option<f32> {
        let f = ray.origin - self.center;
        let b = -f.dot(ray.dir);
        if math::le_zero(b) {
            return None;
        }
        let l = f + ray.dir * b;
        let disc = self.radius2 - l.dot(l);
        if !math::ge_zero(disc) {
            // a grazing ray whose origin was offset outward (it leaves the
            // sphere): b > 0 only by rounding, and the line misses
            return None;
        }
        let t = b + math::sqrt(disc);
        if t < t_max { Some(t) } else { None }
    }

    /// The hit record at ray parameter `t` (from [`Sphere::intersect`]).
    ///
    /// The point is re-projected onto the sphere (pbrt), which leaves an error
    /// e of at most γ(5)·|p − c| per coordinate relative to the centre, plus
    /// the rounding of adding the centre back (γ(1)·|p|, counted as γ(5)·|p|:
    /// the bound then covers five roundings of the point's own coordinates,
    /// which is what lets [`Hit::spawn`](super::Hit::spawn) offset by 1.25
    /// times the bound without directed rounding); the stated distance bound
    /// is e·|n| + |e|²/(2r) (the tangential part counts at second order).
    ///
    /// A sphere much larger than the hit point's coordinates (smallpt's
    /// walls: r = 1e5 around a room 100 units wide) would get a bound of
    /// γ(5)·r that way, far above the scene's own rounding; its hit point
    /// is refined at the point's own scale instead.
    #[inline]
    pub fn hit(&self, ray: &Ray, t: f32, id: ObjectId) -> Hit {
        let p0 = ray.origin + ray.dir * t;
        if self.radius > HUGE * p0.abs().max_component() {
            // the parts come back in a temporary of their own, so that the
            // common path's record can stay in registers
            let (point, normal, error) = self.hit_huge(p0);
            return Hit {
                t,
                point,
                normal,
                error,
                object: id,
                material: self.material,
            };
        }
        let mut local = ray.origin - self.center + ray.dir * t;
        let len = local.length();
        local *= self.radius / len;
        let point = self.center + local;
        let normal = local * (1.0 / self.radius);
        let err = (local.abs() + point.abs()) * math::gamma(5);
        // distance from the surface of the true point moved by e: at most
        // e·n + |e|²/(2r), and at most |e|. The second-order term matters
        // only for spheres a few f32 grid steps wide (r = 0.07 at 8e5, where
        // coordinates are 0.0625 apart): e·n alone falls short there
        let e1 = err.x + err.y + err.z; // ≥ |e|
        let error = math::min(err.dot(normal.abs()) + e1 * e1 * (0.5 / self.radius), e1);
        Hit {
            t,
            point,
            normal,
            error,
            object: id,
            material: self.material,
        }
    }

    /// The point, normal and error bound of the hit record of a sphere at
    /// least [`HUGE`] times larger than the coordinates of the point
    /// `p0 = o + t·d`.
    ///
    /// Re-projecting through the centre would round the point at the
    /// centre's scale (ulp(1e5) = 1/128 for smallpt's walls): an error bound
    /// of γ(5)·r, and spawned rays offset by 0.04 units, which hid the top
    /// seventh of the lamp's 0.27-unit rim from the floor below. Instead
    /// `p0` moves along the normal by its signed distance from the surface,
    /// `s = (|p0 − c|² − r²) / (|p0 − c| + r)`, whose numerator
    /// [`Sphere::origin_power`] gives to a few ulps of itself; the point is
    /// then rounded at its own scale. Its distance from the surface is at
    /// most the rounding of `p0 − n·s` (γ(5)·|p|, counted five times as in
    /// [`Sphere::hit`]), the rounding of `s` and of the normal's direction
    /// applied to it (γ(8)·|s|) and the curvature left by a straight step
    /// (s²/(2r), with no effect at this scale but kept for rigour).
    #[inline(never)]
    fn hit_huge(&self, p0: Vec3) -> (Vec3, Vec3, f32) {
        let local = p0 - self.center;
        let len = local.length();
        let normal = local * (1.0 / len);
        let s = self.origin_power(p0) / (len + self.radius + self.radius_lo);
        let point = p0 - normal * s;
        let s_abs = math::abs(s);
        let error = (point.abs() * math::gamma(5)).dot(normal.abs())
            + s_abs * math::gamma(8)
            + s_abs * s_abs * (0.5 / self.radius);
        (point, normal, error)
    }
}

/// The cheap test of [`Sphere::intersect`]: whether `(f·d)² − c |d|² <
/// −2⁻¹⁸ |f|²`, from `b = −f·d`, `c = |f|² − r²`, `ff = |f|²` and `dd =
/// |d|²` (`f = o − centre`). `c ≤ 0` (inside) never rejects: `b² − c |d|²
/// ≥ 0`.
#[inline(always)]
pub(crate) fn line_misses(b: f32, c: f32, ff: f32, dd: f32) -> bool {
    b * b - c * dd < -ff * (1.0 / 262_144.0)
}

/// `x · 2^(e − sh)` truncated toward zero (`e` the biased exponent of the
/// f32 bits `x`), for `sh ≥ e + 2`: `|result| < 2³⁰`, off by less than 1;
/// 0 for a shift of 32 or more.
#[inline(always)]
fn to_fixed(x: u32, sh: u32) -> i32 {
    let sh = sh - ((x << 1) >> 24);
    // the significand with its leading bit at bit 31 (bogus for a zero or
    // subnormal, whose shift here is always 32 or more)
    let mag = if sh < 32 {
        (((x << 8) | 0x8000_0000) >> sh) as i32
    } else {
        0
    };
    let sign = (x as i32) >> 31;
    (mag ^ sign) - sign
}

/// The biased exponent field of the largest of three f32 magnitudes.
#[inline(always)]
fn max_exponent(v: Vec3) -> u32 {
    let e = |x: f32| (x.to_bits() << 1) >> 24;
    e(v.x).max(e(v.y)).max(e(v.z))
}

/// Whether the line `o + t·d` misses the sphere of centre `centre` and
/// squared radius `r2` by far, in 32-bit integer arithmetic: true only
/// where [`line_misses`], the float test on `f = o − centre` (rounded), is
/// true too; false where it cannot tell (near misses, the origin inside,
/// inputs out of its range).
///
/// `E = (f·d)² − (|f|² − r²)|d|²` (exact arithmetic on the f32 `f`, `d`,
/// `r²`) is within `2⁻¹⁹ |f|² |d|²` of the float test's rounded value if
/// `|f|² > r²` (seventeen roundings of terms up to `|f|²|d|²`), so `E <
/// −2⁻¹⁵ |f|² |d|²` with `|d|² ≥ ½` makes the float test reject. Here `E`
/// is approximated in fixed point: `o` and the centre scaled by a power of
/// two `S` that puts the largest of their components below 2³⁰, truncated,
/// and subtracted (`G`, within 2 units of `f·S`); `G` shifted right by
/// `sh ≥ 4` to put its largest component in [2¹⁴, 2¹⁵) gives `F = f·s`
/// (`s = S/2^sh`) within 1 + 2^(1 − sh) + 2⁻⁹ ≤ 1.13 units (the last term:
/// the rounding of `f`); `D = d·2¹⁴` truncated (within 1). From them `B =
/// Σ F·D`, `FF = Σ F²`, `DD = Σ D²`, `R = ⌊r² s²⌋`, and with `B₁ = B >>
/// 15`, `C₁ = (FF − R) >> 15`, `D₁ = DD >> 15` the value `B₁² − C₁ D₁` is
/// within 897,943 < 2²⁰ of `E s²/4` (error bounds: `B` 143,653, so `B₁²`
/// 431,300; `FF` 222,167; `DD` 80,265; `C₁ D₁` 466,643); and `2⁻¹⁵|f|²|d|²
/// s²/4 < 2¹⁶`, so `B₁² − C₁ D₁ < −(2²⁰ + 2¹⁶)` implies the float test's
/// rejection (and `C₁ > 64`: `|f|² > r²`). It rejects every line whose
/// distance² from the centre exceeds `r² + 0.03 |f|²` (unit `d`, `|f|` at
/// least 2⁻¹² of the largest coordinate).
///
/// Conditions, else false: every coordinate of `o` and the centre below
/// 2⁴¹ and one at least 2⁻⁴⁰, `G`'s largest component at least 2¹⁸
/// (`sh ≥ 4`), |d| components below 2 and `DD` in [2²⁷ + 2¹⁸, 2²⁹ − 2¹⁸]
/// (so `|d|²` in (½, 2)), `r² s² < 2³²` and `C₁ > 64`.
#[inline(always)]
pub(crate) fn line_misses_by_far(o: Vec3, centre: Vec3, d: Vec3, r2: f32) -> bool {
    // the direction first: the same for every sphere of a ray's loop, where
    // this is inlined, so the compiler computes it once per ray
    if max_exponent(d) > 127 {
        return false;
    }
    let (dx, dy, dz) = (d.x.to_bits(), d.y.to_bits(), d.z.to_bits());
    // D = d·2¹⁴: the significand (leading bit at 31) >> (144 − e)
    let (ddx, ddy, ddz) = (to_fixed(dx, 144), to_fixed(dy, 144), to_fixed(dz, 144));
    let dd = (ddx * ddx) as u32 + (ddy * ddy) as u32 + (ddz * ddz) as u32;
    if dd.wrapping_sub((1 << 27) + (1 << 18)) > (1 << 29) - (1 << 27) - (1 << 19) {
        return false;
    }
    // biased exponent in [87, 167]: 2⁻⁴⁰ ≤ the largest coordinate < 2⁴¹
    let m = max_exponent(o).max(max_exponent(centre));
    if m.wrapping_sub(87) > 80 {
        return false;
    }
    // G = (o − centre)·S, S = 2^(156 − m): each coordinate >> (m + 2 − e)
    let g = |a: f32, b: f32| to_fixed(a.to_bits(), m + 2) - to_fixed(b.to_bits(), m + 2);
    let (gx, gy, gz) = (g(o.x, centre.x), g(o.y, centre.y), g(o.z, centre.z));
    // the bit length of the largest |G|, in binary steps (no count-
    // leading-zeros instruction on ARMv6-M); at least 19
    let mut top = gx.unsigned_abs() | gy.unsigned_abs() | gz.unsigned_abs();
    if top < 1 << 18 {
        return false;
    }
    let mut sh = 4;
    if top >= 1 << 26 {
        top >>= 8;
        sh += 8;
    }
    if top >= 1 << 22 {
        top >>= 4;
        sh += 4;
    }
    if top >= 1 << 20 {
        top >>= 2;
        sh += 2;
    }
    if top >= 1 << 19 {
        sh += 1;
    }
    let (ffx, ffy, ffz) = (gx >> sh, gy >> sh, gz >> sh);
    let ff = (ffx * ffx) as u32 + (ffy * ffy) as u32 + (ffz * ffz) as u32;
    // R = ⌊r² s²⌋ = ⌊m_r · 2^(e_r + 162 − 2m − 2sh)⌋ (m_r the 24-bit
    // significand)
    let r = r2.to_bits() & 0x7fff_ffff;
    let er = r >> 23;
    let k = (er + 162) as i32 - 2 * (m + sh) as i32;
    let rr = if er == 0 {
        0 // below 2⁻¹²⁶: r² s² < 2⁻³⁰
    } else if k >= 9 {
        return false; // r² s² ≥ 2³² (also a NaN or infinite r²)
    } else {
        let mr = (r & 0x007f_ffff) | 0x0080_0000;
        if k >= 0 {
            mr << k
        } else if k > -32 {
            mr >> -k
        } else {
            0
        }
    };
    // a rejection needs C₁ D₁ > 2²⁰ with D₁ ≤ 2¹⁴: C₁ > 64, FF − R > 2²¹,
    // far above its error, so |f|² > r² (the origin is outside)
    let c1 = ff.saturating_sub(rr) >> 15;
    if c1 <= 64 {
        return false;
    }
    let b1 = (ffx * ddx + ffy * ddy + ffz * ddz) >> 15;
    let e1 = (b1 * b1) - (c1 * (dd >> 15)) as i32;
    e1 < -((1 << 20) + (1 << 16))
}

/// A sphere whose radius exceeds this multiple of its hit point's largest
/// coordinate gets its hit point refined at the point's scale
/// ([`Sphere::hit_huge`]) rather than re-projected through its centre.
pub const HUGE: f32 = 16.0;

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(c: Vec3, r: f32) -> Sphere {
        Sphere::new(c, r, 0)
    }

    #[test]
    fn hits_from_outside_and_inside() {
        let s = sphere(Vec3::new(0.0, 0.0, -5.0), 1.0);
        let r = Ray::new(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(s.intersect(&r, f32::INFINITY), Some(4.0));
        let inside = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(s.intersect(&inside, f32::INFINITY), Some(1.0));
        let behind = Ray::new(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(s.intersect(&behind, f32::INFINITY), None);
        assert_eq!(s.intersect(&r, 3.9), None);
    }

    /// The cheap rejection before the robust form never drops a hit: on
    /// rays that graze spheres of every scale (the line's distance from the
    /// centre within 1e-5 relative of the radius, either side), with
    /// directions a few ulps off unit length, `intersect` equals the robust
    /// form alone.
    #[test]
    fn cheap_rejection_keeps_every_robust_hit() {
        let mut u = uniform(0x9e37_79b9_7f4a_7c15u64);
        let (mut hits, mut kept) = (0u32, 0u32);
        for k in 0..200_000u32 {
            let scale = math::exp2(u() * 40.0 - 20.0);
            let c = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5) * (scale * 10.0);
            let r = scale * (0.01 + u());
            let s = sphere(c, r);
            let dir = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
            let dir = dir * (1.0 + (u() - 0.5) * 1e-6);
            // a point at distance r (1 ± 1e-5) from the centre, off the line
            // through it along dir; the origin some way back along dir
            let side = dir.basis().0;
            let miss = r * (1.0 + (u() - 0.5) * 2e-5);
            let back = scale * (u() * 100.0 + if k % 2 == 0 { 0.0 } else { -0.5 });
            let o = c + side * miss - dir * back;
            let ray = Ray::new(o, dir);
            let f = o - c;
            let b = -f.dot(dir);
            let robust = s.intersect_robust(&ray, f32::INFINITY, f, b, f.dot(f) - s.radius2);
            let fast = s.intersect(&ray, f32::INFINITY);
            assert_eq!(fast, robust, "case {k}");
            if line_misses_by_far(o, c, dir, s.radius2) {
                assert_eq!(robust, None, "case {k}");
            }
            hits += u32::from(robust.is_some());
            kept += 1;
        }
        // the grazing rays hit and miss about equally often
        assert!(hits > kept / 4 && hits < kept * 3 / 4, "{hits} of {kept}");
    }

    /// Uniform numbers in [0, 1) on the 2⁻²⁴ grid (splitmix64).
    fn uniform(mut z: u64) -> impl FnMut() -> f32 {
        move || {
            z = crate::sampler::mix64(z);
            (z >> 40) as f32 / 16_777_216.0
        }
    }

    /// A random unit vector (up to rounding), from `u` in [0, 1).
    fn unit(u: &mut impl FnMut() -> f32) -> Vec3 {
        loop {
            let v = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5);
            if v.length_squared() > 0.01 {
                return v.normalize();
            }
        }
    }

    /// The integer rejection is conservative: whenever it rejects, the
    /// float test does too (so both targets render the same bits). Lines
    /// at every scale whose squared distance from the centre lies within
    /// a small fraction of |f|² of r², either side (where the two tests'
    /// margins are), origins inside and on the surface, and directions
    /// off unit length by up to 10⁻⁶ relative.
    #[test]
    fn integer_rejection_implies_the_float_rejection() {
        let mut u = uniform(0x2545_f491_4f6c_dd1du64);
        let (mut cases, mut wide, mut wide_int) = (0u32, 0u32, 0u32);
        for k in 0..1_000_000u32 {
            let scale = math::exp2(u() * 90.0 - 45.0);
            let d = unit(&mut u) * (1.0 + (u() - 0.5) * 2e-6);
            // a centre up to 64 |f| from the origin, or anywhere up to 2¹⁶
            // |f| (where f's rounding and the fixed point's scale count)
            let far = if k % 8 == 7 { 65_536.0 } else { 64.0 };
            let centre = unit(&mut u) * (scale * u() * far);
            let o = centre + unit(&mut u) * (scale * (0.5 + u()));
            let f = o - centre;
            let b = -f.dot(d);
            let ff = f.dot(f);
            // squared distance of the centre from the line, and r² near it:
            // within 2⁻²⁶..2⁻² of |f|², or anywhere up to 2 |f|²
            let p = math::max(ff - b * b, 0.0);
            let r2 = match k % 4 {
                0 => u() * 2.0 * ff,
                1 => p + ff * math::exp2(-26.0 + u() * 24.0),
                _ => p - ff * math::exp2(-26.0 + u() * 24.0),
            };
            if !(r2 > 0.0) {
                continue;
            }
            let c = ff - r2;
            let float = line_misses(b, c, ff, d.dot(d));
            let int = line_misses_by_far(o, centre, d, r2);
            assert!(
                !int || float,
                "case {k}: o {o:?} centre {centre:?} d {d:?} r2 {r2}"
            );
            cases += 1;
            // not vacuous: the lines that miss by more than 0.03 |f|² at
            // scales within its range are all rejected
            if p > r2 + 0.031 * ff && far < 100.0 && scale > 1e-10 && scale < 1e9 {
                wide += 1;
                wide_int += u32::from(int);
            }
        }
        assert!(
            cases > 900_000 && wide > 50_000 && wide_int == wide,
            "{wide_int} of {wide}, {cases}"
        );
    }

    /// The integer rejection is effective: it rejects every line whose
    /// squared distance from the centre exceeds r² + 0.03 |f|², for unit
    /// directions, |f| anywhere in [2⁻³⁶, 2³⁴] and centres within 64 |f|
    /// of the origin.
    #[test]
    fn integer_rejection_rejects_every_clear_miss() {
        let mut u = uniform(0x9e37_79b9_7f4a_7c15u64);
        let mut n = 0;
        while n < 200_000 {
            let scale = math::exp2(u() * 68.0 - 35.0);
            let d = unit(&mut u);
            let centre = unit(&mut u) * (scale * u() * 64.0);
            let o = centre + unit(&mut u) * (scale * (0.5 + u()));
            let f = o - centre;
            let ff = f.dot(f);
            let b = f.dot(d);
            let p = ff - b * b;
            // r² = p − k |f|² with k from 0.031 up to p / |f|²
            let kmax = p / ff;
            if kmax <= 0.032 {
                continue;
            }
            let r2 = p - ff * (0.031 + u() * (kmax - 0.031));
            if !(r2 > 0.0) {
                continue;
            }
            assert!(
                line_misses_by_far(o, centre, d, r2),
                "o {o:?} centre {centre:?} d {d:?} r2 {r2}"
            );
            n += 1;
        }
    }

    #[test]
    fn smallpt_wall_is_hit_accurately() {
        // the left wall of smallpt: surface at x = 1
        let s = sphere(Vec3::new(100_001.0, 40.8, 81.6), 100_000.0);
        let r = Ray::new(Vec3::new(50.0, 40.0, 80.0), Vec3::new(-1.0, 0.0, 0.0));
        let t = s.intersect(&r, f32::INFINITY).unwrap();
        // inside the big sphere: the hit is at x = 1, t = 49
        assert!((t - 49.0).abs() < 0.02, "t = {t}");
        let h = s.hit(&r, t, ObjectId::sphere(0));
        assert!((h.point.x - 1.0).abs() <= h.error + 1e-3, "{h:?}");
        assert!(h.error < 0.05);
    }

    #[test]
    fn from_surface_only_far_side() {
        let s = sphere(Vec3::ZERO, 2.0);
        let on = Ray::new(Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(s.intersect_from_surface(&on, f32::INFINITY), Some(4.0));
        let out = Ray::new(Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.6, 0.8));
        assert_eq!(s.intersect_from_surface(&out, f32::INFINITY), None);
    }
}
