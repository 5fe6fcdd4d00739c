//! The fixed budget: accounting (never more than one batch over),
//! completeness (no pixel without a sample), determinism (runs, threads,
//! host and single-core executors), uniform = plain render, adaptive
//! allocation beating uniform at equal paths without bias, and every
//! skip-optimisation leaving the image unchanged.

use embedded_graphics::framebuffer::{Framebuffer, buffer_size};
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::pixelcolor::raw::{BigEndian, RawU16};
use micropt::budget::{BATCH, Clock, TileAccum, render_budget as core_render_budget};
use micropt::film::{tile_at, tile_count};
use micropt::{AdaptiveOptions, Budget, Options, Renderer, Skip, Stats};
use micropt_host::metrics::compare;
use micropt_host::reference::{Reference, scenes_dir};
use micropt_host::render::{
    BudgetJob, HostScene, RenderJob, load_scene, render, render_budget, render_budget_timed,
};
use std::sync::atomic::{AtomicU64, Ordering};

/// The Rgb565 framebuffer of the board executor's 48×32 renders.
type Fb48x32 = Framebuffer<Rgb565, RawU16, BigEndian, 48, 32, { buffer_size::<Rgb565>(48, 32) }>;

fn scene(name: &str) -> Box<HostScene> {
    let path = scenes_dir().join(format!("{name}.scene"));
    micropt_host::render::parse_host(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn job(w: u32, h: u32, budget: Budget, seed: u64, threads: usize, adaptive: bool) -> BudgetJob {
    BudgetJob {
        width: w,
        height: h,
        budget,
        seed,
        threads,
        options: Options::default(),
        adaptive: AdaptiveOptions {
            adaptive,
            ..AdaptiveOptions::default()
        },
    }
}

fn pfm(img: &micropt_host::Image) -> Vec<u8> {
    let mut v = Vec::new();
    img.write_pfm(&mut v).unwrap();
    v
}

#[test]
fn sample_budgets_are_spent_exactly_and_every_pixel_is_sampled() {
    let s = scene("cornell");
    for adaptive in [false, true] {
        for (budget, want) in [
            (Budget::Spp(5), 5 * 40 * 24),
            (Budget::Paths(12_345), 12_345),
            // less than one per pixel: the preview still completes
            (Budget::Paths(7), 40 * 24),
            (Budget::Paths(40 * 24), 40 * 24),
        ] {
            let out = render_budget(&s, &job(40, 24, budget, 1, 2, adaptive), &|| {}).unwrap();
            assert_eq!(out.samples, want, "{budget:?} adaptive {adaptive}");
            // the host executor keeps its preview: traced paths = samples
            assert_eq!(out.stats.paths, want);
            assert_eq!(out.counts.iter().map(|&c| u64::from(c)).sum::<u64>(), want);
            assert!(
                out.counts.iter().all(|&c| c >= 1),
                "a pixel without a sample"
            );
            assert!(out.image.pixels.iter().all(|p| p.is_finite()));
        }
    }
}

#[test]
fn refinement_looks_at_the_clock_at_least_every_batch() {
    let s = scene("spheres");
    let r = Renderer::new(&s, 32, 32).unwrap().seed(3);
    let tile = tile_at(32, 32, 0).unwrap();
    for adaptive in [false, true] {
        let opts = AdaptiveOptions {
            adaptive,
            ..AdaptiveOptions::default()
        };
        let mut acc = TileAccum::new();
        let mut stats = Stats::default();
        r.preview_tile(&tile, &mut acc, &mut stats);
        let tb = 20_000;
        let mut looks = Vec::new();
        let mut stop = |spent: u64| {
            looks.push(spent);
            false
        };
        let mut st = Stats::default();
        let spent = r.refine_tile(&tile, &mut acc, tb, &opts, &mut stop, &mut st);
        assert_eq!(spent, 20_000);
        assert_eq!(st.paths, 20_000);
        let total: u64 = (0..256).map(|i| u64::from(acc.count(i))).sum();
        assert_eq!(total, 256 + 20_000);
        // the first look comes before any sample, then at most BATCH apart
        looks.push(spent);
        assert_eq!(looks[0], 0);
        for pair in looks.windows(2) {
            assert!(
                pair[1] - pair[0] <= BATCH,
                "adaptive {adaptive}: {} samples between looks",
                pair[1] - pair[0]
            );
        }
        // and a stop is obeyed at once
        let mut acc2 = TileAccum::new();
        r.preview_tile(&tile, &mut acc2, &mut stats);
        let mut stop_at = |spent: u64| spent >= 1000;
        let spent = r.refine_tile(&tile, &mut acc2, tb, &opts, &mut stop_at, &mut st);
        assert!(
            (1000..1000 + BATCH).contains(&spent),
            "adaptive {adaptive}: stopped after {spent}"
        );
    }
}

/// A clock that advances one microsecond per sample traced: it reads a
/// shared path counter that the test's scene callback cannot see, so it
/// counts calls instead and the deadline is expressed in looks.
struct LookClock {
    looks: u64,
}

impl Clock for LookClock {
    fn micros(&mut self) -> u64 {
        self.looks += 1;
        self.looks
    }
}

#[test]
fn a_deadline_stops_within_one_batch_and_leaves_a_complete_image() {
    let s = scene("cornell");
    let (w, h) = (48, 32);
    let r = Renderer::new(&s, w, h).unwrap().seed(2);
    let mut acc = TileAccum::new();
    for deadline_looks in [3u64, 10, 40, 200] {
        let mut clock = LookClock { looks: 0 };
        let mut fb = Fb48x32::new();
        let sum = core_render_budget(
            &r,
            Budget::Deadline(deadline_looks),
            &AdaptiveOptions::default(),
            &mut acc,
            &mut clock,
            &mut fb,
            1.0,
        )
        .unwrap();
        // every pixel has its preview sample
        assert!(sum.samples >= u64::from(w * h));
        // looks after the deadline: the one that saw it, and at most one per
        // remaining tile (each skipped at once) and the final reading
        let after = clock.looks.saturating_sub(deadline_looks);
        assert!(
            after <= tile_count(w, h) as u64 + 2,
            "{deadline_looks}: {after} looks after the deadline"
        );
        // samples traced after the deadline are bounded by one batch per look
        // that returned "go on", which is at most the looks before the deadline
        assert!(sum.samples <= u64::from(w * h) + deadline_looks * BATCH + BATCH);
    }
}

/// A scripted clock: one microsecond per look, except that the look that
/// ends the preview (the second) jumps `preview` microseconds, as a host's
/// preview costs several times more per sample than its refinement. A
/// refinement sized once from the preview's rate would end far short of the
/// deadline.
struct SlowPreviewClock {
    looks: u64,
    preview: u64,
}

impl Clock for SlowPreviewClock {
    fn micros(&mut self) -> u64 {
        self.looks += 1;
        self.looks + if self.looks >= 2 { self.preview } else { 0 }
    }
}

/// The board's executor spends a deadline: with a scripted clock (above)
/// it ends within a few looks of the deadline, after at least 90 % of it,
/// having traced nearly a batch per look of the refinement.
#[test]
fn the_board_executor_spends_the_deadline_with_a_scripted_clock() {
    let s = scene("cornell");
    let (w, h) = (48, 32);
    let r = Renderer::new(&s, w, h).unwrap().seed(2);
    let mut acc = TileAccum::new();
    let tiles = tile_count(w, h) as u64;
    for (deadline, preview) in [(400u64, 100u64), (2_000, 300), (5_000, 50)] {
        for adaptive in [true, false] {
            let opts = AdaptiveOptions {
                adaptive,
                ..AdaptiveOptions::default()
            };
            let mut clock = SlowPreviewClock { looks: 0, preview };
            let mut fb = Fb48x32::new();
            let sum = core_render_budget(
                &r,
                Budget::Deadline(deadline),
                &opts,
                &mut acc,
                &mut clock,
                &mut fb,
                1.0,
            )
            .unwrap();
            let what = format!("deadline {deadline}, preview {preview}, adaptive {adaptive}");
            // the clock starts at 1: a render's time is the last reading - 1
            assert!(
                sum.total_micros * 10 >= deadline * 9 && sum.total_micros <= deadline + tiles + 2,
                "{what}: ended after {} us",
                sum.total_micros
            );
            // a look carries at most a batch: the refinement's looks bound
            // its samples; all but a few per tile (the tile's first look, the
            // rate's measurement) carry a full batch
            let refined = sum.samples - u64::from(w * h);
            let most = (deadline - preview) * BATCH;
            eprintln!(
                "board, {what}: {} us, {refined} samples ({:.2} of the looks' batches)",
                sum.total_micros,
                refined as f64 / most as f64
            );
            assert!(
                refined <= most && refined * 100 >= most * 85,
                "{what}: {refined} refinement samples of at most {most}"
            );
        }
    }
}

/// The host's executor spends a deadline, at one thread and at two, with a
/// scripted clock shared by the threads (a microsecond per look, the
/// preview's end `preview` later): it ends within a round's start-up of the
/// deadline after at least 90 % of it, every pixel has its preview, and the
/// uniform allocation leaves the counts level to within the final round.
#[test]
fn the_host_executor_spends_the_deadline_with_a_scripted_clock() {
    let s = scene("cornell");
    let (w, h) = (40, 24);
    for threads in [1, 2] {
        for adaptive in [true, false] {
            let (deadline, preview) = (3_000u64, 400u64);
            let looks = AtomicU64::new(0);
            let clock = || {
                let n = looks.fetch_add(1, Ordering::Relaxed) + 1;
                n + if n >= 2 { preview } else { 0 }
            };
            let out = render_budget_timed(
                &s,
                &job(w, h, Budget::Deadline(deadline), 1, threads, adaptive),
                &|| {},
                &clock,
            )
            .unwrap();
            let what = format!("threads {threads}, adaptive {adaptive}");
            let used = (out.seconds * 1e6).round() as u64;
            let n = looks.load(Ordering::Relaxed);
            assert!(
                used * 10 >= deadline * 9 && used <= deadline + 2 * tile_count(w, h) as u64,
                "{what}: ended after {used} us ({n} looks)"
            );
            assert!(
                out.counts.iter().all(|&c| c >= 1),
                "{what}: a pixel without its preview"
            );
            // a look carries at most a batch; the adaptive refinement looks
            // every batch, the uniform one after every pass over a tile's
            // pixels (960 pixels in 6 tiles: 160 a look on average)
            let refined = out.samples - u64::from(w * h);
            let most = (deadline - preview) * BATCH;
            let expect = if adaptive {
                most
            } else {
                most * u64::from(w * h) / tile_count(w, h) as u64 / BATCH
            };
            eprintln!(
                "host, {what}: {used} us, {refined} samples ({:.2} of the looks' batches), counts {}..{}",
                refined as f64 / most as f64,
                out.counts.iter().min().unwrap(),
                out.counts.iter().max().unwrap()
            );
            assert!(
                refined <= expect && refined * 100 >= expect * 90,
                "{what}: {refined} refinement samples of at most {expect}"
            );
            assert_eq!(out.stats.paths, out.samples);
            if !adaptive {
                let (lo, hi) = (
                    out.counts.iter().min().unwrap(),
                    out.counts.iter().max().unwrap(),
                );
                assert!(hi - lo <= 3, "{what}: counts from {lo} to {hi}");
            }
        }
    }
}

/// A round the deadline cuts (here the scripted clock slows down tenfold
/// after 1,500 looks, so the round then under way overruns) leaves the
/// tiles at most one pass (a quarter of a round) apart: with uniform
/// allocation the counts stay level to within a quarter of the mean.
#[test]
fn a_round_the_deadline_cuts_leaves_the_tiles_level() {
    let s = scene("cornell");
    let (w, h) = (40, 24);
    let looks = AtomicU64::new(0);
    let clock = || {
        let n = looks.fetch_add(1, Ordering::Relaxed) + 1;
        n + n.saturating_sub(1_500) * 9
    };
    let out = render_budget_timed(
        &s,
        &job(w, h, Budget::Deadline(3_000), 1, 1, false),
        &|| {},
        &clock,
    )
    .unwrap();
    let (lo, hi) = (
        out.counts.iter().min().unwrap(),
        out.counts.iter().max().unwrap(),
    );
    let mean = out.samples as f64 / f64::from(w * h);
    eprintln!("a cut round: counts {lo}..{hi}, mean {mean:.1}");
    assert!(
        f64::from(hi - lo) <= mean / 4.0 + 1.0,
        "counts {lo}..{hi}, mean {mean:.1}"
    );
}

/// A deadline refines a tile in several calls: a later call continues
/// where the earlier stopped. Uniform refinement split over calls gives the
/// counts and sums of one call bit for bit (each pixel's samples are its
/// indices in order); adaptive refinement gives every pixel its second
/// sample once and spends exactly what it is given.
#[test]
fn refinement_split_over_calls_continues_where_it_stopped() {
    let s = scene("spheres");
    let r = Renderer::new(&s, 32, 32).unwrap().seed(5);
    let tile = tile_at(32, 32, 3).unwrap();
    let never = &mut |_: u64| false;
    for adaptive in [false, true] {
        let opts = AdaptiveOptions {
            adaptive,
            ..AdaptiveOptions::default()
        };
        let mut st = Stats::default();
        let mut one = TileAccum::new();
        r.preview_tile(&tile, &mut one, &mut st);
        let mut split = one.clone();
        r.refine_tile(&tile, &mut one, 1000, &opts, never, &mut st);
        let mut spent = 0;
        for part in [100, 7, 300, 593] {
            spent += r.refine_tile(&tile, &mut split, part, &opts, never, &mut st);
        }
        assert_eq!(spent, 1000);
        let counts = |a: &TileAccum| (0..256).map(|i| a.count(i)).collect::<Vec<_>>();
        let total: u32 = counts(&split).iter().sum();
        assert_eq!(total, 256 + 1000);
        if adaptive {
            assert!(counts(&split).iter().all(|&c| c >= 2));
        } else {
            assert_eq!(counts(&split), counts(&one));
            let means = |a: &TileAccum| a.mean_iter().map(|c| [c.x, c.y, c.z]).collect::<Vec<_>>();
            assert_eq!(means(&split), means(&one));
            let (lo, hi) = (
                counts(&split).iter().copied().min(),
                counts(&split).iter().copied().max(),
            );
            assert_eq!((lo, hi), (Some(4), Some(5)));
        }
    }
}

/// `preview_and_refine_tile` (sample 0, and sample 1 when the share has one
/// for every pixel, in one walk, then the rest of the share) leaves the same
/// accumulators, bit for bit, and traces the same paths as `preview_tile`
/// followed by `refine_tile` with the whole share: shares
/// below, at and above one sample per pixel, on a full and a cut tile,
/// adaptive and uniform.
#[test]
fn preview_and_first_pass_in_one_walk_change_no_bit() {
    let s = scene("spheres");
    let r = Renderer::new(&s, 40, 20).unwrap().seed(3);
    let never = &mut |_: u64| false;
    // tile 0: 16x16 (256 pixels); tile 2: 8x16 (128)
    for (i, n) in [(0usize, 256u64), (2, 128)] {
        let tile = tile_at(40, 20, i).unwrap();
        for share in [0, 1, n - 1, n, n + 1, 3 * n + 5] {
            for adaptive in [false, true] {
                let opts = AdaptiveOptions {
                    adaptive,
                    ..AdaptiveOptions::default()
                };
                let (mut st_a, mut st_b) = (Stats::default(), Stats::default());
                let (mut a, mut b) = (TileAccum::new(), TileAccum::new());
                r.preview_tile(&tile, &mut a, &mut st_a);
                let spent_a = r.refine_tile(&tile, &mut a, share, &opts, never, &mut st_a);
                let spent_b = r.preview_and_refine_tile(&tile, &mut b, share, &opts, &mut st_b);
                let what = format!("tile {i}, share {share}, adaptive {adaptive}");
                assert_eq!((spent_a, spent_b), (share, share), "{what}");
                let counts =
                    |t: &TileAccum| (0..n as usize).map(|k| t.count(k)).collect::<Vec<_>>();
                assert_eq!(counts(&a), counts(&b), "{what}");
                let means = |t: &TileAccum| {
                    t.mean_iter()
                        .map(|c| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()])
                        .collect::<Vec<_>>()
                };
                assert_eq!(means(&a), means(&b), "{what}");
                assert_eq!(st_a.paths, st_b.paths, "{what}");
            }
        }
    }
}

#[test]
fn sample_budgets_are_deterministic_across_runs_threads_and_executors() {
    let s = scene("spheres");
    for budget in [Budget::Spp(3), Budget::Paths(9_000)] {
        let a = render_budget(&s, &job(48, 32, budget, 9, 1, true), &|| {}).unwrap();
        let b = render_budget(&s, &job(48, 32, budget, 9, 2, true), &|| {}).unwrap();
        let c = render_budget(&s, &job(48, 32, budget, 9, 3, true), &|| {}).unwrap();
        assert_eq!(pfm(&a.image), pfm(&b.image));
        assert_eq!(pfm(&a.image), pfm(&c.image));
        assert_eq!(a.counts, b.counts);
        // the board's single-core executor (recomputing previews) draws the
        // same Rgb565 pixels
        let r = Renderer::new(&s, 48, 32).unwrap().seed(9);
        let mut acc = TileAccum::new();
        let mut fb = Fb48x32::new();
        let mut clock = LookClock { looks: 0 };
        let sum = core_render_budget(
            &r,
            budget,
            &AdaptiveOptions::default(),
            &mut acc,
            &mut clock,
            &mut fb,
            1.0,
        )
        .unwrap();
        assert_eq!(
            fb.data(),
            a.image.to_rgb565_be(1.0).as_slice(),
            "{budget:?}"
        );
        assert_eq!(sum.samples, a.samples);
        // the board recomputes each refined tile's preview: one more path per
        // pixel of a refined tile
        assert!(sum.stats.paths >= a.stats.paths && sum.stats.paths <= a.stats.paths + 48 * 32);
    }
}

/// The board's coarse preview: every pixel of a block (cut at the tile's
/// edges) shows sample 0 of the block's top-left pixel, bit for bit, and one
/// path is traced per block.
#[test]
fn a_block_preview_shows_each_blocks_first_pixel() {
    let s = scene("cornell");
    let (w, h) = (45u32, 29u32);
    let r = Renderer::new(&s, w, h).unwrap().seed(4);
    for side in [2u32, 3] {
        for i in 0..tile_count(w, h) {
            let tile = tile_at(w, h, i).unwrap();
            let mut acc = TileAccum::new();
            let mut stats = Stats::default();
            r.preview_blocks(&tile, &mut acc, side, &mut stats);
            let mut means = vec![micropt::Color::ZERO; tile.len()];
            acc.means(&mut means);
            let mut blocks = 0u64;
            for (k, m) in means.iter().enumerate() {
                let (cx, cy) = (k as u32 % tile.w, k as u32 / tile.w);
                let (bx, by) = (cx - cx % side, cy - cy % side);
                blocks += u64::from((cx, cy) == (bx, by));
                let want = r.sample(tile.x + bx, tile.y + by, 0, &mut Stats::default());
                let bits = |c: &micropt::Color| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()];
                assert_eq!(bits(m), bits(&want), "side {side}, tile {i}, pixel {k}");
            }
            assert_eq!(stats.paths, blocks, "side {side}, tile {i}");
            assert_eq!(
                blocks,
                u64::from(tile.w.div_ceil(side) * tile.h.div_ceil(side))
            );
        }
    }
}

