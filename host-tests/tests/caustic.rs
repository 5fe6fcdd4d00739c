//! The caustic estimator ([`micropt::caustic`]) against double-precision
//! and traced references (host tests: the core itself never mentions
//! double precision).

#![allow(clippy::neg_cmp_op_on_partial_ord)]

use micropt::caustic::{
    CausticSample, GlassPath, ROOTS, bsdf_share, fold_weight, glass_paths, sample,
};
use micropt::material::glass::sample_dielectric;
use micropt::{Color, Hit, Material, ObjectId, Ray, Vec3, math};

/// A xorshift stream of numbers in [0, 1).
fn numbers() -> impl FnMut() -> f32 {
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// The near intersection of the ray (o, d) with the sphere (centre
/// `c`, radius `r`) from outside, or the far one from inside.
fn through(o: Vec3, d: Vec3, c: Vec3, r: f32, inside: bool) -> Option<Vec3> {
    let oc = o - c;
    let b = oc.dot(d);
    let disc = b * b - (oc.length_squared() - r * r);
    if !(disc >= 0.0) {
        return None;
    }
    let t = if inside {
        -b + disc.sqrt()
    } else {
        -b - disc.sqrt()
    };
    (t > 0.0).then(|| o + d * t)
}

/// The direction in which the ray from `x` along `wi` leaves the glass
/// sphere after refracting in and out (the renderer's own refraction).
fn traced(x: Vec3, wi: Vec3, c: Vec3, r: f32, eta: f32) -> Option<Vec3> {
    let p = through(x, wi, c, r, false)?;
    let (inner, _) = sample_dielectric(wi, (p - c).normalize(), eta, 1.0);
    let q = through(p, inner, c, r, true)?;
    let (out, _) = sample_dielectric(inner, (q - c).normalize(), eta, 1.0);
    Some(out)
}

/// The number of impact parameters (of `steps`) whose exit angle
/// crosses `W` (mod 2π), in double precision: the roots a fine scan
/// finds.
fn scanned_roots(d: f64, r: f64, eta: f64, big_w: f64, steps: usize) -> usize {
    let phi = |b: f64| (b / d).asin() - 2.0 * (b / r).asin() + 2.0 * (b / (eta * r)).asin();
    let diff = |b: f64| {
        let a = phi(b) - big_w;
        (a.sin(), a.cos())
    };
    let mut roots = 0;
    let mut prev = diff(-r);
    for k in 1..=steps {
        let b = -r + 2.0 * r * k as f64 / steps as f64;
        let cur = diff(b);
        if (prev.0 <= 0.0) != (cur.0 <= 0.0) && prev.1 > 0.0 && cur.1 > 0.0 {
            roots += 1;
        }
        prev = cur;
    }
    roots
}

/// Law checked: Snell's law, twice. Every path `glass_paths` returns,
/// refracted into and out of the sphere by the renderer's own
/// refraction, leaves along the asked direction; and it finds as many
/// paths as a fine double-precision scan of the impact parameter,
/// including the three that points near the sphere (closer than
/// η r / (2(η − 1)), inside the caustic's cusp) see for some
/// directions.
#[test]
fn glass_paths_refract_into_the_requested_direction() {
    let mut next = numbers();
    let (c, r, eta) = (Vec3::new(0.3, -0.2, 0.5), 0.7f32, 1.5f32);
    let (mut paths, mut three, mut differ, mut cases) = (0, 0, 0, 0);
    for d in [1.05f32, 1.1, 1.2, 1.3, 1.45, 2.0, 6.0, 60.0] {
        for _ in 0..1000 {
            let dir = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let x = c + dir * (d * r);
            let w = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let mut out = [GlassPath::NONE; ROOTS];
            let n = glass_paths(x, c, r, eta, w, &mut out);
            // (grazing paths, whose light is nearly all reflected, can
            // miss the sphere in f32, and there a root's rounding moves
            // the exit by |φ'| ulps: checked where |dω/dω_x| < 10⁴)
            for p in out
                .iter()
                .take(n)
                .filter(|p| p.transmit > 1e-3 && p.jac < 1e4)
            {
                let Some(got) = traced(x, p.wi, c, r, eta) else {
                    panic!("d {d}: path {p:?} misses the sphere");
                };
                // a root's f32 rounding, magnified where φ' is small
                assert!(
                    (got - w).length() < 2e-3,
                    "d {d}: path {p:?} leaves along {got:?}, not {w:?}"
                );
                assert!((p.exit - c).length() - r < 1e-4 * r);
            }
            let a = (c - x).normalize();
            let big_w = f64::from(a.dot(w)).clamp(-1.0, 1.0).acos();
            let want = scanned_roots(f64::from(d * r), f64::from(r), 1.5, big_w, 5_000);
            cases += 1;
            differ += usize::from(want != n);
            paths += n;
            three += usize::from(n == 3);
        }
    }
    assert!(
        three >= 5,
        "points near the sphere see three paths ({three})"
    );
    assert!(paths > 1500, "{paths} paths");
    // a root within a scan step of a fold or an end can be missed by
    // the scan or found by the solver alone
    assert!(
        differ * 500 < cases,
        "{differ} of {cases} counts differ from the scan"
    );
}

/// Law checked: the change of variables. A path's `|dω/dω_x|` equals
/// the solid angle that the exit directions of rays turned by ±ε about
/// `wi` span, over ε² (central differences of the traced paths), to
/// 1 %.
#[test]
fn glass_jacobian_matches_traced_differences() {
    let mut next = numbers();
    let (c, r, eta) = (Vec3::ZERO, 1.0f32, 1.5f32);
    let mut checked = 0;
    for d in [1.3f32, 2.0, 4.0, 12.0] {
        for _ in 0..400 {
            let x = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize() * d;
            let w = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let mut out = [GlassPath::NONE; ROOTS];
            let n = glass_paths(x, c, r, eta, w, &mut out);
            for p in out.iter().take(n) {
                let (a1, a2) = p.wi.basis();
                // small enough for grazing rays, large enough for f32
                let e = 1e-4f32;
                let turn = |a: Vec3, s: f32| traced(x, (p.wi + a * s).normalize(), c, r, eta);
                let (Some(p1), Some(m1), Some(p2), Some(m2)) =
                    (turn(a1, e), turn(a1, -e), turn(a2, e), turn(a2, -e))
                else {
                    continue;
                };
                let fd = ((p1 - m1) * 0.5).cross((p2 - m2) * 0.5).dot(w).abs() / (e * e);
                // grazing rays and folds bend faster than the
                // differences resolve
                if !(p.jac > 0.05 && p.jac < 30.0) {
                    continue;
                }
                assert!(
                    (fd / p.jac - 1.0).abs() < 0.01,
                    "d {d}: |dω/dω_x| {} against differences {fd}",
                    p.jac
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 100, "{checked} paths checked");
}
/// A ball of material `ball` (radius 1, centre at height 1.2: sphere 0)
/// over a white Lambertian ground (plane 0), under a sun of radiance 100
/// and radius 5 high in the sky at 60° (sphere 1).
fn ball_on_ground(ball: Material) -> micropt::Scene<8, 2, 4> {
    let mut b = micropt::SceneBuilder::<8, 2, 4>::new();
    let ground = b.material(Material::Diffuse(Color::splat(1.0))).unwrap();
    let m = b.material(ball).unwrap();
    let sun = b.material(Material::Light(Color::splat(100.0))).unwrap();
    let spec = micropt::camera::CameraSpec::pinhole(
        Vec3::new(0.0, 6.0, 3.0),
        Vec3::ZERO,
        Vec3::new(0.0, 1.0, 0.0),
        30.0,
    );
    b.camera(spec).unwrap();
    b.plane(Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0), ground)
        .unwrap();
    b.sphere(Vec3::new(0.0, 1.2, 0.0), 1.0, m).unwrap();
    b.sphere(Vec3::new(25.0, 43.3, 0.0), 5.0, sun).unwrap();
    b.build().unwrap()
}

/// Law checked: the change of variables, summed over every root, with
/// the partition at [`micropt::caustic::GLASS_JAC_MIN`] and the balance
/// heuristic below it. At points on a ground under a glass ball in a high
/// sun (in its shadow, around its focus, and beyond), the mean of
/// [`micropt::caustic::sample`]'s values `× cos θ / π`, each path of a
/// fold weighted by [`micropt::caustic::fold_weight`] against the cosine
/// pdf, equals what cosine sampling finds of the part of each path that
/// [`micropt::caustic::bsdf_share`] leaves to the sample: rays traced into
/// and out of the ball by the renderer's refraction that meet the light
/// unblocked, weighted by the two transmittances (a Lambertian of albedo
/// 1: `f cos / pdf = 1`) and by `1 − bsdf_share` (1 where
/// `|dω/dω_x| ≥ GLASS_JAC_MIN`, the fold's weight below). Each within 4
/// standard errors of the difference (both estimates' own: 1.2 % where
/// the caustic is brightest outside the focus, 0.2 % at it: 5.919
/// against 5.921 ± 0.011); sabotage: the values 10 % too large or too
/// small fail it, and so does the fold's weight left out of either side
/// (at the focus 25.3 against 5.92).
#[test]
fn glass_caustic_sample_estimates_what_cosine_sampling_finds() {
    let scene = ball_on_ground(Material::Glass(1.5));
    let view = scene.view(-1.0);
    let list = [0u16];
    let c = Vec3::new(0.0, 1.2, 0.0);
    let n = Vec3::new(0.0, 1.0, 0.0);
    let mut next = numbers();
    let mut nonzero = 0;
    for (px, pz) in [
        (-0.4f32, 0.5f32),
        (-0.2, -0.6),
        (-1.0, 0.9),
        (-2.2, 0.8),
        (-0.6, 1.2),
        (0.3, 0.4),
        // at the fold, near the focus: paths with |dω/dω_x| < GLASS_JAC_MIN
        (-0.72, 0.0),
        (-0.6, 0.15),
    ] {
        let x = Vec3::new(px, 0.0, pz);
        let hit = Hit {
            t: 1.0,
            point: x,
            normal: n,
            error: 1e-6,
            object: ObjectId::plane(0),
            material: 0,
        };
        let (mut sc, mut sc2) = (0.0f64, 0.0f64);
        let runs = 200_000;
        let mut rays = 0;
        for _ in 0..runs {
            let mut out = [CausticSample::NONE; ROOTS];
            let u = [next(), next()];
            let k = sample(&view, &list, &hit, n, next(), u, &mut rays, &mut out);
            let v: f64 = out
                .iter()
                .take(k)
                .map(|cs| {
                    let cos = n.dot(cs.wi);
                    let w = if cs.fold_pdf > 0.0 {
                        fold_weight(cs.fold_pdf, cos * math::INV_PI)
                    } else {
                        1.0
                    };
                    f64::from(cs.value.y * cos * w) / core::f64::consts::PI
                })
                .sum();
            sc += v;
            sc2 += v * v;
        }
        let (mut sb, mut sb2) = (0.0f64, 0.0f64);
        let rays_b = 4_000_000;
        for _ in 0..rays_b {
            let (t1, t2) = n.basis();
            let (u1, u2) = (next(), next());
            let (s, co) = math::sincos(math::TWO_PI * u2);
            let rr = math::sqrt(u1);
            let wi = (t1 * (rr * co) + t2 * (rr * s) + n * math::sqrt(1.0 - u1)).normalize();
            let Some(p) = through(x, wi, c, 1.0, false) else {
                continue;
            };
            let n1 = (p - c).normalize();
            let (f1, _) = micropt::material::glass::fresnel_dielectric(-wi.dot(n1), 1.0 / 1.5);
            let (inner, _) = sample_dielectric(wi, n1, 1.5, 1.0);
            let Some(q) = through(p, inner, c, 1.0, true) else {
                continue;
            };
            let n2 = (q - c).normalize();
            let (f2, _) = micropt::material::glass::fresnel_dielectric(inner.dot(n2), 1.5);
            let (out, _) = sample_dielectric(inner, n2, 1.5, 1.0);
            if !(f2 < 1.0) {
                continue;
            }
            let exit = Ray::new(q + n2 * 1e-4, out);
            let Some(h) = view.closest_hit_any(&exit, ObjectId::sphere(0)) else {
                continue;
            };
            if h.object != ObjectId::sphere(1) {
                continue;
            }
            let cos = n.dot(wi);
            let share = bsdf_share(
                &view,
                &list,
                x,
                0,
                &exit,
                ObjectId::sphere(1),
                cos * math::INV_PI,
            );
            let v = f64::from((1.0 - f1) * (1.0 - f2) * 100.0 * (1.0 - share));
            sb += v;
            sb2 += v * v;
        }
        let (mc, mb) = (sc / runs as f64, sb / rays_b as f64);
        let var = (sc2 / runs as f64 - mc * mc) / runs as f64
            + (sb2 / rays_b as f64 - mb * mb) / rays_b as f64;
        assert!(
            (mc - mb).abs() <= 4.0 * var.sqrt(),
            "({px}, {pz}): through the glass {mc}, cosine sampling {mb} ± {}",
            var.sqrt()
        );
        nonzero += usize::from(mb > 10.0 * var.sqrt());
        println!(
            "({px}, {pz}): through the glass {mc:.4}, cosine sampling {mb:.4} ± {:.4}",
            var.sqrt()
        );
    }
    assert!(nonzero >= 3, "the caustic reaches the points ({nonzero})");
}

/// Law checked: a convex mirror spreads the light it reflects
/// (`|dω/dω_x| ≥ 1`: its caustic is never brighter than the light seen
/// directly from the same point would make it), while a glass ball
/// focuses it (`|dω/dω_x| < 1` near the axis behind it). The flag
/// [`CausticSample::focused`], which decides what the denoiser leaves
/// sharp, follows: never on a mirror ball's paths, on some of a glass
/// ball's and not on others.
#[test]
fn a_glass_ball_focuses_its_caustic_and_a_mirror_ball_never_does() {
    let mut counts = [[0u32; 2]; 2];
    for (k, ball) in [Material::Glass(1.5), Material::Mirror(Color::splat(0.9))]
        .into_iter()
        .enumerate()
    {
        let scene = ball_on_ground(ball);
        let view = scene.view(-1.0);
        let n = Vec3::new(0.0, 1.0, 0.0);
        let mut next = numbers();
        for _ in 0..200_000 {
            // a point of the ground within 3 of the ball's foot
            let x = Vec3::new(6.0 * next() - 3.0, 0.0, 6.0 * next() - 3.0);
            let hit = Hit {
                t: 1.0,
                point: x,
                normal: n,
                error: 1e-6,
                object: ObjectId::plane(0),
                material: 0,
            };
            let mut out = [CausticSample::NONE; ROOTS];
            let mut rays = 0;
            let u = [next(), next()];
            let found = sample(&view, &[0u16], &hit, n, next(), u, &mut rays, &mut out);
            for cs in out.iter().take(found) {
                counts[k][usize::from(cs.focused)] += 1;
            }
        }
    }
    let [[glass_broad, glass_focused], [mirror_broad, mirror_focused]] = counts;
    assert!(
        glass_focused > 100 && glass_broad > 100,
        "glass: {glass_focused} focused, {glass_broad} broad"
    );
    assert!(mirror_broad > 100, "mirror: {mirror_broad} paths");
    assert_eq!(mirror_focused, 0, "a mirror ball's focused paths");
}
