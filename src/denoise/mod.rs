//! A denoiser that fits on the board: cross-bilateral filters guided by
//! what the pixel's centre ray sees, at two widths, with the filter
//! strength chosen per pixel by Stein's unbiased risk estimate (SURE), "no
//! filter" among the choices.
//!
//! What it does, pixel by pixel (all in f32, sums in a fixed order, so the
//! same bits on every target and with any number of threads):
//!
//! 1. The input ([`Texel`]) is the mean of the pixel's samples split in
//!    two ([`crate::integrator::PathSum`]): the *direct* part (emitters and
//!    the background seen straight, in mirrors or through glass: lights,
//!    their glints, the sky) is kept as rendered; the *scattered* part
//!    (everything after a non-delta vertex) is filtered. Its variance comes
//!    from the pixel's own samples ([`Moments`]).
//! 2. Each candidate filter `k` averages the scattered radiance divided by
//!    the guide's albedo over the taps within [`RADIUS`] that have the
//!    same guide key (the same chain of mirrors and glass to the same
//!    object) and a normal within [`NORMAL_COS`], with Gaussian spatial
//!    weights of width [`WIDTHS`]`[k]`, and multiplies the albedo back: a
//!    linear filter of the noisy image whose weights depend only on the
//!    noise-free guides.
//! 3. For such a filter, SURE is an unbiased estimate of its squared error
//!    at the pixel: `(F_k − y)² + σ² (2 w_pp / W − 1)` (luminance; `σ²`
//!    the variance of the pixel's mean, `w_pp / W` the pixel's own share of
//!    its weights). "No filter" has SURE `σ²`. Each pixel takes the
//!    candidate whose SURE, summed over the pixels within
//!    [`CHOICE_RADIUS`] (a 9 × 9 window: one pixel's SURE is too noisy to
//!    choose by), is least, and "no filter" on a tie.
//!
//! Pixels whose guide says keep (lights, background, sharp metal), pixels
//! with fewer than two samples, and pixels that saw a light directly while
//! their centre sees a surface (a light's edge) are left as rendered and
//! are nobody's tap.
//!
//! Memory: a ring of [`RING_ROWS`] rows of [`Texel`]s and one of
//! [`CHOICE_ROWS`] rows of [`Candidate`]s ([`workspace_bytes`]); the rows are filled on demand, so
//! a renderer can render a band at a time (the firmware), or read them
//! from whole-frame [`Moments`] (the host).

mod input;
#[cfg(test)]
mod tests;

pub use input::{GUIDE_DEPTH, Guide, GuideKind, Moments, SHARP_ALPHA, guide};

use crate::geometry::{Color, Vec3};
use crate::math;

/// Taps reach this many pixels either side, in x and in y.
pub const RADIUS: usize = 3;
/// Rows the ring holds: the row being filtered and [`RADIUS`] either side.
pub const RING_ROWS: usize = 2 * RADIUS + 1;
/// Gaussian widths (standard deviation, pixels) of the candidate filters:
/// the narrow one over the pixels within 2 in x and y, the wide one within
/// [`RADIUS`]. Each is separable: a pass along the row, then one along
/// the column over the row pass's results.
pub const WIDTHS: [f32; 2] = [1.0, 3.0];
/// The narrow filter's reach.
const NARROW: usize = 2;
/// A pixel's SURE is summed over this many pixels either side, in x and
/// in y, before the choice.
pub const CHOICE_RADIUS: usize = 3;
/// Two pixels are filtered together only if their normals' cosine is at
/// least this.
pub const NORMAL_COS: f32 = 0.9;
/// A filter may move a pixel by at most this many standard errors of the
/// pixel's own mean: the window's SURE speaks for the window, and one
/// pixel of huge variance in it (a firefly) would otherwise choose for its
/// neighbours the filter that spreads it over them.
pub const CONSISTENCY: f32 = 6.0;
/// A tap is an outlier for a pixel where its samples' spread (standard
/// deviation of the mean) is more than this many times the pixel's own.
pub const OUTLIER: f32 = 8.0;
/// ... or than this fraction of the pixel's brightness (squared), for a
/// pixel whose own samples happen to agree.
const OUTLIER_FLOOR: f32 = 0.01;
/// The choice weighs each pixel's SURE by `1 / (b² + RELATIVE_FLOOR)`, `b`
/// its brightness (the relative MSE's floor).
const RELATIVE_FLOOR: f32 = 0.01;
/// Albedo channels below this are divided as if they were this.
const MIN_ALBEDO: f32 = 1.0 / 256.0;
const SIDE: usize = 2 * RADIUS + 1;

