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
//!    [`CHOICE_REACH`] along the row and [`CHOICE_RADIUS`] along the
//!    column (a 7 × 7 window, 11 × 7 at [`FEW_SAMPLES`] or fewer: one
//!    pixel's SURE is too noisy to choose by), is least, and "no filter"
//!    on a tie.
//!
//! Pixels whose guide says keep (lights, background, sharp metal), pixels
//! with fewer than two samples, and pixels that saw a light directly while
//! their centre sees a surface (a light's edge) are left as rendered and
//! are nobody's tap.
//!
//! Memory: one [`Column`] per pixel of a row ([`workspace_bytes`]), each
//! holding that column's rings of rows: what a pixel's neighbours read of
//! it as a tap for the [`RING_ROWS`] rows of the column pass, what only
//! its own candidates read for the [`RADIUS`] + 1 rows until they are
//! computed, its outputs for the [`CHOICE_RADIUS`] + 1 rows until its
//! choice, and the SURE sums of the [`CHOICE_ROWS`] rows the choice adds.
//! Pixels are filled on demand, row by row ([`Denoiser::run`]'s `fill`), so
//! a board renders each pixel as the denoiser needs it and keeps no frame
//! ([`denoise_with`]); the host reads whole-frame [`Moments`]
//! ([`denoise_moments`]).

mod input;
mod seen;
#[cfg(test)]
mod tests;
#[cfg(feature = "checker")]
mod texture;
mod window;

pub use input::{GUIDE_DEPTH, Guide, GuideKind, Moments, SHARP_ALPHA, guide, pixel_moments};
pub use seen::{LightEdges, SEEN_RAYS_PER_SAMPLE, SeenLights};
#[cfg(feature = "checker")]
pub use texture::{FINE_SQUARES, MEASURED_UP_TO, TEXTURE_RAYS_PER_SAMPLE, TextureRatio};

use crate::geometry::{Color, Vec3};
use crate::math;
use window::row_window_sums;

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
/// A pixel's SURE is summed over this many rows either side before the
/// choice (each row a ring of sums in every [`Column`]).
pub const CHOICE_RADIUS: usize = 3;
/// ... and over this many pixels either side along the row.
pub const CHOICE_REACH: usize = 3;
/// At most this many samples a pixel, the choice pools its SURE more
/// widely ([`CHOICE_REACH_FEW`]) and its guard is looser
/// ([`CONSISTENCY_FEW`]): the fewer the samples, the noisier each
/// pixel's SURE against the filters' bias, and the likelier that all of a
/// pixel's samples missed the rarer bright paths its neighbours caught.
/// (At 32 samples and more the wider window cost many and spheres more
/// than it gained cornell: 64 spp, many 2.93× → 2.72× in relMSE.)
pub const FEW_SAMPLES: u32 = 16;
/// The choice's reach along the row at [`FEW_SAMPLES`] or fewer (a few
/// additions a pixel, no memory: wider than tall, since each row of the
/// window costs every column a ring slot; 5 instead of 3 took cornell at
/// 240 × 240, 16 spp, from 0.00356 to 0.00331 in relMSE).
pub const CHOICE_REACH_FEW: usize = 5;
/// Two pixels are filtered together only if their normals' cosine is at
/// least this.
pub const NORMAL_COS: f32 = 0.9;
/// A filter may move a pixel by at most this many standard errors of the
/// pixel's own mean: the window's SURE speaks for the window, and one
/// pixel of huge variance in it (a firefly) would otherwise choose for its
/// neighbours the filter that spreads it over them.
pub const CONSISTENCY: f32 = 6.0;
/// The same at [`FEW_SAMPLES`] or fewer. The pixel's own spread is then
/// that of samples which may all have missed the rarer bright paths that
/// its neighbours caught: at 6, 175 such pixels of cornell at 240 × 240,
/// 16 spp, were refused every filter and held 8.6 % of the denoised
/// frame's relMSE (12: 0.00356 instead of 0.00387, with the 7-wide
/// window). A feature without noise that no guide shows is still refused
/// any filter that moves it.
pub const CONSISTENCY_FEW: f32 = 12.0;
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
    /// The guide's albedo (divided out before the filter, multiplied back
    /// after).
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
}

