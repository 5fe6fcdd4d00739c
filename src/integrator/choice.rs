//! Which light next-event estimation samples at a vertex, and with what
//! probability: by radiance × solid angle, at a glossy vertex mixed with
//! each light's share of the lobe; and the pdf of that choice for a
//! direction that BSDF sampling found (multiple importance sampling needs
//! both to agree bit for bit).

use super::plan::{Ctx, PrevVertex, window_of};
use crate::geometry::Vec3;
use crate::light;
use crate::math;
use crate::sampler::SampleStream;

/// The stratified pair whose first number picks the light at a path's first
/// non-delta vertex.
pub(super) const SELECT_PAIR: u32 = 4;

/// The uniform number that chooses a light: stratified at a path's first
/// non-delta vertex (`first`), independent elsewhere.
#[inline(always)]
pub(super) fn selection_number(first: bool, stream: &mut SampleStream<'_>) -> f32 {
    if first {
        stream.stratified_2d(SELECT_PAIR)[0]
    } else {
        stream.next_f32()
    }
}

/// The weight of the choice by radiance × solid angle in the choice of a
/// light at a glossy vertex ([`Ctx::choose_light_glossy`]): every light
/// keeps at least this fraction of the probability it would have at a
/// Lambertian vertex.
pub(super) const DEFENSIVE: f32 = 0.25;

/// The probability of choosing a light whose radiance × solid angle is `w`
/// and radiance × lobe share is `g`, of sums `sum` and `gsum`.
#[inline(always)]
pub(super) fn mixed_selection(w: f32, g: f32, sum: f32, gsum: f32) -> f32 {
    if gsum > 0.0 {
        DEFENSIVE * (w / sum) + (1.0 - DEFENSIVE) * (g / gsum)
    } else {
        w / sum
    }
}

/// A light's share of a glossy lobe (`metal::light_share`; none in a
/// build without metal, which chooses no light by it).
#[inline(always)]
pub(super) fn light_share(alpha: f32, wo: Vec3, n: Vec3, to_c: Vec3, d2: f32, omc: f32) -> f32 {
    #[cfg(feature = "metal")]
    {
        crate::material::metal::light_share(alpha, wo, n, to_c, d2, omc)
    }
    #[cfg(not(feature = "metal"))]
    {
        let _ = (alpha, wo, n, to_c, d2, omc);
        0.0
    }
}

/// What a glossy vertex's light choice depended on, for the pdf of an
/// emitter its BSDF sample hits. Kept apart from [`PrevVertex`] and
/// written and read only out of line, so that the loop of a scene without
/// metal does no more with it than set it up once per path.
#[derive(Clone, Copy)]
pub(super) struct GlossyChoice {
    /// The lobe's width.
    pub(super) alpha: f32,
    /// The direction back along the ray that reached the vertex.
    pub(super) wo: Vec3,
    /// The sum of the lights' shares of the lobe (radiance × share).
    pub(super) share_sum: f32,
}

/// A light's weights at a glossy vertex ([`Ctx::glossy_weights`]).
pub(super) struct GlossyWeights {
    /// From the vertex to the light's centre, and its squared length.
    pub(super) to_c: Vec3,
    pub(super) d2: f32,
    /// The light's `1 − cos θ_max` seen from the vertex.
    pub(super) omc: f32,
    /// Radiance × solid angle, and radiance × its share of the lobe.
    pub(super) w: f32,
    pub(super) g: f32,
}

/// The light chosen for next-event estimation at a vertex.
pub(super) struct LightChoice {
    pub(super) sphere: usize,
    /// Selection probability.
    pub(super) p_sel: f32,
    /// From the vertex to the light's centre, and its squared length.
    pub(super) to_c: Vec3,
    pub(super) d2: f32,
}

