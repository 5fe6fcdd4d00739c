//! Materials and their BSDFs: Lambertian, perfect mirror, smooth dielectric
//! with the exact Fresnel equations, and emitters.

use crate::geometry::{Color, Vec3};
use crate::math;

/// A surface material (the `material` statement of docs/scene-format.md).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    /// Lambertian reflector with the given albedo, each channel in [0, 1].
    /// Two-sided: both sides of a surface reflect.
    Diffuse(Color),
    /// Perfect specular reflector with the given tint in [0, 1]. Needs the
    /// `mirror` cargo feature (default): without it [`crate::SceneBuilder`]
    /// rejects the material with [`crate::SceneError::MaterialNotBuilt`].
    Mirror(Color),
    /// Smooth dielectric with this index of refraction (> 0) against a vacuum
    /// outside. A sphere's inside is the glass; for a plane, the side its
    /// normal points to is the vacuum and the other side the glass. Needs the
    /// `glass` cargo feature (default): without it [`crate::SceneBuilder`]
    /// rejects the material with [`crate::SceneError::MaterialNotBuilt`].
    Glass(f32),
    /// Emitter with this radiance (≥ 0) on the outward side of a sphere; it
    /// reflects nothing.
    Light(Color),
}

impl Material {
    /// Whether the material's BSDF is a Dirac delta (mirror, glass): no light
    /// sampling, and emitters seen through it get full weight.
    pub fn is_specular(&self) -> bool {
        matches!(self, Material::Mirror(_) | Material::Glass(_))
    }
}

/// Shirley and Chiu's concentric map of `(u1, u2)` in [0,1)² onto the unit
/// disk: area-preserving (uniform points stay uniform), and low distortion,
/// so that stratified points stay well spread. Square rings map to circles:
/// the radius is the larger of |a|, |b| (the square's coordinates in
/// (−1, 1)), and the angle within each quarter is linear in the other
/// coordinate, so only `sin`/`cos` on [−π/4, π/4] are needed
/// ([`math::sincos_quarter`]; micromath's with `fast`).
///
/// Returns `(x, y, ρ²)` with `ρ² = x² + y²` (up to rounding).
/// The square is `a = 2u₁ − (1 − 2⁻²⁴)`: for the 24-bit uniforms of
/// [`crate::sampler`] (multiples of 2⁻²⁴) that is exact, symmetric, never 0
/// and never ±1, so `ρ ≤ 1 − 2⁻²⁴` and `1 − ρ²` is at least 2⁻²³.
#[inline(always)]
pub fn concentric_disk(u1: f32, u2: f32, fast: bool) -> (f32, f32, f32) {
    // 1 − 2⁻²⁴: with u in [0, 1) on the 2⁻²⁴ grid, a is an odd multiple of
    // 2⁻²⁴ in (−1, 1)
    const ONE_BELOW: f32 = 1.0 - 1.0 / 16_777_216.0;
    let a = 2.0 * u1 - ONE_BELOW;
    let b = 2.0 * u2 - ONE_BELOW;
    let (r, q, swap) = if math::abs(a) > math::abs(b) {
        (a, b / a, false)
    } else {
        (b, a / b, true)
    };
    let phi = q * (0.25 * math::PI);
    let (s, c) = if fast {
        math::fast_sincos_quarter(phi)
    } else {
        math::sincos_quarter(phi)
    };
    // angle phi from the x axis in the quarters |a| > |b|, π/2 − phi
    // from it in the others (r's sign turns the opposite quarters)
    if swap {
        (r * s, r * c, r * r)
    } else {
        (r * c, r * s, r * r)
    }
}

/// A cosine-distributed direction about the unit normal `n` from a point of
/// [0,1)²; its pdf is `cos θ / π`. Returns `(direction, cos θ)`.
///
/// Malley's method: a uniform point of the unit disk
/// ([`concentric_disk`]) lifted to the hemisphere, `cos θ = √(1 − ρ²)`
/// (> 0 for inputs in [0,1)).
#[inline(always)]
pub fn sample_cosine(n: Vec3, u1: f32, u2: f32, fast: bool) -> (Vec3, f32) {
    let (x, y, r2) = concentric_disk(u1, u2, fast);
    let cos_t = math::sqrt(math::max(1.0 - r2, 0.0));
    let (t, b) = n.basis();
    (t * x + b * y + n * cos_t, cos_t)
}

/// Mirror reflection of `d` about the unit normal `n` (features `mirror`
/// or `glass`).
#[cfg(any(feature = "mirror", feature = "glass"))]
#[inline(always)]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - n * (2.0 * d.dot(n))
}

