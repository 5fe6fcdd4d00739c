//! The board demo on the desktop: the same app (`micropt::demo`) the board
//! examples run, drawing through embedded-graphics into
//! embedded-graphics-simulator's display. Pass after pass at doubling
//! budgets (1, 2, 4, … samples a pixel), each denoised (or raw) as it
//! lands; keys stand for the Display Pack's buttons.
//!
//! ```text
//! cargo run --release -p micropt-host --example demo --features window [-- --size WxH]
//! cargo run --release -p micropt-host --example demo -- --headless --passes N --out DIR [--size WxH]
//! ```
//!
//! The window needs SDL2 (`--features window`; on Debian `apt install
//! libsdl2-dev`). Keys: `a` next scene, `b` exposure, `x` orbit the
//! camera, `y` raw/denoised, `s` status line on/off; Escape, `q` or
//! closing the window quits. `--headless` opens no window: it writes each
//! pass's panel as `DIR/pass-KK.png` and as `DIR/pass-KK.rgb565` (the
//! bytes a board dumps: big-endian Rgb565) and prints its status line.
//! With `--no-status` (no status line over the last rows) pass `k` is bit
//! for bit the board's pass `k` and the host's `micropt render
//! scenes/cornell.scene --spp 1 --passes k+1 --denoise -o x.rgb565` (with
//! `--size` and `--seed`). Default size 240x240, seed 0, passes 5; the
//! scenes: cornell, spheres, gloss, dof, many.

use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::prelude::*;
use embedded_graphics_simulator::{OutputSettingsBuilder, SimulatorDisplay};
use micropt::demo::{Demo, OneCore, SCENES, Step};
use micropt::denoise::Column;
use micropt::{Clock, Scene};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Microseconds since the demo started.
struct Wall(Instant);

impl Clock for Wall {
    fn micros(&mut self) -> u64 {
        self.0.elapsed().as_micros() as u64
    }
}

struct Args {
    headless: bool,
    passes: u32,
    out: PathBuf,
    size: (u32, u32),
    seed: u64,
    status: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        headless: false,
        passes: 5,
        out: PathBuf::from("demo-passes"),
        size: (240, 240),
        seed: 0,
        status: true,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            "--headless" => a.headless = true,
            "--no-status" => a.status = false,
            "--passes" => {
                a.passes = value("--passes")?
                    .parse()
                    .ok()
                    .filter(|&n| (1..=micropt::demo::LAST_PASS + 1).contains(&n))
                    .ok_or("--passes must be a whole number in 1..=17")?;
            }
            "--out" => a.out = PathBuf::from(value("--out")?),
            "--size" => {
                let v = value("--size")?;
                a.size = v
                    .split_once('x')
                    .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
                    .filter(|&(w, h): &(u32, u32)| {
                        (1..=4096).contains(&w) && (1..=4096).contains(&h)
                    })
                    .ok_or(format!("--size {v}: use WxH, each side in 1..=4096"))?;
            }
            "--seed" => {
                a.seed = value("--seed")?
                    .parse()
                    .map_err(|_| "--seed must be a whole number".to_string())?;
            }
            other => {
                return Err(format!(
                    "unknown argument {other:?} (see the example's docs)"
                ));
            }
        }
    }
    Ok(a)
}

fn main() -> ExitCode {
    match parse_args().and_then(run) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("demo: error: {e}");
            ExitCode::from(2)
        }
    }
}

fn run(a: Args) -> Result<(), String> {
    let (w, h) = a.size;
    let mut scene: Box<Scene> = Box::new(Scene::EMPTY);
    let mut columns = vec![Column::EMPTY; w as usize];
    let mut demo = Demo::new(&SCENES, &mut scene, &mut columns, (w, h), 1, a.seed)
        .map_err(|e| e.to_string())?;
    let mut display: SimulatorDisplay<Rgb565> = SimulatorDisplay::new(Size::new(w, h));
    let mut line = vec![Rgb565::BLACK; w as usize];
    let mut clock = Wall(Instant::now());
    if !a.status {
        demo.apply(micropt::demo::Command::Status)
            .map_err(|e| e.to_string())?;
    }
    if a.headless {
        std::fs::create_dir_all(&a.out)
            .map_err(|e| format!("cannot create {}: {e}", a.out.display()))?;
        let settings = OutputSettingsBuilder::new().scale(1).build();
        for k in 0..a.passes {
            let step = demo
                .step(&mut display, &mut line, &mut OneCore, &mut clock, || None)
                .map_err(|e| e.to_string())?;
            let path = a.out.join(format!("pass-{k:02}.png"));
            display
                .to_rgb_output_image(&settings)
                .save_png(&path)
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
            // the panel's bytes as a board dumps them (big-endian Rgb565)
            let raw: Vec<u8> = display
                .bounding_box()
                .points()
                .flat_map(|p| micropt::film::rgb565_be(display.get_pixel(p)))
                .collect();
            let raw_path = path.with_extension("rgb565");
            std::fs::write(&raw_path, raw)
                .map_err(|e| format!("cannot write {}: {e}", raw_path.display()))?;
            let mut status = String::new();
            demo.status(&mut status).map_err(|e| e.to_string())?;
            let paths = match step {
                Step::Done(p) => p.paths,
                _ => 0,
            };
            println!("{}: {status} ({paths} paths)", path.display());
        }
        return Ok(());
    }
    window::run(&mut demo, display, &mut line, &mut clock)
}

