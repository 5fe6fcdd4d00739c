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

//!
//! One file per job: this module runs the renders; `analysis` aggregates
//! them over seeds and fits the error laws; `report` writes the CSV,
//! markdown and plots; `vs_smallpt` runs micropt against the
//! double-precision smallpt.

mod analysis;
mod report;
mod vs_smallpt;

pub use analysis::{Fit, Point, aggregate, fit_variance_plus_floor, fits, ols_slope};
pub use report::{fits_csv, markdown, plot, points_csv, runs_csv};
pub use vs_smallpt::*;

use crate::image::Image;
use crate::metrics::compare;
use crate::render::{
    BudgetJob, RenderJob, load_scene, render, render_budget, render_denoised, resolve_threads,
};
use micropt::{AdaptiveOptions, Budget, Options, Scene, Strategy};
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
    /// Uniform samples through the core's denoiser (`micropt render
    /// --denoise`); its time counts in the seconds.
    pub denoise: bool,
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
        denoise: false,
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
        Variant {
            denoise: true,
            ..v(
                "denoised",
                "uniform samples through the core's denoiser (--denoise), 1 thread; the \
                 denoiser's time included",
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

/// Process CPU time (all threads) in seconds.
pub(crate) fn process_cpu_seconds() -> f64 {
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
    let job = RenderJob {
        width: reference.width,
        height: reference.height,
        spp,
        seed,
        threads: variant.threads,
        options: variant.options,
    };
    let cpu0 = process_cpu_seconds();
    let (image, stats, threads, seconds) = if variant.denoise {
        let out = render_denoised(scene, &job, &|| {})?;
        let seconds = out.seconds + out.denoise_seconds;
        (out.image, out.stats, out.threads, seconds)
    } else if variant.adaptive {
        let budget_job = BudgetJob {
            width: job.width,
            height: job.height,
            budget: Budget::Spp(spp),
            seed,
            threads: job.threads,
            options: job.options,
            adaptive: AdaptiveOptions::default(),
        };
        let out = render_budget(scene, &budget_job, &|| {})?;
        (out.image, out.stats, out.threads, out.seconds)
    } else {
        let out = render(scene, &job, &|| {})?;
        (out.image, out.stats, out.threads, out.seconds)
    };
    let cpu_seconds = process_cpu_seconds() - cpu0;
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

#[cfg(test)]
mod tests {
    use super::analysis::verdict;
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
