//! `micropt smallpt bench`: micropt against the double-precision smallpt
//! on one scene, single-threaded, at each spp with several seeds, and the
//! efficiency of each.

use super::analysis::median;
use super::report::{md_e, md_f};
use super::{process_cpu_seconds, read_rms_se, seed_for};
use crate::image::Image;
use crate::metrics::compare;
use crate::render::{BudgetJob, load_scene, render_budget};
use crate::smallpt::{self, SmallptJob, SmallptOptions, SmallptScene};
use micropt::{AdaptiveOptions, Budget, Options};
use std::fmt::Write as _;
use std::path::PathBuf;

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
