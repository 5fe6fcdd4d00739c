//! The demo's state machine on a small in-memory panel: passes, presses,
//! the orbit, the status line and its errors.

use super::*;
use core::convert::Infallible;
use embedded_graphics::geometry::OriginDimensions;
use embedded_graphics::pixelcolor::Rgb565;

const W: usize = 16;
const H: usize = 12;

/// A panel in memory, `R` rows.
struct Panel<const R: usize = H> {
    px: [[Rgb565; W]; R],
}

impl<const R: usize> Panel<R> {
    fn new() -> Self {
        Self {
            px: [[Rgb565::new(0, 0, 0); W]; R],
        }
    }
}

impl<const R: usize> OriginDimensions for Panel<R> {
    fn size(&self) -> Size {
        Size::new(W as u32, R as u32)
    }
}

impl<const R: usize> DrawTarget for Panel<R> {
    type Color = Rgb565;
    type Error = Infallible;

    fn draw_iter<I>(&mut self, pixels: I) -> Result<(), Infallible>
    where
        I: IntoIterator<Item = Pixel<Rgb565>>,
    {
        for Pixel(p, c) in pixels {
            if let Some(px) = self
                .px
                .get_mut(p.y as usize)
                .and_then(|r| r.get_mut(p.x as usize))
            {
                *px = c;
            }
        }
        Ok(())
    }
}

/// A clock that advances `step` microseconds each time it is read.
struct Ticks {
    now: u64,
    step: u64,
}

impl Clock for Ticks {
    fn micros(&mut self) -> u64 {
        self.now += self.step;
        self.now
    }
}

const ENTRIES: [Entry; 2] = [
    Entry {
        name: "spo",
        text: include_str!("../../scenes/sphere-over-plane.scene"),
    },
    // diffuse and a light only: the tests run in builds without the
    // other materials too
    Entry {
        name: "two",
        text: "camera 1 2 5   0 0.5 0   0 1 0   40\n\
               material grey diffuse 0.6 0.5 0.4\n\
               material lamp light 6 6 6\n\
               plane 0 0 0   0 1 0   grey\n\
               sphere -0.6 0.5 0   0.5   grey\n\
               sphere 0.8 2.5 0.5   0.4   lamp\n",
    },
];

type TestScene = Scene<8, 8, 8>;

fn demo<'a>(scene: &'a mut TestScene, columns: &'a mut [Column]) -> Demo<'a, 8, 8, 8> {
    Demo::new(&ENTRIES, scene, columns, (W as u32, H as u32), 1, 3).unwrap()
}

#[test]
fn passes_double_their_samples_and_stop_at_the_last() {
    assert_eq!(pass_spp(1, 0), 1);
    assert_eq!(pass_spp(1, 4), 16);
    assert_eq!(pass_spp(3, 2), 12);
    assert_eq!(pass_spp(1, LAST_PASS + 9), 1 << LAST_PASS);
    assert_eq!(pass_spp(u32::MAX, 3), u32::MAX);
}

#[test]
fn a_full_orbit_comes_back_and_keeps_the_distance_to_the_target() {
    let spec = CameraSpec::pinhole(
        Vec3::new(0.0, 1.0, 5.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
        40.0,
    );
    assert_eq!(orbit(&spec, ORBIT_STEPS), orbit(&spec, 0));
    assert_eq!(orbit(&spec, 0).eye, spec.eye);
    for k in 0..ORBIT_STEPS {
        let o = orbit(&spec, k);
        let d = (o.eye - o.target).length();
        assert!((d - 5.0).abs() < 1e-5, "step {k}: distance {d}");
        // about the up axis: the height stays
        assert!((o.eye.y - 1.0).abs() < 1e-6, "step {k}: {:?}", o.eye);
        assert_eq!((o.target, o.up, o.vfov_deg), (spec.target, spec.up, 40.0));
    }
    // a quarter turn about +y takes +z to +x, half a turn to −z
    let q = orbit(&spec, ORBIT_STEPS / 4).eye;
    assert!((q.x - 5.0).abs() < 1e-5 && q.z.abs() < 1e-5, "{q:?}");
    let h = orbit(&spec, ORBIT_STEPS / 2).eye;
    assert!((h.z + 5.0).abs() < 1e-5 && h.x.abs() < 1e-5, "{h:?}");
}

#[test]
fn each_pass_shows_the_denoised_render_at_its_budget() {
    let mut scene = TestScene::EMPTY;
    let mut columns = [Column::EMPTY; W];
    let mut d = demo(&mut scene, &mut columns);
    d.apply(Command::Status).unwrap();
    let (mut panel, mut line) = (Panel::<H>::new(), [Rgb565::new(0, 0, 0); W]);
    let mut clock = Ticks { now: 0, step: 1 };
    for k in 0..3 {
        let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None);
        assert!(matches!(step, Ok(Step::Done(p)) if p.pass == k && p.spp == 1 << k));
    }
    // the same pass rendered apart from the demo: 4 samples a pixel
    let mut other = TestScene::EMPTY;
    crate::parse::parse_into(ENTRIES[0].text, &mut other).unwrap();
    let r = Renderer::new(&other, W as u32, H as u32).unwrap().seed(3);
    let mut cols = [Column::EMPTY; W];
    let mut stats = Stats::default();
    let mut want = [[Rgb565::new(0, 0, 0); W]; H];
    denoise::denoise_with(
        &r,
        |x, y| pixel_moments(&r, 4, x, y, &mut stats),
        4,
        &mut cols,
        |_, _, _| {},
        |y, x, c| want[y as usize][x as usize] = Rgb565::from_encoded(tone_map(c, 1.0), x, y),
    )
    .unwrap();
    assert_eq!(panel.px, want);
}

