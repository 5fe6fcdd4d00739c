//! The thin-lens camera (scene format version 2) against the laws of a thin
//! lens and the pinhole it generalises: every ray through one film position
//! meets the plane of focus in one point, and on a plane at another depth
//! `z` they spread over the circle of confusion of radius
//! `aperture · |z − focus| / focus`; lens positions are uniform over the
//! disk; radiance is constant along rays, so a uniform sky seen through a
//! lens is still uniform and a furnace is still a furnace; and aperture 0 is
//! the pinhole, bit for bit.

mod common;

use common::{D3, cross, d3, dot, len, normalize, sub};
use micropt::parse::parse;
use micropt::{Camera, CameraSpec, Options, Ray, Renderer, Stats, Vec3};
use micropt_host::reference::{scenes_dir, shipped_scenes};
use micropt_host::render::parse_host;

/// Where `ray` meets the plane perpendicular to the unit `forward` at
/// distance `z` from `eye` (in f64, from the f32 ray).
fn at_depth(ray: Ray, eye: D3, forward: D3, z: f64) -> D3 {
    let (o, d) = (d3(ray.origin), d3(ray.dir));
    let t = (z - dot(sub(o, eye), forward)) / dot(d, forward);
    [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]]
}

/// A camera looking along no axis (so that no coordinate is special), with
/// a lens of radius 0.3 focused at 5.
fn tilted() -> CameraSpec {
    CameraSpec::pinhole(
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(-0.5, 0.25, -1.5),
        Vec3::new(0.0, 1.0, 0.0),
        40.0,
    )
    .lens(0.3, 5.0)
}

/// Thin-lens law: rays through one film position from every lens position
/// converge on the plane of focus (spread zero up to f32 rounding), and on
/// a plane at depth z they fill the disk of radius A·|z − F|/F around the
/// pinhole ray's point there: none outside it, some at its rim, and their
/// mean squared distance from its centre R²/2 (a uniform disk's).
#[test]
fn a_point_in_focus_is_sharp_and_the_blur_elsewhere_is_the_circle_of_confusion() {
    let spec = tilted();
    let (a, f) = (f64::from(spec.aperture), f64::from(spec.focus));
    let (w, h) = (32, 24);
    let cam = Camera::new(&spec, w, h).unwrap();
    let pin = Camera::new(
        &CameraSpec {
            aperture: 0.0,
            ..spec
        },
        w,
        h,
    )
    .unwrap();
    let eye = d3(spec.eye);
    let forward = d3(cam.forward());
    // a 64 × 64 grid of cell centres of the unit square: every lens
    // position's ring is covered, the outermost at 63/64 of the radius
    let n = 64;
    let grid: Vec<[f32; 2]> = (0..n * n)
        .map(|i| {
            let c = |k: u32| (k as f32 + 0.5) / n as f32;
            [c(i % n), c(i / n)]
        })
        .collect();
    let mut worst_focus: f64 = 0.0;
    for (fx, fy) in [(0.0, 0.0), (16.0, 12.0), (31.5, 3.25), (32.0, 24.0)] {
        for z in [f, 0.25 * f, 0.5 * f, 2.0 * f, 4.0 * f] {
            let centre = at_depth(pin.ray(fx, fy), eye, forward, z);
            let dists: Vec<f64> = grid
                .iter()
                .map(|&l| {
                    len(sub(
                        at_depth(cam.lens_ray(fx, fy, l), eye, forward, z),
                        centre,
                    ))
                })
                .collect();
            let max = dists.iter().cloned().fold(0.0, f64::max);
            // f32 rounding of the points (magnitude ≲ |eye| + 2z): a few ulps
            let rounding = 8.0 * f64::from(f32::EPSILON) * (len(eye) + 2.0 * z);
            if z == f {
                worst_focus = worst_focus.max(max);
                assert!(max <= rounding, "({fx}, {fy}) in focus: spread {max:e}");
                continue;
            }
            let r = a * (z - f).abs() / f;
            assert!(max <= r + rounding, "({fx}, {fy}) z {z}: {max} > {r}");
            assert!(max >= r * 62.0 / 64.0, "({fx}, {fy}) z {z}: {max} < {r}");
            let mean2 = dists.iter().map(|d| d * d).sum::<f64>() / dists.len() as f64;
            // the grid's deviation from the continuous 1/2 is O(1/n²)
            assert!(
                (mean2 / (r * r) - 0.5).abs() < 1e-3,
                "({fx}, {fy}) z {z}: mean r² {} R²",
                mean2 / (r * r)
            );
        }
    }
    common::figure(
        "lens_focus",
        "largest spread on the plane of focus (world units, focus 5)",
        format!("{worst_focus:e}"),
    );
}

