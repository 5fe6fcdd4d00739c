//! The `micropt` command line: outputs, JSON figures, and one clear error
//! message with a non-zero exit (never a panic) for every bad input.

use std::path::PathBuf;
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_micropt"))
}

fn scene(name: &str) -> PathBuf {
    micropt_host::reference::scenes_dir().join(name)
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("micropt-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn run(args: &[&str]) -> Output {
    bin()
        .args(args)
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap()
}

/// A failed run: non-zero exit, a message on stderr containing `needle`,
/// and no panic or backtrace.
fn assert_clean_error(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "succeeded; stderr: {err}");
    assert!(err.contains(needle), "stderr lacks {needle:?}: {err}");
    assert!(
        !err.contains("panicked") && !err.contains("backtrace"),
        "panic: {err}"
    );
}

#[test]
fn renders_png_pfm_and_rgb565_with_json() {
    let png = tmp("c.png");
    let out = run(&[
        "render",
        scene("cornell.scene").to_str().unwrap(),
        "--spp",
        "2",
        "-o",
        png.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = String::from_utf8(out.stdout).unwrap();
    assert_eq!(line.lines().count(), 1);
    let v: serde_json::Value = serde_json::from_str(line.trim()).unwrap();
    assert_eq!(v["width"], 64);
    assert_eq!(v["height"], 64);
    assert_eq!(v["spp"], 2.0);
    assert_eq!(v["samples"], 64 * 64 * 2);
    assert_eq!(v["paths"], 64 * 64 * 2);
    assert_eq!(v["budget"], "spp 2");
    assert_eq!(v["adaptive"], true);
    assert_eq!(v["estimator"], "adaptive (biased, consistent)");
    assert_eq!(v["nonfinite"], 0);
    assert_eq!(v["leaks"], 0);
    assert_eq!(v["truncated"], 0);
    assert!(v["min_pixel_samples"].as_u64().unwrap() >= 1);
    let rays = v["rays"].as_u64().unwrap();
    let parts = v["camera_rays"].as_u64().unwrap()
        + v["bounce_rays"].as_u64().unwrap()
        + v["shadow_rays"].as_u64().unwrap();
    assert_eq!(rays, parts);
    assert!(v["seconds"].as_f64().unwrap() > 0.0 && v["threads"].as_u64().unwrap() >= 1);
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");

    // furnace at 8x6, 1 spp, into `out` (its extension picks the format)
    let render_small = |out: &PathBuf| {
        let o = run(&[
            "render",
            scene("furnace.scene").to_str().unwrap(),
            "--spp",
            "1",
            "--size",
            "8x6",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success());
    };
    let pfm = tmp("c.pfm");
    render_small(&pfm);
    let img = micropt_host::Image::load_pfm(&pfm).unwrap();
    assert_eq!((img.width, img.height), (8, 6));

    let raw = tmp("c.rgb565");
    render_small(&raw);
    assert_eq!(std::fs::read(&raw).unwrap().len(), 8 * 6 * 2);
}

#[test]
fn output_does_not_depend_on_threads() {
    let a = tmp("t1.pfm");
    let b = tmp("t2.pfm");
    for (t, p) in [("1", &a), ("2", &b)] {
        let out = run(&[
            "render",
            scene("cornell.scene").to_str().unwrap(),
            "--spp",
            "3",
            "--threads",
            t,
            "-o",
            p.to_str().unwrap(),
        ]);
        assert!(out.status.success());
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

#[test]
fn missing_file() {
    assert_clean_error(
        &run(&["render", "/nonexistent/x.scene"]),
        "cannot read scene /nonexistent/x.scene",
    );
}

#[test]
fn unreadable_file_is_a_directory() {
    assert_clean_error(
        &run(&[
            "render",
            std::env::temp_dir().to_str().unwrap(),
            "-o",
            tmp("d.png").to_str().unwrap(),
        ]),
        "cannot read scene",
    );
}

#[test]
fn malformed_scene_names_its_line() {
    let p = tmp("bad.scene");
    std::fs::write(
        &p,
        "camera 0 0 4  0 0 0  0 1 0  40\n# fine\nsphere 0 0 0 -1 grey\n",
    )
    .unwrap();
    let out = run(&[
        "render",
        p.to_str().unwrap(),
        "-o",
        tmp("bad.png").to_str().unwrap(),
    ]);
    assert_clean_error(&out, "line 3: unknown material");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
}

#[test]
fn unknown_output_extension() {
    assert_clean_error(
        &run(&[
            "render",
            scene("furnace.scene").to_str().unwrap(),
            "-o",
            "x.jpg",
        ]),
        "unknown output extension",
    );
}

#[test]
fn zero_size_and_zero_spp() {
    let s = scene("furnace.scene");
    assert_clean_error(
        &run(&["render", s.to_str().unwrap(), "--size", "0x10"]),
        "at least 1",
    );
    assert_clean_error(
        &run(&["render", s.to_str().unwrap(), "--size", "10"]),
        "is not WxH",
    );
    assert_clean_error(
        &run(&["render", s.to_str().unwrap(), "--spp", "0"]),
        "--spp",
    );
    assert_clean_error(
        &run(&["render", s.to_str().unwrap(), "--threads", "0"]),
        "--threads",
    );
}

#[test]
fn unwritable_output() {
    assert_clean_error(
        &run(&[
            "render",
            scene("furnace.scene").to_str().unwrap(),
            "--spp",
            "1",
            "-o",
            "/nonexistent/dir/x.png",
        ]),
        "cannot create",
    );
}

#[test]
fn compare_reports_and_thresholds() {
    let data = micropt_host::reference::data_dir();
    let r = data.join("cornell.pfm");
    let out = run(&["compare", r.to_str().unwrap(), r.to_str().unwrap()]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("mse 0.000000e0") && text.contains("relmse") && text.contains("mean_diff"),
        "{text}"
    );
    let f = data.join("furnace.pfm");
    let out = run(&["compare", f.to_str().unwrap(), r.to_str().unwrap()]);
    assert_clean_error(&out, "size mismatch");
    let img = tmp("c2.pfm");
    assert!(
        run(&[
            "render",
            scene("cornell.scene").to_str().unwrap(),
            "--spp",
            "1",
            "-o",
            img.to_str().unwrap()
        ])
        .status
        .success()
    );
    let out = run(&[
        "compare",
        img.to_str().unwrap(),
        r.to_str().unwrap(),
        "--max-rmse",
        "0.001",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let out = run(&[
        "compare",
        img.to_str().unwrap(),
        r.to_str().unwrap(),
        "--max-rmse",
        "10",
    ]);
    assert!(out.status.success());
    assert_clean_error(
        &run(&["compare", "/nonexistent.pfm", r.to_str().unwrap()]),
        "cannot open",
    );
}

#[test]
fn compare_fails_on_an_exact_mismatch() {
    // one pixel (1, 1, 1) against (0, 0, 0), both standard errors 0: no
    // noise explains the difference, so z is infinite and the check fails
    let pfm = |name: &str, v: f32| {
        let mut i = micropt_host::image::Image::new(1, 1);
        i.pixels[0] = micropt::Color::new(v, v, v);
        let p = tmp(name);
        i.save(&p, 1.0).unwrap();
        p
    };
    let (one, zero) = (pfm("one.pfm", 1.0), pfm("zero.pfm", 0.0));
    let z = |a: &PathBuf, b: &PathBuf| {
        run(&[
            "compare",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--se",
            zero.to_str().unwrap(),
            "--reference-se",
            zero.to_str().unwrap(),
        ])
    };
    let out = z(&one, &zero);
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(text.contains("mean_diff +1.0"), "{text}");
    assert!(text.contains("z image: r +inf g +inf b +inf"), "{text}");
    assert!(text.contains("exact mismatches: 3 "), "{text}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("3 exact mismatch(es)") && err.contains("pixel (0, 0) r: 1 against 0"),
        "{err}"
    );
    // identical noise-free pixels agree: z 0, success
    let out = z(&one, &one);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("z image: r +0.00 g +0.00 b +0.00"), "{text}");
    assert!(text.contains("exact mismatches: 0 "), "{text}");
}

fn json_of(args: &[&str]) -> serde_json::Value {
    let out = run(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_str(String::from_utf8(out.stdout).unwrap().trim()).unwrap()
}

#[test]
fn budget_flags() {
    let s = scene("cornell.scene");
    let s = s.to_str().unwrap();
    let o = tmp("b.pfm");
    let o = o.to_str().unwrap();
    let v = json_of(&[
        "render",
        s,
        "--budget-paths",
        "10000",
        "--size",
        "40x30",
        "--json",
        "-o",
        o,
    ]);
    assert_eq!(v["samples"], 10_000);
    assert_eq!(v["paths"], 10_000);
    assert_eq!(v["budget"], "paths 10000");
    let v = json_of(&[
        "render",
        s,
        "--spp",
        "3",
        "--uniform",
        "--size",
        "40x30",
        "--json",
        "-o",
        o,
    ]);
    assert_eq!(v["adaptive"], false);
    assert_eq!(v["estimator"], "uniform (unbiased)");
    assert_eq!(
        (
            v["min_pixel_samples"].as_u64(),
            v["max_pixel_samples"].as_u64()
        ),
        (Some(3), Some(3))
    );
    let v = json_of(&[
        "render",
        s,
        "--budget-ms",
        "50",
        "--size",
        "40x30",
        "--json",
        "-o",
        o,
    ]);
    assert_eq!(v["budget"], "ms 50");
    assert!(v["min_pixel_samples"].as_u64().unwrap() >= 1);
    assert_clean_error(
        &run(&["render", s, "--spp", "4", "--budget-ms", "5"]),
        "cannot be used with",
    );
    assert_clean_error(
        &run(&["render", s, "--budget-paths", "0"]),
        "--budget-paths",
    );
}

/// `render --help` says what the default estimator is: adaptive, biased and
/// consistent; the unbiased one is `--uniform`.
#[test]
fn render_help_discloses_the_biased_default() {
    let out = run(&["render", "--help"]);
    assert!(out.status.success());
    let help = String::from_utf8(out.stdout).unwrap();
    for needle in [
        "sampling is adaptive",
        "biased and consistent",
        "the bias vanishes as the budget grows",
        "the unbiased estimator",
        "--uniform",
    ] {
        assert!(
            help.contains(needle),
            "render --help lacks {needle:?}:\n{help}"
        );
    }
}

#[test]
fn smallpt_renders_with_standard_errors_and_compares() {
    let img = tmp("sp.pfm");
    let se = tmp("sp.se.pfm");
    let v = json_of(&[
        "smallpt",
        "render",
        scene("smallpt.scene").to_str().unwrap(),
        "--spp",
        "8",
        "--size",
        "16x12",
        "-o",
        img.to_str().unwrap(),
        "--se",
        se.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(v["paths"], 16 * 12 * 8);
    assert_eq!(v["renderer"], "smallpt (f64)");
    let compare_with = |reference_se: &str| {
        run(&[
            "compare",
            img.to_str().unwrap(),
            img.to_str().unwrap(),
            "--se",
            se.to_str().unwrap(),
            "--reference-se",
            reference_se,
        ])
    };
    // an image against itself: no difference, every z is 0
    let out = compare_with(se.to_str().unwrap());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.contains("mse/expected 0.0000"), "{text}");
    assert!(text.contains("z rows: 36 values, chi2/dof 0.000"), "{text}");
    // a standard-error map of another size is refused
    let r = micropt_host::reference::data_dir().join("smallpt.se.pfm");
    assert_clean_error(&compare_with(r.to_str().unwrap()), "size mismatch");
}

#[test]
fn smallpt_counts_paths_ended_by_the_depth_cap() {
    // the camera inside a glass ball, along a chord that total internal
    // reflection keeps for ever: the roulette ends every path (about 1,000
    // hits); a cap of 8 hits ends every one and says so
    let sc = tmp("inside-glass.scene");
    std::fs::write(
        &sc,
        "camera 0 0.9 0   1 0.9 0   0 0 1   0.0001\n\
         background 1 1 1\n\
         material glass glass 1.5\n\
         sphere 0 0 0 1 glass\n",
    )
    .unwrap();
    let img = tmp("inside.pfm");
    let args = |cap: Option<&'static str>| {
        let mut a = vec![
            "smallpt",
            "render",
            sc.to_str().unwrap(),
            "--spp",
            "4",
            "--size",
            "2x2",
            "-o",
            img.to_str().unwrap(),
            "--json",
        ];
        if let Some(c) = cap {
            a.extend(["--max-depth", c]);
        }
        a
    };
    let v = json_of(&args(None));
    assert_eq!(v["truncated"], 0);
    assert_eq!(v["max_depth"], 65536);
    let out = run(&args(Some("8")));
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["truncated"], 16);
    assert_eq!(v["rays"], 16 * 8);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("16 path(s) reached the cap of 8 hits"),
        "{err}"
    );
    assert_clean_error(&run(&args(Some("0"))), "--max-depth");
}

#[test]
fn smallpt_bad_inputs() {
    let s = scene("smallpt.scene");
    assert_clean_error(
        &run(&["smallpt", "render", s.to_str().unwrap(), "--spp", "6"]),
        "multiple of 4",
    );
    assert_clean_error(
        &run(&[
            "smallpt",
            "render",
            s.to_str().unwrap(),
            "--spp",
            "4",
            "--se",
            tmp("x.se.pfm").to_str().unwrap(),
        ]),
        "--spp 8 or more",
    );
    assert_clean_error(
        &run(&[
            "smallpt",
            "render",
            scene("cornell.scene").to_str().unwrap(),
        ]),
        "spheres only",
    );
}

#[test]
fn smallpt_bench_prints_the_table() {
    let out = run(&["smallpt", "bench", "--spp", "4", "--seeds", "1"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("| spp | seeds |"), "{text}");
    assert!(text.contains("\n| 4 | 1 | "), "{text}");
}

/// Huge and hostile inputs: a clear error naming the limit, at once, never a
/// panic, an abort, a hang or a huge allocation.
#[test]
fn huge_inputs_are_refused_with_the_limit_in_the_message() {
    let s = scene("furnace.scene");
    let s = s.to_str().unwrap();
    let o = tmp("huge.png");
    let o = o.to_str().unwrap();
    // a scene asking for 60000x60000 (a 43 GB image): refused at its line
    let big = tmp("big.scene");
    std::fs::write(
        &big,
        "camera 0 0 4  0 0 0  0 1 0  40\nresolution 60000 60000\n",
    )
    .unwrap();
    let out = run(&["render", big.to_str().unwrap(), "-o", o]);
    assert_clean_error(&out, "line 2: resolution out of range");
    assert_clean_error(&out, "each side from 1 to 16384, at most 33554432 pixels");
    // --size: each side, then the product
    assert_clean_error(
        &run(&["render", s, "--size", "60000x60000", "-o", o]),
        "each side must be at most 16384",
    );
    assert_clean_error(
        &run(&["render", s, "--size", "16384x16384", "-o", o]),
        "at most 33554432 pixels",
    );
    assert_clean_error(
        &run(&["render", s, "--size", "99999999999x1", "-o", o]),
        "not a whole number",
    );
    // counts the renderer could not hold or start
    assert_clean_error(
        &run(&["render", s, "--spp", "4294967295", "-o", o]),
        "1..=1048576",
    );
    assert_clean_error(
        &run(&["render", s, "--threads", "4294967295", "-o", o]),
        "1..=1024",
    );
    assert_clean_error(
        &run(&[
            "render",
            s,
            "--size",
            "8x8",
            "--budget-paths",
            "18446744073709551615",
            "-o",
            o,
        ]),
        "more than 1048576 samples per pixel of a 8x8 image (at most 67108864)",
    );
    // at the thread limit, with a tile for each thread: accepted
    let v = json_of(&[
        "render",
        s,
        "--size",
        "512x512",
        "--threads",
        "1024",
        "--spp",
        "1",
        "--json",
        "-o",
        o,
    ]);
    assert_eq!(v["samples"], 512 * 512);
    // a deadline of 584 million years on one pixel ends when the pixel has
    // the most samples a budget may give (2^20)
    let v = json_of(&[
        "render",
        s,
        "--size",
        "1x1",
        "--budget-ms",
        "18446744073709551615",
        "--uniform",
        "--json",
        "-o",
        o,
    ]);
    assert_eq!(v["samples"], 1 << 20);
}

#[test]
fn denoise_writes_every_format_denoised_and_the_guides() {
    let sc = scene("cornell.scene");
    let sc = sc.to_str().unwrap();
    let (pfm, png, rgb, alb, nrm) = (
        tmp("dn.pfm"),
        tmp("dn.png"),
        tmp("dn.rgb565"),
        tmp("albedo.pfm"),
        tmp("normal.pfm"),
    );
    let common = ["render", sc, "--spp", "4", "--size", "24x16", "--denoise"];
    for (o, extra) in [
        (
            &pfm,
            vec![
                "--aov-albedo",
                alb.to_str().unwrap(),
                "--aov-normal",
                nrm.to_str().unwrap(),
            ],
        ),
        (&png, vec![]),
        (&rgb, vec![]),
    ] {
        let mut args = common.to_vec();
        args.extend(["-o", o.to_str().unwrap()]);
        args.extend(extra);
        let out = run(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    // the three outputs are one image: the PNG and the .rgb565 are the
    // denoised PFM's tone mapping
    let img = micropt_host::Image::load_pfm(&pfm).unwrap();
    assert_eq!(std::fs::read(&rgb).unwrap(), img.to_rgb565_be(1.0));
    let mut png_bytes = Vec::new();
    img.write_png(&mut png_bytes, 1.0).unwrap();
    assert_eq!(std::fs::read(&png).unwrap(), png_bytes);
    // OIDN's conventions: albedo in [0, 1], normals in [-1, 1] and unit
    // length where the centre ray finds a surface
    let a = micropt_host::Image::load_pfm(&alb).unwrap();
    assert!(
        a.pixels
            .iter()
            .all(|c| [c.x, c.y, c.z].iter().all(|v| (0.0..=1.0).contains(v)))
    );
    let n = micropt_host::Image::load_pfm(&nrm).unwrap();
    for c in &n.pixels {
        let l = c.x * c.x + c.y * c.y + c.z * c.z;
        assert!(l == 0.0 || (l - 1.0).abs() < 1e-4, "normal {c:?}");
    }
    // a guide is PFM only, and --denoise takes a sample budget only
    assert_clean_error(
        &run(&[
            "render",
            sc,
            "--spp",
            "4",
            "--aov-albedo",
            tmp("a.png").to_str().unwrap(),
        ]),
        "a guide is written as PFM",
    );
    assert_clean_error(
        &run(&["render", sc, "--denoise", "--budget-ms", "10"]),
        "cannot be used with",
    );
}

#[test]
fn passes_give_the_demos_image_after_k_passes() {
    // pass k renders --spp · 2^k samples: after 3 passes at --spp 2, the
    // render at 8, denoised or raw (each pixel's mean, as the demo shows it)
    let cornell = scene("cornell.scene");
    let cornell = cornell.to_str().unwrap();
    for denoise in [true, false] {
        let (a, b) = (tmp("passes-a.rgb565"), tmp("passes-b.rgb565"));
        let (a_s, b_s) = (a.to_str().unwrap(), b.to_str().unwrap());
        let mut args = vec!["render", cornell, "--size", "24x16", "--seed", "4"];
        if denoise {
            args.push("--denoise");
        }
        let passes = [args.clone(), vec!["--spp", "2", "--passes", "3", "-o", a_s]].concat();
        assert!(run(&passes).status.success());
        if denoise {
            let plain = [args.clone(), vec!["--spp", "8", "-o", b_s]].concat();
            assert!(run(&plain).status.success());
        } else {
            // raw: the budget arithmetic, one pass at 8
            let plain = [args.clone(), vec!["--spp", "8", "--passes", "1", "-o", b_s]].concat();
            assert!(run(&plain).status.success());
        }
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&b).unwrap(),
            "denoise {denoise}"
        );
    }
    let out = run(&["render", cornell, "--passes", "18", "-o", "x.png"]);
    assert_clean_error(&out, "--passes");
    let out = run(&[
        "render", cornell, "--spp", "1048576", "--passes", "2", "-o", "x.png",
    ]);
    assert_clean_error(&out, "more than 1048576");
}