/// The coarse preview changes what a board shows first, not the image: the
/// board executor draws the same pixels, samples in the image, for a budget
/// that refines every tile, one that refines none (1 spp: every tile is
/// recomputed at full resolution) and one that refines every tile by a
/// little, and traces `pixels − blocks` paths fewer than with a full
/// preview (`blocks` more at 1 spp, where a full preview is the image and
/// is not recomputed).
#[test]
fn the_block_preview_changes_no_pixel_of_the_image() {
    let s = scene("cornell");
    for (w, h) in [(48u32, 32u32), (45, 29)] {
        let pixels = u64::from(w * h);
        let r = Renderer::new(&s, w, h).unwrap().seed(2);
        for (budget, refined) in [
            (Budget::Spp(4), true),
            (Budget::Spp(1), false),
            (Budget::Paths(pixels + 300), true),
        ] {
            let run = |side: u32| {
                let opts = AdaptiveOptions {
                    preview_block: side,
                    ..AdaptiveOptions::default()
                };
                let mut fb = Fb48x32::new();
                let mut clock = LookClock { looks: 0 };
                let sum = core_render_budget(
                    &r,
                    budget,
                    &opts,
                    &mut TileAccum::new(),
                    &mut clock,
                    &mut fb,
                    1.0,
                )
                .unwrap();
                (fb.data().to_vec(), sum)
            };
            let (full, one) = run(1);
            for side in [2u32, 3] {
                let what = format!("{w}x{h} {budget:?} side {side}");
                let (coarse, sum) = run(side);
                assert!(full == coarse, "{what}: the image changed");
                assert_eq!(sum.samples, one.samples, "{what}");
                let blocks: u64 = (0..tile_count(w, h))
                    .map(|i| tile_at(w, h, i).unwrap())
                    .map(|t| u64::from(t.w.div_ceil(side) * t.h.div_ceil(side)))
                    .sum();
                // full: pixels in the preview; coarse: blocks, and then the
                // pixels' recomputed sample 0 where a full preview is kept
                let kept = if refined { 0 } else { pixels };
                assert_eq!(
                    sum.stats.paths + pixels,
                    one.stats.paths + blocks + kept,
                    "{what}"
                );
            }
        }
    }
}