#[cfg(not(feature = "window"))]
mod window {
    use super::*;

    /// Without SDL there is no window.
    pub fn run<const S: usize, const P: usize, const M: usize>(
        _: &mut Demo<'_, S, P, M>,
        _: SimulatorDisplay<Rgb565>,
        _: &mut [Rgb565],
        _: &mut Wall,
    ) -> Result<(), String> {
        Err(
            "this build has no window: build the example with --features window \
             (SDL2: apt install libsdl2-dev), or pass --headless --passes N --out DIR"
                .into(),
        )
    }
}

#[cfg(feature = "window")]
mod window {
    use super::*;
    use embedded_graphics::primitives::Rectangle;
    use embedded_graphics_simulator::sdl2::Keycode;
    use embedded_graphics_simulator::{SimulatorEvent, Window};
    use micropt::demo::Command;
    use std::cell::RefCell;
    use std::collections::VecDeque;
    use std::time::Duration;

    /// The window and the keys pressed in it, as commands.
    struct Keys {
        window: Window,
        queue: VecDeque<Command>,
        last: Instant,
    }

    impl Keys {
        /// Reads the window's events (at most every 20 ms: the demo asks
        /// before each pixel).
        fn pump(&mut self) {
            if self.last.elapsed() < Duration::from_millis(20) {
                return;
            }
            self.last = Instant::now();
            for e in self.window.events() {
                let c = match e {
                    // the window closed: nothing to keep
                    SimulatorEvent::Quit => std::process::exit(0),
                    SimulatorEvent::KeyDown { keycode, .. } => match keycode {
                        Keycode::A => Command::NextScene,
                        Keycode::B => Command::Exposure,
                        Keycode::X => Command::Orbit,
                        Keycode::Y => Command::Denoise,
                        Keycode::S => Command::Status,
                        Keycode::Escape | Keycode::Q => std::process::exit(0),
                        _ => continue,
                    },
                    _ => continue,
                };
                self.queue.push_back(c);
            }
        }
    }

    /// The simulator's display, shown in the window as rows are drawn (at
    /// most every 40 ms).
    struct Screen<'k> {
        display: SimulatorDisplay<Rgb565>,
        keys: &'k RefCell<Keys>,
        shown: Instant,
    }

    impl Screen<'_> {
        fn show(&mut self) {
            self.shown = Instant::now();
            self.keys.borrow_mut().window.update(&self.display);
        }
    }

    impl OriginDimensions for Screen<'_> {
        fn size(&self) -> Size {
            self.display.size()
        }
    }

    impl DrawTarget for Screen<'_> {
        type Color = Rgb565;
        type Error = core::convert::Infallible;

        fn draw_iter<I>(&mut self, pixels: I) -> Result<(), Self::Error>
        where
            I: IntoIterator<Item = Pixel<Rgb565>>,
        {
            self.display.draw_iter(pixels)
        }

        fn fill_contiguous<I>(&mut self, area: &Rectangle, colors: I) -> Result<(), Self::Error>
        where
            I: IntoIterator<Item = Rgb565>,
        {
            self.display.fill_contiguous(area, colors)?;
            if self.shown.elapsed() >= Duration::from_millis(40) {
                self.show();
            }
            Ok(())
        }
    }

    pub fn run<const S: usize, const P: usize, const M: usize>(
        demo: &mut Demo<'_, S, P, M>,
        display: SimulatorDisplay<Rgb565>,
        line: &mut [Rgb565],
        clock: &mut Wall,
    ) -> Result<(), String> {
        let settings = OutputSettingsBuilder::new().scale(2).build();
        let keys = RefCell::new(Keys {
            window: Window::new(
                "micropt demo (a scene, b exposure, x orbit, y raw, s status)",
                &settings,
            ),
            queue: VecDeque::new(),
            last: Instant::now(),
        });
        let mut screen = Screen {
            display,
            keys: &keys,
            shown: Instant::now(),
        };
        // the window opens at its first update
        screen.show();
        loop {
            // a key pressed during a pass stops it before the next pixel
            let step = demo
                .step(&mut screen, line, &mut OneCore, clock, || {
                    let mut k = keys.borrow_mut();
                    k.pump();
                    k.queue.pop_front()
                })
                .map_err(|e| e.to_string())?;
            screen.show();
            if step == Step::Idle {
                // the last pass is on the screen: wait for a key (the next
                // step asks for it)
                std::thread::sleep(Duration::from_millis(20));
            }
        }
    }
}