#[test]
fn a_press_stops_the_pass_and_a_new_scene_starts_again_at_the_preview() {
    let mut scene = TestScene::EMPTY;
    let mut columns = [Column::EMPTY; W];
    let mut d = demo(&mut scene, &mut columns);
    let (mut panel, mut line) = (Panel::<H>::new(), [Rgb565::new(0, 0, 0); W]);
    let mut clock = Ticks { now: 0, step: 1 };
    for _ in 0..3 {
        d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None)
            .unwrap();
    }
    assert_eq!(d.pass(), 3);
    // raw, no status line, on a panel painted one colour: the poll before
    // pixel 5 of row 2 says "next scene"
    d.apply(Command::Denoise).unwrap();
    d.apply(Command::Status).unwrap();
    let sentinel = Rgb565::new(1, 2, 3);
    panel.px = [[sentinel; W]; H];
    let mut polls = 0;
    let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || {
        polls += 1;
        (polls == 2 * W + 6).then_some(Command::NextScene)
    });
    assert_eq!(step, Ok(Step::Interrupted(Command::NextScene)));
    assert_eq!(polls, 2 * W + 6, "no poll after the press");
    // rows 0 and 1 drawn, the rest as they were
    assert!(panel.px[..2].iter().flatten().all(|&c| c != sentinel));
    assert!(panel.px[2..].iter().flatten().all(|&c| c == sentinel));
    d.apply(Command::Denoise).unwrap();
    d.apply(Command::Status).unwrap();
    assert_eq!((d.pass(), d.settings().scene, d.last()), (0, 1, None));
    let mut second = TestScene::EMPTY;
    crate::parse::parse_into(ENTRIES[1].text, &mut second).unwrap();
    assert_eq!(d.scene().camera(), second.camera());
    // a new exposure shows the same pass again; the orbit starts again
    for _ in 0..2 {
        d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None)
            .unwrap();
    }
    d.apply(Command::Exposure).unwrap();
    assert_eq!((d.pass(), d.settings().exposure), (1, 1));
    d.apply(Command::Denoise).unwrap();
    assert_eq!((d.pass(), d.settings().raw), (1, true));
    let before = *d.scene().camera();
    d.apply(Command::Orbit).unwrap();
    assert_eq!(d.pass(), 0);
    assert_ne!(d.scene().camera().eye, before.eye);
    // and the last scene wraps to the first
    d.apply(Command::NextScene).unwrap();
    assert_eq!((d.settings().scene, d.settings().orbit), (0, 0));
}

#[test]
fn after_the_last_pass_the_image_stays() {
    let mut scene = TestScene::EMPTY;
    let mut columns = [Column::EMPTY; 2];
    let mut d: Demo<'_, 8, 8, 8> =
        Demo::new(&ENTRIES, &mut scene, &mut columns, (2, 2), 1, 0).unwrap();
    d.apply(Command::Denoise).unwrap();
    let (mut panel, mut line) = (Panel::<H>::new(), [Rgb565::new(0, 0, 0); 2]);
    let mut clock = Ticks { now: 0, step: 1 };
    for k in 0..=LAST_PASS {
        let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None);
        assert!(matches!(step, Ok(Step::Done(p)) if p.pass == k), "{step:?}");
    }
    let held = panel.px;
    for _ in 0..3 {
        let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None);
        assert_eq!(step, Ok(Step::Idle));
    }
    assert_eq!(panel.px, held);
    // a press, asked for while idle, starts over
    let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || {
        Some(Command::Orbit)
    });
    assert_eq!(step, Ok(Step::Interrupted(Command::Orbit)));
    assert_eq!(d.pass(), 0);
}

