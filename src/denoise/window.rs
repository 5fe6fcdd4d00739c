//! The choice's sums of SURE along a row: each pixel's window of
//! `2 reach + 1` pixels, clipped to the row, at three additions a pixel
//! whatever its width.

use super::{Column, WIDTHS};

/// Each pixel's SURE summed over the pixels within `reach` along the row
/// (those inside the image), into ring slot `slot` of the row's sums: van
/// Herk and Gil-Werman's running window. The row is cut into blocks of the
/// window's length; a window then spans at most two blocks, and its sum
/// is the first one's sum from the window's start (a suffix) plus the
/// second one's up to its end (a prefix). Three additions a pixel whatever
/// the window's width, and no subtraction (a running sum that subtracted
/// what leaves would keep the rounding of a firefly's SURE in the sums of
/// the quiet pixels after it). The prefixes go into the slot, the
/// suffixes over the pixels' own SURE (read by nothing else).
#[inline(always)]
pub(super) fn row_window_sums(columns: &mut [Column], w: usize, slot: usize, reach: usize) {
    type Sums = [f32; WIDTHS.len() + 1];
    let block = 2 * reach + 1;
    let columns = columns.get_mut(..w).unwrap_or(&mut []);
    let add = |a: Sums, b: &Sums| -> Sums { core::array::from_fn(|k| a[k] + b[k]) };
    for chunk in columns.chunks_mut(block) {
        let mut run = [0.0f32; WIDTHS.len() + 1];
        for c in chunk.iter_mut() {
            run = add(run, &c.sure);
            if let Some(r) = c.row_sure.get_mut(slot) {
                *r = run;
            }
        }
        let mut run = [0.0f32; WIDTHS.len() + 1];
        for c in chunk.iter_mut().rev() {
            run = add(run, &c.sure);
            c.sure = run;
        }
    }
    // each window [a, b], clipped to the row: where a starts a block, the
    // prefix to b (one block); else where a is in the row's last block,
    // the suffix from a (b ends the row); else the suffix from a and the
    // prefix to b in the next block. `phase` is a's place in its block.
    // Slot x is written after every prefix it is read for (b ≥ x)
    let last_start = (w.saturating_sub(1) / block) * block;
    let mut phase = 0;
    for x in 0..w {
        let a = x.saturating_sub(reach);
        let b = (x + reach).min(w - 1);
        if x > reach {
            phase += 1;
            if phase == block {
                phase = 0;
            }
        }
        let prefix = || {
            columns
                .get(b)
                .and_then(|c| c.row_sure.get(slot))
                .copied()
                .unwrap_or_default()
        };
        let suffix = || columns.get(a).map(|c| c.sure).unwrap_or_default();
        let total = if phase == 0 {
            prefix()
        } else if a >= last_start {
            suffix()
        } else {
            add(prefix(), &suffix())
        };
        if let Some(r) = columns.get_mut(x).and_then(|c| c.row_sure.get_mut(slot)) {
            *r = total;
        }
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // the test indexes its rows by pixel
mod tests {
    use super::super::{CHOICE_REACH, CHOICE_REACH_FEW};
    use super::*;
    use crate::math;
    use rand_core::{Rng, SeedableRng};
    use rand_xorshift::XorShiftRng;

    #[test]
    fn the_running_window_sums_what_the_window_holds() {
        // the choice's sums along a row (three additions a pixel, blocks of
        // the window's length) against the plain sum over each window,
        // clipped to the row, for both reaches and every row width up to
        // four blocks, and values spanning twelve orders of magnitude (a
        // firefly's SURE beside quiet pixels')
        const N: usize = 4 * (2 * CHOICE_REACH_FEW + 1) + 3;
        let mut rng = XorShiftRng::seed_from_u64(3);
        let mut columns = [Column::EMPTY; N];
        let slot = 2;
        for reach in [CHOICE_REACH, CHOICE_REACH_FEW] {
            for w in 1..=N {
                let mut sure = [[0.0f32; WIDTHS.len() + 1]; N];
                for (c, s) in columns.iter_mut().zip(sure.iter_mut()).take(w) {
                    for v in s.iter_mut() {
                        let e = (rng.next_u32() % 13) as f32 - 6.0;
                        *v = (rng.next_u32() % 1000) as f32 * math::powf(10.0, e) * 1e-3;
                    }
                    c.sure = *s;
                }
                row_window_sums(&mut columns, w, slot, reach);
                for x in 0..w {
                    let (a, b) = (x.saturating_sub(reach), (x + reach).min(w - 1));
                    for k in 0..WIDTHS.len() + 1 {
                        let want: f32 = sure[a..=b].iter().map(|s| s[k]).sum();
                        let got = columns[x].row_sure[slot][k];
                        assert!(
                            (got - want).abs() <= 1e-5 * want.abs(),
                            "reach {reach}, width {w}, x {x}, k {k}: {got} against {want}"
                        );
                    }
                }
            }
        }
    }
}