/// The renderer's lens positions are uniform over the disk of radius A in
/// the plane through the eye perpendicular to the view direction: mean
/// squared radius A²/2, mean offset 0, a quarter of them within A/2;
/// stratified or not. Tolerances: 4 standard errors of independent
/// samples (the stratified ones do better).
#[test]
fn lens_positions_are_uniform_over_the_disk() {
    let spec = tilted();
    let scene = parse(&format!(
        "camera {} {} {}  {} {} {}  0 1 0  40  {} {}\n",
        spec.eye.x,
        spec.eye.y,
        spec.eye.z,
        spec.target.x,
        spec.target.y,
        spec.target.z,
        spec.aperture,
        spec.focus
    ))
    .unwrap();
    let a = f64::from(spec.aperture);
    let eye = d3(spec.eye);
    for stratified in [true, false] {
        let options = Options {
            stratified,
            ..Options::default()
        };
        let r = Renderer::new(&scene, 16, 12)
            .unwrap()
            .seed(3)
            .options(options);
        let forward = d3(r.camera().forward());
        let n = 1 << 14;
        let (mut r2, mut sx, mut sy, mut inner) = (0.0, 0.0, 0.0, 0u32);
        // the lens' axes: the image's right and up directions
        let right = normalize(cross(forward, [0.0, 1.0, 0.0]));
        let up = cross(right, forward);
        for k in 0..n {
            let ray = r.camera_ray(5, 7, k);
            let o = sub(d3(ray.origin), eye);
            assert!(dot(o, forward).abs() < 1e-6, "off the lens plane: {o:?}");
            let rho = len(o);
            assert!(rho <= a * (1.0 + 1e-6), "outside the lens: {rho}");
            r2 += rho * rho / (a * a);
            sx += dot(o, right) / a;
            sy += dot(o, up) / a;
            inner += u32::from(rho < 0.5 * a);
        }
        let nf = f64::from(n);
        // r²/A² is uniform on [0, 1] (variance 1/12); x/A has variance 1/4;
        // within A/2 is a Bernoulli trial of p = 1/4
        let checks = [
            ("mean r²/A²", r2 / nf, 0.5, (1.0 / 12.0 / nf).sqrt()),
            ("mean x/A", sx / nf, 0.0, (0.25 / nf).sqrt()),
            ("mean y/A", sy / nf, 0.0, (0.25 / nf).sqrt()),
            (
                "share within A/2",
                f64::from(inner) / nf,
                0.25,
                (0.25 * 0.75 / nf).sqrt(),
            ),
        ];
        for (what, got, want, sigma) in checks {
            assert!(
                (got - want).abs() < 4.0 * sigma,
                "stratified {stratified}: {what} = {got}, expected {want} ± 4 × {sigma:e}"
            );
        }
    }
}

