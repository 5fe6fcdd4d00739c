//! What `micropt bench` writes: runs, points and fits as CSV, a markdown
//! table, and log-log plots of MSE against seconds per scene.

use super::{Fit, Point, Run, Variant};
use micropt::Strategy;
use std::fmt::Write as _;
use std::path::Path;

pub(crate) fn csv_f(x: f64) -> String {
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

pub(crate) fn strategy_name(s: Strategy) -> &'static str {
    match s {
        Strategy::Mis => "mis",
        Strategy::BsdfOnly => "bsdf",
        Strategy::LightOnly => "light",
    }
}

pub(crate) fn md_f(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "–".into()
    }
}

pub(crate) fn md_e(x: f64) -> String {
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

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

pub(crate) fn register_font() {
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

pub(crate) fn draw_chart<DB: plotters::prelude::DrawingBackend>(
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
