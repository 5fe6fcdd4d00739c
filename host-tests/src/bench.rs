//! Run time against error: `micropt bench`.
//!
//! For every scene that has a reference image, every variant of the
//! integrator is rendered at a geometric series of sample counts with several
//! seeds; each render is timed and compared with the reference. The results
//! are written as CSV, a markdown table and log-log plots of MSE against
//! seconds (one line per variant, one plot per scene).
//!
//! The reference is itself a Monte Carlo estimate: with an independent
//! reference `r = r* + e_r`, `E[(x − r)²] = E[(x − r*)²] + E[e_r²]`. Its
//! `.json` gives `rms_standard_error`, the root mean square of the per-pixel
//! standard errors, so `rms_standard_error²` is the expected MSE that the
//! reference alone contributes. It is subtracted from every measured MSE
//! (column `mse_corrected`), and efficiency and slopes use the corrected
//! value. relMSE is reported as measured (the per-pixel standard errors it
//! would need are not stored).

use crate::image::Image;
use crate::metrics::compare;
use crate::render::{BudgetJob, RenderJob, load_scene, render, render_budget, resolve_threads};
use crate::smallpt::{self, SmallptJob, SmallptOptions, SmallptScene};
use micropt::{AdaptiveOptions, Budget, Options, Scene, Strategy};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One configuration of the integrator and the executor: a row of the
/// results.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    /// Short name used in files and legends.
    pub name: String,
    /// What it changes against the baseline.
    pub description: String,
    /// Integrator options.
    pub options: Options,
    /// Worker threads (0: all cores).
    pub threads: usize,
    /// Spread the budget where the estimated error is largest (the CLI's
    /// default allocation: biased, consistent) instead of uniformly.
    pub adaptive: bool,
}

/// The variants compared: the baseline (`mis`: MIS, stratified, exact math,
/// one thread) and one change of it each.
pub fn standard_variants() -> Vec<Variant> {
    let base = Options::default();
    let v = |name: &str, description: &str, options: Options, threads: usize| Variant {
        name: name.into(),
        description: description.into(),
        options,
        threads,
        adaptive: false,
    };
    vec![
        v(
            "mis",
            "baseline: MIS (power heuristic), stratified Sobol, exact math, 1 thread",
            base,
            1,
        ),
        v(
            "bsdf-only",
            "BSDF sampling only (no light sampling)",
            Options {
                strategy: Strategy::BsdfOnly,
                ..base
            },
            1,
        ),
        v(
            "light-only",
            "light sampling only (emitters hit after a diffuse bounce ignored)",
            Options {
                strategy: Strategy::LightOnly,
                ..base
            },
            1,
        ),
        v(
            "independent",
            "independent random numbers instead of stratified Sobol",
            Options {
                stratified: false,
                ..base
            },
            1,
        ),
        v(
            "fast-math",
            "micromath's approximate sin/cos in direction sampling",
            Options {
                fast_math: true,
                ..base
            },
            1,
        ),
        v("all-cores", "baseline on all cores", base, 0),
        Variant {
            adaptive: true,
            ..v(
                "adaptive",
                "the CLI's default allocation: samples where the estimated error is largest \
                 (biased, consistent), 1 thread",
                base,
                1,
            )
        },
    ]
}

/// A scene with its reference.
#[derive(Clone, Debug)]
pub struct BenchScene {
    /// Scene name (the file stem).
    pub name: String,
    /// The scene file.
    pub scene_path: PathBuf,
    /// The reference PFM.
    pub reference_path: PathBuf,
    /// `rms_standard_error` of the reference (0 if its .json lacks it).
    pub reference_rms_se: f64,
}

