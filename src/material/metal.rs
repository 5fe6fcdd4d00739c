//! The rough conductor: a GGX (Trowbridge–Reitz) microfacet reflector with
//! a Fresnel factor of 1 tinted per channel and Smith's shadowing-masking
//! in its separable form `G = G1(wi) G1(wo)` (feature `metal`):
//!
//! `f(wo, wi) = F D(wm) G1(wo) G1(wi) / (4 cos θo cos θi)`,
//! `wm = normalize(wo + wi)`, with
//! `D(m) = α² / (π ((m_x² + m_y²) + α² m_z²)²)` for a unit `m` in the
//! local frame (z along the normal; the denominator is `cos⁴θ (α² +
//! tan²θ)²` written without the cancellation of `1 − cos²θ`) and
//! `G1(w) = 2 cos θ / (cos θ + √(cos²θ + α² sin²θ))`.
//!
//! Directions are sampled by the distribution of visible normals (Heitz
//! 2018, "Sampling the GGX Distribution of Visible Normals"; pbrt-v4's
//! `TrowbridgeReitzDistribution::Sample_wm`): a microfacet normal `wm` with
//! density `D_wo(wm) = G1(wo) max(0, wo·wm) D(wm) / cos θo`, reflected into
//! `wi`, whose density is `D_wo(wm) / (4 |wo·wm|) = G1(wo) D(wm) / (4 cos
//! θo)`. A reflection below the surface ends the path (`f` is zero there):
//! the sampled directions' density integrates to 1 over the sphere, and to
//! less over the upper hemisphere. The estimator's weight `f cos θi / pdf`
//! is `F G1(wi)`: never above the tint, never divided by a small pdf.

#[cfg(feature = "metal")]
use super::{BsdfSample, Lobe, reflect};
use crate::error::SceneError;
use crate::error::check_unit_range;
use crate::geometry::Color;
#[cfg(feature = "metal")]
use crate::geometry::Vec3;
#[cfg(feature = "metal")]
use crate::math;
#[cfg(feature = "metal")]
use crate::sampler::concentric_disk;

/// Smallest GGX width α the scene format accepts.
pub const MIN_ALPHA: f32 = 0.001;
/// Largest GGX width α the scene format accepts.
pub const MAX_ALPHA: f32 = 1.0;

/// A rough metal: GGX microfacets of width `alpha` (the α of the
/// distribution itself, not a "perceptual roughness" whose square it would
/// be), Fresnel factor `tint`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metal {
    /// Fresnel factor per channel, each in [0, 1].
    pub tint: Color,
    /// Width α of the distribution, in [[`MIN_ALPHA`], [`MAX_ALPHA`]].
    pub alpha: f32,
}

/// Checks a metal's tint and width, or refuses the material in a build
/// without the `metal` feature.
pub(crate) fn validate(m: &Metal) -> Result<(), SceneError> {
    if !cfg!(feature = "metal") {
        return Err(SceneError::MaterialNotBuilt("metal"));
    }
    check_unit_range(m.tint, "metal reflectance")?;
    if !m.alpha.is_finite() {
        return Err(SceneError::NotFinite);
    }
    if !(MIN_ALPHA..=MAX_ALPHA).contains(&m.alpha) {
        return Err(SceneError::OutOfRange(
            "metal alpha (GGX width, [0.001, 1])",
        ));
    }
    Ok(())
}

