//! Materials and their BSDFs, one file per material: [`diffuse`]
//! (Lambertian), [`mirror`] (perfect specular), [`glass`] (smooth dielectric
//! with the exact Fresnel equations), [`metal`] (GGX microfacet conductor),
//! [`checker`] (Lambertian with a checkerboard albedo) and [`light`]
//! (emitters).
//!
//! The integrator sees a material only through one interface, dispatched
//! over the [`Material`] enum (no trait objects, no heap):
//! [`Material::scatter`] says what a hit does — emit ([`Scatter::Emit`]),
//! continue along a Dirac delta (mirror, glass: [`Scatter::Delta`], the
//! direction already sampled), or offer a non-delta BSDF ([`Scatter::Bsdf`])
//! that next-event estimation evaluates ([`Bsdf::eval`]) and path
//! continuation samples ([`Bsdf::sample`]), both combined by multiple
//! importance sampling. A new material touches this folder (and the
//! parser), not the integrator.

pub mod ball;
pub mod checker;
pub mod diffuse;
pub mod glass;
pub mod light;
pub mod metal;
pub mod mirror;

pub use checker::Checker;
pub use diffuse::{Lambert, sample_cosine};
#[cfg(feature = "glass")]
pub use glass::{fresnel_dielectric, sample_dielectric, split_dielectric};
pub use metal::Metal;
#[cfg(any(feature = "mirror", feature = "glass", feature = "metal"))]
pub use mirror::reflect;

use crate::error::SceneError;
use crate::geometry::{Color, Hit, Vec3};
use crate::sampler::SampleStream;

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
    /// Rough conductor ([`metal`]), two-sided like the Lambertian. Needs the
    /// `metal` cargo feature (default): without it [`crate::SceneBuilder`]
    /// rejects the material with [`crate::SceneError::MaterialNotBuilt`].
    Metal(Metal),
    /// Lambertian with a checkerboard albedo in world coordinates
    /// ([`checker`]). Needs the `checker` cargo feature (default): without
    /// it [`crate::SceneBuilder`] rejects the material with
    /// [`crate::SceneError::MaterialNotBuilt`].
    Checker(Checker),
    /// Emitter with this radiance (≥ 0) on the outward side of a sphere; it
    /// reflects nothing.
    Light(Color),
}

/// What a hit on a material does ([`Material::scatter`]).
#[derive(Clone, Copy, Debug)]
pub enum Scatter {
    /// An emitter: this radiance on the outward side; the path ends.
    Emit(Color),
    /// A Dirac delta BSDF, already sampled: no light sampling there, and
    /// emitters seen through it get full weight.
    Delta(DeltaSample),
    /// A non-delta BSDF: next-event estimation and BSDF sampling, combined
    /// by multiple importance sampling.
    Bsdf(Bsdf),
    /// Nothing (a material this build left out, which no scene can hold):
    /// the path ends.
    Absorb,
}

/// A direction sampled from a Dirac delta BSDF.
#[derive(Clone, Copy, Debug)]
pub struct DeltaSample {
    /// The new unit direction.
    pub dir: Vec3,
    /// Throughput factor of the sample (`f cos / pdf`).
    pub weight: Color,
    /// The part of `weight` that is radiance scaling across an interface
    /// (`(η_i/η_t)²` for refraction, else 1): it cancels on a path that
    /// leaves the medium again, so Russian roulette leaves it out.
    pub scale: f32,
}

/// A non-delta BSDF at one hit point, for the shading normal that faces the
/// incoming ray.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    /// Lambertian of this albedo (diffuse, checker).
    Lambert(Color),
    /// GGX conductor (feature `metal`).
    #[cfg(feature = "metal")]
    Ggx(Metal),
}

/// A direction sampled from a non-delta BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// The new unit direction.
    pub dir: Vec3,
    /// `f cos θ / pdf`: the throughput factor.
    pub weight: Color,
    /// `π ×` the solid-angle pdf of the direction (`cos θ` for the
    /// Lambertian, exactly; the integrator's MIS weights are written in it).
    pub pi_pdf: f32,
}

impl Material {
    /// Checks the material's values (albedo and tint in [0, 1], IOR > 0,
    /// metal width in [0.001, 1], checker size > 0, radiance ≥ 0), and
    /// refuses a material whose cargo feature this build lacks
    /// ([`SceneError::MaterialNotBuilt`]).
    pub fn validate(&self) -> Result<(), SceneError> {
        match self {
            Material::Diffuse(c) => diffuse::validate(*c),
            Material::Mirror(c) => mirror::validate(*c),
            Material::Glass(ior) => glass::validate(*ior),
            Material::Metal(m) => metal::validate(m),
            Material::Checker(c) => checker::validate(c),
            Material::Light(c) => light::validate(*c),
        }
    }

    /// Whether the material's BSDF is a Dirac delta (mirror, glass): no light
    /// sampling, and emitters seen through it get full weight.
    pub fn is_delta(&self) -> bool {
        matches!(self, Material::Mirror(_) | Material::Glass(_))
    }

    /// Whether light passes through the material (glass).
    pub fn is_transparent(&self) -> bool {
        matches!(self, Material::Glass(_))
    }

