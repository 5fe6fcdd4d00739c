//! The Lambertian reflector: `f = albedo / π`, sampled by the cosine.

use super::{BsdfSample, Lobe};
use crate::error::SceneError;
use crate::error::check_unit_range;
use crate::geometry::{Color, Vec3};
use crate::math;
use crate::sampler::concentric_disk;

/// Checks a Lambertian albedo (each channel in [0, 1]).
pub(crate) fn validate(albedo: Color) -> Result<(), SceneError> {
    check_unit_range(albedo, "albedo")
}

/// A cosine-distributed direction about the unit normal `n` from a point of
/// [0,1)²; its pdf is `cos θ / π`. Returns `(direction, cos θ)`.
///
/// Malley's method: a uniform point of the unit disk
/// ([`concentric_disk`]) lifted to the hemisphere, `cos θ = √(1 − ρ²)`.
/// For inputs in [0,1) (the samplers' multiples of 2⁻²⁴) `ρ² ≤ 1 − 2⁻²³`
/// after rounding, so `1 − ρ²` is positive without a clamp.
#[inline(always)]
pub fn sample_cosine(n: Vec3, u1: f32, u2: f32, fast: bool) -> (Vec3, f32) {
    let (x, y, r2) = concentric_disk(u1, u2, fast);
    let cos_t = math::sqrt(1.0 - r2);
    let (t, b) = n.basis();
    (t * x + b * y + n * cos_t, cos_t)
}

/// The Lambertian lobe of this albedo (diffuse and checker vertices).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert(pub Color);

impl Lobe for Lambert {
    #[inline(always)]
    fn tint(&self) -> Color {
        self.0
    }

    /// `f cos / pdf = (albedo/π) cos / (cos/π)`: the albedo, exactly; `π
    /// pdf` is the cosine.
    #[inline(always)]
    fn eval(&self, _wo: Vec3, _n: Vec3, _wi: Vec3, cos_i: f32) -> (f32, f32) {
        (1.0, cos_i)
    }

    #[inline(always)]
    fn sample(&self, _wo: Vec3, n: Vec3, u: [f32; 2], fast: bool) -> Option<BsdfSample> {
        let (dir, cos) = sample_cosine(n, u[0], u[1], fast);
        Some(BsdfSample {
            dir,
            weight: self.0,
            pi_pdf: cos,
        })
    }

    #[inline(always)]
    fn cosine_weight(&self) -> Option<Color> {
        Some(self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_sample_is_on_the_hemisphere() {
        let n = Vec3::new(0.0, 0.0, -1.0);
        for i in 0..64 {
            let (d, c) = sample_cosine(n, i as f32 / 64.0, (i * 7 % 64) as f32 / 64.0, false);
            assert!(math::abs(d.length() - 1.0) < 1e-6);
            assert!(math::abs(d.dot(n) - c) < 1e-6 && c > 0.0);
        }
    }

    /// The Lambertian's contract with the integrator, which samples its
    /// direction after Russian roulette: its sample is the cosine sample of
    /// the same numbers, with the weight `cosine_weight` gives.
    #[test]
    fn the_lambertian_sample_is_the_cosine_sample() {
        let albedo = Vec3::new(0.7, 0.5, 0.25);
        let lobe = Lambert(albedo);
        assert_eq!(lobe.cosine_weight(), Some(albedo));
        let n = Vec3::new(0.3, -0.4, 0.5).normalize();
        for i in 0..256 {
            let u = [(i % 16) as f32 / 16.0 + 0.01, (i / 16) as f32 / 16.0 + 0.02];
            let s = lobe.sample(Vec3::new(0.0, 1.0, 0.0), n, u, false).unwrap();
            let (dir, cos) = sample_cosine(n, u[0], u[1], false);
            assert_eq!((s.dir, s.pi_pdf, s.weight), (dir, cos, albedo));
        }
    }

    /// `sample_cosine` takes `√(1 − ρ²)` without a clamp: at the samplers'
    /// extreme inputs (multiples of 2⁻²⁴ in [0, 1)) the rounded `ρ²` stays
    /// below 1, so the cosine is positive and finite.
    #[test]
    fn extreme_sampler_inputs_give_a_positive_cosine() {
        let edge = [0.0, 1.0 / 16_777_216.0, 0.5, 1.0 - 1.0 / 16_777_216.0];
        for u1 in edge {
            for u2 in edge {
                let (_, _, r2) = concentric_disk(u1, u2, false);
                assert!(1.0 - r2 > 0.0, "{u1} {u2}: rho^2 {r2}");
                let (d, c) = sample_cosine(Vec3::new(0.0, 1.0, 0.0), u1, u2, false);
                assert!(
                    c > 0.0 && c.is_finite() && d.length().is_finite(),
                    "{u1} {u2}: {c}"
                );
            }
        }
    }
}
