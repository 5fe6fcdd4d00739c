//! The demo app's passes on the host: what it draws after pass k is the
//! host's `micropt render --passes k+1` (the render at 2^k samples a pixel,
//! raw or denoised, tone-mapped and dithered as on the panel), bit for bit.

use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::prelude::*;
use embedded_graphics_simulator::SimulatorDisplay;
use micropt::demo::{Command, Demo, Entry, OneCore, Step, pass_spp};
use micropt::denoise::Column;
use micropt::{Options, Scene};
use micropt_host::reference::scenes_dir;
use micropt_host::render::{RenderJob, load_scene, render_denoised};

struct Fixed;

impl micropt::Clock for Fixed {
    fn micros(&mut self) -> u64 {
        0
    }
}

fn panel_bytes(d: &SimulatorDisplay<Rgb565>) -> Vec<u8> {
    d.bounding_box()
        .points()
        .flat_map(|p| micropt::film::rgb565_be(d.get_pixel(p)))
        .collect()
}

#[test]
fn each_pass_is_the_hosts_render_at_its_budget_raw_and_denoised() {
    let (w, h, seed) = (40u32, 28u32, 9u64);
    for name in ["cornell", "gloss", "dof"] {
        let path = scenes_dir().join(format!("{name}.scene"));
        let text = std::fs::read_to_string(&path).unwrap();
        let text: &'static str = Box::leak(text.into_boxed_str());
        let entries = [Entry { name: "s", text }];
        let mut scene: Box<Scene> = Box::new(Scene::EMPTY);
        let mut columns = vec![Column::EMPTY; w as usize];
        let mut demo = Demo::new(&entries, &mut scene, &mut columns, (w, h), 1, seed).unwrap();
        demo.apply(Command::Status).unwrap();
        let mut display: SimulatorDisplay<Rgb565> = SimulatorDisplay::new(Size::new(w, h));
        let mut line = vec![Rgb565::BLACK; w as usize];
        let host_scene = load_scene(&path).unwrap();
        for k in 0..4 {
            // switching shows the same pass again, so the mode the last pass
            // ended in goes first
            let modes = if k % 2 == 0 {
                [false, true]
            } else {
                [true, false]
            };
            for raw in modes {
                if demo.settings().raw != raw {
                    demo.apply(Command::Denoise).unwrap();
                }
                let step = demo
                    .step(&mut display, &mut line, &mut OneCore, &mut Fixed, || None)
                    .unwrap();
                assert!(
                    matches!(step, Step::Done(p) if p.pass == k),
                    "{name} {k}: {step:?}"
                );
                let job = RenderJob {
                    width: w,
                    height: h,
                    spp: pass_spp(1, k),
                    seed,
                    threads: 2,
                    options: Options::default(),
                };
                let out = render_denoised(&host_scene, &job, &|| {}).unwrap();
                let want = if raw { &out.raw } else { &out.image };
                assert_eq!(
                    panel_bytes(&display),
                    want.to_rgb565_be(1.0),
                    "{name}, pass {k}, raw {raw}"
                );
            }
        }
    }
}