impl Texel {
    /// A pixel left as rendered, with this value.
    pub const fn kept(c: Color) -> Self {
        Self {
            scattered: Color::ZERO,
            direct: c,
            albedo: Color::ZERO,
            normal: Vec3::ZERO,
            variance: 0.0,
            spread: 0.0,
            key: 0,
            filtered: false,
            flat: false,
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
        // a light's edge (some camera rays hit a light itself), or a
        // surface seen straight with a direct part: a focused caustic
        // (whose scattered part, near the focal spot, holds the broad
        // paths' spikes) or the background at a silhouette
        let lit_edge = m.seen > 0 || (g.deltas == 0 && math::gt_zero(direct.max_component()));
        let filtered = g.kind == GuideKind::Surface
            && n >= 2
            && !lit_edge
            && math::is_finite(variance)
            && math::is_finite(iid)
            && scattered.is_finite();
        if !filtered {
            return Self::kept(scattered + direct);
        }
        Self {
            scattered,
            direct,
            // a blurred texture's radiance is smoothed as it is
            albedo: if g.blurred { Color::ONE } else { g.albedo },
            normal: g.normal,
            variance,
            spread: iid,
            key: g.key,
            filtered: true,
            flat: g.flat,
        }
    }

    /// The pixel unfiltered: its scattered and direct means.
    pub fn raw(&self) -> Color {
        self.scattered + self.direct
    }

    /// The scattered radiance divided by the albedo (what the filters
    /// average).
    fn shade(&self) -> Color {
        let div = |s: f32, a: f32| s / math::max(a, MIN_ALBEDO);
        Color::new(
            div(self.scattered.x, self.albedo.x),
            div(self.scattered.y, self.albedo.y),
            div(self.scattered.z, self.albedo.z),
        )
    }
}

/// What a pixel's neighbours read of it as a tap (kept for the
/// [`RING_ROWS`] rows of the column pass): its row passes and what the
/// similarity test reads.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Tap {
    /// Each filter's pass along the row: the weighted mean of the shade of
    /// the similar pixels within its reach in the row.
    across: [Color; WIDTHS.len()],
    normal: Vec3,
    spread: f32,
    /// 0 where the pixel is not filtered (and is no tap); else its guide's
    /// key with the lowest bit set, so that one comparison of keys also
    /// tells that a tap is filtered.
    key: u32,
    flat: bool,
}

impl Tap {
    const NONE: Self = Self {
        across: [Color::ZERO; WIDTHS.len()],
        normal: Vec3::ZERO,
        spread: 0.0,
        key: 0,
        flat: false,
    };

    /// Whether the pixel is filtered and is a tap.
    #[inline(always)]
    fn filtered(&self) -> bool {
        self.key != 0
    }
}

/// What only the pixel's own candidates read (kept from its fill to its
/// candidates: [`RADIUS`] + 1 rows).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Centre {
    scattered: Color,
    direct: Color,
    albedo: Color,
    variance: f32,
    /// Each row pass's weight on the pixel itself over its weights' sum
    /// (its derivative with respect to the pixel's own value).
    own: [f32; WIDTHS.len()],
}

impl Centre {
    const NONE: Self = Self {
        scattered: Color::ZERO,
        direct: Color::ZERO,
        albedo: Color::ZERO,
        variance: 0.0,
        own: [0.0; WIDTHS.len()],
    };
}

/// One pixel's outputs, kept from its candidates to its choice
/// ([`CHOICE_RADIUS`] + 1 rows): each filter's and "no filter"'s, the
/// direct part added.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Choice {
    /// Each filter's output, then the pixel as rendered.
    out: [Color; WIDTHS.len() + 1],
    /// Whether each filter passes the consistency guard here.
    consistent: [bool; WIDTHS.len()],
    /// Whether the pixel is filtered (else it is emitted as rendered).
    filtered: bool,
}

