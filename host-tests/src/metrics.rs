//! Error metrics of an image against a reference.

use crate::image::Image;

/// Differences between an image and a reference of the same size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    /// Mean squared error over all pixels and channels.
    pub mse: f64,
    /// √MSE.
    pub rmse: f64,
    /// mean((x − r)² / (r² + 0.01)).
    pub rel_mse: f64,
    /// mean(x − r): the signed bias of the image mean.
    pub mean_diff: f64,
}

/// Compares `img` with `reference`; errors if the sizes differ.
pub fn compare(img: &Image, reference: &Image) -> Result<Errors, String> {
    if (img.width, img.height) != (reference.width, reference.height) {
        return Err(format!(
            "size mismatch: {}x{} against {}x{}",
            img.width, img.height, reference.width, reference.height
        ));
    }
    let (mut se, mut rel, mut diff) = (0.0f64, 0.0f64, 0.0f64);
    for (a, r) in img.pixels.iter().zip(&reference.pixels) {
        for (x, y) in [(a.x, r.x), (a.y, r.y), (a.z, r.z)] {
            let d = f64::from(x) - f64::from(y);
            se += d * d;
            rel += d * d / (f64::from(y) * f64::from(y) + 0.01);
            diff += d;
        }
    }
    let n = (img.pixels.len() * 3).max(1) as f64;
    Ok(Errors {
        mse: se / n,
        rmse: (se / n).sqrt(),
        rel_mse: rel / n,
        mean_diff: diff / n,
    })
}

/// The relative difference up to which two noise-free values count as
/// equal: a mean of many samples that are all the same number is that
/// number only up to the rounding of its sum. A Mitsuba reference's
/// background (an f32 sum of 65,536 equal samples) is off the exact value
/// by up to 2.1e-5 relative, micropt's by an f32 ulp (1.2e-7); this is 5
/// times the larger, far below a visible error (1/255 is 3.9e-3).
pub const ROUNDING: f64 = 1e-4;

/// z-scores of one grouping of the pixels (per group and channel: the mean
/// difference over its standard error).
///
/// Where both images are noise-free (every standard error of the group
/// zero), equal values give z = 0 and are not counted, while a difference
/// is certain, not noise: z = ±∞, counted in `count` and in
/// `exact_mismatches`, and `chi2_per_dof` and `max_abs_z` become ∞. Equal
/// means equal up to [`ROUNDING`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZGroup {
    /// Groups × 3 channels that have a non-zero standard error or an exact
    /// mismatch.
    pub count: usize,
    /// Groups × channels whose standard errors are all zero and whose
    /// means differ by more than [`ROUNDING`]: z = ±∞.
    pub exact_mismatches: usize,
    /// Mean of z²: near 1 when the differences are noise (± √(2/count)
    /// for independent values; the three channels of a group share their
    /// paths, so rather ± √(6/count)); ∞ with any exact mismatch.
    pub chi2_per_dof: f64,
    /// Largest |z| (∞ with any exact mismatch).
    pub max_abs_z: f64,
    /// The group (row-major index) and channel of the largest |z|.
    pub worst: (usize, usize),
}

/// How an image with per-pixel standard errors agrees with a reference
/// with its own: whether their difference is pure noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasReport {
    /// Mean squared difference over pixels and channels.
    pub mse: f64,
    /// Mean of `se_image² + se_reference²`: the MSE that noise alone gives.
    pub expected_mse: f64,
    /// z of the whole image's mean difference, per channel.
    pub image_z: [f64; 3],
    /// One group per pixel. Its `exact_mismatches` counts every pixel
    /// channel where both standard errors are zero and the values differ
    /// (by more than [`ROUNDING`]),
    /// which a row or block with noise elsewhere dilutes into a finite z.
    pub pixels: ZGroup,
    /// One group per row.
    pub rows: ZGroup,
    /// One group per `block` × `block` square (partial at the edges).
    pub blocks: ZGroup,
}