/// Exact Fresnel reflectance of unpolarised light at a smooth dielectric
/// interface, for `cos_i` = cosine of the incident angle (≥ 0) and
/// `eta = eta_i / eta_t`. Returns `(R, cos_t)`; total internal reflection
/// gives `(1, 0)` (feature `glass`).
#[cfg(feature = "glass")]
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32) {
    let sin2_t = eta * eta * math::max(0.0, 1.0 - cos_i * cos_i);
    // `!(x < 1)` rather than `x >= 1`: for eta > 1.8e19 (a legal IOR below
    // 5.4e-20) at normal incidence, eta² · 0 = ∞ · 0 is NaN; the limit of
    // R = ((eta − 1)/(eta + 1))² there is 1, so reflect
    if !(sin2_t < 1.0) {
        return (1.0, 0.0);
    }
    let cos_t = math::sqrt(1.0 - sin2_t);
    // amplitude coefficients with the indices scaled by 1/eta_t
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t)
}

/// Samples a smooth dielectric of index `ior` for the incoming unit direction
/// `d` and the unit outward normal `n`, choosing reflection with probability
/// equal to the Fresnel reflectance (from `u` in [0,1)).
///
/// Returns the new direction and the throughput factor: 1 for reflection,
/// `(eta_i / eta_t)²` for refraction (radiance is scaled by the squared
/// index ratio across an interface; the factors cancel on a path that enters
/// and leaves, and make a light inside glass physically right).
/// (Feature `glass`.)
#[cfg(feature = "glass")]
#[inline]
pub fn sample_dielectric(d: Vec3, n: Vec3, ior: f32, u: f32) -> (Vec3, f32) {
    let cos_dn = d.dot(n);
    let (nf, cos_i, eta) = if cos_dn < 0.0 {
        (n, -cos_dn, 1.0 / ior)
    } else {
        (-n, cos_dn, ior)
    };
    let (r, cos_t) = fresnel_dielectric(cos_i, eta);
    if u < r {
        (reflect(d, nf), 1.0)
    } else if eta < 4096.0 {
        let t = d * eta + nf * (eta * cos_i - cos_t);
        // renormalise: the formula is exact only in exact arithmetic
        (t.normalize(), eta * eta)
    } else {
        // eta ≥ 4096 (an IOR below 1/4096, or above 4096 seen from inside)
        // refracts only at normal incidence within f32 rounding, where
        // d·eta − n·(eta cos_i) cancels to garbage (rounding × eta ≥ 2.4e-4,
        // and up to the wrong side of the surface): build the direction from
        // its unit tangential part and sin_t, cos_t instead
        let tang = d + nf * cos_i;
        let tl = tang.length();
        let sin_t = math::sqrt(1.0 - cos_t * cos_t);
        let t = if tl > 0.0 {
            tang * (sin_t / tl) - nf * cos_t
        } else {
            -nf
        };
        (t, eta * eta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(feature = "glass")]
    #[test]
    fn fresnel_normal_incidence_and_tir() {
        // ((n-1)/(n+1))^2 = 0.04 for n = 1.5
        let (r, ct) = fresnel_dielectric(1.0, 1.0 / 1.5);
        assert!(math::abs(r - 0.04) < 1e-6 && ct == 1.0);
        // from inside beyond the critical angle (41.8 deg): total reflection
        assert_eq!(fresnel_dielectric(0.5, 1.5), (1.0, 0.0));
        // reciprocity: same R from both sides for matching angles
        let (r_in, ct) = fresnel_dielectric(0.8, 1.0 / 1.5);
        let (r_out, _) = fresnel_dielectric(ct, 1.5);
        assert!(math::abs(r_in - r_out) < 1e-6);
    }

    #[cfg(feature = "glass")]
    #[test]
    fn refraction_obeys_snell() {
        let n = Vec3::new(0.0, 1.0, 0.0);
        let d = Vec3::new(0.6, -0.8, 0.0);
        let (t, w) = sample_dielectric(d, n, 1.5, 0.99);
        // sin_t = sin_i / 1.5
        assert!(math::abs(t.x - 0.4) < 1e-6, "{t:?}");
        assert!(t.y < 0.0);
        assert!(math::abs(w - 1.0 / 2.25) < 1e-6);
        let (r, w) = sample_dielectric(d, n, 1.5, 0.0);
        assert_eq!(r, Vec3::new(0.6, 0.8, 0.0));
        assert_eq!(w, 1.0);
    }

    #[test]
    fn cosine_sample_is_on_the_hemisphere() {
        let n = Vec3::new(0.0, 0.0, -1.0);
        for i in 0..64 {
            let (d, c) = sample_cosine(n, i as f32 / 64.0, (i * 7 % 64) as f32 / 64.0, false);
            assert!(math::abs(d.length() - 1.0) < 1e-6);
            assert!(math::abs(d.dot(n) - c) < 1e-6 && c > 0.0);
        }
    }
}