impl<'a> Ctx<'_, 'a> {
    /// Light-selection weight of light `i` at (`x`, `n`): luminance ×
    /// (1 − cos θ_max), i.e. radiance × subtended solid angle; 0 where it
    /// cannot be sampled.
    #[inline]
    pub(super) fn light_weight(&self, x: Vec3, n: Vec3, i: usize, horizon: bool) -> f32 {
        self.samplable(x, n, i, horizon).map_or(0.0, |(_, d2, r2)| {
            self.light_lum(i) * light::one_minus_cos_max(r2, d2)
        })
    }

    /// Picks a light for next-event estimation at `x` by one uniform number
    /// from `stream` (the several-lights variant; with one light the
    /// integrator uses [`OneLight`] and selects nothing); returns the choice
    /// and the weight sum (needed later for MIS).
    #[inline]
    pub(super) fn choose_light(
        &self,
        x: Vec3,
        n: Vec3,
        horizon: bool,
        first: bool,
        stream: &mut SampleStream<'_>,
    ) -> (Option<LightChoice>, f32) {
        let u = selection_number(first, stream);
        let mut sum = 0.0;
        for &l in self.plan.lights {
            sum += self.light_weight(x, n, l as usize, horizon);
        }
        if !(sum > 0.0) {
            return (None, 0.0);
        }
        let target = u * sum;
        let mut acc = 0.0;
        let mut chosen = None;
        for &l in self.plan.lights {
            let i = l as usize;
            let Some((to_c, d2, r2)) = self.samplable(x, n, i, horizon) else {
                continue;
            };
            let w = self.light_lum(i) * light::one_minus_cos_max(r2, d2);
            if w > 0.0 {
                acc += w;
                chosen = Some(LightChoice {
                    sphere: i,
                    p_sel: w / sum,
                    to_c,
                    d2,
                });
                if target < acc {
                    break;
                }
            }
        }
        (chosen, sum)
    }

    /// Light `i`'s two weights at a glossy vertex (`x`, `n`, lobe `alpha`
    /// seen from `wo`), or `None` where it cannot be sampled: the one
    /// computation behind both the choice ([`Ctx::choose_light_glossy`])
    /// and its pdf ([`Ctx::glossy_light_pdf`]), so that they agree bit for
    /// bit.
    #[inline(always)]
    pub(super) fn glossy_weights(
        &self,
        x: Vec3,
        n: Vec3,
        i: usize,
        horizon: bool,
        alpha: f32,
        wo: Vec3,
    ) -> Option<GlossyWeights> {
        let (to_c, d2, r2) = self.samplable(x, n, i, horizon)?;
        let lum = self.light_lum(i);
        let omc = light::one_minus_cos_max(r2, d2);
        Some(GlossyWeights {
            to_c,
            d2,
            omc,
            w: lum * omc,
            g: lum * light_share(alpha, wo, n, to_c, d2, omc),
        })
    }

    /// [`Ctx::choose_light`] at a vertex of a glossy lobe of width `alpha`
    /// ([`Lobe::selective_alpha`]): each light's probability mixes its
    /// share of radiance × solid angle (weight [`DEFENSIVE`]) with its
    /// share of radiance × its part of the lobe (`metal::light_share`), so
    /// that the light in the lobe is sampled most and no light that can
    /// contribute is left out. Returns the choice and the sum of radiance ×
    /// solid angle, and keeps the rest in `glossy` (for [`Ctx::light_pdf`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    pub(super) fn choose_light_glossy(
        &self,
        x: Vec3,
        n: Vec3,
        horizon: bool,
        first: bool,
        stream: &mut SampleStream<'_>,
        alpha: f32,
        wo: Vec3,
        glossy: &mut GlossyChoice,
    ) -> (Option<LightChoice>, f32) {
        let u = selection_number(first, stream);
        let (mut sum, mut gsum) = (0.0, 0.0);
        for &l in self.plan.lights {
            if let Some(gw) = self.glossy_weights(x, n, l as usize, horizon, alpha, wo) {
                sum += gw.w;
                gsum += gw.g;
            }
        }
        if !(sum > 0.0) {
            return (None, 0.0);
        }
        *glossy = GlossyChoice {
            alpha,
            wo,
            share_sum: gsum,
        };
        let mut acc = 0.0;
        let mut chosen = None;
        for &l in self.plan.lights {
            let i = l as usize;
            let Some(gw) = self.glossy_weights(x, n, i, horizon, alpha, wo) else {
                continue;
            };
            if gw.w > 0.0 {
                let p_sel = mixed_selection(gw.w, gw.g, sum, gsum);
                acc += p_sel;
                chosen = Some(LightChoice {
                    sphere: i,
                    p_sel,
                    to_c: gw.to_c,
                    d2: gw.d2,
                });
                if u < acc {
                    break;
                }
            }
        }
        (chosen, sum)
    }

    /// [`Ctx::light_pdf`] where [`Ctx::choose_light_glossy`] chose the light
    /// at `prev`: the same operands, the same bits. Out of line, so that the
    /// loop of a scene without metal keeps its registers.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn glossy_light_pdf(
        &self,
        point: Vec3,
        normal: Vec3,
        horizon: bool,
        sum: f32,
        glossy: &GlossyChoice,
        i: usize,
        dir: Vec3,
    ) -> f32 {
        let Some(gw) = self.glossy_weights(point, normal, i, horizon, glossy.alpha, glossy.wo)
        else {
            return 0.0;
        };
        let p_sel = mixed_selection(gw.w, gw.g, sum, glossy.share_sum);
        match window_of(self.windows(), i) {
            Some(win) if win.covers(point) => p_sel * win.pdf(point, dir),
            _ => p_sel / (math::TWO_PI * gw.omc),
        }
    }

    /// Solid-angle pdf with which next-event estimation at `prev` would have
    /// produced a direction toward light sphere `i` (selection included).
    #[inline]
    pub(super) fn light_pdf<const MANY: bool>(
        &self,
        prev: &PrevVertex,
        glossy: &GlossyChoice,
        i: usize,
        dir: Vec3,
    ) -> f32 {
        if !MANY {
            // bit for bit the pdf from the point and normal: the same
            // one_minus_cos_max of the same operands, or the same window
            return match &self.plan.one {
                // the closed form took all of this light's direct light:
                // an infinite pdf, so the power heuristic gives the hit 0
                Some(one) if one.sphere == i && prev.light_omc == f32::INFINITY => f32::INFINITY,
                Some(one) if one.sphere == i && prev.light_omc > 0.0 => {
                    1.0 / (math::TWO_PI * prev.light_omc)
                }
                Some(one) if one.sphere == i && prev.light_omc < 0.0 => {
                    Self::window_of_one(one).map_or(0.0, |w| w.pdf(prev.point, dir))
                }
                _ => 0.0,
            };
        }
        if !self.plan.lights.contains(&(i as u16)) {
            return 0.0;
        }
        if cfg!(feature = "metal") && prev.weight_sum < 0.0 {
            return self.glossy_light_pdf(
                prev.point,
                prev.normal,
                prev.horizon,
                -prev.weight_sum,
                glossy,
                i,
                dir,
            );
        }
        let Some((_, d2, r2)) = self.samplable(prev.point, prev.normal, i, prev.horizon) else {
            return 0.0;
        };
        if let Some(w) = window_of(self.windows(), i)
            && w.covers(prev.point)
        {
            if !(prev.weight_sum > 0.0) {
                return 0.0;
            }
            let p_sel = self.light_lum(i) * light::one_minus_cos_max(r2, d2) / prev.weight_sum;
            return p_sel * w.pdf(prev.point, dir);
        }
        if prev.weight_sum > 0.0 {
            // p_sel · pdf_cone = (lum · omc / W) · 1 / (2π omc)
            self.light_lum(i) / (math::TWO_PI * prev.weight_sum)
        } else {
            0.0
        }
    }
}
