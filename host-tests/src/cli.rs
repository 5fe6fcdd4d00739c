//! The command line: `micropt render …`, `micropt compare …`.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use micropt::budget::MAX_SPP;
use micropt::{AdaptiveOptions, Budget, Options, Skip};
use micropt_host::bench;
use micropt_host::image::{Image, OutputFormat};
use micropt_host::metrics::compare;
use micropt_host::render::{BudgetJob, MAX_THREADS, check_size, load_scene, render_budget};
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "micropt",
    version,
    about = "A no_std f32 path tracer: the host front end"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to PNG (8-bit sRGB), PFM (linear float) or
    /// .rgb565 (raw big-endian, dithered as on the panel).
    Render(RenderArgs),
    /// Compare two PFM images: MSE, RMSE, relMSE and mean difference.
    Compare(CompareArgs),
    /// Run time against error: render every scene with a reference at a
    /// geometric series of spp for each variant, write CSV, markdown and
    /// log-log plots.
    Bench(BenchArgs),
}

#[derive(clap::Args)]
struct BenchArgs {
    /// A reduced run (spp 1, 2, 4 … 128; 2 seeds) that finishes in well
    /// under two minutes.
    #[arg(long)]
    quick: bool,
    /// Output directory [default: docs/bench; with --quick: target/bench-quick,
    /// so that a quick run never overwrites the committed full results].
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// Directory of the scene files [default: the repository's scenes/].
    #[arg(long)]
    scenes_dir: Option<PathBuf>,
    /// Directory of the reference PFM/JSON pairs [default: host-tests/data/].
    #[arg(long)]
    data_dir: Option<PathBuf>,
    /// Only these scenes (repeatable; by file stem).
    #[arg(long = "scene", value_name = "NAME")]
    scenes: Vec<String>,
    /// Only these variants (repeatable): mis, bsdf-only, light-only,
    /// independent, fast-math, all-cores.
    #[arg(long = "variant", value_name = "NAME")]
    variants: Vec<String>,
    /// Highest spp of the series 1, 2, 4, … [default: 1024; quick: 128].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    max_spp: Option<u32>,
    /// Seeds per spp level [default: 3; quick: 2].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    seeds: Option<u32>,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file (SCENE_FORMAT.md v1).
    scene: PathBuf,
    /// Output file; the extension picks the format [default: SCENE-STEM.png].
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
    /// Samples per pixel (the average, when allocation is adaptive), at
    /// most 1048576 [default: 64 when no other budget is given].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_SPP)), group = "budget")]
    spp: Option<u32>,
    /// Budget: this many path samples for the whole image (at most 1048576
    /// per pixel).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..), group = "budget")]
    budget_paths: Option<u64>,
    /// Budget: stop refining after this many milliseconds (the 1-spp
    /// preview always completes; not deterministic).
    #[arg(long, value_name = "MS", value_parser = clap::value_parser!(u64).range(1..), group = "budget")]
    budget_ms: Option<u64>,
    /// Spend the budget uniformly (every pixel the same number of samples)
    /// instead of where the estimated error is largest.
    #[arg(long)]
    uniform: bool,
    /// Diagnostics: do the work the scene analysis would skip, to measure
    /// what a skip saves. Comma-separated: shadow-occluders, view-culling,
    /// specialize, horizon, unreachable-lights, closed, slabs, or all.
    #[arg(long, value_name = "LIST", value_parser = parse_skips)]
    no_skip: Option<Skip>,
    /// Image size WxH [default: the scene's resolution, else 64x64].
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Render seed: the image is a pure function of scene, size, spp and seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads, at most 1024 [default: all cores]; the image does not
    /// depend on it.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=MAX_THREADS as i64))]
    threads: Option<u32>,
    /// Exposure multiplier applied before tone mapping (PNG, rgb565).
    #[arg(long, default_value_t = 1.0, value_parser = parse_exposure)]
    exposure: f32,
    /// Print one JSON line of figures at the end.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct CompareArgs {
    /// Image to judge (PFM).
    image: PathBuf,
    /// Reference (PFM).
    reference: PathBuf,
    /// Exit with status 1 if the RMSE exceeds this.
    #[arg(long, value_name = "RMSE")]
    max_rmse: Option<f64>,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not WxH (e.g. 160x128)"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("width '{w}' is not a whole number"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("height '{h}' is not a whole number"))?;
    check_size(w, h)?;
    Ok((w, h))
}