/// One pixel as the filter reads it: the means of its samples, their
/// variance, and its guide.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texel {
    /// Mean scattered radiance (the part the filter smooths).
    pub scattered: Color,
    /// Mean direct radiance (kept as rendered).
    pub direct: Color,
    /// The scattered radiance divided by the albedo (what is averaged).
    pub shade: Color,
    /// The guide's albedo (what is multiplied back).
    pub albedo: Color,
    /// The guide's normal.
    pub normal: Vec3,
    /// Variance of the mean scattered luminance, from the difference of
    /// the two halves of the samples (SURE's `σ²`).
    pub variance: f32,
    /// The same from the samples' spread as if they were independent (an
    /// upper bound, with n − 1 degrees of freedom: the consistency guard's
    /// scale).
    pub spread: f32,
    /// The guide's key ([`Guide::key`]).
    pub key: u32,
    /// Whether the pixel is filtered and is a tap.
    pub filtered: bool,
    /// Whether its surface is a plane ([`Guide::flat`]).
    pub flat: bool,
    /// Each filter's pass along the row: the weighted mean of the `shade`
    /// of the similar pixels within its reach in the row.
    pub across: [Color; WIDTHS.len()],
    /// Each row pass's weight on the pixel itself over its weights' sum
    /// (its derivative with respect to the pixel's own value).
    pub own: [f32; WIDTHS.len()],
}

impl Texel {
    /// A pixel left as rendered, with this value.
    pub const fn kept(c: Color) -> Self {
        Self {
            scattered: Color::ZERO,
            direct: c,
            shade: Color::ZERO,
            albedo: Color::ZERO,
            normal: Vec3::ZERO,
            variance: 0.0,
            spread: 0.0,
            key: 0,
            filtered: false,
            flat: false,
            across: [Color::ZERO; WIDTHS.len()],
            own: [0.0; WIDTHS.len()],
        }
    }

    /// The texel of a pixel with `n` samples summed in `m`, and guide `g`.
    pub fn new(m: &Moments, n: u32, g: &Guide) -> Self {
        let nf = n.max(1) as f32;
        let inv = 1.0 / nf;
        let scattered_sum = Color::new(m.scattered[0], m.scattered[1], m.scattered[2]);
        let scattered = scattered_sum * inv;
        let direct = Color::new(m.direct[0], m.direct[1], m.direct[2]) * inv;
        let sum = scattered_sum.luminance();
        // (Σl² − (Σl)²/n) / (n (n − 1)): the variance of the mean of n
        // independent samples
        let iid = if n >= 2 {
            math::max(m.square - sum * sum * inv, 0.0) / (nf * (nf - 1.0))
        } else {
            0.0
        };
        // the samples are stratified (a scrambled Sobol net), and the iid
        // formula overestimates their mean's variance (3-5x where a pixel
        // straddles a smooth gradient). Each half of an even count is a net
        // of its own: ((A − B) / 2)² of the halves' means A and B estimates
        // the variance of (A + B) / 2 as they are sampled (one degree of
        // freedom; SURE sums it over a window)
        let variance = if n >= 2 && n.is_multiple_of(2) {
            let d = (2.0 * m.half - sum) * inv;
            d * d
        } else {
            iid
        };
        let lit_edge = g.deltas == 0 && math::gt_zero(direct.max_component());
        let filtered = g.kind == GuideKind::Surface
            && n >= 2
            && !lit_edge
            && math::is_finite(variance)
            && math::is_finite(iid)
            && scattered.is_finite();
        if !filtered {
            return Self::kept(scattered + direct);
        }
        let div = |s: f32, a: f32| s / math::max(a, MIN_ALBEDO);
        Self {
            scattered,
            direct,
            shade: Color::new(
                div(scattered.x, g.albedo.x),
                div(scattered.y, g.albedo.y),
                div(scattered.z, g.albedo.z),
            ),
            albedo: g.albedo,
            normal: g.normal,
            variance,
            spread: iid,
            key: g.key,
            filtered: true,
            flat: g.flat,
            across: [Color::ZERO; WIDTHS.len()],
            own: [0.0; WIDTHS.len()],
        }
    }

