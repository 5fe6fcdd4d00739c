//! Multi-threaded rendering of the core's tiles on the host.

use crate::image::Image;
use micropt::budget::{
    AdaptiveOptions, Budget, TILE_PIXELS, TileAccum, allocate_tiles, budget_samples,
    deadline_samples,
};
use micropt::film::{TILE, Tile, tile_at, tile_count, tiles};
use micropt::{Color, Options, Renderer, Scene, Stats};
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

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

/// The number of threads `threads` means (0: the machine's cores).
pub fn resolve_threads(threads: usize) -> usize {
    if threads > 0 {
        threads
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    }
}

/// Renders `scene` as `job` says, calling `on_tile` after every finished
/// tile. The image is bit-identical for any number of threads: every pixel
/// depends only on (scene, size, spp, seed, options).
pub fn render<const S: usize, const P: usize, const M: usize>(
    scene: &Scene<S, P, M>,
    job: &RenderJob,
    on_tile: &(dyn Fn() + Sync),
) -> Result<RenderOutput, String> {
    if job.width == 0 || job.height == 0 {
        return Err("image size must be at least 1x1".into());
    }
    if job.spp == 0 {
        return Err("--spp must be at least 1".into());
    }
    let renderer = Renderer::new(scene, job.width, job.height)
        .map_err(|e| format!("camera: {e:?}"))?
        .seed(job.seed)
        .options(job.options);
    let all: Vec<Tile> = tiles(job.width, job.height).collect();
    let threads = resolve_threads(job.threads).min(all.len()).max(1);
    let image = Mutex::new(Image::new(job.width, job.height));
    let stats = Mutex::new(Stats::default());
    let next = AtomicUsize::new(0);
    let start = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                let mut local = Stats::default();
                let mut px = [Color::ZERO; (TILE * TILE) as usize];
                while let Some(tile) = all.get(next.fetch_add(1, Ordering::Relaxed)) {
                    renderer.render_tile(tile, job.spp, &mut px, &mut local);
                    {
                        let mut img = image.lock().unwrap_or_else(|e| e.into_inner());
                        for (i, c) in px.iter().take(tile.len()).enumerate() {
                            let (x, y) = (tile.x + i as u32 % tile.w, tile.y + i as u32 / tile.w);
                            let w = img.width;
                            img.pixels[(y * w + x) as usize] = *c;
                        }
                    }
                    on_tile();
                }
                stats
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .merge(&local);
            });
        }
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

/// Runs `work(tile_index)` for every index in `0..n` on `threads` threads.
fn parallel_tiles(n: usize, threads: usize, work: &(dyn Fn(usize) + Sync)) {
    let next = AtomicUsize::new(0);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= n {
                        break;
                    }
                    work(i);
                }
            });
        }
    });
}

/// Renders `scene` within `job.budget` on threads: the preview pass over
/// all tiles, then the refinement of every tile, with the core's per-tile
/// functions. For sample budgets the image is bit-identical to the core's
/// single-core [`micropt::budget::render_budget`] (which recomputes the
/// preview instead of keeping it) for any thread count.
pub fn render_budget<const S: usize, const P: usize, const M: usize>(
    scene: &Scene<S, P, M>,
    job: &BudgetJob,
    on_tile: &(dyn Fn() + Sync),
) -> Result<BudgetOutput, String> {
    let (w, h) = (job.width, job.height);
    if w == 0 || h == 0 {
        return Err("image size must be at least 1x1".into());
    }
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
    let start = Instant::now();

    // pass 1: preview (sample 0 everywhere), keeping each tile's accumulators
    let previews: Vec<Mutex<Option<Box<TileAccum>>>> = (0..n).map(|_| Mutex::new(None)).collect();
    parallel_tiles(n, threads, &|i| {
        let Some(tile) = tile_at(w, h, i) else { return };
        let mut acc = Box::new(TileAccum::new());
        let mut local = Stats::default();
        renderer.preview_tile(&tile, &mut acc, &mut local);
        *previews[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(acc);
        stats
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .merge(&local);
        on_tile();
    });
    let preview_seconds = start.elapsed().as_secs_f64();

    // allocation
    let pixels = u64::from(w) * u64::from(h);
    let (extra, deadline) = match job.budget {
        Budget::Deadline(us) => {
            let pre_us = (preview_seconds * 1e6) as u64;
            (
                deadline_samples(us, pre_us, pixels, 0),
                Some(start + Duration::from_micros(us)),
            )
        }
        b => (budget_samples(&b, w, h).unwrap_or(pixels) - pixels, None),
    };
    let mut shares = vec![0u64; n];
    allocate_tiles(w, h, extra, |i, s| shares[i] = s);

    // pass 2: refinement
    let image = Mutex::new(Image::new(w, h));
    let counts = Mutex::new(vec![0u32; (w * h) as usize]);
    let spent = AtomicU64::new(0);
    parallel_tiles(n, threads, &|i| {
        let Some(tile) = tile_at(w, h, i) else { return };
        let Some(mut acc) = previews[i].lock().unwrap_or_else(|e| e.into_inner()).take() else {
            return;
        };
        let mut local = Stats::default();
        let mut stop = |_: u64| deadline.is_some_and(|d| Instant::now() >= d);
        if !stop(0) {
            let s = renderer.refine_tile(
                &tile,
                &mut acc,
                shares[i],
                &job.adaptive,
                &mut stop,
                &mut local,
            );
            spent.fetch_add(s, Ordering::Relaxed);
        }
        let mut px = [Color::ZERO; TILE_PIXELS];
        acc.means(&mut px);
        {
            let mut img = image.lock().unwrap_or_else(|e| e.into_inner());
            let mut cnt = counts.lock().unwrap_or_else(|e| e.into_inner());
            for (k, c) in px.iter().take(tile.len()).enumerate() {
                let (x, y) = (tile.x + k as u32 % tile.w, tile.y + k as u32 / tile.w);
                let idx = (y * w + x) as usize;
                img.pixels[idx] = *c;
                cnt[idx] = acc.count(k);
            }
        }
        stats
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .merge(&local);
        on_tile();
    });
    Ok(BudgetOutput {
        image: image.into_inner().unwrap_or_else(|e| e.into_inner()),
        counts: counts.into_inner().unwrap_or_else(|e| e.into_inner()),
        samples: pixels + spent.load(Ordering::Relaxed),
        stats: stats.into_inner().unwrap_or_else(|e| e.into_inner()),
        preview_seconds,
        seconds: start.elapsed().as_secs_f64(),
        threads,
    })
}