fn parse_skips(s: &str) -> Result<Skip, String> {
    let mut k = Skip::ALL;
    for name in s.split(',').map(str::trim) {
        match name {
            "shadow-occluders" => k.shadow_occluders = false,
            "view-culling" => k.view_culling = false,
            "specialize" => k.specialize = false,
            "horizon" => k.horizon = false,
            "unreachable-lights" => k.unreachable_lights = false,
            "closed" => k.closed = false,
            "slabs" => k.slabs = false,
            "all" => k = Skip::NONE,
            other => {
                return Err(format!(
                    "unknown skip '{other}' (shadow-occluders, view-culling, specialize, horizon, unreachable-lights, closed, slabs, all)"
                ));
            }
        }
    }
    Ok(k)
}

fn parse_exposure(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a finite non-negative number")),
    }
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => cmd_render(a),
        Command::Compare(a) => cmd_compare(a),
        Command::Bench(a) => cmd_bench(a),
    };
    match result {
        Ok(code) => code,
        Err(msg) => {
            eprintln!("micropt: error: {msg}");
            ExitCode::from(2)
        }
    }
}

/// Prints to stdout; a closed pipe gives an error message, not a panic.
fn say(text: String) -> Result<(), String> {
    let mut out = std::io::stdout().lock();
    writeln!(out, "{text}")
        .and_then(|_| out.flush())
        .map_err(|e| format!("cannot write to stdout: {e}"))
}