#[test]
fn uniform_spp_budget_equals_the_plain_render_bit_for_bit() {
    let s = scene("cornell");
    let plain = render(
        &s,
        &RenderJob {
            width: 40,
            height: 40,
            spp: 6,
            seed: 4,
            threads: 2,
            options: Options::default(),
        },
        &|| {},
    )
    .unwrap();
    let budget = render_budget(&s, &job(40, 40, Budget::Spp(6), 4, 2, false), &|| {}).unwrap();
    assert_eq!(pfm(&plain.image), pfm(&budget.image));
    assert!(budget.counts.iter().all(|&c| c == 6));
}

/// At the same number of paths, adaptive allocation lowers the MSE against
/// the reference at least 1.5x on cornell and spheres (mean over seeds), and
/// the adaptive image's mean still agrees with the reference (no bias that
/// survives the budget).
#[test]
fn adaptive_beats_uniform_at_equal_paths() {
    for name in ["cornell", "spheres"] {
        let r = Reference::load(name).unwrap();
        let s = load_scene(&r.scene_path()).unwrap();
        let (w, h) = (r.image.width, r.image.height);
        let noise = r.rms_standard_error * r.rms_standard_error;
        let (mut uni, mut ada) = (0.0, 0.0);
        let seeds = 4;
        for seed in 0..seeds {
            let u = render_budget(&s, &job(w, h, Budget::Spp(16), seed, 0, false), &|| {}).unwrap();
            let a = render_budget(&s, &job(w, h, Budget::Spp(16), seed, 0, true), &|| {}).unwrap();
            assert_eq!(u.samples, a.samples);
            uni += compare(&u.image, &r.image).unwrap().mse - noise;
            ada += compare(&a.image, &r.image).unwrap().mse - noise;
        }
        let ratio = uni / ada;
        eprintln!(
            "{name}: uniform MSE {:.3e}, adaptive {:.3e}: {ratio:.2}x",
            uni / seeds as f64,
            ada / seeds as f64
        );
        assert!(ratio >= 1.5, "{name}: adaptive only {ratio:.2}x better");
    }
}