/// Finds every `DATA/NAME.pfm` that has a `SCENES/NAME.scene`, sorted by name.
pub fn discover_scenes(scenes_dir: &Path, data_dir: &Path) -> Result<Vec<BenchScene>, String> {
    let rd = std::fs::read_dir(data_dir)
        .map_err(|e| format!("cannot list references in {}: {e}", data_dir.display()))?;
    let mut out = Vec::new();
    for entry in rd {
        let path = entry
            .map_err(|e| format!("cannot list {}: {e}", data_dir.display()))?
            .path();
        if path.extension().and_then(|e| e.to_str()) != Some("pfm") {
            continue;
        }
        let Some(name) = path.file_stem().and_then(|s| s.to_str()) else {
            continue;
        };
        let scene_path = scenes_dir.join(format!("{name}.scene"));
        if !scene_path.is_file() {
            continue;
        }
        let json = path.with_extension("json");
        let reference_rms_se = if json.is_file() {
            read_rms_se(&json)?
        } else {
            0.0
        };
        out.push(BenchScene {
            name: name.to_owned(),
            scene_path,
            reference_path: path,
            reference_rms_se,
        });
    }
    out.sort_by(|a, b| a.name.cmp(&b.name));
    if out.is_empty() {
        return Err(format!(
            "no reference PFM in {} has a scene in {}",
            data_dir.display(),
            scenes_dir.display()
        ));
    }
    Ok(out)
}

/// `rms_standard_error` from a reference's .json.
pub fn read_rms_se(json: &Path) -> Result<f64, String> {
    let text = std::fs::read_to_string(json)
        .map_err(|e| format!("cannot read {}: {e}", json.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", json.display()))?;
    match v.get("rms_standard_error") {
        None => Ok(0.0),
        Some(x) => x
            .as_f64()
            .filter(|x| x.is_finite() && *x >= 0.0)
            .ok_or_else(|| {
                format!(
                    "{}: rms_standard_error is not a non-negative number",
                    json.display()
                )
            }),
    }
}

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// Scenes with references.
    pub scenes: Vec<BenchScene>,
    /// Variants (rows).
    pub variants: Vec<Variant>,
    /// Samples per pixel, increasing.
    pub spp: Vec<u32>,
    /// Seeds per (scene, variant, spp).
    pub seeds: u32,
}

/// The spp series 1, 2, 4, … up to `max` (a power of two or not).
pub fn geometric_spp(max: u32) -> Vec<u32> {
    let mut v = Vec::new();
    let mut s = 1u32;
    while s <= max {
        v.push(s);
        match s.checked_mul(2) {
            Some(n) => s = n,
            None => break,
        }
    }
    v
}

/// One render.
#[derive(Clone, Debug)]
pub struct Run {
    /// Scene name.
    pub scene: String,
    /// Variant name.
    pub variant: String,
    /// Threads actually used.
    pub threads: usize,
    /// Samples per pixel.
    pub spp: u32,
    /// Render seed.
    pub seed: u64,
    /// Wall-clock seconds of the render.
    pub seconds: f64,
    /// CPU seconds of the process during the render (all threads).
    pub cpu_seconds: f64,
    /// Path samples.
    pub paths: u64,
    /// Camera + bounce + shadow rays.
    pub rays: u64,
    /// Mean squared error against the reference (as measured).
    pub mse: f64,
    /// √MSE (as measured).
    pub rmse: f64,
    /// mean((x − r)² / (r² + 0.01)) (as measured).
    pub rel_mse: f64,
    /// mean(x − r).
    pub mean_diff: f64,
    /// The reference's expected MSE contribution, `rms_standard_error²`.
    pub ref_noise_mse: f64,
}

impl Run {
    /// MSE less the reference's own noise.
    pub fn mse_corrected(&self) -> f64 {
        self.mse - self.ref_noise_mse
    }
}

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

/// Process CPU time (all threads) in seconds.
fn process_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `clock_gettime` writes one `timespec` into the valid, owned
    // `ts`; CLOCK_PROCESS_CPUTIME_ID is supported on Linux and the BSDs.
    #[allow(unsafe_code)]
    let r = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    if r == 0 {
        ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
    } else {
        f64::NAN
    }
}

