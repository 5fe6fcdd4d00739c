//! Sphere lights: uniform sampling of the cone they subtend, and its pdf.

use crate::geometry::Vec3;
use crate::math;
use crate::sampler::concentric_disk;

/// A direction toward a sphere light, the distance to its surface along it,
/// and the pdf of having chosen it (per unit solid angle).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeSample {
    /// Unit direction from the shading point.
    pub dir: Vec3,
    /// Distance from the shading point to the light's surface along `dir`.
    pub dist: f32,
    /// Solid-angle pdf: 1 / (2π (1 − cos θ_max)).
    pub pdf: f32,
}

/// `1 − cos θ_max` of the cone subtended by a sphere of squared radius `r2`
/// seen from squared distance `d2` (> r2), computed without cancellation:
/// with s² = r²/d², `1 − √(1 − s²) = s² / (1 + √(1 − s²))`. The naive form
/// loses every digit in f32 below r/d ≈ 1e-3: `1 − √(1 − s²)` then
/// subtracts two numbers that agree in every bit.
#[inline(always)]
pub fn one_minus_cos_max(r2: f32, d2: f32) -> f32 {
    let s2 = r2 / d2;
    s2 / (1.0 + math::sqrt(1.0 - s2))
}

/// The solid-angle pdf of [`sample_cone`] for any direction inside the cone
/// (0 when `x` is inside the sphere, where the light is not sampled).
#[inline]
pub fn cone_pdf(x: Vec3, center: Vec3, r2: f32) -> f32 {
    let d2 = (center - x).length_squared();
    if d2 <= r2 {
        return 0.0;
    }
    1.0 / (math::TWO_PI * one_minus_cos_max(r2, d2))
}

/// Samples a direction uniformly within the cone that the sphere
/// (`center`, squared radius `r2`) subtends from `x`, from `(u1, u2)` in
/// [0,1)². `None` when `x` is inside or on the sphere (an outward-only emitter
/// sends nothing inward). See [`sample_cone_toward`].
#[inline]
pub fn sample_cone(
    x: Vec3,
    center: Vec3,
    r2: f32,
    u1: f32,
    u2: f32,
    fast: bool,
) -> Option<ConeSample> {
    let to_c = center - x;
    let d2 = to_c.length_squared();
    if !(d2 > r2) {
        return None;
    }
    let s = sample_cone_toward(to_c, d2, r2, u1, u2, fast, true);
    Some(ConeSample {
        dir: s.dir,
        dist: s.dist,
        pdf: 1.0 / (math::TWO_PI * s.omc_max),
    })
}

/// A direction sampled in a light's cone by [`sample_cone_toward`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConeDir {
    /// Unit direction from the shading point.
    pub dir: Vec3,
    /// Distance from the shading point to the light's surface along `dir`
    /// (or to the chord's midpoint, see [`sample_cone_toward`]).
    pub dist: f32,
    /// `1 − cos θ_max` of the cone ([`one_minus_cos_max`]): the pdf is
    /// `1 / (2π omc_max)`.
    pub omc_max: f32,
}

/// [`sample_cone`] from the vector `to_c` to the centre and its squared
/// length `d2` (> `r2`), which the caller has already computed. With
/// `surface` false, `dist` is the midpoint of the direction's chord through
/// the ball, `d cos θ`, instead of the near intersection with the surface
/// (one square root less): as far as a shadow ray must be tested when no
/// occluder reaches into the light.
///
/// A uniform point `(x, y)` of the unit disk ([`concentric_disk`]) with
/// `ρ² = x² + y²` gives `1 − cos θ = ρ² (1 − cos θ_max)`, uniform in the
/// cone's solid angle, and the azimuth of `(x, y)`; `sin θ = ρ √(omc_max
/// (2 − omc))`, so the tangential part is `(x t + y b) √(omc_max (2 − omc))`
/// with no division by ρ. `1 − cos θ` and `sin²θ = (1 − cos θ)(1 + cos θ)`
/// keep full relative precision for tiny cones (r/d down to 1e-6 and below).
#[inline(always)]
pub fn sample_cone_toward(
    to_c: Vec3,
    d2: f32,
    r2: f32,
    u1: f32,
    u2: f32,
    fast: bool,
    surface: bool,
) -> ConeDir {
    let s2 = r2 / d2;
    let omc_max = s2 / (1.0 + math::sqrt(1.0 - s2));
    let (x, y, rho2) = concentric_disk(u1, u2, fast);
    let omc = rho2 * omc_max;
    let cos_t = 1.0 - omc;
    let sin2_t = omc * (2.0 - omc);
    let k = math::sqrt(omc_max * (2.0 - omc));
    let d = math::sqrt(d2);
    let w = to_c * (1.0 / d);
    let (t, b) = w.basis();
    let dir = w * cos_t + (t * x + b * y) * k;
    // near intersection along dir: d cos θ − √(r² − d² sin²θ)
    // (never negative: from a point within rounding of the surface the
    // difference may round below 0)
    let dist = if surface {
        math::max(d * (cos_t - math::safe_sqrt(s2 - sin2_t)), 0.0)
    } else {
        d * cos_t
    };
    ConeDir { dir, dist, omc_max }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stable_one_minus_cos_for_tiny_cones() {
        // r/d = 1e-4: 1 - cos = s^2/2 = 5e-9 (naive f32: 0)
        let v = one_minus_cos_max(1e-8, 1.0);
        assert!(math::abs(v / 5e-9 - 1.0) < 1e-6, "{v}");
        assert!(cone_pdf(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 1e-8).is_finite());
    }

    #[test]
    fn inside_the_light_is_not_sampled() {
        assert!(sample_cone(Vec3::ZERO, Vec3::ZERO, 1.0, 0.5, 0.5, false).is_none());
        assert_eq!(cone_pdf(Vec3::ZERO, Vec3::ZERO, 1.0), 0.0);
    }

    #[test]
    fn sample_reaches_the_surface() {
        let c = Vec3::new(0.0, 2.0, 0.0);
        for i in 0..32 {
            let s = sample_cone(Vec3::ZERO, c, 0.25, i as f32 / 32.0, 0.3, false).unwrap();
            let p = s.dir * s.dist;
            assert!(math::abs((p - c).length() - 0.5) < 1e-5, "{i}: {s:?}");
        }
    }
}

