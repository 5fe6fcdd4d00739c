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

/// The bias of one region of an image (a row or a square block): the
/// pooled mean over several independent renders against the reference's
/// mean over the same pixels, in units of the combined standard error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegionBias {
    /// Left column of the region.
    pub x: u32,
    /// Top row of the region.
    pub y: u32,
    /// Pooled mean of the renders over the region (channel average).
    pub mean: f64,
    /// The reference's mean over the region.
    pub reference: f64,
    /// `(mean − reference) / √(se_renders² + se_reference²)`.
    pub z: f64,
}

impl RegionBias {
    /// `mean / reference − 1`.
    pub fn relative(&self) -> f64 {
        self.mean / self.reference - 1.0
    }
}

/// Rows and `block`×`block` squares of `renders` (independent renders of
/// one scene, at least two) against `reference`, whose per-pixel standard
/// error is `reference_se`.
///
/// A region's value is the mean over its pixels and the three channels.
/// The renders' standard error of that mean comes from its spread over the
/// renders (Student: with `k` renders, `s / √k`); the reference's from its
/// per-pixel errors, the channel average of a pixel taken as correlated
/// (its error the mean of the three) and pixels as independent. An
/// unbiased renderer gives z-scores distributed as Student's t with
/// `k − 1` degrees of freedom (nearly normal for 16 or more renders).
pub fn region_bias(
    renders: &[Image],
    reference: &Image,
    reference_se: &Image,
    block: u32,
) -> Result<(Vec<RegionBias>, Vec<RegionBias>), String> {
    if renders.len() < 2 {
        return Err("region_bias needs at least two renders".into());
    }
    let (w, h) = (reference.width, reference.height);
    for img in renders.iter().chain([reference_se]) {
        if (img.width, img.height) != (w, h) {
            return Err(format!(
                "size mismatch: {}x{} against {w}x{h}",
                img.width, img.height
            ));
        }
    }
    if block == 0 {
        return Err("block size must be at least 1".into());
    }
    let avg = |c: micropt::Color| (f64::from(c.x) + f64::from(c.y) + f64::from(c.z)) / 3.0;
    let region = |x0: u32, y0: u32, x1: u32, y1: u32| {
        let n = f64::from((x1 - x0) * (y1 - y0));
        let mut means = Vec::with_capacity(renders.len());
        for img in renders {
            let mut s = 0.0;
            for y in y0..y1 {
                for x in x0..x1 {
                    s += avg(img.get(x, y));
                }
            }
            means.push(s / n);
        }
        let k = means.len() as f64;
        let mean = means.iter().sum::<f64>() / k;
        let var_mean = means.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / (k - 1.0) / k;
        let (mut r, mut rv) = (0.0, 0.0);
        for y in y0..y1 {
            for x in x0..x1 {
                r += avg(reference.get(x, y));
                let se = avg(reference_se.get(x, y));
                rv += se * se;
            }
        }
        let (r, rv) = (r / n, rv / (n * n));
        let sd = (var_mean + rv).sqrt();
        let z = if sd > 0.0 { (mean - r) / sd } else { 0.0 };
        RegionBias {
            x: x0,
            y: y0,
            mean,
            reference: r,
            z,
        }
    };
    let rows = (0..h).map(|y| region(0, y, w, y + 1)).collect();
    let mut blocks = Vec::new();
    for by in (0..h).step_by(block as usize) {
        for bx in (0..w).step_by(block as usize) {
            blocks.push(region(bx, by, (bx + block).min(w), (by + block).min(h)));
        }
    }
    Ok((rows, blocks))
}
