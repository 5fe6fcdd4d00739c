//! The command line: `micropt render …`, `micropt compare …`.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use micropt::budget::MAX_SPP;
use micropt::{AdaptiveOptions, Budget, Options, Skip, Strategy};
use micropt_host::bench;
use micropt_host::image::{Image, OutputFormat};
use micropt_host::metrics::{self, ZGroup, bias_z, compare};
use micropt_host::render::{
    BudgetJob, MAX_THREADS, RenderJob, check_size, load_scene, render_budget, render_denoised,
};
use micropt_host::smallpt::{self, SmallptJob, SmallptOptions, SmallptScene};
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
    ///
    /// By default sampling is adaptive: after a 1-spp preview the budget goes
    /// where the estimated error is largest. That estimator is biased and
    /// consistent (pixel means come out mostly low where rare bright paths
    /// carry the light; the bias vanishes as the budget grows). --uniform
    /// gives every pixel the same number of samples: the unbiased estimator.
    Render(RenderArgs),
    /// Compare two PFM images: MSE, RMSE, relMSE and mean difference.
    Compare(CompareArgs),
    /// Run time against error: render every scene with a reference at a
    /// geometric series of spp for each variant, write CSV, markdown and
    /// log-log plots.
    Bench(BenchArgs),
    /// smallpt's algorithm in double precision (BSDF sampling only, exact
    /// Fresnel): render a scene of spheres, or compare micropt's efficiency
    /// with it.
    Smallpt {
        #[command(subcommand)]
        command: SmallptCommand,
    },
}

#[derive(Subcommand)]
enum SmallptCommand {
    /// Render a scene of spheres with smallpt's algorithm in f64.
    Render(SmallptRenderArgs),
    /// micropt against smallpt on one scene, both on one thread: MSE against
    /// the reference (its own noise subtracted), seconds and efficiency
    /// 1/(MSE·s) at each spp, as a markdown table.
    Bench(SmallptBenchArgs),
}

