//! The runs of `micropt bench` aggregated over seeds (medians), and the
//! error laws fitted to them: the slope of log MSE against log samples,
//! and variance plus a floor (a floor is bias).

use super::Run;

/// The runs of one (scene, variant, spp), aggregated over seeds.
#[derive(Clone, Debug)]
pub struct Point {
    /// Scene name.
    pub scene: String,
    /// Variant name.
    pub variant: String,
    /// Threads used.
    pub threads: usize,
    /// Samples per pixel.
    pub spp: u32,
    /// Number of seeds.
    pub seeds: usize,
    /// Median wall seconds.
    pub seconds: f64,
    /// Median CPU seconds.
    pub cpu_seconds: f64,
    /// Rays of one render.
    pub rays: u64,
    /// Mean measured MSE over seeds.
    pub mse: f64,
    /// Mean MSE less the reference noise.
    pub mse_corrected: f64,
    /// Mean relMSE.
    pub rel_mse: f64,
    /// Mean of the signed mean difference.
    pub mean_diff: f64,
    /// 1 / (corrected MSE × median seconds); NaN where the corrected MSE is
    /// not positive (below the reference's noise).
    pub efficiency: f64,
}

impl Point {
    /// Rays per wall-clock second.
    pub fn rays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-12)
    }
}

/// Least-squares fits of MSE against spp for one (scene, variant).
#[derive(Clone, Debug)]
pub struct Fit {
    /// Scene name.
    pub scene: String,
    /// Variant name.
    pub variant: String,
    /// Slope of ln(corrected MSE) against ln(spp) over all levels with a
    /// positive corrected MSE (−1 for an unbiased estimator).
    pub slope: f64,
    /// The same over the lower half of those levels.
    pub slope_low: f64,
    /// The same over the upper half: a flattening shows here first.
    pub slope_high: f64,
    /// `c` of the fit MSE = a/spp + c (weighted by 1/MSE²): a floor that does
    /// not fall with spp, i.e. squared bias plus any reference error not
    /// accounted for.
    pub floor: f64,
    /// `floor / a`: the floor as a fraction of the 1-spp variance term.
    pub floor_ratio: f64,
    /// Levels used.
    pub levels: usize,
    /// Reading of the fit.
    pub verdict: String,
}

pub(crate) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Aggregates runs over seeds, keeping the order of first appearance.
pub fn aggregate(runs: &[Run]) -> Vec<Point> {
    let mut keys: Vec<(String, String, u32)> = Vec::new();
    for r in runs {
        let k = (r.scene.clone(), r.variant.clone(), r.spp);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.into_iter()
        .map(|(scene, variant, spp)| {
            let g: Vec<&Run> = runs
                .iter()
                .filter(|r| r.scene == scene && r.variant == variant && r.spp == spp)
                .collect();
            let n = g.len() as f64;
            let mean = |f: &dyn Fn(&Run) -> f64| g.iter().map(|r| f(r)).sum::<f64>() / n;
            let mse = mean(&|r| r.mse);
            let mse_corrected = mean(&|r| r.mse_corrected());
            let seconds = median(&mut g.iter().map(|r| r.seconds).collect::<Vec<_>>());
            let cpu_seconds = median(&mut g.iter().map(|r| r.cpu_seconds).collect::<Vec<_>>());
            Point {
                threads: g.first().map_or(1, |r| r.threads),
                rays: g.first().map_or(0, |r| r.rays),
                seeds: g.len(),
                seconds,
                cpu_seconds,
                mse,
                mse_corrected,
                rel_mse: mean(&|r| r.rel_mse),
                mean_diff: mean(&|r| r.mean_diff),
                efficiency: if mse_corrected > 0.0 {
                    1.0 / (mse_corrected * seconds)
                } else {
                    f64::NAN
                },
                scene,
                variant,
                spp,
            }
        })
        .collect()
}

/// Ordinary least-squares slope of `y` against `x`.
pub fn ols_slope(xy: &[(f64, f64)]) -> f64 {
    let n = xy.len() as f64;
    if xy.len() < 2 {
        return f64::NAN;
    }
    let mx = xy.iter().map(|p| p.0).sum::<f64>() / n;
    let my = xy.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = xy.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = xy.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    sxy / sxx
}

/// Fits `mse = a / spp + c` with weights 1/mse² (relative residuals);
/// returns `(a, c)`.
pub fn fit_variance_plus_floor(pts: &[(f64, f64)]) -> (f64, f64) {
    // minimise sum w (a u + c - m)^2 with u = 1/spp, w = 1/m^2
    let (mut suu, mut su, mut s1, mut sum, mut sm) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(spp, m) in pts {
        let w = 1.0 / (m * m);
        let u = 1.0 / spp;
        suu += w * u * u;
        su += w * u;
        s1 += w;
        sum += w * u * m;
        sm += w * m;
    }
    let det = suu * s1 - su * su;
    if pts.len() < 2 || det == 0.0 {
        return (f64::NAN, f64::NAN);
    }
    ((sum * s1 - su * sm) / det, (suu * sm - su * sum) / det)
}

/// Slope fits for every (scene, variant) of `points`.
pub fn fits(points: &[Point]) -> Vec<Fit> {
    let mut keys: Vec<(String, String)> = Vec::new();
    for p in points {
        let k = (p.scene.clone(), p.variant.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.into_iter()
        .map(|(scene, variant)| {
            let mut pts: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.scene == scene && p.variant == variant && p.mse_corrected > 0.0)
                .map(|p| (f64::from(p.spp), p.mse_corrected))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            let logs: Vec<(f64, f64)> = pts.iter().map(|&(s, m)| (s.ln(), m.ln())).collect();
            let half = logs.len().div_ceil(2);
            let slope = ols_slope(&logs);
            let slope_low = ols_slope(&logs[..half.max(2).min(logs.len())]);
            let slope_high = ols_slope(&logs[logs.len().saturating_sub(half.max(2))..]);
            let (a, c) = fit_variance_plus_floor(&pts);
            let verdict = verdict(slope, slope_low, slope_high, logs.len());
            Fit {
                scene,
                variant,
                slope,
                slope_low,
                slope_high,
                floor: c,
                floor_ratio: c / a,
                levels: logs.len(),
                verdict,
            }
        })
        .collect()
}

pub(crate) fn verdict(slope: f64, low: f64, high: f64, n: usize) -> String {
    if n < 3 || !slope.is_finite() {
        return "too few levels above the reference noise".into();
    }
    if (-1.1..=-0.9).contains(&slope) {
        return if high > -0.8 {
            "1/N overall, but the top levels flatten: bias near the floor".into()
        } else {
            "1/N (unbiased)".into()
        };
    }
    if slope > -0.9 {
        if high > low + 0.15 {
            "flattens at high spp: bias (or reference error) of about the floor".into()
        } else {
            "slower than 1/N throughout".into()
        }
    } else if low < -1.1 && high >= -1.1 {
        "faster than 1/N at low spp (stratification), 1/N at high spp".into()
    } else {
        "faster than 1/N (stratification)".into()
    }
}