/// Renders `scene` once and compares it with `reference`.
#[allow(clippy::too_many_arguments)]
pub fn run_one<const S: usize, const P: usize, const M: usize>(
    scene_name: &str,
    scene: &Scene<S, P, M>,
    reference: &Image,
    ref_noise_mse: f64,
    variant: &Variant,
    spp: u32,
    seed: u64,
) -> Result<Run, String> {
    let (image, stats, threads, seconds, cpu_seconds) = if variant.adaptive {
        let job = BudgetJob {
            width: reference.width,
            height: reference.height,
            budget: Budget::Spp(spp),
            seed,
            threads: variant.threads,
            options: variant.options,
            adaptive: AdaptiveOptions::default(),
        };
        let cpu0 = process_cpu_seconds();
        let out = render_budget(scene, &job, &|| {})?;
        let cpu = process_cpu_seconds() - cpu0;
        (out.image, out.stats, out.threads, out.seconds, cpu)
    } else {
        let job = RenderJob {
            width: reference.width,
            height: reference.height,
            spp,
            seed,
            threads: variant.threads,
            options: variant.options,
        };
        let cpu0 = process_cpu_seconds();
        let out = render(scene, &job, &|| {})?;
        let cpu = process_cpu_seconds() - cpu0;
        (out.image, out.stats, out.threads, out.seconds, cpu)
    };
    let e = compare(&image, reference)?;
    Ok(Run {
        scene: scene_name.to_owned(),
        variant: variant.name.clone(),
        threads,
        spp,
        seed,
        seconds,
        cpu_seconds,
        paths: stats.paths,
        rays: stats.rays(),
        mse: e.mse,
        rmse: e.rmse,
        rel_mse: e.rel_mse,
        mean_diff: e.mean_diff,
        ref_noise_mse,
    })
}

/// The seed of seed number `k` at spp level `spp`: levels get independent
/// streams, so their errors are independent.
pub fn seed_for(spp: u32, k: u32) -> u64 {
    (u64::from(spp) << 20) | u64::from(k + 1)
}

/// Runs the whole benchmark, reporting progress through `log`.
pub fn run_all(cfg: &BenchConfig, log: &mut dyn FnMut(&str)) -> Result<Vec<Run>, String> {
    if cfg.spp.is_empty() || cfg.seeds == 0 || cfg.variants.is_empty() {
        return Err("nothing to run: no spp levels, seeds or variants".into());
    }
    let mut runs = Vec::new();
    for bs in &cfg.scenes {
        let scene = load_scene(&bs.scene_path)?;
        let reference = Image::load_pfm(&bs.reference_path)?;
        let noise = bs.reference_rms_se * bs.reference_rms_se;
        for v in &cfg.variants {
            let t0 = std::time::Instant::now();
            for &spp in &cfg.spp {
                for k in 0..cfg.seeds {
                    runs.push(run_one(
                        &bs.name,
                        &scene,
                        &reference,
                        noise,
                        v,
                        spp,
                        seed_for(spp, k),
                    )?);
                }
            }
            log(&format!(
                "{:<18} {:<12} {:>7.2} s",
                bs.name,
                v.name,
                t0.elapsed().as_secs_f64()
            ));
        }
    }
    Ok(runs)
}

fn median(v: &mut [f64]) -> f64 {
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

fn verdict(slope: f64, low: f64, high: f64, n: usize) -> String {
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

fn csv_f(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.6e}")
    } else {
        String::new()
    }
}