#[test]
fn the_status_line_gives_scene_budget_time_noise_and_mode() {
    let mut scene = TestScene::EMPTY;
    let mut columns = [Column::EMPTY; W];
    let mut d = demo(&mut scene, &mut columns);
    let (mut panel, mut line) = (Panel::<H>::new(), [Rgb565::new(0, 0, 0); W]);
    let mut text: heapless::String<64> = heapless::String::new();
    d.status(&mut text).unwrap();
    assert_eq!(text.as_str(), "spo preview dn");
    // each read of this clock is 8.1 s later: the pass takes 8.1 s
    let mut clock = Ticks {
        now: 0,
        step: 8_100_000,
    };
    d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None)
        .unwrap();
    let Ok(Step::Done(p)) = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None) else {
        panic!("the pass did not finish")
    };
    assert!(p.noise > 0.0 && p.noise < 10.0, "{p:?}");
    text.clear();
    d.status(&mut text).unwrap();
    let want_noise = {
        let mut s: heapless::String<16> = heapless::String::new();
        decimal(&mut s, (p.noise * 1000.0) as u64, 3, 3).unwrap();
        s
    };
    assert_eq!(
        text.as_str(),
        ["spo 2spp 8.1s err ", want_noise.as_str(), " dn"].concat()
    );
    d.apply(Command::Exposure).unwrap();
    d.apply(Command::Orbit).unwrap();
    text.clear();
    d.status(&mut text).unwrap();
    assert_eq!(text.as_str(), "spo preview dn x2 orbit 1/12");
    // drawn white on black over the last rows (status is on)
    d.draw_status(&mut panel).unwrap();
    let band = &panel.px[H - STATUS_HEIGHT as usize..];
    assert!(band.iter().flatten().any(|&c| c == Rgb565::new(31, 63, 31)));
    assert!(band.iter().flatten().any(|&c| c == Rgb565::new(0, 0, 0)));
}

#[test]
fn a_scene_that_does_not_parse_is_an_error_naming_its_line() {
    let bad = [Entry {
        name: "bad",
        text: "camera 0 0 4  0 0 0  0 1 0  40\nsphere 0 0 0 1 nowhere\n",
    }];
    let mut scene = TestScene::EMPTY;
    let mut columns = [Column::EMPTY; W];
    let e = Demo::new(&bad, &mut scene, &mut columns, (16, 12), 1, 0).unwrap_err();
    assert!(matches!(e, DemoError::Scene(0, p) if p.line == 2), "{e:?}");
    let mut text: heapless::String<128> = heapless::String::new();
    write!(text, "{e}").unwrap();
    assert!(text.starts_with("compiled-in scene 0: line 2: "), "{text}");
    let mut narrow = [Column::EMPTY; 4];
    let e = Demo::<8, 8, 8>::new(&ENTRIES, &mut scene, &mut narrow, (16, 12), 1, 0).unwrap_err();
    assert_eq!(e, DemoError::Workspace);
    let e = Demo::<8, 8, 8>::new(&[], &mut scene, &mut columns, (16, 12), 1, 0).unwrap_err();
    assert_eq!(e, DemoError::NoScenes);
}