#[derive(clap::Args)]
struct SmallptRenderArgs {
    /// Scene file (spheres only).
    scene: PathBuf,
    /// Output file (.pfm, .png or .rgb565) [default: SCENE-STEM-smallpt.pfm].
    #[arg(short, long, value_name = "OUT")]
    output: Option<PathBuf>,
    /// Also write each pixel's standard error to this PFM (needs spp >= 8).
    #[arg(long, value_name = "PFM")]
    se: Option<PathBuf>,
    /// Samples per pixel, a multiple of 4 (2x2 strata).
    #[arg(long, default_value_t = 64, value_parser = parse_spp4)]
    spp: u32,
    #[command(flatten)]
    frame: FrameArgs,
    /// End paths at surfaces that reflect nothing (smallpt traces them on
    /// with zero weight until the roulette); same expected image.
    #[arg(long)]
    cutoff: bool,
    /// Hard cap on hits per path. Paths it ends are counted ("truncated" in
    /// --json, a warning on stderr): their further light is lost. The
    /// roulette (survival at most 0.999 per hit) makes the default cap
    /// practically unreachable.
    #[arg(long, value_name = "HITS", default_value_t = smallpt::MAX_DEPTH,
          value_parser = clap::value_parser!(u32).range(1..))]
    max_depth: u32,
    /// Print one JSON line of figures at the end.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct SmallptBenchArgs {
    /// Scene file [default: the repository's scenes/smallpt.scene].
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Reference PFM, with its .json beside it [default:
    /// host-tests/data/smallpt.pfm].
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Samples per pixel, multiples of 4 (repeatable) [default: 64 128 256
    /// 512 1024].
    #[arg(long = "spp", value_name = "N", value_parser = parse_spp4)]
    spp: Vec<u32>,
    /// Seeds per spp.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    seeds: u32,
    /// Run smallpt with --cutoff.
    #[arg(long)]
    cutoff: bool,
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
    /// independent, fast-math, all-cores, adaptive,
    /// denoised.
    #[arg(long = "variant", value_name = "NAME")]
    variants: Vec<String>,
    /// Highest spp of the series 1, 2, 4, … [default: 1024; quick: 128].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    max_spp: Option<u32>,
    /// Seeds per spp level [default: 3; quick: 2].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    seeds: Option<u32>,
}

/// Size, seed and threads of a render (`render` and `smallpt render`).
#[derive(clap::Args)]
struct FrameArgs {
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
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file (format version 2, docs/scene-format.md).
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
    /// Spend the budget uniformly (every pixel the same number of samples):
    /// the unbiased estimator. Without it the budget goes where the
    /// estimated error is largest: adaptive, biased and consistent (the bias
    /// vanishes as the budget grows).
    #[arg(long)]
    uniform: bool,
    /// Diagnostics: do the work the scene analysis would skip, to measure
    /// what a skip saves. Comma-separated: shadow-occluders, view-culling,
    /// specialize, horizon, unreachable-lights, closed, slabs, windows, bvh,
    /// whole-light (this one changes the estimator: the light is sampled
    /// where the closed form would give its direct light), or all.
    #[arg(long, value_name = "LIST", value_parser = parse_skips)]
    no_skip: Option<Skip>,
    /// Diagnostics: the estimator at non-delta vertices: mis (light and BSDF
    /// sampling by the power heuristic, the default), light-only or
    /// bsdf-only (each strategy alone, unbiased; to see what MIS buys).
    #[arg(long, value_name = "NAME", value_parser = parse_strategy, default_value = "mis")]
    strategy: Strategy,
    /// Diagnostics: give the scene a bounding volume hierarchy even if the
    /// analysis finds that it does not pay (to measure where it starts to).
    #[arg(long)]
    force_bvh: bool,
    /// Diagnostics: find the images of lights in mirror spheres by film
    /// sampling only, not also from the light's side (the same expectation,
    /// more noise where such an image is a fraction of a pixel).
    #[arg(long)]
    no_highlights: bool,
    /// Diagnostics: find the light that reaches a surface by one reflection
    /// in a mirror sphere by BSDF sampling only, not also by a sample
    /// through the mirror (the same expectation, more noise in the
    /// caustics of small lights).
    #[arg(long)]
    no_caustics: bool,
    /// Denoise the image (every output format): render --spp samples in
    /// every pixel (uniform sampling; needs --spp or its default, not
    /// --budget-paths or --budget-ms) and filter them with the core's
    /// denoiser (docs/denoise.md). Bit-identical for any --threads.
    #[arg(long, conflicts_with_all = ["budget_paths", "budget_ms"])]
    denoise: bool,
    /// Write the denoiser's albedo guide to this PFM (OIDN's convention:
    /// linear, in [0, 1]; the first surface behind mirrors and glass).
    /// Renders as --denoise does.
    #[arg(long, value_name = "PFM", conflicts_with_all = ["budget_paths", "budget_ms"])]
    aov_albedo: Option<PathBuf>,
    /// Write the denoiser's normal guide to this PFM (world space, in
    /// [-1, 1], toward the camera ray). Renders as --denoise does.
    #[arg(long, value_name = "PFM", conflicts_with_all = ["budget_paths", "budget_ms"])]
    aov_normal: Option<PathBuf>,
    /// The image the demo (examples/demo.rs, the board examples) shows
    /// after K passes: pass k renders --spp (default 1 here) times 2^k
    /// samples in every pixel, so this is the render at --spp · 2^(K-1),
    /// raw (each pixel's mean) or, with --denoise, denoised; bit for bit
    /// the demo's and the firmware's MICROPT_FW_PASSES=K (passes keep
    /// nothing from each other, so only the last is rendered). K in 1..=17.
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..=i64::from(micropt::demo::LAST_PASS) + 1), conflicts_with_all = ["budget_paths", "budget_ms"])]
    passes: Option<u32>,
    #[command(flatten)]
    frame: FrameArgs,
    /// Exposure multiplier applied before tone mapping (PNG, rgb565).
    #[arg(long, default_value_t = 1.0, value_parser = parse_exposure)]
    exposure: f32,
    /// Print one JSON line of figures at the end ("estimator" says which:
    /// "adaptive (biased, consistent)" or "uniform (unbiased)").
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
    /// The image's per-pixel standard errors (PFM); with --reference-se,
    /// prints z-scores of the differences of pixel, row, block and image
    /// means: whether image and reference differ by more than noise. A
    /// difference where both standard errors are 0 is an exact mismatch
    /// (z infinite): counted, and the exit status is 1.
    #[arg(long, value_name = "PFM", requires = "reference_se")]
    se: Option<PathBuf>,
    /// The reference's per-pixel standard errors (PFM).
    #[arg(long, value_name = "PFM", requires = "se")]
    reference_se: Option<PathBuf>,
    /// Block size of the block z-scores.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..))]
    block: u32,
}

