//! Multi-threaded rendering of the core's tiles on the host.

use crate::image::Image;
use micropt::film::{TILE, Tile, tiles};
use micropt::{Color, Options, Renderer, Scene, Stats};
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Reads and parses a scene file; the error message names the file and, for
/// malformed scenes, the line.
pub fn load_scene(path: &Path) -> Result<Scene, String> {
    let bytes =
        std::fs::read(path).map_err(|e| format!("cannot read scene {}: {e}", path.display()))?;
    micropt::parse::parse_bytes(&bytes).map_err(|e| format!("{}: {e}", path.display()))
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
pub fn render(
    scene: &Scene,
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