/// Groups pixels by `group(x, y)` (< `n`) and returns the z-scores of the
/// group means of `img − reference`, whose variance is the sum of both
/// images' squared standard errors.
fn group_z(
    img: &Image,
    img_se: &Image,
    reference: &Image,
    ref_se: &Image,
    n: usize,
    group: &dyn Fn(u32, u32) -> usize,
) -> (ZGroup, Vec<[f64; 3]>) {
    let mut d = vec![[0.0f64; 3]; n];
    let mut v = vec![[0.0f64; 3]; n];
    // the sum of max(|image|, |reference|): the scale of the rounding
    let mut m = vec![[0.0f64; 3]; n];
    for y in 0..img.height {
        for x in 0..img.width {
            let g = group(x, y);
            let (a, sa, r, sr) = (
                img.get(x, y),
                img_se.get(x, y),
                reference.get(x, y),
                ref_se.get(x, y),
            );
            for (c, (a, sa, r, sr)) in [
                (a.x, sa.x, r.x, sr.x),
                (a.y, sa.y, r.y, sr.y),
                (a.z, sa.z, r.z, sr.z),
            ]
            .into_iter()
            .enumerate()
            {
                d[g][c] += f64::from(a) - f64::from(r);
                v[g][c] += f64::from(sa).powi(2) + f64::from(sr).powi(2);
                m[g][c] += f64::from(a.abs().max(r.abs()));
            }
        }
    }
    let mut z = vec![[0.0f64; 3]; n];
    let mut out = ZGroup {
        count: 0,
        exact_mismatches: 0,
        chi2_per_dof: 0.0,
        max_abs_z: 0.0,
        worst: (0, 0),
    };
    for g in 0..n {
        for c in 0..3 {
            let zz = if v[g][c] > 0.0 {
                d[g][c] / v[g][c].sqrt()
            } else if d[g][c].abs() > ROUNDING * m[g][c] || d[g][c].is_nan() {
                out.exact_mismatches += 1;
                f64::INFINITY.copysign(d[g][c])
            } else {
                continue;
            };
            z[g][c] = zz;
            out.count += 1;
            out.chi2_per_dof += zz * zz;
            if zz.abs() > out.max_abs_z {
                out.max_abs_z = zz.abs();
                out.worst = (g, c);
            }
        }
    }
    out.chi2_per_dof /= out.count.max(1) as f64;
    (out, z)
}

/// Checks whether `img` (with per-pixel standard errors `img_se`) and
/// `reference` (with `ref_se`) differ by more than their noise: the
/// z-scores of the differences of pixel, row, block and image means.
pub fn bias_z(
    img: &Image,
    img_se: &Image,
    reference: &Image,
    ref_se: &Image,
    block: u32,
) -> Result<BiasReport, String> {
    let size = (img.width, img.height);
    for (what, i) in [
        ("standard-error map", img_se),
        ("reference", reference),
        ("reference standard-error map", ref_se),
    ] {
        if (i.width, i.height) != size {
            return Err(format!(
                "size mismatch: the {what} is {}x{}, the image {}x{}",
                i.width, i.height, size.0, size.1
            ));
        }
    }
    if block == 0 {
        return Err("the block size must be at least 1".into());
    }
    let e = compare(img, reference)?;
    let (w, h) = size;
    let bw = w.div_ceil(block);
    let zg =
        |n: usize, f: &dyn Fn(u32, u32) -> usize| group_z(img, img_se, reference, ref_se, n, f);
    let (pixels, _) = zg((w * h) as usize, &|x, y| (y * w + x) as usize);
    let (rows, _) = zg(h as usize, &|_, y| y as usize);
    let (blocks, _) = zg((bw * h.div_ceil(block)) as usize, &|x, y| {
        ((y / block) * bw + x / block) as usize
    });
    let (_, whole) = zg(1, &|_, _| 0);
    let mut expected = 0.0;
    for (a, b) in img_se.pixels.iter().zip(&ref_se.pixels) {
        for (a, b) in [(a.x, b.x), (a.y, b.y), (a.z, b.z)] {
            expected += f64::from(a).powi(2) + f64::from(b).powi(2);
        }
    }
    Ok(BiasReport {
        mse: e.mse,
        expected_mse: expected / (img.pixels.len() * 3).max(1) as f64,
        image_z: whole[0],
        pixels,
        rows,
        blocks,
    })
}

/// The mean of independent renders of one scene (at least two) and the
/// standard error of that mean, per pixel and channel, from the renders'
/// spread (`s / √k` for `k` renders): what [`bias_z`] takes for an image
/// whose renderer writes no standard-error map of its own.
pub fn pooled(renders: &[Image]) -> Result<(Image, Image), String> {
    let Some(first) = renders.first() else {
        return Err("pooling needs at least two renders".into());
    };
    if renders.len() < 2 {
        return Err("pooling needs at least two renders".into());
    }
    let (w, h) = (first.width, first.height);
    if let Some(i) = renders.iter().find(|i| (i.width, i.height) != (w, h)) {
        return Err(format!(
            "size mismatch: {}x{} against {w}x{h}",
            i.width, i.height
        ));
    }
    let k = renders.len() as f64;
    let (mut mean, mut se) = (Image::new(w, h), Image::new(w, h));
    for (p, (m, e)) in mean.pixels.iter_mut().zip(se.pixels.iter_mut()).enumerate() {
        let ch = |c: usize| {
            let v: Vec<f64> = renders
                .iter()
                .map(|i| {
                    let q = i.pixels[p];
                    f64::from([q.x, q.y, q.z][c])
                })
                .collect();
            let mu = v.iter().sum::<f64>() / k;
            let var = v.iter().map(|x| (x - mu) * (x - mu)).sum::<f64>() / (k - 1.0);
            (mu as f32, (var / k).sqrt() as f32)
        };
        let (x, y, z) = (ch(0), ch(1), ch(2));
        *m = micropt::Color::new(x.0, y.0, z.0);
        *e = micropt::Color::new(x.1, y.1, z.1);
    }
    Ok((mean, se))
}

#[cfg(test)]
mod tests {
    use super::*;
    use micropt::Color;