/// The raw runs as CSV.
pub fn runs_csv(runs: &[Run], variants: &[Variant]) -> String {
    let mut s = String::from(
        "scene,variant,strategy,stratified,fast_math,threads,spp,seed,seconds,cpu_seconds,paths,rays,rays_per_second,mse,rmse,rel_mse,mean_diff,ref_noise_mse,mse_corrected,efficiency\n",
    );
    for r in runs {
        let v = variants.iter().find(|v| v.name == r.variant);
        let (strategy, stratified, fast) = v.map_or(("", "", ""), |v| {
            (
                strategy_name(v.options.strategy),
                if v.options.stratified {
                    "true"
                } else {
                    "false"
                },
                if v.options.fast_math { "true" } else { "false" },
            )
        });
        let mc = r.mse_corrected();
        let eff = if mc > 0.0 {
            1.0 / (mc * r.seconds)
        } else {
            f64::NAN
        };
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.scene,
            r.variant,
            strategy,
            stratified,
            fast,
            r.threads,
            r.spp,
            r.seed,
            csv_f(r.seconds),
            csv_f(r.cpu_seconds),
            r.paths,
            r.rays,
            csv_f(r.rays as f64 / r.seconds.max(1e-12)),
            csv_f(r.mse),
            csv_f(r.rmse),
            csv_f(r.rel_mse),
            csv_f(r.mean_diff),
            csv_f(r.ref_noise_mse),
            csv_f(mc),
            csv_f(eff),
        );
    }
    s
}

/// The aggregated points as CSV.
pub fn points_csv(points: &[Point]) -> String {
    let mut s = String::from(
        "scene,variant,threads,spp,seeds,seconds_median,cpu_seconds_median,rays,rays_per_second,mse_mean,mse_corrected,rel_mse_mean,mean_diff,efficiency\n",
    );
    for p in points {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            p.scene,
            p.variant,
            p.threads,
            p.spp,
            p.seeds,
            csv_f(p.seconds),
            csv_f(p.cpu_seconds),
            p.rays,
            csv_f(p.rays_per_second()),
            csv_f(p.mse),
            csv_f(p.mse_corrected),
            csv_f(p.rel_mse),
            csv_f(p.mean_diff),
            csv_f(p.efficiency),
        );
    }
    s
}

/// The fits as CSV.
pub fn fits_csv(fits: &[Fit]) -> String {
    let mut s = String::from(
        "scene,variant,slope,slope_low,slope_high,floor,floor_over_a,levels,verdict\n",
    );
    for f in fits {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},\"{}\"",
            f.scene,
            f.variant,
            csv_f(f.slope),
            csv_f(f.slope_low),
            csv_f(f.slope_high),
            csv_f(f.floor),
            csv_f(f.floor_ratio),
            f.levels,
            f.verdict
        );
    }
    s
}

fn strategy_name(s: Strategy) -> &'static str {
    match s {
        Strategy::Mis => "mis",
        Strategy::BsdfOnly => "bsdf",
        Strategy::LightOnly => "light",
    }
}

fn md_f(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "–".into()
    }
}

fn md_e(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2e}")
    } else {
        "–".into()
    }
}

