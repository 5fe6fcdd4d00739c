//! The smooth dielectric: exact Fresnel reflection and refraction, no
//! absorption (feature `glass`).

#[cfg(feature = "glass")]
use super::reflect;
#[cfg(feature = "glass")]
use crate::geometry::Vec3;
#[cfg(feature = "glass")]
use crate::math;
use crate::scene::SceneError;

/// Checks an index of refraction (finite, > 0), or refuses the material in
/// a build without the `glass` feature.
pub(crate) fn validate(ior: f32) -> Result<(), SceneError> {
    if !cfg!(feature = "glass") {
        return Err(SceneError::MaterialNotBuilt("glass"));
    }
    if !ior.is_finite() {
        return Err(SceneError::NotFinite);
    }
    if !(ior > 0.0) {
        return Err(SceneError::OutOfRange("index of refraction"));
    }
    Ok(())
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

#[cfg(all(test, feature = "glass"))]
mod tests {
    use super::*;

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
}
