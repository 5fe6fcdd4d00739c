//! The denoiser on the shipped scenes and on five scenes written for it
//! (`host-tests/data/denoise/`: glass balls and their caustics, GGX metals
//! under coloured lights, a thin lens, a room with a tiny light, glass and
//! mirror under a sky and a sun, each with its own Mitsuba 3.9.1
//! reference): the same bits with any number of threads, and a
//! whole-image MSE never above the raw image's, at 16 and at 1024 samples
//! per pixel.

use micropt::Options;
use micropt_host::Image;
use micropt_host::metrics::compare;
use micropt_host::reference::{Reference, data_dir, names, scenes_dir};
use micropt_host::render::{DenoisedOutput, RenderJob, load_scene, render_denoised};
use std::path::Path;

fn denoised(name: &str, w: u32, h: u32, spp: u32, seed: u64, threads: usize) -> DenoisedOutput {
    denoised_file(
        &scenes_dir().join(format!("{name}.scene")),
        w,
        h,
        spp,
        seed,
        threads,
    )
}

fn denoised_file(
    path: &Path,
    w: u32,
    h: u32,
    spp: u32,
    seed: u64,
    threads: usize,
) -> DenoisedOutput {
    let scene = load_scene(path).unwrap();
    let job = RenderJob {
        width: w,
        height: h,
        spp,
        seed,
        threads,
        options: Options::default(),
    };
    render_denoised(&scene, &job, &|| {}).unwrap()
}

/// MSE over all pixels and channels (the harness's metric).
fn mse(a: &Image, b: &Image) -> f64 {
    compare(a, b).unwrap().mse
}

#[test]
fn the_denoised_image_does_not_depend_on_the_threads() {
    for name in ["cornell", "gloss", "many"] {
        let one = denoised(name, 40, 30, 8, 3, 1);
        let two = denoised(name, 40, 30, 8, 3, 2);
        let bits = |i: &Image| -> Vec<u32> {
            i.pixels
                .iter()
                .flat_map(|c| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()])
                .collect()
        };
        assert_eq!(bits(&one.image), bits(&two.image), "{name}");
        assert_eq!(bits(&one.raw), bits(&two.raw), "{name}");
    }
}

#[test]
fn rendering_each_pixel_as_the_denoiser_asks_gives_the_whole_frames_bits() {
    // a board keeps no frame of moments: `denoise_with` renders each pixel
    // when the rings need it. Same samples, same sums, same filter: the
    // same bits as the host's whole-frame path
    use micropt::denoise::{self, Column, Moments};
    for name in ["cornell", "dof", "many"] {
        let (w, h, spp, seed) = (37, 23, 8, 5);
        let whole = denoised(name, w, h, spp, seed, 2);
        let scene = load_scene(&scenes_dir().join(format!("{name}.scene"))).unwrap();
        let renderer = micropt::Renderer::new(&scene, w, h).unwrap().seed(seed);
        let mut columns = vec![Column::EMPTY; w as usize];
        let mut streamed = Image::new(w, h);
        let mut stats = micropt::Stats::default();
        let mut order = Vec::new();
        denoise::denoise_with(
            &renderer,
            |x, y| {
                order.push((y, x));
                let pixel = renderer.pixel(x, y);
                let mut m = Moments::ZERO;
                for k in 0..spp {
                    m.add(
                        renderer.sample_parts_in(&pixel, x, y, k, &mut stats),
                        k < spp / 2,
                    );
                }
                m
            },
            spp,
            &mut columns,
            |_, _, _| {},
            |y, x, c| streamed.set(x, y, c),
        )
        .unwrap();
        // each pixel asked for once, row by row
        let expected: Vec<(u32, u32)> = (0..h).flat_map(|y| (0..w).map(move |x| (y, x))).collect();
        assert_eq!(order, expected, "{name}");
        let bits = |i: &Image| -> Vec<u32> {
            i.pixels
                .iter()
                .flat_map(|c| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()])
                .collect()
        };
        assert_eq!(bits(&streamed), bits(&whole.image), "{name}");
    }
}