    /// The pixel unfiltered: its scattered and direct means.
    pub fn raw(&self) -> Color {
        self.scattered + self.direct
    }
}

/// One pixel's candidates, kept until its choice: what each filter gives,
/// each one's SURE, and what the pixel is without a filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// Each filter's scattered radiance.
    pub filtered: [Color; WIDTHS.len()],
    /// Each filter's SURE, and "no filter"'s last (0 for a pixel left as
    /// rendered, which no choice counts).
    pub sure: [f32; WIDTHS.len() + 1],
    /// The same summed over the pixels within [`CHOICE_RADIUS`] in the row
    /// (once per row, so that the choice adds rows, not pixels).
    pub row_sure: [f32; WIDTHS.len() + 1],
    /// The pixel's own scattered mean.
    pub scattered: Color,
    /// The pixel's direct mean (added to whatever is chosen).
    pub direct: Color,
    /// The variance of the pixel's scattered mean (luminance) as if its
    /// samples were independent (the consistency guard's scale).
    pub variance: f32,
    /// Whether the pixel is filtered (else it is emitted as rendered).
    pub filtered_pixel: bool,
}

impl Candidate {
    /// Nothing yet.
    pub const ZERO: Self = Self {
        filtered: [Color::ZERO; WIDTHS.len()],
        sure: [0.0; WIDTHS.len() + 1],
        row_sure: [0.0; WIDTHS.len() + 1],
        scattered: Color::ZERO,
        direct: Color::ZERO,
        variance: 0.0,
        filtered_pixel: false,
    };
}

/// Rows of candidates a denoiser keeps: the row being chosen and
/// [`CHOICE_RADIUS`] either side.
pub const CHOICE_ROWS: usize = 2 * CHOICE_RADIUS + 1;

/// The texels a denoiser of a `width`-pixel row needs in its ring.
pub const fn ring_len(width: usize) -> usize {
    RING_ROWS * width
}

/// The candidates a denoiser of a `width`-pixel row needs.
pub const fn candidates_len(width: usize) -> usize {
    CHOICE_ROWS * width
}

/// The bytes of a denoiser's workspace for a `width`-pixel row: the ring
/// of texels and the ring of candidates.
pub const fn workspace_bytes(width: usize) -> usize {
    ring_len(width) * core::mem::size_of::<Texel>()
        + candidates_len(width) * core::mem::size_of::<Candidate>()
}

/// Why a denoiser cannot run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DenoiseError {
    /// The image has no pixels, or more than `u32` can count.
    Size,
    /// The workspace given is smaller than [`ring_len`] texels or
    /// [`candidates_len`] candidates.
    Workspace,
}

impl core::fmt::Display for DenoiseError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DenoiseError::Size => f.write_str("the image has no pixels"),
            DenoiseError::Workspace => f.write_str("the denoiser's workspace is too small"),
        }
    }
}