#[test]
fn buttons_count_after_the_bounce_and_tell_short_from_long() {
    let mut b: Buttons<2> = Buttons::new();
    let ms = |t: u64| t * 1000;
    // contact bounce: readings that flip within the debounce time
    for (t, p) in [(0, true), (3, false), (6, true), (9, false)] {
        assert_eq!(b.update(ms(t), [p, false]), None);
    }
    assert_eq!(b.update(ms(40), [false, false]), None);
    // a clean 100 ms press of button 0: short, on release
    let mut events = [None; 300];
    for (t, e) in events.iter_mut().enumerate() {
        let t = 100 + t as u64;
        *e = b.update(ms(t), [(100..200).contains(&t), false]);
    }
    let got: heapless::Vec<Press, 4> = events.iter().flatten().copied().collect();
    assert_eq!(got.as_slice(), &[Press::Short(0)]);
    // button 1 held 900 ms: long once, at 600 ms, and its release is nothing
    let mut got: heapless::Vec<(u64, Press), 4> = heapless::Vec::new();
    for t in 1000..2200u64 {
        if let Some(e) = b.update(ms(t), [false, (1000..1900).contains(&t)]) {
            got.push((t, e)).unwrap();
        }
    }
    assert_eq!(got.as_slice(), &[(1600, Press::Long(1))]);
    // a press shorter than the debounce time is no press
    let mut none = true;
    for t in 3000..3100u64 {
        none &= b
            .update(ms(t), [(3000..3010).contains(&t), false])
            .is_none();
    }
    assert!(none);
}

#[test]
fn the_first_pass_starts_with_a_preview_of_one_pixel_per_block() {
    for n in [2, 4] {
        let mut scene = TestScene::EMPTY;
        let mut columns = [Column::EMPTY; W];
        let mut d = demo(&mut scene, &mut columns);
        d.set_preview_block(n as u32);
        d.apply(Command::Status).unwrap();
        let (mut panel, mut line) = (Panel::<H>::new(), [Rgb565::new(0, 0, 0); W]);
        let mut clock = Ticks { now: 0, step: 1 };
        // the press comes at the first poll after the preview's blocks: the
        // panel holds the whole preview
        let blocks = (W / n) * (H / n);
        let mut polls = 0;
        let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || {
            polls += 1;
            (polls == blocks + 1).then_some(Command::Orbit)
        });
        assert_eq!(step, Ok(Step::Interrupted(Command::Orbit)));
        let mut distinct = 0;
        for by in (0..H).step_by(n) {
            for bx in (0..W).step_by(n) {
                let c = panel.px[by][bx];
                for y in by..by + n {
                    for x in bx..bx + n {
                        assert_eq!(panel.px[y][x], c, "block ({bx}, {by}) of {n}");
                    }
                }
                distinct += usize::from(bx > 0 && c != panel.px[by][bx - n]);
            }
        }
        // an image, not a flat fill
        assert!(distinct > 0, "{n}");
        assert_eq!(d.pass(), 0);
    }
    // no preview: the first poll is pass 0's first pixel's
    let mut scene = TestScene::EMPTY;
    let mut columns = [Column::EMPTY; W];
    let mut d = demo(&mut scene, &mut columns);
    d.set_preview_block(1);
    let (mut panel, mut line) = (Panel::<H>::new(), [Rgb565::new(0, 0, 0); W]);
    let mut clock = Ticks { now: 0, step: 1 };
    let mut polls = 0;
    let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || {
        polls += 1;
        None
    });
    assert!(matches!(step, Ok(Step::Done(p)) if p.pass == 0), "{step:?}");
    assert_eq!(polls, W * H);
}

#[test]
fn passes_stop_before_a_pixel_could_outlast_the_pixel_limit() {
    let mut scene = TestScene::EMPTY;
    let mut columns = [Column::EMPTY; 4];
    let mut d: Demo<'_, 8, 8, 8> =
        Demo::new(&ENTRIES, &mut scene, &mut columns, (4, 3), 1, 0).unwrap();
    let (mut panel, mut line) = (Panel::<H>::new(), [Rgb565::new(0, 0, 0); 4]);
    // every read of this clock is 1 ms later: each pixel is timed (two
    // reads) at 1 ms, whatever its samples; the next pass is started only
    // while 4 × 1 ms fits the limit
    let mut clock = Ticks {
        now: 0,
        step: 1_000,
    };
    d.set_pixel_limit(3_999);
    let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None);
    assert!(
        matches!(step, Ok(Step::Done(p)) if p.pass == 0 && p.slowest_us == 1_000),
        "{step:?}"
    );
    assert!(d.held());
    assert_eq!(
        d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None),
        Ok(Step::Idle)
    );
    // at 4 ms the next pass fits, and pass after pass is started
    d.set_pixel_limit(4_000);
    assert!(!d.held());
    let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None);
    assert!(matches!(step, Ok(Step::Done(p)) if p.pass == 1), "{step:?}");
    // a new exposure re-renders the pass shown (not held), a press while
    // held is applied
    d.set_pixel_limit(10);
    assert!(d.held());
    let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || {
        Some(Command::Exposure)
    });
    assert_eq!(step, Ok(Step::Interrupted(Command::Exposure)));
    assert!(!d.held());
    let step = d.step(&mut panel, &mut line, &mut OneCore, &mut clock, || None);
    assert!(matches!(step, Ok(Step::Done(p)) if p.pass == 1), "{step:?}");
    assert!(d.held());
}