fn parse_spp4(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(n) if n > 0 && n % 4 == 0 => Ok(n),
        _ => Err(format!(
            "'{s}' is not a positive multiple of 4 (smallpt samples 2x2 strata)"
        )),
    }
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
            "windows" => k.windows = false,
            "bvh" => k.bvh = false,
            "whole-light" => k.whole_light = false,
            "all" => k = Skip::NONE,
            other => {
                return Err(format!(
                    "unknown skip '{other}' (shadow-occluders, view-culling, specialize, horizon, unreachable-lights, closed, slabs, windows, bvh, whole-light, all)"
                ));
            }
        }
    }
    Ok(k)
}

fn parse_strategy(s: &str) -> Result<Strategy, String> {
    match s {
        "mis" => Ok(Strategy::Mis),
        "light-only" => Ok(Strategy::LightOnly),
        "bsdf-only" => Ok(Strategy::BsdfOnly),
        other => Err(format!(
            "unknown strategy '{other}' (mis, light-only, bsdf-only)"
        )),
    }
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
        Command::Smallpt {
            command: SmallptCommand::Render(a),
        } => cmd_smallpt_render(a),
        Command::Smallpt {
            command: SmallptCommand::Bench(a),
        } => cmd_smallpt_bench(a),
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

/// `output`, or SCENE-STEM + `suffix` in the current directory.
fn output_or_default(output: Option<PathBuf>, scene: &std::path::Path, suffix: &str) -> PathBuf {
    output.unwrap_or_else(|| {
        let stem = scene
            .file_stem()
            .map_or("out".into(), |s| s.to_string_lossy().into_owned());
        PathBuf::from(format!("{stem}{suffix}"))
    })
}

impl RenderArgs {
    /// The integrator options the flags choose.
    fn options(&self) -> Options {
        Options {
            skip: self.no_skip.unwrap_or(Skip::ALL),
            strategy: self.strategy,
            highlights: !self.no_highlights,
            caustics: !self.no_caustics,
            ..Options::default()
        }
    }
}

fn cmd_render(a: RenderArgs) -> Result<ExitCode, String> {
    let output = output_or_default(a.output.clone(), &a.scene, ".png");
    // check the extension before spending time on the render
    OutputFormat::from_path(&output)?;
    let mut scene = load_scene(&a.scene)?;
    if a.force_bvh {
        scene.set_bvh(true);
    }
    let (width, height) = a.frame.size.or(scene.resolution()).unwrap_or((64, 64));
    if let Some(p) = a.budget_paths {
        let most = u64::from(width) * u64::from(height) * u64::from(MAX_SPP);
        if p > most {
            return Err(format!(
                "--budget-paths {p} is more than {MAX_SPP} samples per pixel of a {width}x{height} image (at most {most})"
            ));
        }
    }
    if a.denoise || a.aov_albedo.is_some() || a.aov_normal.is_some() || a.passes.is_some() {
        return render_denoised_to(&a, &scene, width, height, &output);
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
        seed: a.frame.seed,
        threads: a.frame.threads.map_or(0, |t| t as usize),
        options: a.options(),
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
    if out.stats.truncated > 0 {
        // the depth cap dropped light: the image is biased (`--json` counts it)
        eprintln!(
            "micropt: warning: {} of {} paths reached the depth cap of {} bounces and were \
             cut short (their remaining light is missing)",
            out.stats.truncated, out.stats.paths, job.options.max_depth
        );
    }
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
            "estimator": if a.uniform {
                "uniform (unbiased)"
            } else {
                "adaptive (biased, consistent)"
            },
            "samples": out.samples,
            "spp": out.samples as f64 / pixels,
            "min_pixel_samples": out.counts.iter().copied().min().unwrap_or(0),
            "max_pixel_samples": out.counts.iter().copied().max().unwrap_or(0),
            "seed": a.frame.seed,
            "preview_seconds": out.preview_seconds,
            "seconds": out.seconds,
            "paths": s.paths,
            "rays": s.rays(),
            "camera_rays": s.paths,
            "bounce_rays": s.bounce_rays,
            "shadow_rays": s.shadow_rays,
            "nonfinite": s.nonfinite,
            "leaks": s.leaks,
            "truncated": s.truncated,
            "bvh_nodes": if job.options.skip.bvh { scene.bvh().len() } else { 0 },
            "bvh_depth": if job.options.skip.bvh { scene.bvh().depth() } else { 0 },
            "highlight_pairs": micropt::Renderer::new(&scene, width, height)
                .map_or(0, |r| r.options(job.options).highlight_pairs()),
            "caustic_spheres": micropt::Renderer::new(&scene, width, height)
                .map_or(0, |r| r.options(job.options).caustic_spheres()),
            "threads": out.threads,
            "rays_per_second": s.rays() as f64 / out.seconds.max(1e-9),
        });
        say(v.to_string())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// `micropt render --denoise` (or with a guide output, or `--passes`):
/// uniform samples into moments, the core's denoiser, the outputs.
fn render_denoised_to(
    a: &RenderArgs,
    scene: &micropt_host::render::HostScene,
    width: u32,
    height: u32,
    output: &std::path::Path,
) -> Result<ExitCode, String> {
    for p in [&a.aov_albedo, &a.aov_normal].into_iter().flatten() {
        if OutputFormat::from_path(p)? != OutputFormat::Pfm {
            return Err(format!("{}: a guide is written as PFM (.pfm)", p.display()));
        }
    }
    let spp = match a.passes {
        Some(k) => {
            let spp = micropt::demo::pass_spp(a.spp.unwrap_or(1), k - 1);
            if spp > MAX_SPP {
                return Err(format!(
                    "--passes {k} at --spp {}: {spp} samples per pixel, more than {MAX_SPP}",
                    a.spp.unwrap_or(1)
                ));
            }
            spp
        }
        None => a.spp.unwrap_or(64),
    };
    let job = RenderJob {
        width,
        height,
        spp,
        seed: a.frame.seed,
        threads: a.frame.threads.map_or(0, |t| t as usize),
        options: a.options(),
    };
    let out = render_denoised(scene, &job, &|| {})?;
    let image = if a.denoise { &out.image } else { &out.raw };
    image.save(output, a.exposure)?;
    if let Some(p) = &a.aov_albedo {
        out.albedo.save(p, 1.0)?;
    }
    if let Some(p) = &a.aov_normal {
        out.normal.save(p, 1.0)?;
    }
    if a.json {
        let s = &out.stats;
        let v = serde_json::json!({
            "scene": a.scene.display().to_string(),
            "output": output.display().to_string(),
            "width": width,
            "height": height,
            "budget": format!("spp {}", job.spp),
            "adaptive": false,
            "estimator": "uniform (unbiased)",
            "denoised": a.denoise,
            "passes": a.passes,
            "spp": job.spp,
            "seed": a.frame.seed,
            "seconds": out.seconds,
            "denoise_seconds": out.denoise_seconds,
            "paths": s.paths,
            "rays": s.rays(),
            "nonfinite": s.nonfinite,
            "leaks": s.leaks,
            "truncated": s.truncated,
            "threads": out.threads,
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
    let mut failed = false;
    if let (Some(se), Some(rse)) = (&a.se, &a.reference_se) {
        let (img_se, ref_se) = (Image::load_pfm(se)?, Image::load_pfm(rse)?);
        let z = bias_z(&img, &img_se, &reference, &ref_se, a.block)?;
        let ch = ["r", "g", "b"];
        let group = |name: &str, g: &ZGroup, unit: &str| {
            format!(
                "z {name}: {} values, chi2/dof {:.3} (noise: 1 +- {:.3}), max |z| {:.2} at {unit} {} {}",
                g.count,
                g.chi2_per_dof,
                // the channels of a group are strongly correlated (same
                // paths): about count/3 independent values
                (6.0 / g.count.max(1) as f64).sqrt(),
                g.max_abs_z,
                g.worst.0,
                ch[g.worst.1]
            )
        };
        say(format!(
            "expected_mse {:.6e} (noise of both)\nmse/expected {:.4}\nz image: r {:+.2} g {:+.2} b {:+.2}\n{}\n{}\n{}",
            z.expected_mse,
            z.mse / z.expected_mse,
            z.image_z[0],
            z.image_z[1],
            z.image_z[2],
            group("rows", &z.rows, "row"),
            group(&format!("{0}x{0} blocks", a.block), &z.blocks, "block"),
            group("pixels", &z.pixels, "pixel"),
        ))?;
        let n = z.pixels.exact_mismatches;
        say(format!(
            "exact mismatches: {n} (pixel channels where both standard errors are 0 and the values differ by more than rounding, {:e} relative)",
            metrics::ROUNDING
        ))?;
        if n > 0 {
            let (p, c) = z.pixels.worst;
            let (x, y) = (p as u32 % img.width, p as u32 / img.width);
            let v = |i: &Image| {
                let q = i.get(x, y);
                [q.x, q.y, q.z][c]
            };
            eprintln!(
                "micropt: {n} exact mismatch(es): image and reference differ where neither has noise (z infinite), e.g. pixel ({x}, {y}) {}: {} against {}, both standard errors 0",
                ch[c],
                v(&img),
                v(&reference)
            );
            failed = true;
        }
    }
    if let Some(max) = a.max_rmse
        && e.rmse > max
    {
        eprintln!("micropt: rmse {:.6e} exceeds --max-rmse {max:e}", e.rmse);
        failed = true;
    }
    Ok(if failed {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
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

fn cmd_smallpt_render(a: SmallptRenderArgs) -> Result<ExitCode, String> {
    let output = output_or_default(a.output, &a.scene, "-smallpt.pfm");
    OutputFormat::from_path(&output)?;
    if a.se.is_some() && a.spp < 8 {
        return Err("--se needs --spp 8 or more (two samples in each stratum)".into());
    }
    let scene = SmallptScene::load(&a.scene)?;
    let (width, height) = a.frame.size.or(scene.resolution).unwrap_or((64, 64));
    let out = smallpt::render(
        &scene,
        &SmallptJob {
            width,
            height,
            spp: a.spp,
            seed: a.frame.seed,
            threads: a.frame.threads.map_or(0, |t| t as usize),
            options: SmallptOptions {
                cutoff: a.cutoff,
                max_depth: a.max_depth,
            },
        },
    )?;
    out.image.save(&output, 1.0)?;
    if let Some(se) = &a.se {
        out.standard_error.save(se, 1.0)?;
    }
    if out.truncated > 0 {
        eprintln!(
            "micropt: warning: {} path(s) reached the cap of {} hits and were ended there; the light they would have gathered further is missing (the image is biased low)",
            out.truncated, a.max_depth
        );
    }
    if a.json {
        let v = serde_json::json!({
            "scene": a.scene.display().to_string(),
            "output": output.display().to_string(),
            "renderer": "smallpt (f64)",
            "cutoff": a.cutoff,
            "width": width,
            "height": height,
            "spp": a.spp,
            "seed": a.frame.seed,
            "seconds": out.seconds,
            "paths": out.paths,
            "rays": out.rays,
            "max_depth": a.max_depth,
            "truncated": out.truncated,
            "threads": out.threads,
            "paths_per_second": out.paths_per_second(),
            "rays_per_second": out.rays as f64 / out.seconds.max(1e-9),
            "mean_rgb": out.image.mean(),
        });
        say(v.to_string())?;
    }
    Ok(ExitCode::SUCCESS)
}

fn cmd_smallpt_bench(a: SmallptBenchArgs) -> Result<ExitCode, String> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let cfg = bench::VsSmallptConfig {
        scene_path: a
            .scene
            .unwrap_or_else(|| root.join("scenes").join("smallpt.scene")),
        reference_path: a
            .reference
            .unwrap_or_else(|| root.join("host-tests").join("data").join("smallpt.pfm")),
        spp: if a.spp.is_empty() {
            vec![64, 128, 256, 512, 1024]
        } else {
            a.spp
        },
        seeds: a.seeds,
        smallpt: SmallptOptions {
            cutoff: a.cutoff,
            ..SmallptOptions::default()
        },
    };
    let machine = bench::machine_summary();
    let (runs, noise) = bench::vs_smallpt(&cfg, &mut |l| eprintln!("{l}"))?;
    say(format!(
        "micropt (`micropt render {} --spp N --uniform --threads 1`) against smallpt in f64{} (`micropt smallpt render … --threads 1`), {} seeds per spp; \
         MSE: mean over seeds less the reference's noise {noise:.3e}; seconds: median; eff = 1/(MSE·s); \
         ratios micropt/smallpt. {machine}; load at the end {}.\n\n{}",
        cfg.scene_path.display(),
        if a.cutoff { " with --cutoff" } else { "" },
        cfg.seeds,
        bench::load_average(),
        bench::vs_smallpt_table(&runs, noise)
    ))?;
    Ok(ExitCode::SUCCESS)
}