impl Choice {
    const NONE: Self = Self {
        out: [Color::ZERO; WIDTHS.len() + 1],
        consistent: [false; WIDTHS.len()],
        filtered: false,
    };
}

/// Rows of SURE sums a denoiser keeps: the row being chosen and
/// [`CHOICE_RADIUS`] either side.
pub const CHOICE_ROWS: usize = 2 * CHOICE_RADIUS + 1;
/// Rows whose centre data a denoiser keeps: from the row just filled back
/// to the row whose candidates are computed.
const CENTRE_ROWS: usize = RADIUS + 1;
/// Rows whose outputs a denoiser keeps: from the row whose candidates are
/// computed back to the row being chosen.
const CHOICE_KEPT: usize = CHOICE_RADIUS + 1;

/// A denoiser's memory for one column of the image, all its rings of rows
/// together (the caller owns a slice of these, one per column).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Column {
    taps: [Tap; RING_ROWS],
    centres: [Centre; CENTRE_ROWS],
    /// The row just filled: its pixel's shade, for the row pass.
    shade: Color,
    /// The row whose candidates are computed: the pixel's own SURE of each
    /// candidate, "no filter" last.
    sure: [f32; WIDTHS.len() + 1],
    /// Each row's SURE summed over the pixels within the choice's reach in
    /// the row (once per row, so that the choice adds rows, not pixels).
    row_sure: [[f32; WIDTHS.len() + 1]; CHOICE_ROWS],
    choices: [Choice; CHOICE_KEPT],
}

impl Column {
    /// An empty column (its contents are written before they are read).
    pub const EMPTY: Self = Self {
        taps: [Tap::NONE; RING_ROWS],
        centres: [Centre::NONE; CENTRE_ROWS],
        shade: Color::ZERO,
        sure: [0.0; WIDTHS.len() + 1],
        row_sure: [[0.0; WIDTHS.len() + 1]; CHOICE_ROWS],
        choices: [Choice::NONE; CHOICE_KEPT],
    };
}

/// The bytes of a denoiser's workspace for a `width`-pixel row: one
/// [`Column`] a pixel of the row.
pub const fn workspace_bytes(width: usize) -> usize {
    width * core::mem::size_of::<Column>()
}

/// Why a denoiser cannot run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DenoiseError {
    /// The image has no pixels, or more than `u32` can count.
    Size,
    /// The workspace given has fewer [`Column`]s than the image's width.
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

