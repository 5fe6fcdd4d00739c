//! The smooth dielectric: exact Fresnel reflection and refraction, no
//! absorption (feature `glass`).

#[cfg(feature = "glass")]
use super::reflect;
use crate::error::SceneError;
#[cfg(feature = "glass")]
use crate::geometry::Vec3;
#[cfg(feature = "glass")]
use crate::math;

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

/// For the unit direction `d` meeting a surface of outward normal `n` and
/// index `ior`: the normal facing `d`'s origin, the cosine of incidence and
/// the ratio `eta_i / eta_t` (feature `glass`).
#[cfg(feature = "glass")]
#[inline(always)]
fn facing(d: Vec3, n: Vec3, ior: f32) -> (Vec3, f32, f32) {
    let cos_dn = d.dot(n);
    if cos_dn < 0.0 {
        (n, -cos_dn, 1.0 / ior)
    } else {
        (-n, cos_dn, ior)
    }
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
    let (nf, cos_i, eta) = facing(d, n, ior);
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

/// Both continuations of a ray meeting a smooth dielectric: the reflection
/// with its Fresnel weight `R`, and the refraction with its weight `1 − R`
/// and its radiance scaling `(eta_i / eta_t)²` (the same direction and
/// scaling as [`sample_dielectric`] refracts with). `None` where one of
/// them carries everything (total internal reflection, or `R` = 0), so that
/// there is nothing to split. Returns `(reflected, R, refracted, scale)`.
/// (Feature `glass`.)
#[cfg(feature = "glass")]
#[inline]
pub fn split_dielectric(d: Vec3, n: Vec3, ior: f32) -> Option<(Vec3, f32, Vec3, f32)> {
    let (nf, cos_i, eta) = facing(d, n, ior);
    let (r, _) = fresnel_dielectric(cos_i, eta);
    if !(r > 0.0 && r < 1.0) {
        return None;
    }
    // u = 1 ≥ R: sample_dielectric's refraction, bit for bit
    let (t, scale) = sample_dielectric(d, n, ior, 1.0);
    Some((reflect(d, nf), r, t, scale))
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

    /// The split's two continuations are sample_dielectric's two choices,
    /// with weights that sum to the interface's energy (R + (1 − R) = 1 before
    /// the radiance scaling).
    #[test]
    fn split_gives_both_choices_of_the_sampler() {
        let n = Vec3::new(0.0, 1.0, 0.0);
        for d in [
            Vec3::new(0.6, -0.8, 0.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(0.3, 0.9539392, 0.0),
        ] {
            let (r_dir, r, t_dir, scale) = split_dielectric(d, n, 1.5).expect("both continue");
            assert_eq!((r_dir, 1.0), sample_dielectric(d, n, 1.5, 0.0));
            assert_eq!((t_dir, scale), sample_dielectric(d, n, 1.5, 0.999_999));
            let cos_i = math::abs(d.dot(n));
            let eta = if d.dot(n) < 0.0 { 1.0 / 1.5 } else { 1.5 };
            assert_eq!(r, fresnel_dielectric(cos_i, eta).0);
        }
        // from inside beyond the critical angle: only reflection
        assert!(split_dielectric(Vec3::new(0.8, 0.6, 0.0), n, 1.5).is_none());
        // an index of 1 reflects nothing
        assert!(split_dielectric(Vec3::new(0.6, -0.8, 0.0), n, 1.0).is_none());
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
