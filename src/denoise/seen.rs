//! Lights seen directly, by their coverage of the pixel.
//!
//! A pixel that a light's silhouette crosses holds two kinds of samples:
//! those whose camera ray hits the light (each worth exactly the light's
//! `L_e`: lights reflect nothing) and the others. The pixel's value is
//! `C + (1 − c) μ_B`, where `c` is the part of the pixel (and lens) whose
//! rays meet a light first, `C` the integral of `L_e` over it, and `μ_B`
//! the mean of the rest. The render estimates all three with its `n`
//! samples, and the noise of its estimate of `c` (a light's edge moving
//! a sample in or out) weighs `L_e − μ_B`: at a bright light's edge,
//! nearly all of the pixel's error. Here `c` and `C` are measured with
//! `4n` rays of their own, independent of the render's, and `μ_B` is the
//! mean of the samples that missed the lights: post-stratification
//! ([`SeenLights::estimate`]), the noise of where the edge fell among the
//! samples gone.
//!
//! Which pixels: those whose centre ray passes within a pixel's reach (and
//! the lens's) of a light's silhouette, from the light's angular radius
//! seen from the eye ([`LightEdges`]); the test depends on the geometry
//! only, never on the samples, so that a pixel left out keeps its unbiased
//! raw value.

use super::input::Moments;
use crate::geometry::{Color, Vec3};
use crate::math;
use crate::render::Renderer;

/// Lights whose edges the denoiser finds (the first of the scene's
/// emitters; a pixel crossed by another keeps its raw value).
const EDGE_LIGHTS: usize = 8;

/// Rays that measure a pixel's lights for each of its samples.
pub const SEEN_RAYS_PER_SAMPLE: u32 = 4;

/// At most this many measuring rays a pixel.
const SEEN_RAYS_MAX: u32 = 1 << 14;

/// Angle added to every edge test's reach, radians: more than the
/// rounding of the directions it compares.
const SLACK: f32 = 1e-4;

/// One light's silhouette as the pixels' centre rays see it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Edge {
    /// The unit direction from the eye to the light's centre.
    axis: Vec3,
    /// The light's `L_e`.
    emission: Color,
    /// A pixel whose centre ray lies between these angles from `axis` may
    /// hold rays that meet the light and rays that miss it.
    inner: f32,
    outer: f32,
    /// `cos outer`: a quick test for the pixels far from the light.
    cos_outer: f32,
    /// The pixels that can lie between the angles: `x0..=x1`, `y0..=y1`.
    x0: u32,
    x1: u32,
    y0: u32,
    y1: u32,
}

impl Edge {
    const NONE: Self = Self {
        axis: Vec3::ZERO,
        emission: Color::ZERO,
        inner: 0.0,
        outer: 0.0,
        cos_outer: 2.0,
        x0: 1,
        x1: 0,
        y0: 1,
        y1: 0,
    };
}

/// The silhouettes of the lights a camera sees, found once a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightEdges {
    edges: [Edge; EDGE_LIGHTS],
    len: usize,
    /// The box around all the edges' boxes (empty when there are none).
    all: Edge,
}