/// Denoised and raw MSE against the reference at `spp`, seed 0: the
/// denoised may not be above the raw. MSE against a reference is the true
/// MSE plus the reference's own noise (the same for both) plus a cross
/// term `2 mean((x − truth)(truth − ref))`, whose difference between the two
/// images has a standard deviation of `2 √(Σ (denoised − raw)² se²) / N`
/// over the N pixel channels, `se` the reference's standard error there:
/// from its map where it has one (`NAME.se.pfm`), else its RMS over the
/// image. The allowance is 4 of those.
fn never_worse(spp: u32) {
    let mut cases: Vec<(String, std::path::PathBuf, Image, Option<Image>, f64)> = names()
        .into_iter()
        .map(|name| {
            let r = Reference::load(&name).unwrap();
            let path = r.scene_path();
            let se = Image::load_pfm(&data_dir().join(format!("{name}.se.pfm"))).ok();
            (name, path, r.image, se, r.rms_standard_error)
        })
        .collect();
    let extra = data_dir().join("denoise");
    for name in ["caustics", "metals", "lens", "room", "mix"] {
        let json: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(extra.join(format!("{name}.json"))).unwrap(),
        )
        .unwrap();
        let se = json["rms_standard_error"].as_f64().unwrap();
        let image = Image::load_pfm(&extra.join(format!("{name}.pfm"))).unwrap();
        let map = Image::load_pfm(&extra.join(format!("{name}.se.pfm"))).ok();
        cases.push((
            name.into(),
            extra.join(format!("{name}.scene")),
            image,
            map,
            se,
        ));
    }
    for (name, path, reference, se_map, rms_se) in cases {
        let out = denoised_file(&path, reference.width, reference.height, spp, 0, 0);
        let raw = mse(&out.raw, &reference);
        let dn = mse(&out.image, &reference);
        let n = (3 * reference.pixels.len()) as f64;
        let weighted: f64 = out
            .image
            .pixels
            .iter()
            .zip(&out.raw.pixels)
            .enumerate()
            .map(|(i, (d, r))| {
                let e = se_map.as_ref().map_or(
                    micropt::Color::new(rms_se as f32, rms_se as f32, rms_se as f32),
                    |m| m.pixels[i],
                );
                let v = *d - *r;
                [(v.x, e.x), (v.y, e.y), (v.z, e.z)]
                    .iter()
                    .map(|&(v, e)| f64::from(v) * f64::from(v) * f64::from(e) * f64::from(e))
                    .sum::<f64>()
            })
            .sum();
        let allowance = 4.0 * 2.0 * weighted.sqrt() / n;
        println!(
            "{name} {spp} spp: MSE raw {raw:.4e}, denoised {dn:.4e} (allowance {allowance:.1e})"
        );
        assert!(
            dn <= raw + allowance,
            "{name} at {spp} spp: denoised MSE {dn:.4e} above the raw image's {raw:.4e} (+{allowance:.1e})"
        );
    }
}

#[test]
fn at_16_spp_the_mse_is_never_above_the_raw_images() {
    never_worse(16);
}

#[test]
fn at_1024_spp_the_filter_backs_off_and_the_mse_is_not_above_the_raw_images() {
    never_worse(1024);
}

/// dof at 64 spp, seed 0: the caustic under the glass ball falls on the
/// checker floor, and one dark square's pixel holds a rare bright path.
/// The filters average radiance over albedo, where that firefly weighs 8
/// times its radiance (albedo 0.1 against 0.8): compared in radiance it
/// was no outlier, and spread into the light squares beside it it made
/// the image's MSE 1.49 times the raw one's. Compared in the filters'
/// domain it is left out.
#[test]
fn a_firefly_on_a_dark_texel_is_an_outlier_in_the_filters_domain() {
    let r = Reference::load("dof").unwrap();
    let path = scenes_dir().join("dof.scene");
    let out = denoised_file(&path, r.image.width, r.image.height, 64, 0, 0);
    let raw = mse(&out.raw, &r.image);
    let dn = mse(&out.image, &r.image);
    println!("dof 64 spp seed 0: MSE raw {raw:.4e}, denoised {dn:.4e}");
    assert!(
        dn < raw,
        "denoised MSE {dn:.4e} above the raw image's {raw:.4e}"
    );
}

/// The guides of a `w × h` render of scene `text`, row-major.
fn guides(text: &str, w: u32, h: u32) -> Vec<micropt::denoise::Guide> {
    let scene = micropt_host::render::parse_host(text).unwrap();
    let renderer = micropt::Renderer::new(&scene, w, h).unwrap();
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| micropt::denoise::guide(&renderer, x, y))
        .collect()
}

