//! The Pico 2 example's two-core split (examples/boards/pico2/src/split.rs,
//! core code only, so it runs here on threads): the panel gets the same
//! Rgb565 pixels as from the core's single-core board executor for any
//! number of workers and any assignment of tiles to them, and every preview
//! is drawn before the first refined tile.

#[path = "../../examples/boards/pico2/src/split.rs"]
mod split;

use embedded_graphics::framebuffer::{Framebuffer, buffer_size};
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::pixelcolor::raw::{BigEndian, RawU16};
use micropt::budget::{Clock, TileAccum, render_budget};
use micropt::film::{draw_tile_iter, tile_count};
use micropt::{AdaptiveOptions, Budget, Renderer, Stats};
use micropt_host::reference::scenes_dir;
use micropt_host::render::load_scene;
use std::sync::Mutex;

type Fb48x32 = Framebuffer<Rgb565, RawU16, BigEndian, 48, 32, { buffer_size::<Rgb565>(48, 32) }>;

/// A clock that never advances (sample budgets do not read it).
struct Still;

impl Clock for Still {
    fn micros(&mut self) -> u64 {
        0
    }
}

#[test]
fn split_over_workers_draws_the_single_core_image_previews_first() {
    let s = load_scene(&scenes_dir().join("spheres.scene")).unwrap();
    let (w, h) = (48, 32);
    let n = tile_count(w, h);
    let r = Renderer::new(&s, w, h).unwrap().seed(5);
    let opts = AdaptiveOptions::default();
    for budget in [Budget::Spp(3), Budget::Paths(7_000)] {
        let mut single = Fb48x32::new();
        let mut acc = TileAccum::new();
        render_budget(&r, budget, &opts, &mut acc, &mut Still, &mut single, 1.0).unwrap();

        let mut shares = vec![0u64; n];
        assert_eq!(split::shares(&budget, w, h, &mut shares), Some(n));
        assert_eq!(split::shares(&budget, w, h, &mut shares[..n - 1]), None);
        for workers in [1, 2, 3] {
            let work = split::Split::new();
            // the panel and the order of the draws: (tile x, y, refined)
            let panel = Mutex::new((Fb48x32::new(), Vec::new()));
            let paths = Mutex::new(0u64);
            std::thread::scope(|scope| {
                for _ in 0..workers {
                    scope.spawn(|| {
                        let mut acc = TileAccum::new();
                        let mut stats = Stats::default();
                        work.work(&r, &shares, &opts, &mut acc, &mut stats, |tile, acc| {
                            let mut p = panel.lock().unwrap();
                            draw_tile_iter(&mut p.0, tile, acc.mean_iter(), 1.0).unwrap();
                            // a tile's first draw is its preview
                            let refined = p.1.iter().any(|&(x, y, _)| (x, y) == (tile.x, tile.y));
                            p.1.push((tile.x, tile.y, refined));
                        });
                        *paths.lock().unwrap() += stats.paths;
                    });
                }
            });
            let (fb, order) = panel.into_inner().unwrap();
            assert_eq!(fb.data(), single.data(), "{budget:?}, {workers} workers");
            let first_refined = order.iter().position(|d| d.2).unwrap_or(order.len());
            assert_eq!(first_refined, n, "every preview before a refined tile");
            assert!(order[n..].iter().all(|d| d.2), "no tile previewed twice");
            // every image sample traced once, plus at most one recomputed
            // preview per pixel
            let samples = match budget {
                Budget::Spp(k) => u64::from(k) * u64::from(w * h),
                Budget::Paths(p) => p,
                Budget::Deadline(_) => unreachable!(),
            };
            let traced = *paths.lock().unwrap();
            assert!(
                traced >= samples && traced <= samples + u64::from(w * h),
                "{traced} paths for {samples} samples"
            );
        }
    }
}