/// The streaming denoiser: rings of rows over caller-owned memory.
#[derive(Debug)]
pub struct Denoiser<'w> {
    width: usize,
    height: usize,
    columns: &'w mut [Column],
    /// Each filter's Gaussian weight per tap offset `−RADIUS ..= RADIUS`
    /// (0 beyond its reach), along a row and along a column alike.
    weights: [[f32; SIDE]; WIDTHS.len()],
    /// Which choice the guards leave (tests turn them off one at a time).
    guards: Guards,
    /// The choice's reach along the row ([`CHOICE_REACH`] or
    /// [`CHOICE_REACH_FEW`]).
    reach: usize,
    /// The consistency guard's bound ([`CONSISTENCY`] or
    /// [`CONSISTENCY_FEW`]), squared.
    consistency2: f32,
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
    /// [`CONSISTENCY`] (or [`CONSISTENCY_FEW`]) standard errors of the
    /// pixel's own mean.
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
    /// A denoiser of a `width × height` image over `columns` (at least
    /// `width` of them).
    pub fn new(width: u32, height: u32, columns: &'w mut [Column]) -> Result<Self, DenoiseError> {
        let (w, h) = (width as usize, height as usize);
        if w == 0 || h == 0 {
            return Err(DenoiseError::Size);
        }
        let Some(columns) = columns.get_mut(..w) else {
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
            columns,
            weights,
            guards: Guards::default(),
            reach: CHOICE_REACH,
            consistency2: CONSISTENCY * CONSISTENCY,
        })
    }

    /// The same denoiser for pixels of `n` samples: at [`FEW_SAMPLES`] or
    /// fewer, the choice's wider window and looser guard.
    pub fn for_samples(mut self, n: u32) -> Self {
        let (reach, k) = if n <= FEW_SAMPLES {
            (CHOICE_REACH_FEW, CONSISTENCY_FEW)
        } else {
            (CHOICE_REACH, CONSISTENCY)
        };
        self.reach = reach;
        self.consistency2 = k * k;
        self
    }

    /// The same denoiser with some safeguards off (for tests that show
    /// what each one guards).
    pub fn with_guards(mut self, guards: Guards) -> Self {
        self.guards = guards;
        self
    }

    /// Denoises the image row by row. `fill(y, x)` gives pixel (x, y)'s
    /// texel (called once per pixel, row by row and left to right within a
    /// row, [`RADIUS`] rows ahead of the row whose candidates are
    /// computed); `emit(y, x, colour)` receives each output pixel, row by
    /// row ([`CHOICE_RADIUS`] rows behind).
    pub fn run(&mut self, fill: impl FnMut(u32, u32) -> Texel, emit: impl FnMut(u32, u32, Color)) {
        self.run_while(fill, emit, |_| true);
    }

    /// [`Denoiser::run`], asking `go_on(y)` after each output row `y`
    /// whether to go on: `false` stops the run there (a demo's button
    /// press). Returns whether every row was emitted.
    pub fn run_while(
        &mut self,
        mut fill: impl FnMut(u32, u32) -> Texel,
        mut emit: impl FnMut(u32, u32, Color),
        mut go_on: impl FnMut(u32) -> bool,
    ) -> bool {
        let h = self.height;
        let mut filled = 0;
        for y in 0..h {
            while filled < h && filled <= y + RADIUS {
                self.fill_row(filled, &mut fill);
                self.across(filled);
                filled += 1;
            }
            self.candidates(y);
            if y >= CHOICE_RADIUS {
                let out = y - CHOICE_RADIUS;
                self.choose(out, &mut emit);
                if !go_on(out as u32) {
                    return false;
                }
            }
        }
        for y in h.saturating_sub(CHOICE_RADIUS)..h {
            self.choose(y, &mut emit);
            if !go_on(y as u32) {
                return false;
            }
        }
        true
    }

    /// Row `y`'s texels into the rings: the tap's and the centre's parts,
    /// and the shade for the row pass.
    fn fill_row(&mut self, y: usize, fill: &mut impl FnMut(u32, u32) -> Texel) {
        let (tap, centre) = (y % RING_ROWS, y % CENTRE_ROWS);
        for (x, col) in self.columns.iter_mut().enumerate() {
            let t = fill(y as u32, x as u32);
            let (Some(slot), Some(c)) = (col.taps.get_mut(tap), col.centres.get_mut(centre)) else {
                continue;
            };
            *slot = Tap {
                across: [Color::ZERO; WIDTHS.len()],
                normal: t.normal,
                // in the filters' domain (radiance over albedo), where the
                // outlier test compares taps
                spread: t.spread / albedo_square(t.albedo),
                key: if t.filtered { t.key | 1 } else { 0 },
                flat: t.flat,
            };
            *c = Centre {
                scattered: t.scattered,
                direct: t.direct,
                albedo: t.albedo,
                variance: t.variance,
                own: [0.0; WIDTHS.len()],
            };
            col.shade = if t.filtered { t.shade() } else { Color::ZERO };
        }
    }

    /// The row pass of every pixel of row `y` (just filled): each filter's
    /// weighted mean of the similar pixels' shade within its reach, and its
    /// own share.
    // out of line (once a row): its code does not depend on the fill's
    #[inline(never)]
    fn across(&mut self, y: usize) {
        let (slot, centre) = (y % RING_ROWS, y % CENTRE_ROWS);
        let w = self.width;
        let [narrow, wide] = &self.weights;
        for x in 0..w {
            let Some(g) = self.columns.get(x).and_then(|c| {
                let t = c.taps.get(slot)?;
                let p = c.centres.get(centre)?;
                t.filtered()
                    .then(|| guide3(t, p, albedo_square(p.albedo), self.guards))
            }) else {
                continue;
            };
            let mut sum = [Color::ZERO; WIDTHS.len()];
            let mut wsum = [0.0f32; WIDTHS.len()];
            // the weight tables' entries of the taps within the row, and
            // those taps' columns (from x − RADIUS, or the row's start)
            let first = RADIUS.saturating_sub(x);
            let end = SIDE.min(w - x + RADIUS);
            let lo = x.saturating_sub(RADIUS);
            let cols = self.columns.get(lo..lo + (end - first)).unwrap_or(&[]);
            let ws = wide.get(first..end).unwrap_or(&[]);
            let ns = narrow.get(first..end).unwrap_or(&[]);
            for ((col, &ww), &wn) in cols.iter().zip(ws).zip(ns) {
                let Some(q) = col.taps.get(slot) else {
                    continue;
                };
                if !similar(&g, q) {
                    continue;
                }
                sum[1] += col.shade * ww;
                wsum[1] += ww;
                // the narrow filter's weights are 0 beyond its reach
                if math::gt_zero(wn) {
                    sum[0] += col.shade * wn;
                    wsum[0] += wn;
                }
            }
            let Some(col) = self.columns.get_mut(x) else {
                continue;
            };
            let mut across = [Color::ZERO; WIDTHS.len()];
            let mut own = [0.0; WIDTHS.len()];
            for k in 0..WIDTHS.len() {
                // the pixel is its own tap, of weight 1: wsum ≥ 1
                let inv = 1.0 / wsum[k];
                across[k] = sum[k] * inv;
                own[k] = inv;
            }
            if let Some(t) = col.taps.get_mut(slot) {
                t.across = across;
            }
            if let Some(c) = col.centres.get_mut(centre) {
                c.own = own;
            }
        }
    }

    /// The candidates and their SURE for every pixel of row `y`.
    // out of line (once a row): its code does not depend on the fill's
    #[inline(never)]
    fn candidates(&mut self, y: usize) {
        let (w, h) = (self.width, self.height);
        // the ring slots of rows y − RADIUS ..= y + RADIUS, and the range
        // of them inside the image
        let rows = Window {
            slots: core::array::from_fn(|dy| (y + dy + RING_ROWS - RADIUS) % RING_ROWS),
            first: RADIUS.saturating_sub(y),
            end: SIDE.min(h - y + RADIUS),
        };
        let (centre, kept) = (y % CENTRE_ROWS, y % CHOICE_KEPT);
        for col in self.columns.iter_mut() {
            candidate_at(
                col,
                &rows,
                centre,
                kept,
                &self.weights,
                self.guards,
                self.consistency2,
            );
        }
        row_window_sums(self.columns, w, y % CHOICE_ROWS, self.reach);
    }

    /// The choice for every pixel of row `y`, emitted: the candidate whose
    /// SURE summed over the pixels within the reach along the row
    /// ([`CHOICE_REACH`] or [`CHOICE_REACH_FEW`]) and [`CHOICE_RADIUS`]
    /// along the column is least, "no filter" on a tie.
    fn choose(&mut self, y: usize, emit: &mut impl FnMut(u32, u32, Color)) {
        let h = self.height;
        // the ring slots of rows y − CHOICE_RADIUS ..= y + CHOICE_RADIUS
        // inside the image
        let slots: [usize; CHOICE_ROWS] =
            core::array::from_fn(|dy| (y + dy + CHOICE_ROWS - CHOICE_RADIUS) % CHOICE_ROWS);
        let rows = slots
            .get(CHOICE_RADIUS.saturating_sub(y)..CHOICE_ROWS.min(h - y + CHOICE_RADIUS))
            .unwrap_or(&[]);
        let kept = y % CHOICE_KEPT;
        for (x, col) in self.columns.iter().enumerate() {
            let Some(p) = col.choices.get(kept) else {
                continue;
            };
            if !p.filtered {
                emit(y as u32, x as u32, p.out[WIDTHS.len()]);
                continue;
            }
            let mut total = [0.0f32; WIDTHS.len() + 1];
            for s in rows.iter().filter_map(|&r| col.row_sure.get(r)) {
                for (t, s) in total.iter_mut().zip(s.iter()) {
                    *t += *s;
                }
            }
            // without "no filter" among the choices, the narrowest filter
            // is what is left
            let (mut best, mut best_sure) = if self.guards.no_filter {
                (WIDTHS.len(), total[WIDTHS.len()])
            } else {
                (0, f32::INFINITY)
            };
            for (k, (t, &consistent)) in total.iter().zip(&p.consistent).enumerate() {
                if consistent && math::lt(*t, best_sure) {
                    best = k;
                    best_sure = *t;
                }
            }
            let out = p.out.get(best).copied().unwrap_or(p.out[WIDTHS.len()]);
            emit(y as u32, x as u32, out);
        }
    }
}