#[test]
fn the_guide_tells_a_hard_shadow_from_the_lit_floor() {
    // a floor seen from straight above, a small light at (4, 5, 0) and a
    // ball at (2, 2.5, 0) on the line from the light to the floor's
    // origin: the image's centre is in the ball's shadow. Albedo, normal
    // and object are the floor's everywhere but on the ball; only the
    // visibility of the light tells the shadow's pixels from the lit ones
    let text = "camera 0 10 0   0 0 0   0 0 -1   60\n\
                material floor diffuse 0.5 0.5 0.5\n\
                material grey diffuse 0.5 0.5 0.5\n\
                material lamp light 50 50 50\n\
                plane 0 0 0   0 1 0   floor\n\
                sphere 4 5 0   0.2   lamp\n\
                sphere 2 2.5 0   0.5   grey\n";
    let (w, h) = (64, 64);
    let g = guides(text, w, h);
    let at = |x: u32, y: u32| g[(y * w + x) as usize];
    let shadow = at(32, 32);
    let lit = [at(7, 7), at(57, 57), at(7, 57), at(57, 7)];
    for l in lit {
        assert_eq!(l.key, lit[0].key, "lit floor pixels share a key");
        assert_eq!((l.albedo, l.normal), (shadow.albedo, shadow.normal));
    }
    assert_ne!(
        shadow.key, lit[0].key,
        "the shadow's key is the lit floor's"
    );
    // the key changes where the light's centre goes behind the ball: an
    // ellipse of radii 1 (the ball's radius, twice as far from the light)
    // and 1.28 (the light's slant, 6.4 / 5), 4.0 square units at 5.5
    // pixels a unit: about 123 pixels
    let shadowed = g.iter().filter(|p| p.key == shadow.key).count();
    assert!(
        (100..=150).contains(&shadowed),
        "{shadowed} pixels in the shadow"
    );
}

#[test]
fn a_texture_edge_inside_a_pixel_is_blurred_with_the_mean_albedo() {
    // a checker of 1-unit squares seen from straight above, 8.8 pixels a
    // square: a pixel whose box holds a square's edge sees two albedos,
    // and its guide says so (the mean albedo, divided out by nobody);
    // a pixel inside a square keeps its square's albedo
    let text = "camera 0.01 10 0.01   0.01 0 0.01   0 0 -1   40\n\
                material floor checker 0.8 0.8 0.8   0.2 0.2 0.2   1\n\
                plane 0 0 0   0 1 0   floor\n";
    let (w, h) = (64, 64);
    let g = guides(text, w, h);
    let (mut blurred, mut sharp) = (0, 0);
    for p in &g {
        assert_eq!(p.kind, micropt::denoise::GuideKind::Surface);
        let a = p.albedo.x;
        if p.blurred {
            blurred += 1;
            assert!(a > 0.2 && a < 0.8, "a blurred pixel's albedo {a}");
        } else {
            sharp += 1;
            assert!(a == 0.8 || a == 0.2, "a sharp pixel's albedo {a}");
        }
    }
    // the guide looks 0.45 pixels either side of the centre: a square's
    // edge is seen from 0.9 of every 8.8 pixel columns and rows, about
    // 1 − (7.9/8.8)² = 19 % of the pixels
    let share = blurred as f64 / (blurred + sharp) as f64;
    assert!(
        (0.15..0.25).contains(&share),
        "{blurred} blurred of {}",
        g.len()
    );
}

#[test]
fn a_checker_far_out_of_focus_is_blurred() {
    // the same checker through a thin lens focused at 1 (the floor at 10,
    // the lens's radius 0.5): each pixel's samples spread over squares,
    // and the lens's rim sees other albedos than its centre almost
    // everywhere; in focus (at 10) the share is the pinhole's
    let scene = |focus: f32| {
        format!(
            "camera 0.01 10 0.01   0.01 0 0.01   0 0 -1   40   0.5 {focus}\n\
             material floor checker 0.8 0.8 0.8   0.2 0.2 0.2   1\n\
             plane 0 0 0   0 1 0   floor\n"
        )
    };
    let share = |focus: f32| {
        let g = guides(&scene(focus), 64, 64);
        g.iter().filter(|p| p.blurred).count() as f64 / g.len() as f64
    };
    let (blurred, sharp) = (share(1.0), share(10.0));
    assert!(blurred > 0.9, "out of focus: {blurred} blurred");
    assert!(sharp < 0.25, "in focus: {sharp} blurred");
}

/// A light out of focus behind a thin lens, and a red ball at `ball`.
fn lens_scene(ball: &str) -> String {
    format!(
        "camera 0 1 6   0 1 0   0 1 0   40   0.15 3\n\
         background 0.2 0.3 0.4\n\
         material grey diffuse 0.5 0.5 0.5\n\
         material red diffuse 0.7 0.2 0.1\n\
         material lamp light 30 30 20\n\
         plane 0 0 0   0 1 0   grey\n\
         sphere 0.4 1.3 -2   0.5   lamp\n\
         sphere {ball}   0.3   red\n"
    )
}

