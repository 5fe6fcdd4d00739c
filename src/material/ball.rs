//! Paths from a point through a glass ball: in, out, and along a given
//! direction (the caustics through a ball, `crate::caustic`, and the
//! chains of the highlight estimator, `crate::highlight`, solve for them).

use crate::geometry::Vec3;
use crate::math;

/// Most paths from one point through one glass sphere along one exit
/// direction.
pub const ROOTS: usize = 3;

/// A path from a point through a glass sphere: in along `wi`, out along the
/// requested direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlassPath {
    /// Unit direction from the point to the entry.
    pub wi: Vec3,
    /// Distance from the point to the entry.
    pub t_entry: f32,
    /// The entry point.
    pub entry: Vec3,
    /// Unit direction inside the sphere.
    pub inner: Vec3,
    /// Length of the chord inside.
    pub chord: f32,
    /// The exit point.
    pub exit: Vec3,
    /// The two Fresnel transmittances (equal: the inner angle of incidence
    /// is the angle of refraction at the entry).
    pub transmit: f32,
    /// `|dω/dω_x|`: solid angle of exit directions per solid angle of
    /// directions from the point.
    pub jac: f32,
}

impl GlassPath {
    /// No path.
    pub const NONE: Self = Self {
        wi: Vec3::ZERO,
        t_entry: 0.0,
        entry: Vec3::ZERO,
        inner: Vec3::ZERO,
        chord: 0.0,
        exit: Vec3::ZERO,
        transmit: 0.0,
        jac: 0.0,
    };
}

