//! Renders a scene the way a display board shows it — tile by tile through
//! embedded-graphics into an Rgb565 panel, ordered-dithered — using
//! embedded-graphics-simulator's display (no SDL window), and saves the
//! panel's pixels as a PNG.
//!
//! ```text
//! cargo run --release -p micropt-host --example panel -- [SCENE] [WxH] [SPP] [OUT.png]
//! ```
//! Defaults: `scenes/cornell.scene`, `160x128` (a common ST7735 panel), 16
//! spp, `panel.png`.

use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::prelude::*;
use embedded_graphics_simulator::{OutputSettingsBuilder, SimulatorDisplay};
use micropt::film::{TILE, draw_tile, tiles};
use micropt::{Color, Renderer, Stats};
use std::process::ExitCode;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("panel: error: {e}");
            ExitCode::from(2)
        }
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene_path = args.first().map_or("scenes/cornell.scene", String::as_str);
    let size = args.get(1).map_or("160x128", String::as_str);
    let spp: u32 = args
        .get(2)
        .map_or(Ok(16), |s| s.parse())
        .map_err(|_| "SPP must be a whole number")?;
    let out = args.get(3).map_or("panel.png", String::as_str);
    let (w, h) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| w > 0 && h > 0 && spp > 0)
        .ok_or("size must be WxH with W, H > 0, and SPP > 0")?;

    let scene = micropt_host::load_scene(std::path::Path::new(scene_path))?;
    let renderer = Renderer::new(&scene, w, h)
        .map_err(|e| format!("camera: {e:?}"))?
        .seed(1);
    let mut display: SimulatorDisplay<Rgb565> = SimulatorDisplay::new(Size::new(w, h));
    let mut stats = Stats::default();
    let mut px = [Color::ZERO; (TILE * TILE) as usize];
    let start = std::time::Instant::now();
    // exactly what the firmware does: render a tile, tone-map and dither it
    // to Rgb565, push it to the panel with one fill_contiguous
    for tile in tiles(w, h) {
        renderer.render_tile(&tile, spp, &mut px, &mut stats);
        draw_tile(&mut display, &tile, &px, 1.0).map_err(|e| format!("draw: {e:?}"))?;
    }
    let secs = start.elapsed().as_secs_f64();
    let settings = OutputSettingsBuilder::new().scale(1).build();
    display
        .to_rgb_output_image(&settings)
        .save_png(out)
        .map_err(|e| format!("cannot write {out}: {e}"))?;
    println!(
        "{out}: {w}x{h} Rgb565 panel, {spp} spp, {} paths, {} rays in {secs:.2} s (one thread)",
        stats.paths,
        stats.rays()
    );
    Ok(())
}