/// The markdown report: per scene, one row per variant at the highest spp,
/// with the slope fit and the efficiency relative to the baseline (the first
/// variant).
pub fn markdown(points: &[Point], fits: &[Fit], variants: &[Variant], header: &str) -> String {
    let mut s = String::new();
    s.push_str(header);
    let mut scenes: Vec<&str> = Vec::new();
    for p in points {
        if !scenes.contains(&p.scene.as_str()) {
            scenes.push(&p.scene);
        }
    }
    s.push_str("\nVariants (each a change of the baseline `mis`):\n\n");
    for v in variants {
        let _ = writeln!(s, "- `{}`: {}", v.name, v.description);
    }
    s.push('\n');
    for scene in scenes {
        let top = points
            .iter()
            .filter(|p| p.scene == scene)
            .map(|p| p.spp)
            .max()
            .unwrap_or(0);
        let at = |variant: &str| {
            points
                .iter()
                .find(|p| p.scene == scene && p.variant == variant && p.spp == top)
        };
        let base_eff = variants
            .first()
            .and_then(|v| at(&v.name))
            .map_or(f64::NAN, |p| p.efficiency);
        let _ = writeln!(s, "### {scene} ({top} spp)\n");
        s.push_str("| variant | threads | seconds | CPU s | M rays/s | MSE (corrected) | relMSE | efficiency 1/(MSE·s) | vs `mis` | MSE slope | floor | reading |\n");
        s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n");
        for v in variants {
            let Some(p) = at(&v.name) else { continue };
            let f = fits
                .iter()
                .find(|f| f.scene == scene && f.variant == v.name);
            let _ = writeln!(
                s,
                "| `{}` | {} | {} | {} | {} | {} | {} | {} | {}× | {} | {} | {} |",
                v.name,
                p.threads,
                md_f(p.seconds, 3),
                md_f(p.cpu_seconds, 3),
                md_f(p.rays_per_second() * 1e-6, 1),
                md_e(p.mse_corrected),
                md_e(p.rel_mse),
                md_e(p.efficiency),
                md_f(p.efficiency / base_eff, 2),
                f.map_or("–".into(), |f| md_f(f.slope, 3)),
                f.map_or("–".into(), |f| md_e(f.floor)),
                f.map_or("", |f| f.verdict.as_str()),
            );
        }
        s.push('\n');
    }
    s
}

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // the embedded font is valid; a failure would only lose the labels
        let _ =
            plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, FONT);
    });
}

/// Draws MSE (corrected) against seconds, log-log, one line per variant,
/// for `scene`, to `path` (`.svg` or `.png`).
pub fn plot(
    points: &[Point],
    variants: &[Variant],
    scene: &str,
    path: &Path,
) -> Result<(), String> {
    use plotters::prelude::*;
    register_font();
    let series: Vec<(String, Vec<(f64, f64)>)> = variants
        .iter()
        .map(|v| {
            let mut pts: Vec<(u32, f64, f64)> = points
                .iter()
                .filter(|p| {
                    p.scene == scene
                        && p.variant == v.name
                        && p.mse_corrected > 0.0
                        && p.seconds > 0.0
                })
                .map(|p| (p.spp, p.seconds, p.mse_corrected))
                .collect();
            // joined in order of spp: timing noise must not reorder the line
            pts.sort_by_key(|p| p.0);
            let line: Vec<(f64, f64)> = pts.into_iter().map(|p| (p.1, p.2)).collect();
            (v.name.clone(), line)
        })
        .filter(|(_, p)| !p.is_empty())
        .collect();
    let all = || series.iter().flat_map(|(_, p)| p.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in all() {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if series.is_empty() {
        return Err(format!("no positive MSE to plot for {scene}"));
    }
    let caption = format!("{scene}: MSE against render time (log-log)");
    let ranges = (x0 / 1.5, x1 * 1.5, y0 / 1.5, y1 * 1.5);
    let size = (800, 560);
    let r = match path.extension().and_then(|x| x.to_str()) {
        Some("svg") => draw_chart(
            SVGBackend::new(path, size).into_drawing_area(),
            &caption,
            ranges,
            &series,
        ),
        Some("png") => draw_chart(
            BitMapBackend::new(path, size).into_drawing_area(),
            &caption,
            ranges,
            &series,
        ),
        _ => return Err(format!("plot {}: use .svg or .png", path.display())),
    };
    r.map_err(|e| format!("plot {}: {e}", path.display()))
}

type Series = [(String, Vec<(f64, f64)>)];

fn draw_chart<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    caption: &str,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
    series: &Series,
) -> Result<(), String> {
    use plotters::prelude::*;
    let e = |x: &dyn std::fmt::Debug| format!("{x:?}");
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, ("sans-serif", 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc("seconds (wall clock)")
        .y_desc("MSE (reference noise subtracted)")
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|x| e(&x))?;
    for (i, (name, pts)) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
            .map_err(|x| e(&x))?
            .label(name.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
            .map_err(|x| e(&x))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(|x| e(&x))?;
    root.present().map_err(|x| e(&x))
}

/// The 1-minute load average (Linux), for the report.
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "?".into())
}

