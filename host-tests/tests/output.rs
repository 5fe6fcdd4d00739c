//! Output through embedded-graphics: a rendered tile drawn into a
//! `Framebuffer` and a `MockDisplay` pixel by pixel, and the host's Rgb565
//! file bytes equal to what the panel path draws.

use embedded_graphics::framebuffer::{Framebuffer, buffer_size};
use embedded_graphics::mock_display::MockDisplay;
use embedded_graphics::pixelcolor::raw::{BigEndian, RawU16};
use embedded_graphics::pixelcolor::{Rgb565, Rgb888, RgbColor};
use embedded_graphics::prelude::*;
use micropt::film::{FromEncoded, TILE, draw_tile, tiles, tone_map};
use micropt::{Color, Options, Renderer, Stats};
use micropt_host::reference::scenes_dir;
use micropt_host::render::{RenderJob, load_scene, render};

#[test]
fn framebuffer_matches_the_host_rgb565_bytes() {
    let scene = load_scene(&scenes_dir().join("cornell.scene")).unwrap();
    const W: usize = 40;
    const H: usize = 24;
    let r = Renderer::new(&scene, W as u32, H as u32).unwrap().seed(5);
    let mut fb =
        Framebuffer::<Rgb565, RawU16, BigEndian, W, H, { buffer_size::<Rgb565>(W, H) }>::new();
    let mut stats = Stats::default();
    let mut px = [Color::ZERO; (TILE * TILE) as usize];
    for t in tiles(W as u32, H as u32) {
        r.render_tile(&t, 2, &mut px, &mut stats);
        draw_tile(&mut fb, &t, &px, 1.0).unwrap();
    }
    let job = RenderJob {
        width: W as u32,
        height: H as u32,
        spp: 2,
        seed: 5,
        threads: 2,
        options: Options::default(),
    };
    let host = render(&scene, &job, &|| {}).unwrap();
    assert_eq!(fb.data(), host.image.to_rgb565_be(1.0).as_slice());
    assert_eq!(stats, host.stats);
}

#[test]
fn mock_display_pixel_by_pixel() {
    // a furnace render: background exactly 1 (white), sphere exactly 0.5
    let scene = load_scene(&scenes_dir().join("furnace.scene")).unwrap();
    let r = Renderer::new(&scene, 32, 32).unwrap().seed(1);
    let mut display: MockDisplay<Rgb888> = MockDisplay::new();
    let mut stats = Stats::default();
    let mut px = [Color::ZERO; (TILE * TILE) as usize];
    let mut linear = vec![Color::ZERO; 32 * 32];
    for t in tiles(32, 32) {
        r.render_tile(&t, 4, &mut px, &mut stats);
        draw_tile(&mut display, &t, &px, 1.0).unwrap();
        for (i, p) in px.iter().take(t.len()).enumerate() {
            let (x, y) = (t.x + i as u32 % t.w, t.y + i as u32 / t.w);
            linear[(y * 32 + x) as usize] = *p;
        }
    }
    for y in 0..32 {
        for x in 0..32 {
            let want = Rgb888::from_encoded(tone_map(linear[y * 32 + x], 1.0), x as u32, y as u32);
            assert_eq!(
                display.get_pixel(Point::new(x as i32, y as i32)),
                Some(want)
            );
        }
    }
    // corners are sky, the centre is the grey sphere: sRGB(0.5) = 188
    assert_eq!(display.get_pixel(Point::new(0, 0)), Some(Rgb888::WHITE));
    assert_eq!(
        display.get_pixel(Point::new(16, 16)),
        Some(Rgb888::new(188, 188, 188))
    );
}