/// The streaming denoiser: a ring of rows over caller-owned memory.
#[derive(Debug)]
pub struct Denoiser<'w> {
    width: usize,
    height: usize,
    ring: &'w mut [Texel],
    row: &'w mut [Candidate],
    /// Each filter's Gaussian weight per tap offset `−RADIUS ..= RADIUS`
    /// (0 beyond its reach), along a row and along a column alike.
    weights: [[f32; SIDE]; WIDTHS.len()],
    /// Which choice the guards leave (tests turn them off one at a time).
    guards: Guards,
}

/// The safeguards of the choice, each on by default; a test turns one off
/// to show that a test fails without it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Guards {
    /// "No filter" is a candidate (without it, a pixel no filter suits
    /// gets the narrowest).
    pub no_filter: bool,
    /// The divergence term of SURE (`2 σ² w_pp / W`) is counted.
    pub divergence: bool,
    /// A filter is chosen only where it moves the pixel by at most
    /// [`CONSISTENCY`] standard errors of the pixel's own mean.
    pub consistency: bool,
    /// A tap whose samples spread [`OUTLIER`] times more than the pixel's
    /// (a firefly) is no tap.
    pub outlier: bool,
}

impl Default for Guards {
    fn default() -> Self {
        Self {
            no_filter: true,
            divergence: true,
            consistency: true,
            outlier: true,
        }
    }
}

impl<'w> Denoiser<'w> {
    /// A denoiser of a `width × height` image over `ring` (at least
    /// [`ring_len`]`(width)` texels) and `row` (at least
    /// [`candidates_len`]`(width)` candidates).
    pub fn new(
        width: u32,
        height: u32,
        ring: &'w mut [Texel],
        row: &'w mut [Candidate],
    ) -> Result<Self, DenoiseError> {
        let (w, h) = (width as usize, height as usize);
        if w == 0 || h == 0 {
            return Err(DenoiseError::Size);
        }
        let (Some(texels), Some(cands)) = (w.checked_mul(RING_ROWS), w.checked_mul(CHOICE_ROWS))
        else {
            return Err(DenoiseError::Size);
        };
        let (Some(ring), Some(row)) = (ring.get_mut(..texels), row.get_mut(..cands)) else {
            return Err(DenoiseError::Workspace);
        };
        let mut weights = [[0.0; SIDE]; WIDTHS.len()];
        for (k, (table, width)) in weights.iter_mut().zip(WIDTHS).enumerate() {
            let reach = if k == 0 { NARROW } else { RADIUS };
            // exp(−d²/2σ²) = 2^(−d² log2(e) / 2σ²)
            let c = -core::f32::consts::LOG2_E / (2.0 * width * width);
            for (i, wt) in table.iter_mut().enumerate() {
                let d = i.abs_diff(RADIUS);
                *wt = if d <= reach {
                    math::exp2(c * (d * d) as f32)
                } else {
                    0.0
                };
            }
        }
        Ok(Self {
            width: w,
            height: h,
            ring,
            row,
            weights,
            guards: Guards::default(),
        })
    }

    /// The same denoiser with some safeguards off (for tests that show
    /// what each one guards).
    pub fn with_guards(mut self, guards: Guards) -> Self {
        self.guards = guards;
        self
    }

    /// Denoises the image row by row. `fill(y, row)` writes row `y`'s
    /// texels (called once per row, in order, [`RADIUS`] rows ahead of the
    /// row whose candidates are computed); `emit(y, x, colour)` receives
    /// each output pixel, row by row ([`CHOICE_RADIUS`] rows behind).
    pub fn run(
        &mut self,
        mut fill: impl FnMut(u32, &mut [Texel]),
        mut emit: impl FnMut(u32, u32, Color),
    ) {
        let (w, h) = (self.width, self.height);
        let mut filled = 0;
        for y in 0..h {
            while filled < h && filled <= y + RADIUS {
                let slot = (filled % RING_ROWS) * w;
                if let Some(texels) = self.ring.get_mut(slot..slot + w) {
                    fill(filled as u32, texels);
                    across(texels, &self.weights, self.guards);
                }
                filled += 1;
            }
            self.candidates(y);
            if y >= CHOICE_RADIUS {
                self.choose(y - CHOICE_RADIUS, &mut emit);
            }
        }
        for y in h.saturating_sub(CHOICE_RADIUS)..h {
            self.choose(y, &mut emit);
        }
    }