#[cfg(feature = "metal")]
impl Metal {
    /// `π D(m)` for a unit microfacet normal `m` in the local frame (0 below
    /// the surface). At most `1/α²` (10⁶), and for a unit `m` the
    /// denominator is at least `α⁴`: finite for every α of the format.
    #[inline(always)]
    fn pi_d(&self, m: Vec3) -> f32 {
        if !(m.z > 0.0) {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let den = (m.x * m.x + m.y * m.y) + a2 * (m.z * m.z);
        a2 / (den * den)
    }

    /// The GGX distribution `D(m)` of microfacet normals (local frame, unit
    /// `m`; 0 for `m` below the surface).
    pub fn d(&self, m: Vec3) -> f32 {
        self.pi_d(m) * math::INV_PI
    }

    /// `G1(w) / cos θ = 2 / (cos θ + √(cos²θ + α² sin²θ))` for `w.z > 0`:
    /// at most `2/(α sin θ)`, finite at grazing angles.
    #[inline(always)]
    fn g1_over_cos(&self, w: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        let s2 = w.x * w.x + w.y * w.y;
        2.0 / (w.z + math::sqrt(w.z * w.z + a2 * s2))
    }

    /// Smith's masking function `G1(w)` (local frame, unit `w`; 0 at and
    /// below the horizon).
    pub fn g1(&self, w: Vec3) -> f32 {
        if !(w.z > 0.0) {
            return 0.0;
        }
        w.z * self.g1_over_cos(w)
    }

    /// The BSDF `f(wo, wi)` for unit directions in the local frame (z along
    /// the normal; zero unless both are above the surface). Symmetric in
    /// its arguments.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Color {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Color::ZERO;
        }
        let m = (wo + wi).normalize();
        // G1(wo) G1(wi) / (4 cos θo cos θi) without dividing by the cosines
        let g = self.g1_over_cos(wo) * self.g1_over_cos(wi);
        self.tint * (self.d(m) * g * 0.25)
    }

    /// `π ×` the density of [`Metal::sample_local`]'s reflection toward
    /// `wi` (before a reflection below the surface is dropped): `π G1(wo)
    /// D(wm) / (4 cos θo)`; 0 for `wo` at or below the horizon.
    #[inline(always)]
    fn pi_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(wo.z > 0.0) {
            return 0.0;
        }
        // wo·wm = |wo + wi| / 2 ≥ 0: only wi = −wo has none, and its
        // half vector (zero, normalised to NaN) fails m.z > 0 in pi_d
        let m = (wo + wi).normalize();
        self.g1_over_cos(wo) * self.pi_d(m) * 0.25
    }

    /// Solid-angle density with which [`Metal::sample_local`] reflects `wo`
    /// into `wi` (local frame), over the whole sphere of `wi`: it integrates
    /// to 1 there; the part below the surface is what the sampler drops.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.pi_pdf(wo, wi) * math::INV_PI
    }

    /// Samples a direction `wi` for the unit `wo` (local frame, `wo.z > 0`)
    /// from `u` in [0,1)² by the visible normals: `None` where the
    /// reflection falls at or below the surface (the path ends: `f` is zero
    /// there) or `wo` is not above it. The sample's `weight` is `f cos θi /
    /// pdf = tint G1(wi)`; its `pi_pdf` is `π ×` [`Metal::pdf`].
    pub fn sample_local(&self, wo: Vec3, u: [f32; 2], fast: bool) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let a = self.alpha;
        // the view direction stretched to the configuration of α = 1
        let wh = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        // an orthonormal basis around it (any one serves near the pole)
        let (t1, t2) = if wh.z < 0.99999 {
            let t1 = Vec3::new(-wh.y, wh.x, 0.0).normalize();
            (t1, wh.cross(t1))
        } else {
            (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0))
        };
        // a uniform point of the disk, its second coordinate warped onto
        // the projection of the visible half of the hemisphere
        let (px, py, _) = concentric_disk(u[0], u[1], fast);
        let h = math::sqrt(math::max(0.0, 1.0 - px * px));
        let s = 0.5 * (1.0 + wh.z);
        let py = (1.0 - s) * h + s * py;
        let pz = math::sqrt(math::max(0.0, 1.0 - px * px - py * py));
        let nh = t1 * px + t2 * py + wh * pz;
        // back to the ellipsoid's configuration: the microfacet normal
        let m = Vec3::new(a * nh.x, a * nh.y, math::max(1.0e-6, nh.z)).normalize();
        let wi = reflect(-wo, m);
        if !(wi.z > 0.0) {
            return None;
        }
        Some(BsdfSample {
            dir: wi,
            weight: self.tint * self.g1(wi),
            pi_pdf: self.g1_over_cos(wo) * self.pi_d(m) * 0.25,
        })
    }
}

#[cfg(feature = "metal")]
impl Lobe for Metal {
    #[inline(always)]
    fn tint(&self) -> Color {
        self.tint
    }