/// Adaptive allocation steered by a pixel's own samples biases its mean
/// low (the module docs of `micropt::budget` explain and measure it); the
/// bias must vanish as the budget grows: at 16x the budget it is at most half
/// as large, and below 1 % of the image mean.
#[test]
fn adaptive_bias_vanishes_as_the_budget_grows() {
    let r = Reference::load("cornell").unwrap();
    let s = load_scene(&r.scene_path()).unwrap();
    let bias = |spp: u32| {
        let mut b = 0.0;
        for seed in 0..2 {
            let out = render_budget(
                &s,
                &job(64, 64, Budget::Spp(spp), 50 + seed, 0, true),
                &|| {},
            )
            .unwrap();
            b += compare(&out.image, &r.image).unwrap().mean_diff / 2.0;
        }
        b
    };
    let (lo, hi) = (bias(16), bias(256));
    let mean = r.mean_rgb.iter().sum::<f64>() / 3.0;
    eprintln!("adaptive bias: {lo:+.2e} at 16 spp, {hi:+.2e} at 256 spp (image mean {mean:.3})");
    assert!(
        hi.abs() <= 0.5 * lo.abs(),
        "bias does not shrink: {lo:e} -> {hi:e}"
    );
    assert!(hi.abs() < 0.01 * mean, "bias {hi:e} at 256 spp");
}