/// Radiance is constant along rays: a scene of nothing but a uniform sky
/// shows exactly the sky through a lens, in every sample.
#[test]
fn a_uniform_sky_through_a_lens_is_exactly_uniform() {
    let scene = parse("background 0.2 0.5 0.9\ncamera 0 0 0  0 0 -1  0 1 0  60  0.5 3\n").unwrap();
    let r = Renderer::new(&scene, 24, 16).unwrap().seed(5);
    let mut stats = Stats::default();
    for y in 0..16 {
        for x in 0..24 {
            for k in 0..8 {
                assert_eq!(
                    r.sample(x, y, k, &mut stats),
                    Vec3::new(0.2, 0.5, 0.9),
                    "({x}, {y}) sample {k}"
                );
            }
        }
    }
    assert_eq!(stats.nonfinite, 0);
}

/// The furnace through a lens: a Lambertian sphere of albedo 0.5 under a
/// uniform sky of radiance 1 reflects exactly 0.5 at every point, so every
/// sample of a blurred image of it is either 0.5 (up to the rounding the
/// furnace test allows) or exactly the sky, and both occur.
#[test]
fn the_furnace_through_a_lens() {
    let text = std::fs::read_to_string(scenes_dir().join("furnace.scene")).unwrap();
    let text: String = text
        .lines()
        .map(|l| {
            if l.trim_start().starts_with("camera") {
                // focused in front of the sphere: everything is blurred
                format!("{}  0.4 2\n", l.split('#').next().unwrap())
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let scene = parse(&text).unwrap();
    assert!(scene.camera().has_lens());
    let r = Renderer::new(&scene, 32, 32).unwrap().seed(2);
    let mut stats = Stats::default();
    let (mut on, mut off) = (0, 0);
    for y in 0..32 {
        for x in 0..32 {
            for k in 0..4 {
                let c = r.sample(x, y, k, &mut stats);
                if c == Vec3::ONE {
                    off += 1;
                } else {
                    on += 1;
                    for v in [c.x, c.y, c.z] {
                        assert!((v - 0.5).abs() <= 1e-4, "({x}, {y}) sample {k}: {c:?}");
                    }
                }
            }
        }
    }
    assert!(on > 500 && off > 500, "on {on}, off {off}");
}

/// Aperture 0 is the pinhole bit for bit: every shipped scene with its
/// camera written in the 12-value form with aperture 0 renders the same
/// samples as the 10-value form (the lens draws nothing, so the streams
/// are the same).
#[test]
fn aperture_zero_is_the_pinhole_bit_for_bit() {
    for name in shipped_scenes() {
        let text = std::fs::read_to_string(scenes_dir().join(format!("{name}.scene"))).unwrap();
        // the pinhole scenes (a scene with a lens already has 12 values)
        let lens = text.lines().any(|l| {
            let t: Vec<&str> = l
                .split('#')
                .next()
                .unwrap_or("")
                .split_whitespace()
                .collect();
            t.first() == Some(&"camera") && t.len() > 11
        });
        if lens {
            continue;
        }
        let zero: String = text
            .lines()
            .map(|l| {
                if l.trim_start().starts_with("camera") {
                    format!("{}  0 7.5\n", l.split('#').next().unwrap())
                } else {
                    format!("{l}\n")
                }
            })
            .collect();
        let (a, b) = (parse_host(&text).unwrap(), parse_host(&zero).unwrap());
        assert_eq!(b.camera().focus, 7.5, "{name}");
        assert!(!b.camera().has_lens());
        let (w, h) = (24, 16);
        let ra = Renderer::new(&a, w, h).unwrap().seed(11);
        let rb = Renderer::new(&b, w, h).unwrap().seed(11);
        let (mut sa, mut sb) = (Stats::default(), Stats::default());
        for y in 0..h {
            for x in 0..w {
                for k in 0..4 {
                    assert_eq!(ra.camera_ray(x, y, k), rb.camera_ray(x, y, k), "{name}");
                    let (ca, cb) = (ra.sample(x, y, k, &mut sa), rb.sample(x, y, k, &mut sb));
                    assert_eq!(
                        [ca.x.to_bits(), ca.y.to_bits(), ca.z.to_bits()],
                        [cb.x.to_bits(), cb.y.to_bits(), cb.z.to_bits()],
                        "{name} ({x}, {y}) sample {k}"
                    );
                }
            }
        }
        assert_eq!(sa.rays(), sb.rays(), "{name}");
    }
}

/// The lens test's camera: vertical field of view in degrees, focus
/// distance, image side in pixels, samples per pixel.
const VFOV: f32 = 20.0;
const FOCUS: f32 = 4.0;
const SIDE: u32 = 64;
const SPP: u32 = 256;

/// A lamp's image: its flux (sum of the pixels, in px²: the lamp has
/// radiance 1), the number of samples that hit it, its flux-weighted
/// centroid over the pixel centres, its second moments about the centroid
/// `[xx, yy, xy]`, and the variances of one hit's contribution to each
/// (`E[(dx²)²] − xx²`, …: what makes the moments' standard errors).
struct LampImage {
    flux: f64,
    hits: f64,
    centroid: [f64; 2],
    moments: [f64; 3],
    variances: [f64; 3],
}

/// The image of a lamp of radiance 1 at (`x`, `y`, −`depth`) of radius
/// `r`, black elsewhere, through the camera at the origin looking down −z
/// ([`VFOV`], +y up) with a lens of radius `aperture` focused at [`FOCUS`]
/// (aperture 0: the pinhole), [`SIDE`]² pixels at [`SPP`].
fn lamp_image(x: f32, y: f32, depth: f32, r: f32, aperture: f32) -> LampImage {
    let scene = parse(&format!(
        "camera 0 0 0  0 0 -1  0 1 0  {VFOV}  {aperture} {FOCUS}\n\
         material lamp light 1 1 1\n\
         sphere {x} {y} {}  {r}  lamp\n",
        -depth
    ))
    .unwrap();
    let rend = Renderer::new(&scene, SIDE, SIDE).unwrap().seed(9);
    let mut stats = Stats::default();
    let mut pixels = Vec::new();
    for py in 0..SIDE {
        for px in 0..SIDE {
            let mut sum = 0.0;
            for k in 0..SPP {
                let c = rend.sample(px, py, k, &mut stats);
                // a sample sees the lamp (radiance 1) or the black sky
                assert!(c == Vec3::ZERO || c == Vec3::ONE, "({px}, {py}) {k}: {c:?}");
                sum += f64::from(c.x);
            }
            pixels.push((
                f64::from(px) + 0.5,
                f64::from(py) + 0.5,
                sum / f64::from(SPP),
            ));
        }
    }
    let flux: f64 = pixels.iter().map(|p| p.2).sum();
    let mean =
        |f: &dyn Fn(f64, f64) -> f64| pixels.iter().map(|p| f(p.0, p.1) * p.2).sum::<f64>() / flux;
    let (cx, cy) = (mean(&|x, _| x), mean(&|_, y| y));
    let parts: [&dyn Fn(f64, f64) -> f64; 3] = [
        &|x, _| (x - cx) * (x - cx),
        &|_, y| (y - cy) * (y - cy),
        &|x, y| (x - cx) * (y - cy),
    ];
    let moments = parts.map(&mean);
    let variances = [0, 1, 2].map(|i| mean(&|x, y| parts[i](x, y).powi(2)) - moments[i].powi(2));
    LampImage {
        flux,
        hits: flux * f64::from(SPP),
        centroid: [cx, cy],
        moments,
        variances,
    }
}

/// Thin-lens law on the rendered film: a point at depth d along the view
/// axis images to a uniform disk (the circle of confusion) of radius
/// `APERTURE · |d − FOCUS| / (FOCUS · d)` in units of the film's tangent
/// plane, `H / (2 tan(VFOV/2))` pixels per unit (APERTURE is the lens'
/// radius: the diameter is twice that); at d = FOCUS it is a point: sharp.
/// A lamp's image through the lens is its pinhole image convolved with that
/// disk, so its centroid is the pinhole image's, its flux the same (the
/// lens moves light on the film, it adds none), and its second moments
/// those of the pinhole image plus the disk's, `R²/4` along each film axis
/// and 0 across. Lamps of film radius 2 px at depths 2 to 12 against focus
/// 4 (blur radii 0 to 13.6 px), off the axis, 64 × 64 pixels at 256 spp.
/// Tolerances: 4 standard errors of the hits as independent draws (the
/// stratified samples do better), plus for the moments 1/6 px², the whole
/// of a pixel's own moment (pixel centres stand for their squares, and the
/// sharp-edged pinhole disk and the blurred one round differently).
#[test]
fn a_small_lamp_blurs_into_the_circle_of_confusion() {
    let aperture = 0.3;
    let scale = f64::from(SIDE) / (2.0 * (f64::from(VFOV) / 2.0).to_radians().tan());
    let f = f64::from(FOCUS);
    let half = f64::from(SIDE) / 2.0;
    // the lamp's own film radius, in pixels
    let lamp_px = 2.0;
    for (depth, off) in [
        (4.0f32, [0.3, -0.2]),
        (2.0, [-3.7, 2.4]),
        (3.0, [5.2, 4.1]),
        (8.0, [0.0, 0.0]),
        (12.0, [-6.4, -9.3]),
    ] {
        let d = f64::from(depth);
        // the lamp whose pinhole image is `off` pixels from the film's
        // centre (film y grows downwards)
        let x = (off[0] / scale * d) as f32;
        let y = (-off[1] / scale * d) as f32;
        let r = (lamp_px / scale * d) as f32;
        let pin = lamp_image(x, y, depth, r, 0.0);
        let lens = lamp_image(x, y, depth, r, aperture);
        let blur = f64::from(aperture) * (d - f).abs() / (f * d) * scale;
        let want = [blur * blur / 4.0, blur * blur / 4.0, 0.0];
        let got: Vec<f64> = (0..3).map(|i| lens.moments[i] - pin.moments[i]).collect();
        let measured = (2.0 * (got[0] + got[1])).max(0.0).sqrt();
        let shift = (lens.centroid[0] - pin.centroid[0]).hypot(lens.centroid[1] - pin.centroid[1]);
        common::figure(
            "lens_blur",
            &format!(
                "depth {depth}: blur radius px, thin lens / measured; centroid shift px; flux / pinhole's"
            ),
            format!(
                "{blur:.3} / {measured:.3}; {shift:.3}; {:.4}",
                lens.flux / pin.flux
            ),
        );
        for i in 0..3 {
            let se = (lens.variances[i] / lens.hits + pin.variances[i] / pin.hits).sqrt();
            assert!(
                (got[i] - want[i]).abs() <= 4.0 * se + 1.0 / 6.0,
                "depth {depth}: second moment {} of the blur {} px², thin lens {} px² \
                 (radius {blur} px; standard error {se})",
                ["xx", "yy", "xy"][i],
                got[i],
                want[i]
            );
        }
        // the pinhole image is where the camera maps the lamp's centre
        let se_c = (pin.moments[0] + pin.moments[1]) / pin.hits;
        let pin_off = (pin.centroid[0] - half - off[0]).hypot(pin.centroid[1] - half - off[1]);
        assert!(
            pin_off <= 4.0 * se_c.sqrt() + 0.5,
            "depth {depth}: pinhole image {pin_off} px off"
        );
        let se_c = ((lens.moments[0] + lens.moments[1]) / lens.hits + se_c).sqrt();
        assert!(
            shift <= 4.0 * se_c,
            "depth {depth}: the blur's centre moved {shift} px (standard error {se_c})"
        );
        let se_flux = (1.0 / lens.hits + 1.0 / pin.hits).sqrt();
        assert!(
            (lens.flux / pin.flux - 1.0).abs() <= 4.0 * se_flux,
            "depth {depth}: flux {} against the pinhole's {}",
            lens.flux,
            pin.flux
        );
    }
}
