//! The shared-core executor (`micropt::multicore`): cores on std threads give
//! the single-core budget executor's image bit for bit, and between them
//! trace exactly its samples and paths.

use embedded_graphics::framebuffer::{Framebuffer, buffer_size};
use embedded_graphics::pixelcolor::Rgb565;
use embedded_graphics::pixelcolor::raw::{BigEndian, RawU16};
use micropt::budget::{Clock, Summary, TileAccum, budget_samples, render_budget, tile_share};
use micropt::film::{tile_at, tile_count};
use micropt::multicore::{
    AtomicQueue, DealtQueue, Pass, SharedError, SharedFramebuffer, WorkQueue, render_shared,
    wait_all,
};
use micropt::{AdaptiveOptions, Budget, Renderer};
use micropt_host::reference::scenes_dir;
use micropt_host::render::{HostScene, load_scene};

const W: usize = 40;
const H: usize = 27;
type Fb = Framebuffer<Rgb565, RawU16, BigEndian, W, H, { buffer_size::<Rgb565>(W, H) }>;

fn scene(name: &str) -> Box<HostScene> {
    load_scene(&scenes_dir().join(format!("{name}.scene"))).unwrap()
}

/// A clock that never moves (sample budgets read it only for the summary).
struct Still;
impl Clock for Still {
    fn micros(&mut self) -> u64 {
        0
    }
}

/// A queue on a thread, yielding the thread while waiting: the shared
/// counter, or the tiles dealt out in turn; `slow` makes one core sleep
/// before each take, so that with the counter the other takes most tiles.
struct Threads<'a> {
    queue: &'a AtomicQueue,
    dealt: Option<DealtQueue<'a>>,
    slow: bool,
}

impl WorkQueue for Threads<'_> {
    fn take(&self, pass: Pass) -> usize {
        if self.slow {
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        match &self.dealt {
            Some(d) => d.take(pass),
            None => self.queue.take(pass),
        }
    }
    fn done(&self, pass: Pass) {
        self.queue.done(pass)
    }
    fn all_done(&self, pass: Pass) -> bool {
        self.queue.all_done(pass)
    }
    fn idle(&self) {
        std::thread::yield_now();
    }
}

/// How the cores of a test share the tiles.
#[derive(Clone, Copy, Debug)]
enum Split {
    /// The shared counter (`AtomicQueue`).
    Counter,
    /// Dealt out in turn (`DealtQueue`).
    Dealt,
}

/// Renders on `cores` threads (core 0 slow if `slow`); the image's bytes
/// and the summaries of the cores.
fn shared(
    r: &Renderer<'_>,
    budget: Budget,
    opts: &AdaptiveOptions,
    (cores, split, slow): (usize, Split, bool),
) -> (Vec<u8>, Vec<Summary>) {
    let fb = SharedFramebuffer::<{ W * H }>::new(W as u32, H as u32);
    let queue = AtomicQueue::new(cores);
    let sums = std::thread::scope(|s| {
        let handles: Vec<_> = (0..cores)
            .map(|c| {
                let (fb, queue) = (&fb, &queue);
                s.spawn(move || {
                    let q = Threads {
                        queue,
                        dealt: matches!(split, Split::Dealt).then(|| DealtQueue::new(queue, c)),
                        slow: slow && c == 0,
                    };
                    let mut acc = TileAccum::new();
                    let mut target = fb;
                    let sum = render_shared(r, budget, opts, &mut acc, &q, &mut target, 1.0);
                    wait_all(&q, Pass::Refine);
                    sum.unwrap()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap())
            .collect::<Vec<_>>()
    });
    (fb.bytes_be().collect(), sums)
}

#[test]
fn cores_on_threads_draw_the_single_core_image_bit_for_bit() {
    for (name, budget, adaptive, seed) in [
        ("cornell", Budget::Spp(5), true, 0),
        (
            "spheres",
            Budget::Paths(W as u64 * H as u64 * 3 + 77),
            true,
            3,
        ),
        ("cornell", Budget::Spp(3), false, 1),
        // no refinement: every tile's sample 0 recomputed over its coarse
        // preview
        ("cornell", Budget::Spp(1), true, 2),
    ] {
        let s = scene(name);
        let r = Renderer::new(&s, W as u32, H as u32).unwrap().seed(seed);
        let opts = AdaptiveOptions {
            adaptive,
            ..AdaptiveOptions::default()
        };
        let mut fb = Fb::new();
        let one = render_budget(
            &r,
            budget,
            &opts,
            &mut TileAccum::new(),
            &mut Still,
            &mut fb,
            1.0,
        )
        .unwrap();
        for run in [
            (1, Split::Counter, false),
            (2, Split::Counter, false),
            (2, Split::Counter, true),
            (3, Split::Counter, false),
            (2, Split::Dealt, true),
            (3, Split::Dealt, false),
        ] {
            let (cores, split, slow) = run;
            let (bytes, sums) = shared(&r, budget, &opts, run);
            let what = format!(
                "{name} {budget:?} adaptive {adaptive}: {cores} cores, {split:?}, slow {slow}"
            );
            assert_eq!(bytes.as_slice(), fb.data(), "{what}");
            let samples: u64 = sums.iter().map(|s| s.samples).sum();
            let paths: u64 = sums.iter().map(|s| s.stats.paths).sum();
            assert_eq!((samples, paths), (one.samples, one.stats.paths), "{what}");
            match (split, slow) {
                // the other core took tiles while the slow one slept: the
                // split was not the single core's
                (Split::Counter, true) => {
                    assert!(sums[1].stats.paths > sums[0].stats.paths, "{what}")
                }
                // dealt out: each core traced its own tiles' samples (the
                // preview and the tile's share), whatever the timing
                (Split::Dealt, _) => {
                    let total = budget_samples(&budget, W as u32, H as u32).unwrap();
                    let extra = total - (W * H) as u64;
                    for (k, sum) in sums.iter().enumerate() {
                        let own: u64 = (k..tile_count(W as u32, H as u32))
                            .step_by(cores)
                            .map(|i| {
                                let t = tile_at(W as u32, H as u32, i).unwrap();
                                t.len() as u64 + tile_share(W as u32, H as u32, extra, i)
                            })
                            .sum();
                        assert_eq!(sum.samples, own, "{what}: core {k}");
                    }
                }
                _ => {}
            }
        }
    }
}

#[test]
fn a_deadline_is_refused_by_every_core() {
    let s = scene("cornell");
    let r = Renderer::new(&s, 16, 16).unwrap();
    let fb = SharedFramebuffer::<256>::new(16, 16);
    let q = AtomicQueue::new(2);
    let got = render_shared(
        &r,
        Budget::Deadline(1000),
        &AdaptiveOptions::default(),
        &mut TileAccum::new(),
        &q,
        &mut &fb,
        1.0,
    );
    assert_eq!(got, Err(SharedError::Deadline));
    // nothing taken, nothing drawn
    assert_eq!(q.take(Pass::Preview), 0);
    assert!(fb.bytes_be().all(|b| b == 0));
}