    /// Row `r`'s candidates (empty if out of reach: never, for the rows
    /// `run` asks for).
    fn candidate_row(&self, r: usize) -> &[Candidate] {
        let start = (r % CHOICE_ROWS) * self.width;
        self.row.get(start..start + self.width).unwrap_or(&[])
    }

    /// The candidates and their SURE for every pixel of row `y`.
    fn candidates(&mut self, y: usize) {
        let (w, h) = (self.width, self.height);
        // the ring's rows y − RADIUS ..= y + RADIUS (empty outside the image)
        let rows: [&[Texel]; SIDE] =
            core::array::from_fn(|dy| match (y + dy).checked_sub(RADIUS).filter(|&q| q < h) {
                Some(qy) => {
                    let start = (qy % RING_ROWS) * w;
                    self.ring.get(start..start + w).unwrap_or(&[])
                }
                None => &[],
            });
        let start = (y % CHOICE_ROWS) * w;
        let out = self.row.get_mut(start..start + w).unwrap_or(&mut []);
        for (x, slot) in out.iter_mut().enumerate() {
            candidate_at(&rows, x, &self.weights, self.guards, slot);
        }
        for x in 0..w {
            let x0 = x.saturating_sub(CHOICE_RADIUS);
            let x1 = (x + CHOICE_RADIUS).min(w - 1);
            let mut total = [0.0f32; WIDTHS.len() + 1];
            for q in out.get(x0..=x1).unwrap_or(&[]) {
                for (t, s) in total.iter_mut().zip(q.sure.iter()) {
                    *t += *s;
                }
            }
            if let Some(slot) = out.get_mut(x) {
                slot.row_sure = total;
            }
        }
    }

    /// The choice for every pixel of row `y`, emitted: the candidate whose
    /// SURE summed over the pixels within [`CHOICE_RADIUS`] (in x and y)
    /// is least, "no filter" on a tie.
    fn choose(&mut self, y: usize, emit: &mut impl FnMut(u32, u32, Color)) {
        let h = self.height;
        // the candidate rows y − CHOICE_RADIUS ..= y + CHOICE_RADIUS
        // (empty outside the image)
        let rows: [&[Candidate]; CHOICE_ROWS] = core::array::from_fn(|dy| {
            match (y + dy).checked_sub(CHOICE_RADIUS).filter(|&q| q < h) {
                Some(qy) => self.candidate_row(qy),
                None => &[],
            }
        });
        for (x, p) in rows[CHOICE_RADIUS].iter().enumerate() {
            if !p.filtered_pixel {
                emit(y as u32, x as u32, p.direct);
                continue;
            }
            let mut total = [0.0f32; WIDTHS.len() + 1];
            for row in &rows {
                if let Some(q) = row.get(x) {
                    for (t, s) in total.iter_mut().zip(q.row_sure.iter()) {
                        *t += *s;
                    }
                }
            }
            // without "no filter" among the choices, the narrowest filter
            // is what is left
            let (mut best, mut best_sure) = if self.guards.no_filter {
                (None, total[WIDTHS.len()])
            } else {
                (Some(0), f32::INFINITY)
            };
            let y_lum = p.scattered.luminance();
            for (k, (t, f)) in total.iter().zip(&p.filtered).enumerate() {
                // the consistency guard: a filter may move the pixel by at
                // most CONSISTENCY of its own standard errors (else it is
                // biased here, whatever its window's SURE says)
                let d = f.luminance() - y_lum;
                let consistent =
                    !self.guards.consistency || d * d <= CONSISTENCY * CONSISTENCY * p.variance;
                if consistent && math::lt(*t, best_sure) {
                    best = Some(k);
                    best_sure = *t;
                }
            }
            let out = match best.and_then(|k| p.filtered.get(k)) {
                Some(f) => *f,
                None => p.scattered,
            };
            emit(y as u32, x as u32, out + p.direct);
        }
    }
}