/// The paths from `x` that refract into the glass sphere (centre `c`,
/// radius `r`, index `eta`), refract out and leave along the unit direction
/// `w`, written to `out`; returns how many (0 to [`ROOTS`]).
///
/// A ray through a sphere stays in the plane of its line and the centre:
/// the plane of `a = (c − x)/d` and `w`, in which `w` makes the angle `W`
/// with `a`. A ray from `x` of impact parameter `b` (signed distance of its
/// line from `c`) has direction angle `θ` (`sin θ = b/d`), angles of
/// incidence and refraction `θi` (`sin θi = b/r`) and `θt` (`sin θt = b /
/// (η r)`), and leaves at `φ(b) = θ − 2(θi − θt)`, with
/// `φ'(b) = 1/(d cos θ) − 2/(r cos θi) + 2/(η r cos θt)`. `φ'` is even with
/// at most one zero `b*` on (0, r), and only where `x` is nearer than
/// `η r / (2(η − 1))`; so `φ` is monotone on `[−r, −b*]`, `[−b*, b*]` and
/// `[b*, r]` (or on the whole `[−r, r]`), and each piece holds at most one
/// root of `φ = W` (or of `φ = W − 2π`, for a point so near that `φ`
/// passes −π), found by Newton's method kept in its bracket. The density
/// ratio is `|dω/dω_x| = sin W |φ'(b)| d cos θ / |sin θ|` (a turn about
/// the axis `x c` turns both directions alike).
pub fn glass_paths(
    x: Vec3,
    c: Vec3,
    r: f32,
    eta: f32,
    w: Vec3,
    out: &mut [GlassPath; ROOTS],
) -> usize {
    let to_c = c - x;
    let d = to_c.length();
    if !(d > r) || !(eta > 1.0) {
        return 0;
    }
    let a = to_c * (1.0 / d);
    let cw = a.dot(w);
    let perp = w - a * cw;
    let sw = perp.length();
    let v = if sw > 1e-6 {
        perp * (1.0 / sw)
    } else {
        a.basis().0
    };
    let big_w = math::atan2(sw, cw);
    let inv_er = 1.0 / (eta * r);
    // φ and φ' at b
    let phi = |b: f32| math::asin(b / d) - 2.0 * math::asin(b / r) + 2.0 * math::asin(b * inv_er);
    let cosine = |s: f32| math::sqrt((1.0 - s) * (1.0 + s));
    let dphi = |b: f32| {
        1.0 / (d * cosine(b / d)) - 2.0 / (r * cosine(b / r)) + 2.0 * inv_er / cosine(b * inv_er)
    };
    let edge = r * (1.0 - 1.0 / 1_048_576.0);
    // the zero b* of φ' on (0, r), if φ' > 0 at 0 (it falls to −∞ at r):
    // roots near it have |dω/dω_x| near 0, below GLASS_JAC_MIN, so a
    // bracket of r / 2¹⁶ serves
    let mut ends = [-edge, edge, edge, edge];
    let mut pieces = 1;
    if dphi(0.0) > 0.0 {
        let (mut lo, mut hi) = (0.0f32, edge);
        for _ in 0..16 {
            let mid = 0.5 * (lo + hi);
            if dphi(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let b_star = 0.5 * (lo + hi);
        ends = [-edge, -b_star, b_star, edge];
        pieces = 3;
    }
    // φ at the pieces' ends, shared by both targets
    let at_ends = ends.map(phi);
    let mut found = 0;
    for k in 0..pieces {
        let (Some(&lo), Some(&hi), Some(&flo), Some(&fhi)) = (
            ends.get(k),
            ends.get(k + 1),
            at_ends.get(k),
            at_ends.get(k + 1),
        ) else {
            continue;
        };
        if !(hi > lo) {
            continue;
        }
        for target in [big_w, big_w - math::TWO_PI] {
            let Some(b) = bracketed_root(
                |b| phi(b) - target,
                dphi,
                lo,
                hi,
                flo - target,
                fhi - target,
            ) else {
                continue;
            };
            let Some(p) = glass_path(x, c, r, eta, d, a, v, b, sw) else {
                continue;
            };
            if let Some(slot) = out.get_mut(found) {
                *slot = p;
                found += 1;
            }
        }
    }
    found
}

/// The root of the monotone `f` (derivative `df`) on `[lo, hi]` (where it
/// is `flo` and `fhi`), if `f` changes sign there: Newton's method kept in
/// the bracket (bisection when a step would leave it).
fn bracketed_root(
    f: impl Fn(f32) -> f32,
    df: impl Fn(f32) -> f32,
    lo: f32,
    hi: f32,
    flo: f32,
    fhi: f32,
) -> Option<f32> {
    if !((flo <= 0.0 && fhi >= 0.0) || (flo >= 0.0 && fhi <= 0.0)) {
        return None;
    }
    // orient so that f(a) ≤ 0 ≤ f(b)
    let (mut a, mut b) = if flo <= 0.0 { (lo, hi) } else { (hi, lo) };
    // the secant of the bracket's ends to start
    let mut t = lo + (hi - lo) * math::clamp(flo / (flo - fhi), 0.0, 1.0);
    for _ in 0..48 {
        let ft = f(t);
        if ft <= 0.0 {
            a = t;
        } else {
            b = t;
        }
        let step = ft / df(t);
        let next = t - step;
        let inside = (next - a) * (next - b) < 0.0;
        if inside && math::abs(step) <= 1e-7 * math::max(math::abs(t), 1e-3 * math::abs(hi - lo)) {
            return Some(next);
        }
        t = if inside { next } else { 0.5 * (a + b) };
        if !(math::abs(b - a) > 1e-7 * math::abs(hi - lo)) {
            return Some(t);
        }
    }
    Some(t)
}

/// The path of impact parameter `b` (see [`glass_paths`]), or `None` where
/// its geometry degenerates (a ray through the centre, which only `W = 0`
/// has, or total internal reflection, which a sphere never gives).
#[allow(clippy::too_many_arguments)]
fn glass_path(
    x: Vec3,
    c: Vec3,
    r: f32,
    eta: f32,
    d: f32,
    a: Vec3,
    v: Vec3,
    b: f32,
    sw: f32,
) -> Option<GlassPath> {
    let s = b / d;
    if !(math::abs(s) > 1e-7) {
        return None;
    }
    let cos_t = math::sqrt((1.0 - s) * (1.0 + s));
    let wi = (a * cos_t + v * s).normalize();
    let si = b / r;
    let cos_i = math::sqrt((1.0 - si) * (1.0 + si));
    let t_entry = d * cos_t - r * cos_i;
    let entry = x + wi * t_entry;
    let n1 = (entry - c) * (1.0 / r);
    let st = si / eta;
    let cos_r = math::sqrt((1.0 - st) * (1.0 + st));
    // Snell's law, inward: wi / η + n (cos θi / η − cos θt) with n outward
    let inner = (wi * (1.0 / eta) + n1 * (cos_i / eta - cos_r)).normalize();
    let chord = 2.0 * r * cos_r;
    let exit = entry + inner * chord;
    let transmit = transmittance(cos_i, eta);
    let jac = glass_jacobian(d, r, eta, b, sw);
    Some(GlassPath {
        wi,
        t_entry,
        entry,
        inner,
        chord,
        exit,
        transmit: transmit * transmit,
        jac,
    })
}

/// `|dω/dω_x| = sin W |φ'(b)| d cos θ / |sin θ|` of the path of impact
/// parameter `b` from a point at distance `d` from the centre of a glass
/// sphere (radius `r`, index `eta`), leaving at `sin W = sw` from the
/// axis (see [`glass_paths`]); even in `b`.
pub(crate) fn glass_jacobian(d: f32, r: f32, eta: f32, b: f32, sw: f32) -> f32 {
    let cosine = |s: f32| math::sqrt((1.0 - s) * (1.0 + s));
    let s = b / d;
    let dphi =
        1.0 / (d * cosine(s)) - 2.0 / (r * cosine(b / r)) + 2.0 / (eta * r * cosine(b / (eta * r)));
    sw * math::abs(dphi) * d * cosine(s) / math::abs(s)
}

/// `1 − F` at the entry of glass of index `eta` for the cosine of
/// incidence `cos_i`.
#[cfg(feature = "glass")]
fn transmittance(cos_i: f32, eta: f32) -> f32 {
    1.0 - crate::material::glass::fresnel_dielectric(cos_i, 1.0 / eta).0
}

#[cfg(not(feature = "glass"))]
fn transmittance(_: f32, _: f32) -> f32 {
    0.0
}