    /// `(G1(wi), π ×` [`Metal::pdf`]`)`: `f cos θi / pdf = tint G1(wi)`.
    /// Out of line: the integrator's loop keeps the Lambertian's registers.
    #[inline(never)]
    fn eval(&self, wo: Vec3, n: Vec3, wi: Vec3, _cos_i: f32) -> (f32, f32) {
        let (t, b) = n.basis();
        let lo = Vec3::new(wo.dot(t), wo.dot(b), wo.dot(n));
        let li = Vec3::new(wi.dot(t), wi.dot(b), wi.dot(n));
        (self.g1(li), self.pi_pdf(lo, li))
    }

    #[inline(always)]
    fn selective_alpha(&self) -> f32 {
        self.alpha
    }

    /// [`Metal::sample_local`] about `n`, for world directions.
    #[inline(never)]
    fn sample(&self, wo: Vec3, n: Vec3, u: [f32; 2], fast: bool) -> Option<BsdfSample> {
        let (t, b) = n.basis();
        let s = self.sample_local(Vec3::new(wo.dot(t), wo.dot(b), wo.dot(n)), u, fast)?;
        let d = s.dir;
        Some(BsdfSample {
            dir: t * d.x + b * d.y + n * d.z,
            ..s
        })
    }
}

/// A light's share of a GGX lobe of width `alpha`, for choosing which light
/// next-event estimation samples at a glossy vertex: about the fraction of
/// the lobe's samples that would land in the light's cone, at most 1.
///
/// `wo` is the unit direction back along the incoming ray, `n` the unit
/// normal facing it, `to_c` the vector to the light's centre (squared length
/// `d2`), `omc` the cone's `1 − cos θ_max`. The lobe's density
/// `D(h) / (4 cos θo)` is taken at the direction of the cone nearest the
/// mirror direction, whose half vector is half that angle from the normal,
/// times the cone's solid angle `2π omc`. Only an estimate of the light's
/// importance: the integrator mixes it with the choice by radiance × solid
/// angle, so that no light that can contribute is ever left out.
#[cfg(feature = "metal")]
pub(crate) fn light_share(alpha: f32, wo: Vec3, n: Vec3, to_c: Vec3, d2: f32, omc: f32) -> f32 {
    cap_share(lobe_share(alpha, wo, n, to_c, d2, omc))
}

/// [`light_share`] before its cap: finite and ≥ 0 for `cos θo` > 0, +∞ at
/// grazing incidence (`cos θo` = 0).
#[cfg(feature = "metal")]
#[inline(always)]
fn lobe_share(alpha: f32, wo: Vec3, n: Vec3, to_c: Vec3, d2: f32, omc: f32) -> f32 {
    let cos_o = n.dot(wo);
    let r = n * (2.0 * cos_o) - wo;
    let cos_g = r.dot(to_c) / math::sqrt(d2);
    let cos_m = 1.0 - omc;
    // cos of the angle from r to the nearest direction of the cone
    let cos_d = if cos_g >= cos_m {
        1.0
    } else {
        let sin_g = math::sqrt(math::max(0.0, 1.0 - cos_g * cos_g));
        let sin_m = math::sqrt(math::max(0.0, omc * (2.0 - omc)));
        cos_g * cos_m + sin_g * sin_m
    };
    // π D at the half angle: cos² and sin² of half the angle
    let c2 = 0.5 + 0.5 * cos_d;
    let s2 = 0.5 - 0.5 * cos_d;
    let a2 = alpha * alpha;
    let den = c2 * a2 + s2;
    let pi_d = a2 / (den * den);
    // 2π omc · D / (4 cos θo)
    omc * pi_d / (2.0 * cos_o)
}

/// A share capped at all of the lobe: values from 1 up (+∞ included) give
/// 1, and NaN, which no valid input gives, gives 0 rather than passing for
/// a whole lobe (the choice by radiance × solid angle still reaches the
/// light).
#[cfg(feature = "metal")]
#[inline(always)]
fn cap_share(share: f32) -> f32 {
    if share < 1.0 {
        share
    } else if share >= 1.0 {
        1.0
    } else {
        0.0
    }
}

#[cfg(all(test, feature = "metal"))]
mod tests {
    use super::*;

    fn metal(alpha: f32) -> Metal {
        Metal {
            tint: Color::ONE,
            alpha,
        }
    }