/// Machine description for the report: `lscpu`'s model line and core count,
/// or what std knows.
pub fn machine_summary() -> String {
    let cores = resolve_threads(0);
    let model = std::process::Command::new("lscpu")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Model name:"))
                .map(|l| l.trim_start_matches("Model name:").trim().to_owned())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let load = load_average();
    format!("{model}, {cores} cores available; 1-minute load average at the start {load}")
}

/// Writes every output into `dir`: `runs.csv`, `points.csv`, `fits.csv`,
/// `results.md` and `SCENE.svg` / `SCENE.png`. Returns the files written.
pub fn write_outputs(
    dir: &Path,
    runs: &[Run],
    variants: &[Variant],
    header: &str,
) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let points = aggregate(runs);
    let fits = fits(&points);
    let mut written = Vec::new();
    let mut put = |name: &str, text: String| -> Result<(), String> {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        written.push(p);
        Ok(())
    };
    put("runs.csv", runs_csv(runs, variants))?;
    put("points.csv", points_csv(&points))?;
    put("fits.csv", fits_csv(&fits))?;
    put("results.md", markdown(&points, &fits, variants, header))?;
    let mut scenes: Vec<&str> = Vec::new();
    for r in runs {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    for scene in scenes {
        for ext in ["svg", "png"] {
            let p = dir.join(format!("{scene}.{ext}"));
            plot(&points, variants, scene, &p)?;
            written.push(p);
        }
    }
    Ok(written)
}

/// What `micropt smallpt bench` runs: micropt and the double-precision
/// smallpt on one scene, single-threaded, at each spp with several seeds.
#[derive(Clone, Debug)]
pub struct VsSmallptConfig {
    /// The scene file.
    pub scene_path: PathBuf,
    /// The reference PFM (its `.json` beside it gives `rms_standard_error`).
    pub reference_path: PathBuf,
    /// Samples per pixel (multiples of 4).
    pub spp: Vec<u32>,
    /// Seeds per spp.
    pub seeds: u32,
    /// Options of the smallpt renderer.
    pub smallpt: SmallptOptions,
}

/// One render of one renderer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timed {
    /// Wall-clock seconds of the render.
    pub seconds: f64,
    /// CPU seconds of the process during the render: on a loaded machine a
    /// steadier measure of a one-thread render's cost than the wall clock.
    pub cpu_seconds: f64,
    /// MSE against the reference, as measured.
    pub mse: f64,
    /// Camera paths.
    pub paths: u64,
    /// Rays traced.
    pub rays: u64,
}

/// micropt's and smallpt's render at one (spp, seed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VsRun {
    /// Samples per pixel.
    pub spp: u32,
    /// Render seed (the same for both).
    pub seed: u64,
    /// `micropt render --spp N --uniform --threads 1 --seed S`.
    pub micropt: Timed,
    /// The double-precision smallpt, one thread.
    pub smallpt: Timed,
}

