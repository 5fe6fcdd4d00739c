//! Multi-threaded rendering of the core's tiles on the host.

use crate::image::Image;
use micropt::budget::{
    AdaptiveOptions, Budget, MAX_SPP, Pace, TILE_PIXELS, TileAccum, allocate_tiles, budget_samples,
};
use micropt::film::{TILE, tile_at, tile_count};
use micropt::scene::{MAX_PIXELS, MAX_SIDE};
use micropt::{Color, Options, Renderer, Scene, Stats};
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

/// Most worker threads a render starts (each is an operating-system thread
/// with its own stack; far more than any host has cores).
pub const MAX_THREADS: usize = 1024;

/// The host's sphere capacity: scenes of thousands of spheres.
pub const HOST_SPHERES: usize = 4096;
/// The host's plane capacity.
pub const HOST_PLANES: usize = 64;
/// The host's material capacity.
pub const HOST_MATERIALS: usize = 1024;
/// The scenes the host CLI and bench load (about 0.8 MB: kept on the heap).
pub type HostScene = Scene<HOST_SPHERES, HOST_PLANES, HOST_MATERIALS>;

/// A parse error's message, with the host's capacity named when a scene does
/// not fit (the core's message says only that the build's capacity is
/// exceeded).
pub fn host_error(e: &micropt::parse::ParseError) -> String {
    use micropt::SceneError::Capacity;
    use micropt::parse::ParseErrorKind::Scene;
    match e.kind {
        Scene(Capacity(what)) => {
            let cap = match what {
                "spheres" => HOST_SPHERES,
                "planes" => HOST_PLANES,
                _ => HOST_MATERIALS,
            };
            format!("line {}: too many {what} (capacity {cap})", e.line)
        }
        _ => e.to_string(),
    }
}

/// Parses a scene text at the host's capacity (on the heap).
pub fn parse_host(text: &str) -> Result<Box<HostScene>, micropt::parse::ParseError> {
    let mut scene = Box::new(HostScene::EMPTY);
    micropt::parse::parse_into(text, &mut scene)?;
    Ok(scene)
}

/// Reads and parses a scene file; the error message names the file and, for
/// malformed scenes, the line.
pub fn load_scene(path: &Path) -> Result<Box<HostScene>, String> {
    let bytes =
        std::fs::read(path).map_err(|e| format!("cannot read scene {}: {e}", path.display()))?;
    let mut scene = Box::new(HostScene::EMPTY);
    micropt::parse::parse_bytes_into(&bytes, &mut scene)
        .map_err(|e| format!("{}: {}", path.display(), host_error(&e)))?;
    Ok(scene)
}

/// What to render.
#[derive(Clone, Copy, Debug)]
pub struct RenderJob {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel (> 0).
    pub spp: u32,
    /// Render seed.
    pub seed: u64,
    /// Worker threads (0: all cores).
    pub threads: usize,
    /// Integrator options.
    pub options: Options,
}

/// A finished render.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    /// Mean linear radiance per pixel.
    pub image: Image,
    /// Work counters.
    pub stats: Stats,
    /// Wall-clock seconds of the render (excluding parsing and file output).
    pub seconds: f64,
    /// Threads used.
    pub threads: usize,
}

/// The number of threads `threads` means (0: the machine's cores), at most
/// [`MAX_THREADS`].
pub fn resolve_threads(threads: usize) -> usize {
    if threads > 0 {
        threads.min(MAX_THREADS)
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    }
}

/// Checks an image size against the limits of the scene format
/// ([`MAX_SIDE`] per side, [`MAX_PIXELS`] in all); the message names them.
pub fn check_size(width: u32, height: u32) -> Result<(), String> {
    if width == 0 || height == 0 {
        return Err("image size must be at least 1x1".into());
    }
    if width > MAX_SIDE || height > MAX_SIDE {
        return Err(format!(
            "image size {width}x{height} is too large: each side must be at most {MAX_SIDE}"
        ));
    }
    if u64::from(width) * u64::from(height) > u64::from(MAX_PIXELS) {
        return Err(format!(
            "image size {width}x{height} is too large: at most {MAX_PIXELS} pixels"
        ));
    }
    Ok(())
}