impl LightEdges {
    /// The edges of `renderer`'s lights (the first eight of its
    /// emitters that the eye is outside of).
    pub fn new(renderer: &Renderer<'_>) -> Self {
        let mut out = Self {
            edges: [Edge::NONE; EDGE_LIGHTS],
            len: 0,
            all: Edge::NONE,
        };
        let camera = renderer.camera();
        let scene = renderer.scene();
        let (w, h) = (camera.width(), camera.height());
        let eye = camera.eye();
        let (aperture, slope) = camera.lens();
        // a pixel's reach: the largest angle between its centre ray and a
        // corner's, at the film's centre (a pinhole's pixels shrink
        // toward the edges of the film)
        let (cx, cy) = (w as f32 * 0.5, h as f32 * 0.5);
        let centre = camera.ray(cx, cy).dir;
        let mut reach = 0.0f32;
        for [dx, dy] in [[-0.5, -0.5], [0.5, -0.5], [-0.5, 0.5], [0.5, 0.5]] {
            reach = math::max(reach, angle(centre, camera.ray(cx + dx, cy + dy).dir));
        }
        for &i in scene.emitters.iter() {
            if out.len >= EDGE_LIGHTS {
                break;
            }
            let Some((s, emission)) = scene.sphere_light(i) else {
                continue;
            };
            let v = s.center - eye;
            let d = v.length();
            if !(math::gt(d, s.radius + aperture) && math::is_finite(d)) {
                continue;
            }
            let axis = v * (1.0 / d);
            // a lens ray leaves the pinhole ray through the same film
            // point at the plane of focus, and at depth z lies beside it by
            // at most aperture · |1 − z / focus|: where it passes the light
            // (z within the light's radius of its centre's depth), the
            // light's silhouette seems to move by that much
            let depth = v.dot(camera.forward());
            let shift = if math::gt_zero(aperture) {
                let focus = aperture / slope;
                let off = |z: f32| math::abs(1.0 - z / focus);
                aperture * math::max(off(depth - s.radius), off(depth + s.radius)) * 1.05
            } else {
                0.0
            };
            let (inner, outer) = if math::gt(depth, s.radius) {
                // the pixel's reach, and the rounding of the angles
                let turn = reach * 1.05 + SLACK;
                let near = math::asin(math::min((s.radius + shift) / d, 1.0));
                let far = math::asin(math::max(s.radius - shift, 0.0) / d);
                (far - turn, near + turn)
            } else {
                // the light reaches beside or behind the eye: any pixel
                (-1.0, math::PI)
            };
            let Some([x0, x1, y0, y1]) = film_box(renderer, axis, outer) else {
                continue;
            };
            let cos_outer = if math::lt(outer, math::PI) {
                math::sincos(outer).1 - SLACK
            } else {
                -2.0
            };
            if let Some(e) = out.edges.get_mut(out.len) {
                *e = Edge {
                    axis,
                    emission,
                    inner,
                    outer,
                    cos_outer,
                    x0,
                    x1,
                    y0,
                    y1,
                };
                out.len += 1;
            }
            let a = &mut out.all;
            if a.x0 > a.x1 {
                (a.x0, a.x1, a.y0, a.y1) = (x0, x1, y0, y1);
            } else {
                (a.x0, a.x1) = (a.x0.min(x0), a.x1.max(x1));
                (a.y0, a.y1) = (a.y0.min(y0), a.y1.max(y1));
            }
        }
        out
    }

    /// Whether pixel (x, y) lies in the box around the lights' edges
    /// (where [`LightEdges::crossed`] may hold).
    #[inline(always)]
    pub fn near(&self, x: u32, y: u32) -> bool {
        let a = &self.all;
        x >= a.x0 && x <= a.x1 && y >= a.y0 && y <= a.y1
    }

    /// The `L_e` of the first light whose silhouette may cross pixel
    /// (x, y), if one may.
    pub fn crossed(&self, renderer: &Renderer<'_>, x: u32, y: u32) -> Option<Color> {
        let mut dir = None;
        for e in self.edges.iter().take(self.len) {
            if x < e.x0 || x > e.x1 || y < e.y0 || y > e.y1 {
                continue;
            }
            let d = *dir
                .get_or_insert_with(|| renderer.camera().ray(x as f32 + 0.5, y as f32 + 0.5).dir);
            if math::lt(e.axis.dot(d), e.cos_outer) {
                continue;
            }
            let a = angle(e.axis, d);
            if !math::lt(a, e.inner) && !math::gt(a, e.outer) {
                return Some(e.emission);
            }
        }
        None
    }
}

/// The angle between two unit vectors (accurate when small).
fn angle(a: Vec3, b: Vec3) -> f32 {
    math::atan2(a.cross(b).length(), a.dot(b))
}