/// The opening through which an opaque wall lets a sphere light be seen:
/// a light whose ball crosses the wall shows only the cap on the camera's
/// side, bounded by the disk where the wall cuts the ball.
///
/// Next-event estimation by the cone that the whole ball subtends wastes
/// every sample behind the wall: smallpt's lamp, a ball of radius 600
/// poking 0.27 units through the ceiling, is 95 % hidden from the floor.
/// A point of the disk sampled uniformly by area, seen from a shading point
/// `x`, gives a direction with solid-angle pdf `|y − x|² / (A |n·ω|)`; the
/// ray toward it meets the cap before the disk. Every direction toward the
/// visible cap crosses the disk when every point of the cap faces `x`
/// ([`Window::covers`]): a ray entering the cap must then leave the cap's
/// convex region through the disk. Where that fails, the cone is sampled
/// instead; MIS uses the same rule, so the estimator stays unbiased.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window {
    /// Index of the light sphere.
    pub light: u16,
    /// The light's centre.
    pub light_center: Vec3,
    /// The light's radius.
    pub light_radius: f32,
    /// Centre of the disk.
    pub center: Vec3,
    /// Unit normal of the disk, pointing from the light's centre toward the
    /// visible cap (into the region of the camera).
    pub normal: Vec3,
    /// Radius of the disk.
    pub radius: f32,
    /// `cos α` and `sin α` of the half-angle α of the cap's normals about
    /// `normal` (`cos α` = the disk's distance from the light's centre
    /// over the light's radius).
    pub cos_a: f32,
    /// See `cos_a`.
    pub sin_a: f32,
}

impl Window {
    /// The window of a light (`center`, `radius`) cut at distance `s0`
    /// (≥ 0) from its centre along the unit vector `toward` by a wall;
    /// `None` when the wall misses the ball or leaves less than a sliver
    /// of it outside. The disk is widened by a relative 1e-4 (a direction
    /// through the widened rim that misses the cap reaches the wall first
    /// and is blocked), so that rounding never leaves part of the cap out.
    pub fn new(light: u16, center: Vec3, radius: f32, toward: Vec3, s0: f32) -> Option<Self> {
        let r2 = radius * radius;
        let rho2 = r2 - s0 * s0;
        if !(s0 >= 0.0 && rho2 > 0.0 && s0 < radius) {
            return None;
        }
        let rho = math::sqrt(rho2) * (1.0 + 1e-4);
        Some(Self {
            light,
            light_center: center,
            light_radius: radius,
            center: center + toward * s0,
            normal: toward,
            radius: rho,
            cos_a: s0 / radius,
            sin_a: math::min(rho / radius, 1.0),
        })
    }

    /// Whether every point of the cap faces `x`, so that every direction
    /// from `x` toward the visible cap crosses the disk: `x` lies beyond
    /// the tangent plane of every point of the cap, `(x − c)·m > r` for
    /// every normal `m` within α of the disk's normal, i.e.
    /// `|x − c| cos(β + α) > r` with β the angle of `x − c` from the normal.
    /// A relative margin of 1e-4 keeps rounding on the safe side.
    #[inline]
    pub fn covers(&self, x: Vec3) -> bool {
        let v = x - self.light_center;
        let along = v.dot(self.normal);
        let lateral = math::sqrt(math::max(v.length_squared() - along * along, 0.0));
        along * self.cos_a - lateral * self.sin_a > self.light_radius * (1.0 + 1e-4)
    }

    /// Area of the disk.
    #[inline]
    pub fn area(&self) -> f32 {
        math::PI * self.radius * self.radius
    }

    /// A direction from `x` through a uniform point of the disk (from
    /// `(u1, u2)` in [0,1)²), and `A |n·ω| / |y − x|²`, the reciprocal of
    /// its solid-angle pdf (0 when the point is degenerate).
    #[inline]
    pub fn sample(&self, x: Vec3, u1: f32, u2: f32, fast: bool) -> (Vec3, f32) {
        let (dx, dy, _) = concentric_disk(u1, u2, fast);
        let (t, b) = self.normal.basis();
        let y = self.center + (t * dx + b * dy) * self.radius;
        let w = y - x;
        let d2 = w.length_squared();
        if !(d2 > 0.0) {
            return (self.normal, 0.0);
        }
        let dir = w * (1.0 / math::sqrt(d2));
        let inv_pdf = self.area() * math::abs(dir.dot(self.normal)) / d2;
        (dir, inv_pdf)
    }

    /// The solid-angle pdf with which [`Window::sample`] from `x` gives the
    /// unit direction `dir`: 0 when the ray misses the disk.
    #[inline]
    pub fn pdf(&self, x: Vec3, dir: Vec3) -> f32 {
        let dn = dir.dot(self.normal);
        let h = (self.center - x).dot(self.normal);
        // the ray reaches the disk's plane at s = h / (dir·n) > 0
        if !(dn * h > 0.0) {
            return 0.0;
        }
        let s = h / dn;
        let y = x + dir * s;
        if (y - self.center).length_squared() > self.radius * self.radius {
            return 0.0;
        }
        s * s / (self.area() * math::abs(dn))
    }
}
