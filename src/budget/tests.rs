//! Unit tests of the budget: the exact splits, the tile shares, the
//! preview and refinement, the pace of a deadline.

use super::tile::split;
use super::*;

#[test]
fn cumulative_split_is_exact_and_proportional() {
    let w = [1.0f32, 3.0, 0.0, 4.0];
    let mut got = [0u64; 4];
    split(4, 1000, 0.0, |i| w[i], |i, s| got[i] = s);
    assert_eq!(got.iter().sum::<u64>(), 1000);
    assert_eq!(got, [125, 375, 0, 500]);
    // the floor lifts the zero weight to a quarter of the mean (2)
    split(4, 1000, 0.25, |i| w[i], |i, s| got[i] = s);
    assert_eq!(got.iter().sum::<u64>(), 1000);
    assert!(got[2] > 0 && got[2] < got[0]);
    // all zero: even
    split(4, 10, 0.25, |_| 0.0, |i, s| got[i] = s);
    assert_eq!(got.iter().sum::<u64>(), 10);
    assert!(got.iter().all(|&s| s == 2 || s == 3));
    // NaN and negative weights do not poison the split
    split(
        2,
        7,
        0.25,
        |i| if i == 0 { f32::NAN } else { -1.0 },
        |i, s| got[i] = s,
    );
    assert_eq!(got[0] + got[1], 7);
}

/// The guarantee of `split` (its docs): with weights floored at `f`
/// times the mean, every share is at least `total · f / (n + (n − 1) f)`
/// less one sample of rounding (and the f32 rounding of the cumulative
/// sums, a few ulps of `total`), and one item holding all the weight
/// brings the others down to that bound: a third of the even share for
/// `f = ½`, not a half.
#[test]
fn split_floor_guarantees_f_over_1_plus_f_of_the_even_share() {
    // a small deterministic generator for weights (LCG, top bits)
    let mut state = 0x2545_f491_u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    };
    let mut shares = [0u64; TILE_PIXELS];
    for &n in &[1usize, 2, 3, 7, 16, 100, 255, 256] {
        for &f in &[0.5f32, 0.25, 0.1, 0.9] {
            for &total in &[10u64, 999, 256 * 64, 256 * 1000] {
                let bound = total as f32 * f / (n as f32 + (n as f32 - 1.0) * f);
                let slack = 1.0 + 4.0 * total as f32 / (1u32 << 24) as f32;
                // weights: one heavy item, random ones, sparse random ones
                let mut cases: [[f32; TILE_PIXELS]; 3] = [[0.0; TILE_PIXELS]; 3];
                cases[0][n / 2] = 1.0;
                let [_, random, sparse] = &mut cases;
                for (r, s) in random.iter_mut().zip(sparse.iter_mut()).take(n) {
                    *r = next();
                    *s = if next() < 0.1 { 100.0 * next() } else { 0.0 };
                }
                for (k, w) in cases.iter().enumerate() {
                    split(n, total, f, |i| w[i], |i, s| shares[i] = s);
                    assert_eq!(shares[..n].iter().sum::<u64>(), total);
                    let min = *shares[..n].iter().min().unwrap();
                    assert!(
                        min as f32 + slack >= bound,
                        "n {n}, f {f}, total {total}, case {k}: min share {min} < bound {bound}"
                    );
                    if k == 0 && n > 1 {
                        // attained: the others get the bound, not f of the even share
                        assert!(
                            min as f32 <= bound + slack,
                            "n {n}, f {f}, total {total}: min share {min} above bound {bound}"
                        );
                    }
                }
            }
        }
    }
    // the default floor at a full tile: a third of the even share (64),
    // not a half
    let mut w = [0.0f32; TILE_PIXELS];
    w[0] = 1.0;
    split(
        TILE_PIXELS,
        256 * 64,
        AdaptiveOptions::default().floor,
        |i| w[i],
        |i, s| shares[i] = s,
    );
    let min = *shares.iter().min().unwrap();
    assert!((21..=22).contains(&min), "{min}");
}

#[test]
fn tiles_get_shares_by_pixel_count() {
    let mut got = [0u64; 4];
    // 20x20: tiles of 256, 64, 64, 16 pixels
    allocate_tiles(20, 20, 400, |i, s| got[i] = s);
    assert_eq!(got, [256, 64, 64, 16]);
}