fn skip_with(f: impl Fn(&mut Skip)) -> Options {
    let mut o = Options::default();
    f(&mut o.skip);
    o
}

fn plain_pfm(s: &HostScene, w: u32, h: u32, o: Options) -> Vec<u8> {
    let out = render(
        &s.clone(),
        &RenderJob {
            width: w,
            height: h,
            spp: 4,
            seed: 5,
            threads: 2,
            options: o,
        },
        &|| {},
    )
    .unwrap();
    assert_eq!(out.stats.nonfinite, 0);
    pfm(&out.image)
}

/// Skips that leave the estimator unchanged give the same bits: shadow
/// occluder lists, view culling, the closed-scene background skip, walls
/// tested as slabs, and the
/// horizon test with one light (a light below the horizon has zero
/// contribution either way, and the random numbers are drawn before the
/// test). These images are made with the closed form of a wholly visible
/// light off (`whole_light`: another estimator, which the occluder lists'
/// and the tree's switches also turn off). The specialised integrator draws
/// fewer random numbers, and the closed form leaves the light unsampled
/// where it applies, so both are checked within noise.
#[test]
fn estimator_preserving_skips_change_no_bit() {
    for name in &micropt_host::reference::shipped_scenes() {
        let s = scene(name);
        let (w, h) = (40, 30);
        let all = plain_pfm(&s, w, h, skip_with(|k| k.whole_light = false));
        let cases: [(&str, Options); 6] = [
            (
                "shadow_occluders",
                skip_with(|k| k.shadow_occluders = false),
            ),
            ("view_culling", skip_with(|k| k.view_culling = false)),
            ("closed", skip_with(|k| k.closed = false)),
            ("horizon", skip_with(|k| k.horizon = false)),
            ("slabs", skip_with(|k| k.slabs = false)),
            ("bvh", skip_with(|k| k.bvh = false)),
        ];
        for (what, mut o) in cases {
            o.skip.whole_light = false;
            if what == "horizon" && s.lights().len() > 1 {
                // with several lights the horizon changes the selection
                // probabilities: same expectation, other random choices
                agree_within_noise(&s, name, what, o);
                continue;
            }
            assert!(
                all == plain_pfm(&s, w, h, o),
                "{name}: turning off {what} changed the image"
            );
        }
        if s.lights().len() <= 1 {
            // one light: the general integrator draws a selection number the
            // specialised one does not; the images agree within noise
            agree_within_noise(&s, name, "specialize", skip_with(|k| k.specialize = false));
        }
        agree_within_noise(
            &s,
            name,
            "whole_light",
            skip_with(|k| k.whole_light = false),
        );
    }
}

