//! The split at the first glass vertex a camera ray meets: both the
//! refraction and the reflection traced, weighted by the Fresnel
//! transmittance and reflectance, instead of one chosen by them.

use crate::geometry::{Color, Hit, ObjectId, Ray};
use crate::material::Material;

/// The branch of a path that waits while the other is traced: its ray,
/// throughput, roulette scale, depth and the object it leaves.
#[cfg(feature = "glass")]
pub(super) struct Branch {
    pub(super) ray: Ray,
    pub(super) thr: Color,
    pub(super) rr_scale: f32,
    pub(super) depth: u32,
    pub(super) from: ObjectId,
}

/// Splitting at a glass vertex (`split`: the path may split here): the
/// refraction, weighted by `1 − R`, for the path to continue with, and the
/// reflection, weighted by `R` (in `thr`, a factor of the path's
/// throughput; `rr_scale`, a factor of its roulette scale, undoes it), for
/// it to trace after. Russian roulette leaves both weights out, so each
/// branch survives as the unsplit path would have. `None` where the path may not split,
/// the material is not glass, or one continuation carries everything.
///
/// Choosing one of the two by the reflectance is what a glass vertex does
/// elsewhere; it adds variance where the two see very different radiance
/// (the sun reflected in a glass ball against the scene seen through it).
/// Tracing both once per path removes that variance at the vertex the
/// camera sees, for at most one extra branch per path.
#[cfg(feature = "glass")]
#[inline(always)]
pub(super) fn split_at_glass(
    mat: &Material,
    hit: &Hit,
    ray: &Ray,
    split: bool,
) -> Option<(crate::material::DeltaSample, Branch)> {
    if !split {
        return None;
    }
    let Material::Glass(ior) = *mat else {
        return None;
    };
    split_glass(ior, hit, ray)
}

/// The two continuations of [`split_at_glass`]. Out of line on a board
/// (no OS): it runs at most once per path, and each path variant of the
/// tracer held a copy of it in the flash.
#[cfg(feature = "glass")]
#[cfg_attr(target_os = "none", inline(never))]
#[cfg_attr(not(target_os = "none"), inline(always))]
pub(super) fn split_glass(
    ior: f32,
    hit: &Hit,
    ray: &Ray,
) -> Option<(crate::material::DeltaSample, Branch)> {
    let (r_dir, r, t_dir, scale) = crate::material::split_dielectric(ray.dir, hit.normal, ior)?;
    Some((
        crate::material::DeltaSample {
            dir: t_dir,
            weight: Color::splat((1.0 - r) * scale),
            // roulette leaves the split's weight out with the scaling, so
            // that it treats each branch as the path that chose it
            scale: (1.0 - r) * scale,
        },
        Branch {
            ray: hit.spawn(r_dir),
            thr: Color::splat(r),
            rr_scale: 1.0 / r,
            depth: 0,
            from: hit.object,
        },
    ))
}