/// A lamp of radius 0.5 over a floor (sphere-over-plane), a tiny light
/// covering part of one pixel beside a large dim one, and a light out of
/// focus behind a thin lens (a ball beside it): the scenes whose lights'
/// edges the tests below find and measure.
fn edge_scenes() -> Vec<(&'static str, String)> {
    vec![
        (
            "lamp",
            "camera 0 3 6   0 0 0   0 1 0   45\n\
             material grey diffuse 0.5 0.5 0.5\n\
             material lamp light 8 8 8\n\
             plane 0 0 0   0 1 0   grey\n\
             sphere 0 2 0   0.5   lamp\n"
                .into(),
        ),
        (
            "tiny",
            "camera 0 1 6   0 1 0   0 1 0   40\n\
             material grey diffuse 0.5 0.5 0.5\n\
             material tiny light 4000 3000 2000\n\
             material big light 2 2 2\n\
             plane 0 0 0   0 1 0   grey\n\
             sphere 0.3 1.2 0   0.015   tiny\n\
             sphere -1 1.5 -2   0.6   big\n"
                .into(),
        ),
        ("lens", lens_scene("-1.2 0.3 1")),
    ]
}

/// The lens scene with the ball out of focus in front of the light,
/// hiding part of it: pixels where the ball's edge, not the light's,
/// divides the samples keep their raw values, and the rays that measure
/// the light must see the ball as the samples do.
fn occluded_scene() -> (&'static str, String) {
    ("occluded", lens_scene("0 1 2"))
}

/// Every pixel of a `w × h` render of `text` at `n` samples: its moments.
fn moments_of(
    renderer: &micropt::Renderer<'_>,
    n: u32,
) -> Vec<(u32, u32, micropt::denoise::Moments)> {
    let (w, h) = (renderer.width(), renderer.height());
    let mut stats = micropt::Stats::default();
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            (
                x,
                y,
                micropt::denoise::pixel_moments(renderer, n, x, y, &mut stats),
            )
        })
        .collect()
}

#[test]
fn every_pixel_whose_samples_both_see_and_miss_a_light_is_on_an_edge() {
    // the edge test decides from the geometry alone which pixels get their
    // lights measured; a pixel it misses keeps its raw value (unbiased,
    // but noisy). Conservative: every pixel whose 256 samples include
    // both rays that hit a light and rays that miss it is on an edge; and
    // tight: no more than 3 times as many pixels are
    use micropt::denoise::LightEdges;
    for (name, text) in edge_scenes() {
        let scene = micropt_host::render::parse_host(&text).unwrap();
        let renderer = micropt::Renderer::new(&scene, 64, 48).unwrap().seed(9);
        let edges = LightEdges::new(&renderer);
        let n = 256;
        let (mut mixed, mut crossed) = (0, 0);
        for (x, y, m) in moments_of(&renderer, n) {
            let on_edge = edges.crossed(&renderer, x, y).is_some();
            crossed += usize::from(on_edge);
            if m.seen > 0 && m.seen < n {
                mixed += 1;
                assert!(
                    on_edge,
                    "{name}: pixel ({x}, {y}) is mixed and not on an edge"
                );
            }
        }
        println!("{name}: {mixed} mixed pixels, {crossed} on edges");
        assert!(mixed > 0, "{name}: no light's edge in the image");
        assert!(
            crossed <= 3 * mixed,
            "{name}: {crossed} pixels on edges, {mixed} mixed"
        );
    }
}