    /// The cap keeps fractions, makes 1 of everything from 1 up and 0 of
    /// NaN (which would otherwise count as a whole lobe).
    #[test]
    fn the_cap_passes_fractions_and_rejects_nan() {
        for v in [0.0f32, 1e-30, 0.25, 0.999_999_94] {
            assert_eq!(cap_share(v), v);
        }
        for v in [1.0f32, 1.5, 1e30, f32::INFINITY] {
            assert_eq!(cap_share(v), 1.0);
        }
        assert_eq!(cap_share(f32::NAN), 0.0);
    }

    /// A light's share of the lobe is a fraction: finite and in [0, 1] for
    /// every width of the format, from normal to grazing incidence (cos θo
    /// down to 0), for cones from 1e-12 sr to a hemisphere, in front of and
    /// behind the surface.
    #[test]
    fn light_share_is_a_finite_fraction() {
        let n = Vec3::new(0.0, 0.0, 1.0);
        for alpha in [MIN_ALPHA, 0.02, 0.18, 0.45, MAX_ALPHA] {
            for cos_o in [0.0f32, 1e-7, 1e-3, 0.1, 0.5, 0.9, 1.0] {
                let wo = Vec3::new(math::sqrt(1.0 - cos_o * cos_o), 0.0, cos_o);
                for k in 0..64 {
                    let (s, c) = math::sincos(k as f32 * 0.41);
                    let to_c = Vec3::new(s, c * 0.6, c * 0.8 - 0.3) * (1.0 + k as f32);
                    let d2 = to_c.length_squared();
                    for omc in [1e-12f32, 1e-6, 1e-3, 0.1, 0.7, 1.0] {
                        let g = light_share(alpha, wo, n, to_c, d2, omc);
                        assert!(
                            g.is_finite() && (0.0..=1.0).contains(&g),
                            "alpha {alpha}, cos_o {cos_o}, k {k}, omc {omc}: share {g}"
                        );
                        // before the cap: finite unless grazing, where it
                        // is +∞ (a cap that hides NaN or ∞ cannot see them)
                        let raw = lobe_share(alpha, wo, n, to_c, d2, omc);
                        assert!(
                            raw >= 0.0 && (raw.is_finite() || cos_o == 0.0),
                            "alpha {alpha}, cos_o {cos_o}, k {k}, omc {omc}: uncapped share {raw}"
                        );
                        assert_eq!(g.to_bits(), cap_share(raw).to_bits());
                    }
                }
            }
        }
    }

    /// For a light small against the lobe, centred on the mirror direction,
    /// the share is the lobe's sampling density there times the cone's solid
    /// angle, `2π omc · pdf(wo, r) / G1(wo)` (the share leaves out the
    /// masking of `wo`); 20° away from it a sharp lobe gives such a light
    /// almost nothing.
    #[test]
    fn light_share_is_the_lobe_mass_in_the_cone() {
        let n = Vec3::new(0.0, 0.0, 1.0);
        for alpha in [0.02f32, 0.18, 0.45] {
            let m = metal(alpha);
            for cos_o in [0.3f32, 0.7, 1.0] {
                let wo = Vec3::new(math::sqrt(1.0 - cos_o * cos_o), 0.0, cos_o);
                let r = n * (2.0 * cos_o) - wo;
                let omc = 1e-7;
                let share = light_share(alpha, wo, n, r * 5.0, 25.0, omc);
                let mass = 2.0 * math::PI * omc * m.pdf(wo, r) / m.g1(wo);
                assert!(
                    (share / mass - 1.0).abs() < 1e-3,
                    "alpha {alpha}, cos_o {cos_o}: share {share}, lobe mass {mass}"
                );
                // 20 degrees from r, rotated about the y axis
                let (s, c) = math::sincos(20.0 * math::PI / 180.0);
                let off = Vec3::new(r.x * c + r.z * s, r.y, r.z * c - r.x * s);
                let far = light_share(alpha, wo, n, off * 5.0, 25.0, omc);
                if alpha == 0.02 {
                    assert!(far < share * 1e-3, "cos_o {cos_o}: {far} against {share}");
                } else {
                    assert!(
                        far < share,
                        "alpha {alpha}, cos_o {cos_o}: {far} against {share}"
                    );
                }
            }
        }
    }
}
