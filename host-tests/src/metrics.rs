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