#[test]
fn the_measured_coverage_is_the_part_of_the_pixels_that_sees_a_light() {
    // the rays that measure a pixel's lights and the render's samples ask
    // the same question of their camera rays: over the edge pixels, the
    // measured coverage and the samples' share that hit a light estimate
    // the same area. Their variances are at most the binomial c(1 − c)/N
    // (the nets stratify), so the sums agree within 4 of those
    use micropt::denoise::{LightEdges, SeenLights};
    for (name, text) in edge_scenes().into_iter().chain([occluded_scene()]) {
        let scene = micropt_host::render::parse_host(&text).unwrap();
        let renderer = micropt::Renderer::new(&scene, 64, 48).unwrap().seed(4);
        let edges = LightEdges::new(&renderer);
        let n = 1024;
        let (mut measured, mut sampled, mut var) = (0.0f64, 0.0f64, 0.0f64);
        for (x, y, m) in moments_of(&renderer, n) {
            if edges.crossed(&renderer, x, y).is_none() {
                continue;
            }
            let c = f64::from(SeenLights::measure(&renderer, x, y, n).coverage);
            let k = f64::from(m.seen) / f64::from(n);
            measured += c;
            sampled += k;
            var += c * (1.0 - c) * (1.0 / f64::from(n) + 1.0 / f64::from(4 * n));
        }
        let z = (measured - sampled) / var.sqrt().max(1e-9);
        println!("{name}: coverage measured {measured:.3}, sampled {sampled:.3} pixels, z {z:.2}");
        assert!(
            z.abs() <= 4.0,
            "{name}: measured {measured}, sampled {sampled}"
        );
    }
}

#[test]
fn a_lights_edge_is_measured_unbiased_and_quieter_than_sampled() {
    // the denoised image's pixels that hold a light's edge (at least a
    // tenth of the pixel is light, measured with 16,384 rays of another
    // seed) are the raw mean with the lights' share replaced by the
    // measured one (control variates with mean zero): over 32 seeds at 16
    // spp their mean is the pixel's value (each pixel within 4.5 standard
    // errors of the seeds' spread of a 16,384-spp raw render, the sum of
    // their differences within 4), and their squared error against that
    // render is under a quarter of the raw image's
    use micropt::denoise::{LightEdges, SeenLights};
    for (name, text) in edge_scenes().into_iter().chain([occluded_scene()]) {
        let scene = micropt_host::render::parse_host(&text).unwrap();
        let (w, h) = (48, 36);
        let job = |spp: u32, seed: u64| RenderJob {
            width: w,
            height: h,
            spp,
            seed,
            threads: 0,
            options: Options::default(),
        };
        let truth = micropt_host::render::render(&*scene, &job(16_384, 99), &|| {})
            .unwrap()
            .image;
        let renderer = micropt::Renderer::new(&scene, w, h).unwrap().seed(1000);
        let edges = LightEdges::new(&renderer);
        let edge: Vec<usize> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                edges.crossed(&renderer, x, y).is_some()
                    && !renderer.has_highlights(x, y)
                    && SeenLights::measure(&renderer, x, y, 4096).coverage >= 0.1
            })
            .map(|(x, y)| (y * w + x) as usize)
            .collect();
        assert!(
            edge.len() >= 10,
            "{name}: {} pixels hold a light's edge",
            edge.len()
        );
        let seeds = 32;
        let (mut sum, mut sum2) = (vec![0.0f64; edge.len()], vec![0.0f64; edge.len()]);
        let (mut err_dn, mut err_raw) = (0.0f64, 0.0f64);
        for seed in 0..seeds {
            let out = render_denoised(&scene, &job(16, seed), &|| {}).unwrap();
            for (j, &i) in edge.iter().enumerate() {
                let (d, r, t) = (out.image.pixels[i], out.raw.pixels[i], truth.pixels[i]);
                let v = f64::from(d.luminance());
                sum[j] += v;
                sum2[j] += v * v;
                let sq = |a: micropt::Color| {
                    let e = a - t;
                    f64::from(e.dot(e))
                };
                err_dn += sq(d);
                err_raw += sq(r);
            }
        }
        let s = f64::from(seeds as u32);
        let (mut total, mut total_var, mut worst) = (0.0, 0.0, 0.0f64);
        for (j, &i) in edge.iter().enumerate() {
            let mean = sum[j] / s;
            let var = ((sum2[j] / s - mean * mean) * s / (s - 1.0)).max(0.0) / s;
            let diff = mean - f64::from(truth.pixels[i].luminance());
            total += diff;
            total_var += var;
            if var > 0.0 {
                worst = worst.max(diff.abs() / var.sqrt());
            }
        }
        let z = total / total_var.sqrt().max(1e-12);
        println!(
            "{name}: {} edge pixels, summed z {z:.2}, worst pixel z {worst:.2}, squared error denoised / raw {:.3}",
            edge.len(),
            err_dn / err_raw
        );
        assert!(z.abs() <= 4.0, "{name}: edge pixels biased (z {z})");
        assert!(worst <= 4.5, "{name}: an edge pixel biased (z {worst})");
        assert!(
            err_dn < 0.25 * err_raw,
            "{name}: {err_dn} against raw {err_raw}"
        );
    }
}