    /// Whether the material reflects with a non-delta BSDF, so that
    /// next-event estimation runs at its vertices.
    pub fn samples_lights(&self) -> bool {
        matches!(
            self,
            Material::Diffuse(_) | Material::Metal(_) | Material::Checker(_)
        )
    }

    /// The radiance the material emits on its outward side, if it is an
    /// emitter.
    #[inline(always)]
    pub fn emission(&self) -> Option<Color> {
        match self {
            Material::Light(le) => Some(*le),
            _ => None,
        }
    }

    /// What a ray of unit direction `d` does at `hit` on this material: the
    /// one call the integrator makes. A delta BSDF samples its direction
    /// here (glass draws one number from `stream`, the mirror none); a
    /// non-delta one is returned for the integrator to evaluate and sample,
    /// with its values at the hit point (the checker's albedo).
    #[inline(always)]
    pub fn scatter(&self, hit: &Hit, d: Vec3, stream: &mut SampleStream<'_>) -> Scatter {
        let _ = (&hit, &d, &stream);
        match self {
            Material::Light(le) => Scatter::Emit(*le),
            Material::Diffuse(albedo) => Scatter::Bsdf(Bsdf::Lambert(*albedo)),
            #[cfg(feature = "mirror")]
            Material::Mirror(tint) => Scatter::Delta(DeltaSample {
                dir: reflect(d, hit.normal),
                weight: *tint,
                scale: 1.0,
            }),
            #[cfg(feature = "glass")]
            Material::Glass(ior) => {
                let (dir, f) = sample_dielectric(d, hit.normal, *ior, stream.next_f32());
                Scatter::Delta(DeltaSample {
                    dir,
                    weight: Color::splat(f),
                    scale: f,
                })
            }
            #[cfg(feature = "metal")]
            Material::Metal(m) => Scatter::Bsdf(Bsdf::Ggx(*m)),
            #[cfg(feature = "checker")]
            Material::Checker(c) => Scatter::Bsdf(Bsdf::Lambert(c.albedo_at_hit(hit))),
            // a material this build left out: `SceneBuilder` rejects it, so
            // no scene holds one
            #[allow(unreachable_patterns)]
            _ => Scatter::Absorb,
        }
    }
}

/// A non-delta BSDF as the integrator uses it, for world directions about
/// the unit shading normal `n` that faces the incoming ray, `wo` the unit
/// direction back along it. The integrator is compiled once per lobe type
/// ([`Bsdf`] picks it: static dispatch), so that the Lambertian's vertex
/// costs what it did before there were other lobes.
pub trait Lobe: Copy {
    /// The colour factor of every weight (albedo, tint): `f cos / pdf` is
    /// this times the scalar of [`Lobe::eval`] or the sample's weight.
    fn tint(&self) -> Color;
    /// For a light sample's unit direction `wi` (with `cos_i = n · wi >
    /// 0`): `(s, π pdf)` with `f cos θi / pdf = tint × s`; `s` is
    /// meaningful where the pdf is positive. The Lambertian's are `1` and
    /// `cos_i`, exactly.
    fn eval(&self, wo: Vec3, n: Vec3, wi: Vec3, cos_i: f32) -> (f32, f32);
    /// Samples a direction from `u` in [0,1)² (`fast`: approximate
    /// trigonometry); `None` ends the path (a metal's reflection below the
    /// surface, where `f` is zero).
    fn sample(&self, wo: Vec3, n: Vec3, u: [f32; 2], fast: bool) -> Option<BsdfSample>;
    /// The lobe's width for choosing lights: 0 for a lobe whose value does
    /// not favour one light over another (the Lambertian, whose lights are
    /// chosen by radiance × solid angle alone); a metal's α, whose lights
    /// are chosen by their share of the lobe too.
    #[inline(always)]
    fn selective_alpha(&self) -> f32 {
        0.0
    }
    /// `Some(weight)` for a lobe whose [`Lobe::sample`] is always the
    /// cosine sample ([`diffuse::sample_cosine`]) of `n` and `u` with this
    /// weight (the Lambertian, whose weight is its albedo): the weight does
    /// not depend on the direction, so the integrator decides Russian
    /// roulette before it samples the direction, which a path that roulette
    /// ends never needs.
    #[inline(always)]
    fn cosine_weight(&self) -> Option<Color> {
        None
    }
}

impl Bsdf {
    /// [`Lobe::eval`] of the lobe, as `(f cos θi / pdf, π pdf)`.
    pub fn eval(&self, wo: Vec3, n: Vec3, wi: Vec3, cos_i: f32) -> (Color, f32) {
        match self {
            Bsdf::Lambert(albedo) => {
                let l = Lambert(*albedo);
                let (s, p) = l.eval(wo, n, wi, cos_i);
                (l.tint() * s, p)
            }
            #[cfg(feature = "metal")]
            Bsdf::Ggx(m) => {
                let (s, p) = m.eval(wo, n, wi, cos_i);
                (m.tint() * s, p)
            }
        }
    }

    /// [`Lobe::sample`] of the lobe.
    pub fn sample(&self, wo: Vec3, n: Vec3, u: [f32; 2], fast: bool) -> Option<BsdfSample> {
        match self {
            Bsdf::Lambert(albedo) => Lambert(*albedo).sample(wo, n, u, fast),
            #[cfg(feature = "metal")]
            Bsdf::Ggx(m) => m.sample(wo, n, u, fast),
        }
    }
}