/// Runs micropt (exactly as `micropt render SCENE --spp N --uniform
/// --threads 1 --seed S`) and the double-precision smallpt one after the
/// other at every (spp, seed); returns the runs and the reference's noise
/// MSE (`rms_standard_error²`).
pub fn vs_smallpt(
    cfg: &VsSmallptConfig,
    log: &mut dyn FnMut(&str),
) -> Result<(Vec<VsRun>, f64), String> {
    let scene = load_scene(&cfg.scene_path)?;
    let scene64 = SmallptScene::load(&cfg.scene_path)?;
    let reference = Image::load_pfm(&cfg.reference_path)?;
    let rms_se = read_rms_se(&cfg.reference_path.with_extension("json"))?;
    let (width, height) = (reference.width, reference.height);
    let mut runs = Vec::new();
    for &spp in &cfg.spp {
        for k in 0..cfg.seeds {
            let seed = seed_for(spp, k);
            let job = BudgetJob {
                width,
                height,
                budget: Budget::Spp(spp),
                seed,
                threads: 1,
                options: Options::default(),
                adaptive: AdaptiveOptions {
                    adaptive: false,
                    ..AdaptiveOptions::default()
                },
            };
            let cpu0 = process_cpu_seconds();
            let m = render_budget(&scene, &job, &|| {})?;
            let micropt = Timed {
                cpu_seconds: process_cpu_seconds() - cpu0,
                seconds: m.seconds,
                mse: compare(&m.image, &reference)?.mse,
                paths: m.stats.paths,
                rays: m.stats.rays(),
            };
            let cpu0 = process_cpu_seconds();
            let s = smallpt::render(
                &scene64,
                &SmallptJob {
                    width,
                    height,
                    spp,
                    seed,
                    threads: 1,
                    options: cfg.smallpt,
                },
            )?;
            if s.truncated > 0 {
                return Err(format!(
                    "smallpt ended {} path(s) at its cap of {} hits at spp {spp}, seed {seed}: its image lacks their light, so its MSE is no measure of its variance",
                    s.truncated, cfg.smallpt.max_depth
                ));
            }
            let smallpt = Timed {
                cpu_seconds: process_cpu_seconds() - cpu0,
                seconds: s.seconds,
                mse: compare(&s.image, &reference)?.mse,
                paths: s.paths,
                rays: s.rays,
            };
            log(&format!(
                "spp {spp:>5} seed {seed:>10}: micropt {:.3} s ({:.3} CPU s) MSE {:.3e}   smallpt {:.3} s ({:.3} CPU s) MSE {:.3e}",
                micropt.seconds,
                micropt.cpu_seconds,
                micropt.mse,
                smallpt.seconds,
                smallpt.cpu_seconds,
                smallpt.mse
            ));
            runs.push(VsRun {
                spp,
                seed,
                micropt,
                smallpt,
            });
        }
    }
    Ok((runs, rms_se * rms_se))
}

/// Aggregates of one renderer at one spp over seeds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VsSide {
    /// Mean MSE less the reference's noise.
    pub mse: f64,
    /// Median CPU seconds.
    pub cpu_seconds: f64,
    /// Median wall seconds.
    pub seconds: f64,
    /// 1 / (MSE · median CPU seconds); NaN if the MSE is not positive.
    pub efficiency: f64,
    /// 1 / (MSE · median wall seconds).
    pub efficiency_wall: f64,
    /// Paths per CPU second, over all seeds.
    pub paths_per_cpu_second: f64,
}

fn vs_side(g: &[&VsRun], ref_noise_mse: f64, f: &dyn Fn(&VsRun) -> Timed) -> VsSide {
    let n = g.len() as f64;
    let mse = g.iter().map(|r| f(r).mse).sum::<f64>() / n - ref_noise_mse;
    let cpu = median(&mut g.iter().map(|r| f(r).cpu_seconds).collect::<Vec<_>>());
    let wall = median(&mut g.iter().map(|r| f(r).seconds).collect::<Vec<_>>());
    let eff = |s: f64| {
        if mse > 0.0 { 1.0 / (mse * s) } else { f64::NAN }
    };
    let paths = g.iter().map(|r| f(r).paths).sum::<u64>() as f64;
    let cpu_all = g.iter().map(|r| f(r).cpu_seconds).sum::<f64>();
    VsSide {
        mse,
        cpu_seconds: cpu,
        seconds: wall,
        efficiency: eff(cpu),
        efficiency_wall: eff(wall),
        paths_per_cpu_second: paths / cpu_all.max(1e-12),
    }
}