fn cmd_render(a: RenderArgs) -> Result<ExitCode, String> {
    let output = match a.output {
        Some(o) => o,
        None => {
            let stem = a
                .scene
                .file_stem()
                .map_or("out".into(), |s| s.to_string_lossy().into_owned());
            PathBuf::from(format!("{stem}.png"))
        }
    };
    // check the extension before spending time on the render
    OutputFormat::from_path(&output)?;
    let scene = load_scene(&a.scene)?;
    let (width, height) = a.size.or(scene.resolution()).unwrap_or((64, 64));
    if let Some(p) = a.budget_paths {
        let most = u64::from(width) * u64::from(height) * u64::from(MAX_SPP);
        if p > most {
            return Err(format!(
                "--budget-paths {p} is more than {MAX_SPP} samples per pixel of a {width}x{height} image (at most {most})"
            ));
        }
    }
    let budget = match (a.spp, a.budget_paths, a.budget_ms) {
        (_, Some(p), _) => Budget::Paths(p),
        (_, _, Some(ms)) => Budget::Deadline(ms.saturating_mul(1000)),
        (spp, _, _) => Budget::Spp(spp.unwrap_or(64)),
    };
    let job = BudgetJob {
        width,
        height,
        budget,
        seed: a.seed,
        threads: a.threads.map_or(0, |t| t as usize),
        options: Options {
            skip: a.no_skip.unwrap_or(Skip::ALL),
            ..Options::default()
        },
        adaptive: AdaptiveOptions {
            adaptive: !a.uniform,
            ..AdaptiveOptions::default()
        },
    };
    // a preview and a refinement step per tile
    let n_tiles = 2 * micropt::film::tile_count(width, height) as u64;
    let bar = if std::io::stderr().is_terminal() {
        let b = ProgressBar::new(n_tiles);
        b.set_style(
            ProgressStyle::with_template(
                "{spinner} {bar:40} {pos}/{len} tile passes  {elapsed} (eta {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b
    } else {
        ProgressBar::hidden()
    };
    let out = render_budget(&scene, &job, &|| bar.inc(1))?;
    bar.finish_and_clear();
    out.image.save(&output, a.exposure)?;
    if a.json {
        let s = &out.stats;
        let pixels = f64::from(width) * f64::from(height);
        let v = serde_json::json!({
            "scene": a.scene.display().to_string(),
            "output": output.display().to_string(),
            "width": width,
            "height": height,
            "budget": match budget {
                Budget::Spp(n) => format!("spp {n}"),
                Budget::Paths(n) => format!("paths {n}"),
                Budget::Deadline(us) => format!("ms {}", us / 1000),
            },
            "adaptive": !a.uniform,
            "samples": out.samples,
            "spp": out.samples as f64 / pixels,
            "min_pixel_samples": out.counts.iter().copied().min().unwrap_or(0),
            "max_pixel_samples": out.counts.iter().copied().max().unwrap_or(0),
            "seed": a.seed,
            "preview_seconds": out.preview_seconds,
            "seconds": out.seconds,
            "paths": s.paths,
            "rays": s.rays(),
            "camera_rays": s.paths,
            "bounce_rays": s.bounce_rays,
            "shadow_rays": s.shadow_rays,
            "nonfinite": s.nonfinite,
            "leaks": s.leaks,
            "threads": out.threads,
            "rays_per_second": s.rays() as f64 / out.seconds.max(1e-9),
        });
        say(v.to_string())?;
    }
    Ok(ExitCode::SUCCESS)
}

fn cmd_compare(a: CompareArgs) -> Result<ExitCode, String> {
    let img = Image::load_pfm(&a.image)?;
    let reference = Image::load_pfm(&a.reference)?;
    let e = compare(&img, &reference)?;
    say(format!(
        "mse {:.6e}\nrmse {:.6e}\nrelmse {:.6e}\nmean_diff {:+.6e}",
        e.mse, e.rmse, e.rel_mse, e.mean_diff
    ))?;
    match a.max_rmse {
        Some(max) if e.rmse > max => {
            eprintln!("micropt: rmse {:.6e} exceeds --max-rmse {max:e}", e.rmse);
            Ok(ExitCode::from(1))
        }
        _ => Ok(ExitCode::SUCCESS),
    }
}

fn cmd_bench(a: BenchArgs) -> Result<ExitCode, String> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let scenes_dir = a.scenes_dir.unwrap_or_else(|| root.join("scenes"));
    let data_dir = a
        .data_dir
        .unwrap_or_else(|| root.join("host-tests").join("data"));
    let mut scenes = bench::discover_scenes(&scenes_dir, &data_dir)?;
    if !a.scenes.is_empty() {
        for want in &a.scenes {
            if !scenes.iter().any(|s| &s.name == want) {
                return Err(format!(
                    "no scene '{want}' with a reference (have: {})",
                    scenes
                        .iter()
                        .map(|s| s.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
        }
        scenes.retain(|s| a.scenes.contains(&s.name));
    }
    let mut variants = bench::standard_variants();
    if !a.variants.is_empty() {
        for want in &a.variants {
            if !variants.iter().any(|v| &v.name == want) {
                return Err(format!(
                    "no variant '{want}' (have: {})",
                    variants
                        .iter()
                        .map(|v| v.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
        }
        variants.retain(|v| a.variants.contains(&v.name));
    }
    let (spp, seeds) = if a.quick {
        (
            bench::geometric_spp(a.max_spp.unwrap_or(128)),
            a.seeds.unwrap_or(2),
        )
    } else {
        (
            bench::geometric_spp(a.max_spp.unwrap_or(1024)),
            a.seeds.unwrap_or(3),
        )
    };
    let machine = bench::machine_summary();
    let started = std::time::Instant::now();
    eprintln!(
        "micropt bench: {} scenes x {} variants x spp {:?} x {} seeds on {machine}",
        scenes.len(),
        variants.len(),
        spp,
        seeds
    );
    let cfg = bench::BenchConfig {
        scenes,
        variants: variants.clone(),
        spp,
        seeds,
    };
    let runs = bench::run_all(&cfg, &mut |line| eprintln!("{line}"))?;
    let header = format!(
        "## micropt bench results\n\nCommand: `micropt bench{}`. Machine: {machine}; 1-minute load average at the end {}. \
         Total bench time {:.0} s. Seconds are wall-clock medians over {} seeds; \
         MSE is the mean over seeds with the reference's own noise \
         (rms_standard_error², from its .json) subtracted. Absolute times \
         vary between machines; the ratios are what carry.\n",
        if a.quick { " --quick" } else { "" },
        bench::load_average(),
        started.elapsed().as_secs_f64(),
        cfg.seeds
    );
    let out = a.out.unwrap_or_else(|| {
        PathBuf::from(if a.quick {
            "target/bench-quick"
        } else {
            "docs/bench"
        })
    });
    let written = bench::write_outputs(&out, &runs, &variants, &header)?;
    for p in written {
        eprintln!("wrote {}", p.display());
    }
    eprintln!("bench finished in {:.1} s", started.elapsed().as_secs_f64());
    Ok(ExitCode::SUCCESS)
}
