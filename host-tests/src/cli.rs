//! The command line: `micropt render …`, `micropt compare …`.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use micropt::{AdaptiveOptions, Budget, Options};
use micropt_host::image::{Image, OutputFormat};
use micropt_host::metrics::compare;
use micropt_host::render::{BudgetJob, load_scene, render_budget};
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
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file (SCENE_FORMAT.md v1).
    scene: PathBuf,
    /// Output file; the extension picks the format [default: SCENE-STEM.png].
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
    /// Samples per pixel (the average, when allocation is adaptive)
    /// [default: 64 when no other budget is given].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..), group = "budget")]
    spp: Option<u32>,
    /// Budget: this many path samples for the whole image.
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
    /// Image size WxH [default: the scene's resolution, else 64x64].
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Render seed: the image is a pure function of scene, size, spp and seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads [default: all cores]; the image does not depend on it.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
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
    if w == 0 || h == 0 {
        return Err("width and height must be at least 1".into());
    }
    if w > 16_384 || h > 16_384 {
        return Err("width and height must be at most 16384".into());
    }
    Ok((w, h))
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
        options: Options::default(),
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