/// Runs `work(tile_index)` for every index in `0..n` on up to `threads`
/// threads, this one included. A thread the system refuses to start is done
/// without (the work is shared through one counter), so a render never
/// aborts for want of threads.
fn parallel_tiles(n: usize, threads: usize, work: &(dyn Fn(usize) + Sync)) {
    let next = AtomicUsize::new(0);
    let run = || {
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= n {
                break;
            }
            work(i);
        }
    };
    let run = &run;
    std::thread::scope(|s| {
        for _ in 1..threads.min(n) {
            if std::thread::Builder::new().spawn_scoped(s, run).is_err() {
                break;
            }
        }
        run();
    });
}

/// The renderer of `job` (its size checked against the format's limits,
/// at least one sample per pixel).
fn job_renderer<'a, const S: usize, const P: usize, const M: usize>(
    scene: &'a Scene<S, P, M>,
    job: &RenderJob,
) -> Result<Renderer<'a>, String> {
    check_size(job.width, job.height)?;
    if job.spp == 0 {
        return Err("--spp must be at least 1".into());
    }
    Ok(Renderer::new(scene, job.width, job.height)
        .map_err(|e| format!("camera: {e:?}"))?
        .seed(job.seed)
        .options(job.options))
}

/// Renders `scene` as `job` says, calling `on_tile` after every finished
/// tile. The image is bit-identical for any number of threads: every pixel
/// depends only on (scene, size, spp, seed, options).
pub fn render<const S: usize, const P: usize, const M: usize>(
    scene: &Scene<S, P, M>,
    job: &RenderJob,
    on_tile: &(dyn Fn() + Sync),
) -> Result<RenderOutput, String> {
    let renderer = job_renderer(scene, job)?;
    let n = tile_count(job.width, job.height);
    let threads = resolve_threads(job.threads).min(n).max(1);
    let image = Mutex::new(Image::new(job.width, job.height));
    let stats = Mutex::new(Stats::default());
    let start = Instant::now();
    parallel_tiles(n, threads, &|i| {
        let Some(tile) = tile_at(job.width, job.height, i) else {
            return;
        };
        let mut local = Stats::default();
        let mut px = [Color::ZERO; (TILE * TILE) as usize];
        renderer.render_tile(&tile, job.spp, &mut px, &mut local);
        image
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .put_tile(&tile, &px);
        stats
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .merge(&local);
        on_tile();
    });
    let seconds = start.elapsed().as_secs_f64();
    Ok(RenderOutput {
        image: image.into_inner().unwrap_or_else(|e| e.into_inner()),
        stats: stats.into_inner().unwrap_or_else(|e| e.into_inner()),
        seconds,
        threads,
    })
}

/// A render within a [`Budget`], progressive and (by default) adaptive.
#[derive(Clone, Copy, Debug)]
pub struct BudgetJob {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// What the render may spend.
    pub budget: Budget,
    /// Render seed.
    pub seed: u64,
    /// Worker threads (0: all cores).
    pub threads: usize,
    /// Integrator options.
    pub options: Options,
    /// How the budget is spread.
    pub adaptive: AdaptiveOptions,
}

/// A finished budgeted render.
#[derive(Clone, Debug)]
pub struct BudgetOutput {
    /// Mean linear radiance per pixel.
    pub image: Image,
    /// Samples each pixel received (row-major).
    pub counts: Vec<u32>,
    /// Samples in the image (what the budget counts).
    pub samples: u64,
    /// Work counters.
    pub stats: Stats,
    /// Wall-clock seconds of the preview pass.
    pub preview_seconds: f64,
    /// Wall-clock seconds of the whole render.
    pub seconds: f64,
    /// Threads used.
    pub threads: usize,
}

/// Renders `scene` within `job.budget` on threads: the preview pass over
/// all tiles, then the refinement of every tile, with the core's per-tile
/// functions. For sample budgets the image is bit-identical to the core's
/// single-core [`micropt::budget::render_budget`] (which recomputes the
/// preview instead of keeping it) for any thread count. A deadline is read
/// from the system's monotonic clock.
pub fn render_budget<const S: usize, const P: usize, const M: usize>(
    scene: &Scene<S, P, M>,
    job: &BudgetJob,
    on_tile: &(dyn Fn() + Sync),
) -> Result<BudgetOutput, String> {
    let start = Instant::now();
    let clock = || u64::try_from(start.elapsed().as_micros()).unwrap_or(u64::MAX);
    render_budget_timed(scene, job, on_tile, &clock)
}