/// A Lambertian checker (squares of side 1) under a uniform sky and
/// nothing else, seen from 10 above through a lens of radius 0.5 focused
/// at `focus`, 32 x 24 pixels at 16 samples over 8 seeds: the MSE of the
/// raw and of the denoised images against a 4,096-sample render, and the
/// denoised image's mean error in its standard errors. The plane sees only
/// sky, so every sample is its albedo times the sky's radiance (the
/// furnace's law for a plane), and a pixel's noise is which squares its
/// samples saw.
fn defocused_checker(focus: f32) -> (f64, f64, f64) {
    let text = format!(
        "camera 0.01 10 0.01   0.01 0 0.01   0 0 -1   40   0.5 {focus}\n\
         background 0.5 0.5 0.5\n\
         material floor checker 0.8 0.8 0.8   0.2 0.2 0.2   1\n\
         plane 0 0 0   0 1 0   floor\n"
    );
    let scene = micropt_host::render::parse_host(&text).unwrap();
    let job = |spp, seed| RenderJob {
        width: 32,
        height: 24,
        spp,
        seed,
        threads: 0,
        options: Options::default(),
    };
    let truth = render_denoised(&scene, &job(4096, 1000), &|| {})
        .unwrap()
        .raw;
    let (mut raw, mut dn, mut error) = (0.0f64, 0.0f64, Vec::new());
    let seeds = 8;
    for seed in 0..seeds {
        let out = render_denoised(&scene, &job(16, seed), &|| {}).unwrap();
        raw += mse(&out.raw, &truth) / seeds as f64;
        dn += mse(&out.image, &truth) / seeds as f64;
        error.extend(
            out.image
                .pixels
                .iter()
                .zip(&truth.pixels)
                .map(|(d, t)| f64::from(d.y - t.y)),
        );
    }
    let n = error.len() as f64;
    let mean = error.iter().sum::<f64>() / n;
    let sd = (error.iter().map(|b| (b - mean) * (b - mean)).sum::<f64>() / (n - 1.0)).sqrt();
    // a pixel's 8 seeds share its truth's error: the mean's standard
    // error, conservatively, as if only the 32 x 24 pixels were independent
    let z = mean / (sd / (n / seeds as f64).sqrt());
    println!(
        "checker focused at {focus}: MSE raw {raw:.3e}, denoised {dn:.3e} ({:.1}x), mean error {mean:.2e} (z {z:.2})",
        raw / dn
    );
    (raw, dn, z)
}

/// The squared error that a pixel's albedo measured with 4n rays leaves,
/// over the n samples' own, where each ray and sample sees a square as
/// if at random, with the truth's own noise (4,096 samples):
/// (1/64 + 1/4096) / (1/16 + 1/4096). (Both are stratified nets, each
/// better than random by its own factor: the ratio is a guide, not a
/// bound.)
const MEASURED_OVER_SAMPLED: f64 = 0.265;

#[test]
fn a_checker_slightly_out_of_focus_is_its_measured_albedo_times_the_sky() {
    // focused at 20 (the circle of confusion on the floor half a square
    // across): squares differ from pixel to pixel, and a blurred pixel's
    // value is its measured albedo times the light on the floor (its
    // samples' radiance over their own albedos, exactly the sky here):
    // unbiased, and the measured albedo's error alone. At least 85 % of
    // the predicted gain
    let (raw, dn, z) = defocused_checker(20.0);
    assert!(
        dn * 0.85 < raw * MEASURED_OVER_SAMPLED,
        "raw {raw:.3e}, denoised {dn:.3e}"
    );
    assert!(z.abs() < 4.0, "z {z:.2}");
}

#[test]
fn a_checker_far_out_of_focus_is_smoothed_as_it_is() {
    // focused at 1 (the circle of confusion 9 squares across): pixels do
    // not tell the squares apart and the image is flat. Its pixels are
    // smoothed as they are, with each other, which averages their
    // squares' noise over the widest filter's neighbours (about 44: its
    // Gaussian weights' effective count, 6.7 a side): better than the
    // ratio estimate's 1 / MEASURED_OVER_SAMPLED = 3.77, which measured
    // albedos would leave. At least twice that (measured: 16.3 times less
    // than raw; as the ratio estimate, 3.7)
    let (raw, dn, z) = defocused_checker(1.0);
    assert!(
        dn * 2.0 < raw * MEASURED_OVER_SAMPLED,
        "raw {raw:.3e}, denoised {dn:.3e}"
    );
    assert!(z.abs() < 4.0, "z {z:.2}");
}