/// [`vs_smallpt`]'s runs per spp: (spp, seeds, micropt, smallpt).
pub fn vs_smallpt_points(runs: &[VsRun], ref_noise_mse: f64) -> Vec<(u32, usize, VsSide, VsSide)> {
    let mut levels: Vec<u32> = runs.iter().map(|r| r.spp).collect();
    levels.dedup();
    levels
        .into_iter()
        .map(|spp| {
            let g: Vec<&VsRun> = runs.iter().filter(|r| r.spp == spp).collect();
            (
                spp,
                g.len(),
                vs_side(&g, ref_noise_mse, &|r| r.micropt),
                vs_side(&g, ref_noise_mse, &|r| r.smallpt),
            )
        })
        .collect()
}

/// The markdown table of [`vs_smallpt`]'s runs: per spp, each renderer's
/// corrected MSE, MSE·spp (constant for an unbiased estimator), median CPU
/// and wall seconds, efficiency 1/(MSE·CPU s), and micropt's efficiency
/// over smallpt's (from CPU and from wall seconds).
pub fn vs_smallpt_table(runs: &[VsRun], ref_noise_mse: f64) -> String {
    let mut s = String::from(
        "| spp | seeds | micropt MSE | MSE·spp | CPU s | wall s | eff | smallpt MSE | MSE·spp | CPU s | wall s | eff | smallpt k paths/CPU s | micropt k paths/CPU s | eff ratio micropt/smallpt | (wall) |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for (spp, n, m, p) in vs_smallpt_points(runs, ref_noise_mse) {
        let side = |x: &VsSide| {
            format!(
                "{} | {} | {} | {} | {}",
                md_e(x.mse),
                md_f(x.mse * f64::from(spp), 4),
                md_f(x.cpu_seconds, 3),
                md_f(x.seconds, 3),
                md_f(x.efficiency, 1),
            )
        };
        let _ = writeln!(
            s,
            "| {spp} | {n} | {} | {} | {} | {} | {} | {} |",
            side(&m),
            side(&p),
            md_f(p.paths_per_cpu_second * 1e-3, 0),
            md_f(m.paths_per_cpu_second * 1e-3, 0),
            md_f(m.efficiency / p.efficiency, 3),
            md_f(m.efficiency_wall / p.efficiency_wall, 3),
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spp_series_is_geometric() {
        assert_eq!(geometric_spp(1), vec![1]);
        assert_eq!(geometric_spp(10), vec![1, 2, 4, 8]);
        assert_eq!(geometric_spp(1024).len(), 11);
    }

    #[test]
    fn fits_recover_known_laws() {
        // pure 1/N: slope -1, no floor
        let pts: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0, 16.0]
            .iter()
            .map(|&n: &f64| (n, 0.5 / n))
            .collect();
        let logs: Vec<(f64, f64)> = pts.iter().map(|&(a, b)| (a.ln(), b.ln())).collect();
        assert!((ols_slope(&logs) + 1.0).abs() < 1e-12);
        let (a, c) = fit_variance_plus_floor(&pts);
        assert!((a - 0.5).abs() < 1e-12 && c.abs() < 1e-12, "{a} {c}");
        // a floor (squared bias) shows up as c and flattens the slope
        let pts: Vec<(f64, f64)> = pts.iter().map(|&(n, m)| (n, m + 0.01)).collect();
        let (a, c) = fit_variance_plus_floor(&pts);
        assert!((a - 0.5).abs() < 1e-9 && (c - 0.01).abs() < 1e-9, "{a} {c}");
    }

    #[test]
    fn verdicts() {
        assert_eq!(verdict(-1.0, -1.0, -1.0, 8), "1/N (unbiased)");
        assert!(verdict(-0.6, -0.95, -0.3, 8).starts_with("flattens"));
        assert!(verdict(-1.3, -1.4, -1.2, 8).starts_with("faster"));
        assert!(verdict(-1.0, -1.0, -1.0, 2).starts_with("too few"));
    }
}