/// Pixel `x`'s candidates and their SURE into `cand`, from the ring's rows
/// around it (`rows[RADIUS]` its own): the column pass over the row
/// passes' results.
#[inline(always)]
fn candidate_at(
    rows: &[&[Texel]; SIDE],
    x: usize,
    weights: &[[f32; SIDE]; WIDTHS.len()],
    guards: Guards,
    cand: &mut Candidate,
) {
    let Some(p) = rows[RADIUS].get(x) else {
        *cand = Candidate::ZERO;
        return;
    };
    if !p.filtered {
        *cand = Candidate {
            direct: p.raw(),
            ..Candidate::ZERO
        };
        return;
    }
    let mut sum = [Color::ZERO; WIDTHS.len()];
    let mut wsum = [0.0f32; WIDTHS.len()];
    let [narrow, wide] = weights;
    let g = Guide3 {
        key: p.key,
        flat: p.flat,
        normal: p.normal,
        outlier: outlier(p, guards),
    };
    for ((row, &ww), &wn) in rows.iter().zip(wide).zip(narrow) {
        let Some(q) = row.get(x) else {
            continue;
        };
        if !similar(&g, q) {
            continue;
        }
        sum[1] += q.across[1] * ww;
        wsum[1] += ww;
        // the narrow filter's weights are 0 beyond its reach
        if math::gt_zero(wn) {
            sum[0] += q.across[0] * wn;
            wsum[0] += wn;
        }
    }
    let y_lum = p.scattered.luminance();
    cand.scattered = p.scattered;
    cand.direct = p.direct;
    cand.variance = p.spread;
    cand.filtered_pixel = true;
    for (((f, sure), (s, ws)), own) in cand
        .filtered
        .iter_mut()
        .zip(cand.sure.iter_mut())
        .zip(sum.iter().zip(wsum))
        .zip(p.own)
    {
        // the pixel itself is always a tap, of weight 1: ws ≥ 1
        let inv = 1.0 / ws;
        *f = p.albedo * (*s * inv);
        let d = f.luminance() - y_lum;
        // ∂F/∂y at the pixel: its own share of the column pass times its
        // own share of its row pass (no other row holds it)
        let div = if guards.divergence {
            2.0 * inv * own - 1.0
        } else {
            -1.0
        };
        *sure = d * d + p.variance * div;
    }
    cand.sure[WIDTHS.len()] = p.variance;
    // each pixel's estimates relative to its brightness (the widest
    // filter's, the least noisy guess of it), so that a dark pixel's choice
    // is not made by its bright neighbours' errors
    let b = cand.filtered[WIDTHS.len() - 1].luminance();
    let rel = 1.0 / (b * b + RELATIVE_FLOOR);
    for s in cand.sure.iter_mut() {
        *s *= rel;
    }
}

/// Whether `q` is a tap of `p`'s filters: both filtered, the same chain of
/// objects, normals within [`NORMAL_COS`] (a plane's are equal).
#[inline(always)]
fn similar(p: &Guide3, q: &Texel) -> bool {
    // a plane's pixels of the same key share its normal: no test
    q.filtered
        && q.key == p.key
        && !math::gt(q.spread, p.outlier)
        && (p.flat || !math::lt(p.normal.dot(q.normal), NORMAL_COS))
}