/// The ring slots of the rows a pixel's column pass reads, `RADIUS` either
/// side of its own: those of `first..end` lie inside the image.
struct Window {
    slots: [usize; SIDE],
    first: usize,
    end: usize,
}

/// Pixel `col`'s candidates, their SURE (into `col.sure`) and its outputs
/// (into `col.choices[kept]`), from the taps of the ring slots `rows`
/// (`rows.slots[RADIUS]` its own row's) and its centre data in slot
/// `centre`: the column pass over the row passes' results.
#[inline(always)]
fn candidate_at(
    col: &mut Column,
    rows: &Window,
    centre: usize,
    kept: usize,
    weights: &[[f32; SIDE]; WIDTHS.len()],
    guards: Guards,
    consistency2: f32,
) {
    let Column {
        taps,
        centres,
        sure: own_sure,
        choices,
        ..
    } = col;
    let (Some(t), Some(p), Some(choice)) = (
        taps.get(rows.slots[RADIUS]),
        centres.get(centre),
        choices.get_mut(kept),
    ) else {
        *own_sure = [0.0; WIDTHS.len() + 1];
        return;
    };
    let raw = p.scattered + p.direct;
    if !t.filtered() {
        *choice = Choice {
            out: [Color::ZERO, Color::ZERO, raw],
            consistent: [false; WIDTHS.len()],
            filtered: false,
        };
        *own_sure = [0.0; WIDTHS.len() + 1];
        return;
    }
    let mut sum = [Color::ZERO; WIDTHS.len()];
    let mut wsum = [0.0f32; WIDTHS.len()];
    let [narrow, wide] = weights;
    let p_albedo2 = albedo_square(p.albedo);
    let g = guide3(t, p, p_albedo2, guards);
    let range = rows.first..rows.end;
    let slots = rows.slots.get(range.clone()).unwrap_or(&[]);
    let ws = wide.get(range.clone()).unwrap_or(&[]);
    let ns = narrow.get(range).unwrap_or(&[]);
    for ((&r, &ww), &wn) in slots.iter().zip(ws).zip(ns) {
        let Some(q) = taps.get(r) else {
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
    let mut filtered = [Color::ZERO; WIDTHS.len()];
    let mut sure = [0.0f32; WIDTHS.len() + 1];
    let mut consistent = [false; WIDTHS.len()];
    for k in 0..WIDTHS.len() {
        // the pixel itself is always a tap, of weight 1: wsum ≥ 1
        let inv = 1.0 / wsum[k];
        let f = p.albedo * (sum[k] * inv);
        let d = f.luminance() - y_lum;
        // ∂F/∂y at the pixel: its own share of the column pass times its
        // own share of its row pass (no other row holds it)
        let div = if guards.divergence {
            2.0 * inv * p.own[k] - 1.0
        } else {
            -1.0
        };
        sure[k] = d * d + p.variance * div;
        // the consistency guard: a filter may move the pixel by at most
        // CONSISTENCY (or CONSISTENCY_FEW) of its own standard errors
        // (else it is biased here, whatever its window's SURE says)
        // (the pixel's spread back in radiance: the tap's is over albedo)
        consistent[k] = !guards.consistency || d * d <= consistency2 * t.spread * p_albedo2;
        filtered[k] = f;
    }
    sure[WIDTHS.len()] = p.variance;
    // each pixel's estimates relative to its brightness (the widest
    // filter's, the least noisy guess of it), so that a dark pixel's choice
    // is not made by its bright neighbours' errors
    let b = filtered[WIDTHS.len() - 1].luminance();
    let rel = 1.0 / (b * b + RELATIVE_FLOOR);
    for s in sure.iter_mut() {
        *s *= rel;
    }
    *own_sure = sure;
    *choice = Choice {
        out: [filtered[0] + p.direct, filtered[1] + p.direct, raw],
        consistent,
        filtered: true,
    };
}

/// The square of an albedo's luminance (at least [`MIN_ALBEDO`]): what a
/// spread of radiance is divided by in the filters' domain.
#[inline(always)]
fn albedo_square(albedo: Color) -> f32 {
    let a = math::max(albedo.luminance(), MIN_ALBEDO);
    a * a
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

/// The similarity test's view of a filtered pixel: its tap part `t` and
/// centre part `p`. The outlier threshold: a firefly (one rare bright path
/// among the pixel's samples) has a spread far above its neighbours'; as
/// a tap it would move them by more than their own noise. (The pixel
/// itself is always its own tap.)
#[inline(always)]
fn guide3(t: &Tap, p: &Centre, albedo2: f32, guards: Guards) -> Guide3 {
    let outlier = if guards.outlier {
        let l = p.scattered.luminance();
        // both in the filters' domain (over the albedo): a tap's samples
        // are averaged divided by its albedo, so a firefly on a dark
        // texel weighs as much more as its albedo is darker
        OUTLIER * OUTLIER * math::max(t.spread, OUTLIER_FLOOR * l * l / albedo2)
    } else {
        f32::INFINITY
    };
    Guide3 {
        key: t.key,
        flat: t.flat,
        normal: t.normal,
        outlier,
    }
}

/// Whether `q` is a tap of `p`'s filters: both filtered, the same chain of
/// objects, normals within [`NORMAL_COS`] (a plane's are equal).
#[inline(always)]
fn similar(p: &Guide3, q: &Tap) -> bool {
    // p is filtered, so its key is not 0: equal keys say that q is
    // filtered too; a plane's pixels of the same key share its normal: no
    // test
    q.key == p.key
        && !math::gt(q.spread, p.outlier)
        && (p.flat || !math::lt(p.normal.dot(q.normal), NORMAL_COS))
}

/// Pixel (x, y) near a light's edge ([`LightEdges::near`]), of moments
/// `m` (`n` samples): where the edge crosses it, its lights measured and
/// the pixel left unfiltered ([`SeenLights::estimate`], `background` the
/// radiance around the lights from the pixels before it; a pixel with the
/// highlight estimator's images of lights, added to every sample, keeps
/// its raw value); else `None`. Out of line: most pixels are near no
/// light.
#[inline(never)]
fn edge_texel(
    renderer: &crate::render::Renderer<'_>,
    edges: &LightEdges,
    m: &Moments,
    n: u32,
    x: u32,
    y: u32,
    background: &mut Color,
) -> Option<Texel> {
    let around = *background;
    if let Some(b) = SeenLights::background(m, n) {
        *background = b;
    }
    let edge = edges.crossed(renderer, x, y)?;
    if renderer.has_highlights(x, y) {
        return None;
    }
    let c = SeenLights::measure(renderer, x, y, n).estimate(m, n, edge, around)?;
    Some(Texel::kept(c))
}

/// Denoises a whole frame whose samples are summed in `moments` (row-major,
/// `n` samples a pixel), its guides computed by [`guide`] pixel by pixel
/// and shown to `on_guide(x, y, guide)` (the host's guide images; a
/// firmware passes a closure that does nothing): `emit(y, x, colour)`
/// receives each output pixel. The workspace is as for [`Denoiser::new`].
pub fn denoise_moments(
    renderer: &crate::render::Renderer<'_>,
    moments: &[Moments],
    n: u32,
    columns: &mut [Column],
    on_guide: impl FnMut(u32, u32, &Guide),
    emit: impl FnMut(u32, u32, Color),
) -> Result<(), DenoiseError> {
    let (w, h) = (renderer.width(), renderer.height());
    if moments.len() < (w as usize).saturating_mul(h as usize) {
        return Err(DenoiseError::Size);
    }
    denoise_with(
        renderer,
        |x, y| {
            moments
                .get(y as usize * w as usize + x as usize)
                .copied()
                .unwrap_or(Moments::ZERO)
        },
        n,
        columns,
        on_guide,
        emit,
    )
}

/// Denoises a frame whose pixels' moments `pixel(x, y)` gives when the
/// denoiser needs them (row by row, left to right, [`RADIUS`] rows ahead
/// of the row being filtered): a board renders each pixel's `n` samples
/// there, and keeps no frame of moments. Otherwise as [`denoise_moments`].
pub fn denoise_with(
    renderer: &crate::render::Renderer<'_>,
    pixel: impl FnMut(u32, u32) -> Moments,
    n: u32,
    columns: &mut [Column],
    on_guide: impl FnMut(u32, u32, &Guide),
    emit: impl FnMut(u32, u32, Color),
) -> Result<(), DenoiseError> {
    denoise_while(renderer, pixel, n, columns, on_guide, emit, |_| true).map(|_| ())
}

/// [`denoise_with`], asking `go_on(y)` after each output row `y` whether
/// to go on ([`Denoiser::run_while`]). Returns whether every row was
/// emitted.
pub fn denoise_while(
    renderer: &crate::render::Renderer<'_>,
    mut pixel: impl FnMut(u32, u32) -> Moments,
    n: u32,
    columns: &mut [Column],
    mut on_guide: impl FnMut(u32, u32, &Guide),
    emit: impl FnMut(u32, u32, Color),
    go_on: impl FnMut(u32) -> bool,
) -> Result<bool, DenoiseError> {
    let mut d = Denoiser::new(renderer.width(), renderer.height(), columns)?.for_samples(n);
    let edges = LightEdges::new(renderer);
    // the radiance around the lights, from the last pixel filled near one
    // whose samples missed them (not from the pixel it serves: see
    // `SeenLights::estimate`)
    let mut background = Color::ZERO;
    Ok(d.run_while(
        |y, x| {
            let m = pixel(x, y);
            let g = guide(renderer, x, y);
            on_guide(x, y, &g);
            // (below two samples the denoiser keeps every pixel as
            // rendered, these too)
            if n >= 2
                && edges.near(x, y)
                && let Some(t) = edge_texel(renderer, &edges, &m, n, x, y, &mut background)
            {
                return t;
            }
            #[cfg(feature = "checker")]
            if g.blurred
                && let Some(t) =
                    TextureRatio::measure(renderer, &g, x, y, n).and_then(|r| r.texel(&m, n, &g))
            {
                return t;
            }
            Texel::new(&m, n, &g)
        },
        emit,
        go_on,
    ))
}