    fn flat(w: u32, h: u32, v: f32) -> Image {
        let mut i = Image::new(w, h);
        i.pixels.fill(Color::new(v, v, v));
        i
    }

    #[test]
    fn bias_z_scales_as_the_square_root_of_the_group_size() {
        // a constant offset d with per-pixel standard errors s (image and
        // reference each): the mean of n pixels has standard error
        // s·sqrt(2/n), so z = d·sqrt(n) / (s·sqrt(2))
        let (img, reference, se) = (flat(16, 16, 0.1), flat(16, 16, 0.0), flat(16, 16, 0.1));
        let z = bias_z(&img, &se, &reference, &se, 8).unwrap();
        let want = |n: f64| 0.1 * n.sqrt() / (0.1 * 2f64.sqrt());
        let close = |a: f64, b: f64| (a - b).abs() < 1e-5 * b;
        assert!(close(z.pixels.max_abs_z, want(1.0)), "{z:?}");
        assert!(close(z.rows.max_abs_z, want(16.0)), "{z:?}");
        assert!(close(z.blocks.max_abs_z, want(64.0)), "{z:?}");
        assert!(close(z.image_z[1], want(256.0)), "{z:?}");
        assert_eq!(
            (z.pixels.count, z.rows.count, z.blocks.count),
            (768, 48, 12)
        );
        assert!(close(z.rows.chi2_per_dof, want(16.0).powi(2)), "{z:?}");
        assert!(close(z.mse, 0.01) && close(z.expected_mse, 0.02), "{z:?}");
        // a 10x12 image in 8x8 blocks: 2x2 blocks, the edge ones partial
        let z = bias_z(
            &flat(10, 12, 0.1),
            &flat(10, 12, 0.1),
            &flat(10, 12, 0.0),
            &flat(10, 12, 0.1),
            8,
        )
        .unwrap();
        assert_eq!(z.blocks.count, 12);
        assert!(close(z.blocks.max_abs_z, want(64.0)), "{z:?}");
        assert!(bias_z(&img, &se, &flat(8, 8, 0.0), &se, 8).is_err());
        assert!(bias_z(&img, &se, &reference, &se, 0).is_err());
    }

    #[test]
    fn a_difference_without_noise_is_an_exact_mismatch() {
        // one pixel (1, 1, 1) against (0, 0, 0), both standard errors 0:
        // no noise can explain the difference, so z is infinite
        let (one, zero) = (flat(1, 1, 1.0), flat(1, 1, 0.0));
        let z = bias_z(&one, &zero, &zero, &zero, 8).unwrap();
        for g in [z.pixels, z.rows, z.blocks] {
            assert_eq!((g.count, g.exact_mismatches), (3, 3), "{z:?}");
            assert_eq!(g.max_abs_z, f64::INFINITY, "{z:?}");
            assert_eq!(g.chi2_per_dof, f64::INFINITY, "{z:?}");
        }
        assert_eq!(z.image_z, [f64::INFINITY; 3]);
        // the sign is the difference's
        let z = bias_z(&zero, &zero, &one, &zero, 8).unwrap();
        assert_eq!(z.image_z, [f64::NEG_INFINITY; 3]);
        // identical noise-free pixels agree exactly: z = 0, not counted
        let z = bias_z(&one, &zero, &one, &zero, 8).unwrap();
        assert_eq!((z.pixels.count, z.pixels.exact_mismatches), (0, 0));
        assert_eq!((z.pixels.max_abs_z, z.image_z), (0.0, [0.0; 3]));
        // so do ones that differ by the rounding of a sum of equal samples
        // (5e-5 relative), not ones that differ by 2e-4
        let z = bias_z(&flat(1, 1, 1.00005), &zero, &one, &zero, 8).unwrap();
        assert_eq!((z.pixels.exact_mismatches, z.pixels.max_abs_z), (0, 0.0));
        let z = bias_z(&flat(1, 1, 1.0002), &zero, &one, &zero, 8).unwrap();
        assert_eq!(z.pixels.exact_mismatches, 3);
        // one noise-free pixel off by 1e-3 among noisy ones: rows, blocks
        // and the image mean dilute it into a small finite z, the pixel
        // group names it
        let (img, mut reference, mut se) =
            (flat(16, 16, 0.5), flat(16, 16, 0.5), flat(16, 16, 0.1));
        reference.pixels[17] = Color::new(0.5, 0.501, 0.5);
        se.pixels[17] = Color::new(0.1, 0.0, 0.1);
        let z = bias_z(&img, &se, &reference, &se, 8).unwrap();
        assert_eq!(z.pixels.exact_mismatches, 1, "{z:?}");
        assert_eq!(
            (z.pixels.worst, z.pixels.max_abs_z),
            ((17, 1), f64::INFINITY)
        );
        assert_eq!(z.rows.exact_mismatches + z.blocks.exact_mismatches, 0);
        assert!(
            z.rows.max_abs_z < 0.01 && z.image_z[1].abs() < 0.01,
            "{z:?}"
        );
    }
}