/// [`render_budget`] with the time read from `clock` (microseconds from any
/// fixed origin; called from every worker thread), e.g. a scripted clock
/// that makes a deadline's accounting testable.
///
/// A deadline refines in rounds over the whole image (every tile keeps its
/// accumulators here), each sized by [`Pace::round`] from the rate the
/// rounds so far measured and the time left: half of what it affords until
/// that is less than two samples per pixel, then the rest, which the
/// deadline (looked at every [`micropt::budget::BATCH`] samples) may cut.
/// Each round goes over the tiles in up to 4 passes, so a cut round leaves
/// the tiles at most a pass apart.
pub fn render_budget_timed<const S: usize, const P: usize, const M: usize>(
    scene: &Scene<S, P, M>,
    job: &BudgetJob,
    on_tile: &(dyn Fn() + Sync),
    clock: &(dyn Fn() -> u64 + Sync),
) -> Result<BudgetOutput, String> {
    let (w, h) = (job.width, job.height);
    check_size(w, h)?;
    match job.budget {
        Budget::Spp(0) => return Err("--spp must be at least 1".into()),
        Budget::Deadline(0) => return Err("--budget-ms must be at least 1".into()),
        _ => {}
    }
    let renderer = Renderer::new(scene, w, h)
        .map_err(|e| format!("camera: {e:?}"))?
        .seed(job.seed)
        .options(job.options);
    let n = tile_count(w, h);
    let threads = resolve_threads(job.threads).min(n).max(1);
    let stats = Mutex::new(Stats::default());
    let merge = |local: &Stats| {
        stats.lock().unwrap_or_else(|e| e.into_inner()).merge(local);
    };
    let start = clock();

    // pass 1: preview (sample 0 everywhere), keeping each tile's accumulators
    let accs: Vec<Mutex<Option<Box<TileAccum>>>> = (0..n).map(|_| Mutex::new(None)).collect();
    parallel_tiles(n, threads, &|i| {
        let Some(tile) = tile_at(w, h, i) else { return };
        let mut acc = Box::new(TileAccum::new());
        let mut local = Stats::default();
        renderer.preview_tile(&tile, &mut acc, &mut local);
        *accs[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(acc);
        merge(&local);
        on_tile();
    });
    let preview_us = clock().saturating_sub(start);

    // pass 2: refinement, in rounds of `total` samples split over the tiles
    // by pixel count. A deadline's round goes over the tiles in `passes`
    // (each a part of every tile's share), so that a round the deadline cuts
    // leaves the tiles at most one pass apart, not some of them a whole
    // round behind. A sample budget's one round is one pass: one
    // `refine_tile` call per tile, as on the board.
    let round = |total: u64, deadline: Option<u64>, passes: u64| -> u64 {
        let mut shares = vec![0u64; n];
        allocate_tiles(w, h, total, |i, s| shares[i] = s);
        let spent = AtomicU64::new(0);
        let items = n.saturating_mul(passes as usize);
        parallel_tiles(items, threads, &|j| {
            let (i, pass) = (j % n, (j / n) as u64);
            // this pass's part of the share: cumulative rounding
            let part = shares[i] * (pass + 1) / passes - shares[i] * pass / passes;
            let mut guard = accs[i].lock().unwrap_or_else(|e| e.into_inner());
            if let (Some(tile), Some(acc), true) = (tile_at(w, h, i), guard.as_mut(), part > 0) {
                let mut local = Stats::default();
                let mut stop = |_: u64| deadline.is_some_and(|d| clock() >= d);
                let s =
                    renderer.refine_tile(&tile, acc, part, &job.adaptive, &mut stop, &mut local);
                spent.fetch_add(s, Ordering::Relaxed);
                merge(&local);
            }
            if deadline.is_none() {
                on_tile();
            }
        });
        spent.into_inner()
    };
    let pixels = u64::from(w) * u64::from(h);
    let refined = match job.budget {
        Budget::Deadline(us) => {
            let deadline = start.saturating_add(us);
            let mut pace = Pace::new(deadline, pixels, preview_us);
            let most = pixels.saturating_mul(u64::from(MAX_SPP) - 1);
            let begin = clock();
            let mut refined = 0u64;
            loop {
                let now = clock();
                let total = pace.round(now, pixels).min(most - refined);
                if total == 0 || now >= deadline {
                    break;
                }
                // passes of at least one sample per pixel, at most 4
                let passes = (total / pixels).clamp(1, 4);
                refined += round(total, Some(deadline), passes);
                pace.measured(refined, clock().saturating_sub(begin));
            }
            (0..n).for_each(|_| on_tile());
            refined
        }
        b => round(budget_samples(&b, w, h).unwrap_or(pixels) - pixels, None, 1),
    };

    let mut image = Image::new(w, h);
    let mut counts = vec![0u32; image.pixels.len()];
    let mut px = [Color::ZERO; TILE_PIXELS];
    for (i, acc) in accs.into_iter().enumerate() {
        let (Some(tile), Some(acc)) = (
            tile_at(w, h, i),
            acc.into_inner().unwrap_or_else(|e| e.into_inner()),
        ) else {
            continue;
        };
        acc.means(&mut px);
        image.put_tile(&tile, &px);
        for (k, c) in image.tile_indices(&tile).enumerate() {
            counts[c] = acc.count(k);
        }
    }
    let seconds = clock().saturating_sub(start) as f64 * 1e-6;
    Ok(BudgetOutput {
        image,
        counts,
        samples: pixels + refined,
        stats: stats.into_inner().unwrap_or_else(|e| e.into_inner()),
        preview_seconds: preview_us as f64 * 1e-6,
        seconds,
        threads,
    })
}

/// A denoised render ([`render_denoised`]).
#[derive(Clone, Debug)]
pub struct DenoisedOutput {
    /// The denoised image.
    pub image: Image,
    /// The same samples' mean, unfiltered.
    pub raw: Image,
    /// Each pixel's guide albedo (OIDN's convention: in [0, 1]).
    pub albedo: Image,
    /// Each pixel's guide normal (world space, in [−1, 1]).
    pub normal: Image,
    /// Work counters of the render.
    pub stats: Stats,
    /// Wall-clock seconds of the render's samples.
    pub seconds: f64,
    /// Wall-clock seconds of the denoiser (guides included).
    pub denoise_seconds: f64,
    /// Threads used for the samples (the denoiser runs on one).
    pub threads: usize,
}

/// Renders `job.spp` samples of every pixel into per-pixel moments (rows
/// shared among threads; each pixel's sums in sample order, so the bits do
/// not depend on the threads) and denoises them with the core's
/// [`micropt::denoise`].
pub fn render_denoised<const S: usize, const P: usize, const M: usize>(
    scene: &Scene<S, P, M>,
    job: &RenderJob,
    on_row: &(dyn Fn() + Sync),
) -> Result<DenoisedOutput, String> {
    use micropt::denoise::{self, Column, Moments};
    let renderer = job_renderer(scene, job)?;
    let (w, h) = (job.width as usize, job.height as usize);
    let threads = resolve_threads(job.threads).min(h).max(1);
    let rows: Vec<Mutex<Vec<Moments>>> = (0..h).map(|_| Mutex::new(Vec::new())).collect();
    let stats = Mutex::new(Stats::default());
    let start = Instant::now();
    parallel_tiles(h, threads, &|y| {
        let mut local = Stats::default();
        let mut row = vec![Moments::ZERO; w];
        for (x, m) in row.iter_mut().enumerate() {
            *m = denoise::pixel_moments(&renderer, job.spp, x as u32, y as u32, &mut local);
        }
        *rows[y].lock().unwrap_or_else(|e| e.into_inner()) = row;
        stats
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .merge(&local);
        on_row();
    });
    let seconds = start.elapsed().as_secs_f64();
    let moments: Vec<Moments> = rows
        .into_iter()
        .flat_map(|r| r.into_inner().unwrap_or_else(|e| e.into_inner()))
        .collect();
    let start = Instant::now();
    let mut image = Image::new(job.width, job.height);
    let mut albedo = Image::new(job.width, job.height);
    let mut normal = Image::new(job.width, job.height);
    let mut columns = vec![Column::EMPTY; w];
    denoise::denoise_moments(
        &renderer,
        &moments,
        job.spp,
        &mut columns,
        |x, y, g| {
            albedo.set(x, y, g.albedo);
            normal.set(x, y, g.normal);
        },
        |y, x, c| image.set(x, y, c),
    )
    .map_err(|e| format!("denoise: {e}"))?;
    let denoise_seconds = start.elapsed().as_secs_f64();
    let mut raw = Image::new(job.width, job.height);
    for (px, m) in raw.pixels.iter_mut().zip(&moments) {
        *px = m.mean(job.spp);
    }
    Ok(DenoisedOutput {
        image,
        raw,
        albedo,
        normal,
        stats: stats.into_inner().unwrap_or_else(|e| e.into_inner()),
        seconds,
        denoise_seconds,
        threads,
    })
}