/// Renders `s` with the default options and with `o` (other seeds, 64 spp)
/// and checks that the image means agree within 4 standard errors. The
/// pixels are the independent samples, not their channels: a pixel's three
/// channels come from the same paths (identical in a grey scene), so the
/// standard error is taken over the pixels' channel means.
fn agree_within_noise(s: &HostScene, name: &str, what: &str, o: Options) {
    let (w, h) = (40, 30);
    let run = |options: Options, seed| {
        render(
            s,
            &RenderJob {
                width: w,
                height: h,
                spp: 64,
                seed,
                threads: 2,
                options,
            },
            &|| {},
        )
        .unwrap()
        .image
    };
    let (a, b) = (run(Options::default(), 5), run(o, 6));
    let d: Vec<f64> = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| {
            let c = |u: f32, v: f32| f64::from(u) - f64::from(v);
            (c(p.x, q.x) + c(p.y, q.y) + c(p.z, q.z)) / 3.0
        })
        .collect();
    let n = d.len() as f64;
    let mean_diff = d.iter().sum::<f64>() / n;
    let sigma = (d.iter().map(|x| x * x).sum::<f64>() / n / n).sqrt();
    assert!(
        mean_diff.abs() < 4.0 * sigma,
        "{name}: {what}: {mean_diff} vs {sigma}"
    );
}

/// Dropping unreachable lights changes which lights are sampled, so only the
/// expectation is unchanged: a light behind a wall adds nothing either way.
#[test]
fn unreachable_light_skip_keeps_the_expectation() {
    let text = "camera 0 1 5 0 1 0 0 1 0 50\nmaterial g diffuse 0.5 0.5 0.5\nmaterial l light 4 4 4\n\
                plane 0 0 0 0 1 0 g\nsphere 0 -3 0 1 l\nsphere 1 3 0 0.5 l\n";
    let s = micropt::parse::parse(text).unwrap();
    assert_eq!(s.lights(), &[1]);
    let run = |o: Options, seed| {
        render(
            &s,
            &RenderJob {
                width: 32,
                height: 24,
                spp: 256,
                seed,
                threads: 2,
                options: o,
            },
            &|| {},
        )
        .unwrap()
        .image
    };
    let a = run(Options::default(), 1);
    let b = run(skip_with(|k| k.unreachable_lights = false), 2);
    let e = compare(&a, &b).unwrap();
    let sigma = (e.mse / (32.0 * 24.0 * 3.0)).sqrt();
    assert!(
        e.mean_diff.abs() < 4.0 * sigma,
        "{} vs {sigma}",
        e.mean_diff
    );
}