/// The spread above which a tap is an outlier for pixel `p`'s filters: a
/// firefly (one rare bright path among the pixel's samples) has a spread
/// far above its neighbours'; as a tap it would move them by more than
/// their own noise. (The pixel itself is always its own tap.)
#[inline(always)]
fn outlier(p: &Texel, guards: Guards) -> f32 {
    if !guards.outlier {
        return f32::INFINITY;
    }
    let l = p.scattered.luminance();
    OUTLIER * OUTLIER * math::max(p.spread, OUTLIER_FLOOR * l * l)
}

/// What [`similar`] reads of the pixel whose taps it tests.
#[derive(Clone, Copy)]
struct Guide3 {
    key: u32,
    flat: bool,
    normal: Vec3,
    /// A tap whose samples spread more than this is an outlier here.
    outlier: f32,
}

/// The row pass of every pixel of `row`: each filter's weighted mean of
/// the similar pixels' shade within its reach, and its own share.
fn across(row: &mut [Texel], weights: &[[f32; SIDE]; WIDTHS.len()], guards: Guards) {
    let w = row.len();
    for x in 0..w {
        // what the similarity test reads of the pixel (not the whole texel)
        let p = match row.get(x) {
            Some(t) if t.filtered => Guide3 {
                key: t.key,
                flat: t.flat,
                normal: t.normal,
                outlier: outlier(t, guards),
            },
            _ => continue,
        };
        let x0 = x.saturating_sub(RADIUS);
        let mut sum = [Color::ZERO; WIDTHS.len()];
        let mut wsum = [0.0f32; WIDTHS.len()];
        let taps = row.get(x0..=(x + RADIUS).min(w - 1)).unwrap_or(&[]);
        // the weight tables' entry of the first tap
        let t0 = x0 + RADIUS - x;
        let [narrow, wide] = weights;
        for ((q, &ww), &wn) in taps
            .iter()
            .zip(wide.get(t0..).unwrap_or(&[]))
            .zip(narrow.get(t0..).unwrap_or(&[]))
        {
            if !similar(&p, q) {
                continue;
            }
            sum[1] += q.shade * ww;
            wsum[1] += ww;
            // the narrow filter's weights are 0 beyond its reach
            if math::gt_zero(wn) {
                sum[0] += q.shade * wn;
                wsum[0] += wn;
            }
        }
        if let Some(t) = row.get_mut(x) {
            for k in 0..WIDTHS.len() {
                // the pixel is its own tap, of weight 1: wsum ≥ 1
                let inv = 1.0 / wsum[k];
                t.across[k] = sum[k] * inv;
                t.own[k] = inv;
            }
        }
    }
}

/// Denoises a whole frame whose samples are summed in `moments` (row-major,
/// `n` samples a pixel), its guides computed by [`guide`] row by row and
/// shown to `on_guide(x, y, guide)` (the host's guide images; a firmware
/// passes a closure that does nothing): `emit(y, x, colour)` receives each
/// output pixel. The workspace is as for [`Denoiser::new`].
pub fn denoise_moments(
    renderer: &crate::render::Renderer<'_>,
    moments: &[Moments],
    n: u32,
    ring: &mut [Texel],
    row: &mut [Candidate],
    mut on_guide: impl FnMut(u32, u32, &Guide),
    emit: impl FnMut(u32, u32, Color),
) -> Result<(), DenoiseError> {
    let (w, h) = (renderer.width(), renderer.height());
    if moments.len() < (w as usize).saturating_mul(h as usize) {
        return Err(DenoiseError::Size);
    }
    let mut d = Denoiser::new(w, h, ring, row)?;
    d.run(
        |y, texels| {
            let start = y as usize * w as usize;
            let row = moments.get(start..).unwrap_or(&[]);
            for (x, (t, m)) in texels.iter_mut().zip(row).enumerate() {
                let g = guide(renderer, x as u32, y);
                on_guide(x as u32, y, &g);
                *t = Texel::new(m, n, &g);
            }
        },
        emit,
    );
    Ok(())
}