#[test]
fn the_boards_note_is_drawn_above_the_status_line_and_cut_to_fit() {
    const TALL: usize = 2 * STATUS_HEIGHT as usize + 4;
    let mut scene = TestScene::EMPTY;
    let mut columns = [Column::EMPTY; W];
    let mut d: Demo<'_, 8, 8, 8> = Demo::new(
        &ENTRIES,
        &mut scene,
        &mut columns,
        (W as u32, TALL as u32),
        1,
        0,
    )
    .unwrap();
    let mut panel = Panel::<TALL>::new();
    let white = Rgb565::new(31, 63, 31);
    d.draw_status(&mut panel).unwrap();
    let above = TALL - 2 * STATUS_HEIGHT as usize..TALL - STATUS_HEIGHT as usize;
    assert!(
        !panel.px[above.clone()]
            .iter()
            .flatten()
            .any(|&c| c == white)
    );
    d.set_note("reset: watchdog");
    assert_eq!(d.note(), "reset: watchdog");
    d.draw_status(&mut panel).unwrap();
    assert!(panel.px[above].iter().flatten().any(|&c| c == white));
    let long = "x".repeat(NOTE_LEN + 5);
    d.set_note(&long);
    assert_eq!(d.note().len(), NOTE_LEN);
    d.set_note("");
    assert_eq!(d.note(), "");
}

/// A pixel source that counts its passes and checks they are bracketed.
#[derive(Default)]
struct Counted {
    begun: u32,
    ended: u32,
    open: bool,
    pixels: u32,
}

impl Pixels for Counted {
    fn begin(&mut self, _: &Renderer<'_>, _: u32) {
        assert!(!self.open, "begin without end");
        self.open = true;
        self.begun += 1;
    }

    fn moments(&mut self, r: &Renderer<'_>, spp: u32, x: u32, y: u32, s: &mut Stats) -> Moments {
        assert!(self.open, "a pixel outside a pass");
        self.pixels += 1;
        pixel_moments(r, spp, x, y, s)
    }

    fn end(&mut self) -> u64 {
        assert!(self.open, "end without begin");
        self.open = false;
        self.ended += 1;
        1000
    }
}

#[test]
fn every_pass_is_ended_before_its_renderer_goes_however_it_ends() {
    let mut scene = TestScene::EMPTY;
    let mut columns = [Column::EMPTY; W];
    let mut d = demo(&mut scene, &mut columns);
    let (mut panel, mut line) = (Panel::<H>::new(), [Rgb565::new(0, 0, 0); W]);
    let mut clock = Ticks { now: 0, step: 1 };
    let mut px = Counted::default();
    // finished: pass 0 and 1, the other core's paths counted
    for k in 0..2 {
        let step = d.step(&mut panel, &mut line, &mut px, &mut clock, || None);
        let Ok(Step::Done(p)) = step else {
            panic!("{step:?}")
        };
        assert_eq!(p.paths, 1000 + u64::from(pass_spp(1, k)) * (W * H) as u64);
    }
    // stopped by a press on the 5th pixel
    let mut polls = 0;
    let step = d.step(&mut panel, &mut line, &mut px, &mut clock, || {
        polls += 1;
        (polls == 5).then_some(Command::Exposure)
    });
    assert_eq!(step, Ok(Step::Interrupted(Command::Exposure)));
    // failed: a row buffer too short is refused before the pass begins,
    // a panel that refuses a row fails inside it
    struct Refusing;
    impl embedded_graphics::geometry::OriginDimensions for Refusing {
        fn size(&self) -> Size {
            Size::new(W as u32, H as u32)
        }
    }
    impl DrawTarget for Refusing {
        type Color = Rgb565;
        type Error = ();
        fn draw_iter<I: IntoIterator<Item = Pixel<Rgb565>>>(&mut self, _: I) -> Result<(), ()> {
            Err(())
        }
    }
    let step = d.step(&mut Refusing, &mut line, &mut px, &mut clock, || None);
    assert_eq!(step, Err(DemoError::Draw));
    assert_eq!((px.begun, px.ended, px.open), (4, 4, false));
    assert!(px.pixels > 0);
}