/// `tile_share` is `allocate_tiles`' share of each tile, bit for bit:
/// small images with cut edge tiles, and the largest images the scene
/// format allows (2²⁵ pixels, where f32 sums of sizes stop being exact
/// for odd values) with an odd corner tile.
#[test]
fn tile_share_equals_the_walk_over_the_tiles() {
    let sizes = [
        (1, 1),
        (15, 17),
        (16, 16),
        (20, 20),
        (64, 64),
        (100, 37),
        (16_384, 2_048),
        (16_383, 2_048),
        (2_047, 16_383),
    ];
    for (w, h) in sizes {
        let pixels = u64::from(w) * u64::from(h);
        for total in [0, 1, 7, pixels - 1, pixels * 15, pixels * 15 + 13] {
            let (mut tiles, mut sum) = (0usize, 0u64);
            allocate_tiles(w, h, total, |i, s| {
                assert_eq!(tile_share(w, h, total, i), s, "{w}x{h}, {total}: tile {i}");
                tiles += 1;
                sum += s;
            });
            assert_eq!((tiles, sum), (tile_count(w, h), total), "{w}x{h}, {total}");
            assert_eq!(tile_share(w, h, total, tiles), 0);
        }
    }
}

#[test]
fn budgets_in_samples() {
    assert_eq!(budget_samples(&Budget::Spp(4), 10, 10), Some(400));
    assert_eq!(budget_samples(&Budget::Paths(50), 10, 10), Some(100));
    assert_eq!(budget_samples(&Budget::Paths(500), 10, 10), Some(500));
    assert_eq!(budget_samples(&Budget::Deadline(5), 10, 10), None);
}

#[test]
fn pace_sizes_rounds_from_the_measured_rate_and_the_time_left() {
    // 1000 paths in 100 us (10 per us); deadline at 1100: at 100, 1000 us
    // left afford 10,000 paths, a quarter of the pixels 2,500
    let mut p = Pace::new(1100, 1000, 100);
    assert_eq!(p.afford(100, 1, 1), 10_000);
    assert_eq!(p.afford(100, 1, 4), 2_500);
    // the first round, from the first guess, is at most 1 per pixel
    assert_eq!(p.round(100, 1000), 1_000);
    assert_eq!(p.round(100, 20_000), 10_000);
    // a measurement replaces the rate (30 per us, 500 us left)
    p.measured(3000, 100);
    assert_eq!(p.afford(600, 1, 1), 15_000);
    // a round is half of it while that leaves 2 samples per pixel
    assert_eq!(p.round(600, 1000), 7_500);
    assert_eq!(p.round(600, 7_500), 7_500);
    // else all of it
    assert_eq!(p.round(600, 7_501), 15_000);
    // at or past the deadline nothing is affordable
    assert_eq!(p.afford(1100, 1, 1), 0);
    assert_eq!(p.round(5000, 1), 0);
    // no time measured yet counts as one microsecond
    assert_eq!(Pace::new(10, 5, 0).afford(0, 1, 1), 50);
}

/// The round policy with a scripted clock: time advances by a scripted
/// cost per sample (a preview 4x dearer per sample than the refinement,
/// as the host measures, and a refinement whose cost per sample changes
/// by 2x half-way). Rounds re-read the clock, so the render uses at least
/// 90 % of the deadline and ends within one round of it.
#[test]
fn rounds_spend_the_deadline_with_a_scripted_clock() {
    for (deadline, pixels) in [(500_000u64, 4096u64), (2_000_000, 4096), (20_000, 64)] {
        // the preview: 4 us per sample
        let preview = 4 * pixels;
        let mut pace = Pace::new(deadline, pixels, preview);
        let (mut now, mut spent, mut rounds) = (preview, 0u64, 0);
        loop {
            let round = pace.round(now, pixels);
            if round == 0 {
                break;
            }
            rounds += 1;
            // in batches, the stop asked before each: 1 us per sample in
            // the first half of the time, 2 us after
            let mut done = 0;
            while done < round && now < deadline {
                let k = (round - done).min(BATCH);
                now += k * if now < deadline / 2 { 1 } else { 2 };
                done += k;
            }
            spent += done;
            pace.measured(spent, now - preview);
        }
        assert!(
            now * 10 >= deadline * 9 && now <= deadline + 2 * BATCH,
            "deadline {deadline}: ended at {now} after {rounds} rounds"
        );
        assert!(rounds <= 40, "{rounds} rounds");
        // and it traced what that time affords at the scripted costs (up
        // to a batch more at the change of cost and at the deadline,
        // which both fall inside a batch)
        let ideal = (deadline / 2 - preview) + deadline / 2 / 2;
        assert!(
            spent * 10 >= ideal * 9 && spent <= ideal + 2 * BATCH,
            "deadline {deadline}: {spent} samples of {ideal} after {rounds} rounds"
        );
    }
}