/// The pixels (`[x0, x1, y0, y1]`, inclusive) that the cone of half-angle
/// `outer` around the unit direction `axis` from the eye can reach, or
/// `None` if it reaches none. Its rim, as the 16-gon around it (the cone
/// widened by 1 / cos(π/16) and 2 %, so that the polygon holds it),
/// projected on the film: a pinhole maps great circles to lines, so the
/// polygon's image holds the cone's. A cone wider than a radian, or
/// reaching behind the eye, may reach any pixel.
fn film_box(renderer: &Renderer<'_>, axis: Vec3, outer: f32) -> Option<[u32; 4]> {
    let camera = renderer.camera();
    let (w, h) = (camera.width(), camera.height());
    let all = Some([0, w.saturating_sub(1), 0, h.saturating_sub(1)]);
    if !math::lt(outer, 1.0) {
        return all;
    }
    let rho = outer * (1.02 / 0.980_785_3);
    let (sr, cr) = math::sincos(rho);
    let (t1, t2) = axis.basis();
    let eye = camera.eye();
    let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for k in 0..16 {
        let (sp, cp) = math::sincos_turns(k as f32 / 16.0);
        let d = axis * cr + (t1 * cp + t2 * sp) * sr;
        let Some(f) = camera.film_of(eye + d) else {
            return all;
        };
        for j in 0..2 {
            lo[j] = math::min(lo[j], f[j]);
            hi[j] = math::max(hi[j], f[j]);
        }
    }
    // a pixel (x, y) covers the film's [x, x + 1) × [y, y + 1)
    let first = |v: f32| math::max(math::floor(v) - 1.0, 0.0) as u32;
    let last = |v: f32, n: u32| math::min(math::floor(v) + 1.0, n as f32 - 1.0);
    let (x1, y1) = (last(hi[0], w), last(hi[1], h));
    if !(math::ge_zero(x1)
        && math::ge_zero(y1)
        && math::lt(lo[0], w as f32)
        && math::lt(lo[1], h as f32))
    {
        return None;
    }
    Some([first(lo[0]), x1 as u32, first(lo[1]), y1 as u32])
}

/// What a pixel's measuring rays found: the mean `L_e` over the pixel
/// (`C`) and the part of it whose rays met a light first (`c`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeenLights {
    /// `C`: the lights' `L_e` averaged over the pixel (and lens).
    pub emitted: Color,
    /// `c`: the part of the pixel whose rays meet a light first.
    pub coverage: f32,
}

impl SeenLights {
    /// Measures pixel (x, y)'s lights with [`SEEN_RAYS_PER_SAMPLE`] rays
    /// for each of its `n` samples ([`Renderer::lights_seen`]).
    pub fn measure(renderer: &Renderer<'_>, x: u32, y: u32, n: u32) -> Self {
        let count = n
            .saturating_mul(SEEN_RAYS_PER_SAMPLE)
            .clamp(16, SEEN_RAYS_MAX);
        let (sum, hits) = renderer.lights_seen(x, y, count);
        let inv = 1.0 / count as f32;
        Self {
            emitted: sum * inv,
            coverage: hits as f32 * inv,
        }
    }

    /// The pixel's value from its `n` samples' moments `m` and these
    /// measures: `C + (1 − c) β`, where `β` is the mean of the samples that
    /// missed the lights (their sum is the samples' sum less `k L`, `k` the
    /// samples whose camera ray hit a light and `L = C / c` the lights'
    /// radiance where the rays met them, or `edge`, the `L_e` of the light
    /// whose edge crosses the pixel, where they met none), or where every
    /// sample hit a light, `background`: the radiance around the lights
    /// from the pixels before. Post-stratification, the strata's sizes
    /// measured: the mean of the samples that missed depends little on how
    /// many did, and `C` and `c` are unbiased and independent of the
    /// samples, so the value is unbiased but where every sample hit a light
    /// and the background is not the pixel's own (a bias of `1 − c` times
    /// that difference times the chance of it, at a light's inner rim).
    /// `None` where neither the rays nor the samples met a light (the pixel
    /// is what it was).
    pub fn estimate(&self, m: &Moments, n: u32, edge: Color, background: Color) -> Option<Color> {
        if n == 0 || (m.seen == 0 && !math::gt_zero(self.coverage)) {
            return None;
        }
        let light = if math::gt_zero(self.coverage) {
            self.emitted * (1.0 / self.coverage)
        } else {
            edge
        };
        let missed = n.saturating_sub(m.seen);
        let rest = if missed > 0 {
            (m.mean(n) * n as f32 - light * m.seen as f32) * (1.0 / missed as f32)
        } else {
            background
        };
        let v = self.emitted + rest * (1.0 - self.coverage);
        v.is_finite().then_some(v)
    }

    /// The mean of the samples of moments `m` (`n` of them) if none of
    /// them met a light: the next pixels' background.
    pub fn background(m: &Moments, n: u32) -> Option<Color> {
        if m.seen > 0 || n == 0 {
            return None;
        }
        let v = m.mean(n);
        v.is_finite().then_some(v)
    }
}
