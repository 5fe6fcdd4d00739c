//! `micropt bench` end to end on the cheapest scene, and the law it checks:
//! an unbiased Monte Carlo estimator's MSE falls as 1/N.

use micropt_host::bench::{self, BenchConfig};
use std::path::PathBuf;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The furnace scene with its reference: the cheapest bench scene.
fn furnace() -> Vec<bench::BenchScene> {
    bench::discover_scenes(&root().join("scenes"), &root().join("host-tests/data"))
        .unwrap()
        .into_iter()
        .filter(|s| s.name == "furnace")
        .collect()
}

#[test]
fn bench_writes_every_output_and_mse_falls_as_one_over_n() {
    let scenes = furnace();
    assert_eq!(scenes.len(), 1, "the furnace scene and its reference");
    // the reference's noise is read from its .json
    let ref_se = scenes[0].reference_rms_se;
    assert!(ref_se > 0.0);
    let variants: Vec<_> = bench::standard_variants()
        .into_iter()
        .filter(|v| v.name == "mis" || v.name == "independent")
        .collect();
    let cfg = BenchConfig {
        scenes,
        variants: variants.clone(),
        spp: bench::geometric_spp(64),
        seeds: 2,
    };
    let runs = bench::run_all(&cfg, &mut |_| {}).unwrap();
    assert_eq!(runs.len(), 2 * 7 * 2);
    for r in &runs {
        assert_eq!(r.paths, 32 * 32 * u64::from(r.spp));
        assert!(r.rays >= r.paths && r.mse > 0.0 && r.seconds > 0.0);
        // each run carries the reference's noise as read from its .json
        // (what `mse_corrected` subtracts)
        assert_eq!(r.ref_noise_mse, ref_se * ref_se, "{}", r.variant);
    }
    let points = bench::aggregate(&runs);
    let fits = bench::fits(&points);
    // independent samples: the plain Monte Carlo law, MSE ∝ 1/N
    let ind = fits.iter().find(|f| f.variant == "independent").unwrap();
    assert!((-1.25..=-0.75).contains(&ind.slope), "{ind:?}");
    // stratified samples do no worse
    let mis = fits.iter().find(|f| f.variant == "mis").unwrap();
    assert!(mis.slope <= -0.9, "{mis:?}");

    let dir = std::env::temp_dir().join(format!("micropt-bench-test-{}", std::process::id()));
    let written = bench::write_outputs(&dir, &runs, &variants, "# test\n").unwrap();
    for name in [
        "runs.csv",
        "points.csv",
        "fits.csv",
        "results.md",
        "furnace.svg",
        "furnace.png",
    ] {
        let p = dir.join(name);
        assert!(written.contains(&p), "{name} not reported");
        let len = std::fs::metadata(&p).unwrap().len();
        assert!(len > 100, "{name} is {len} bytes");
    }
    let md = std::fs::read_to_string(dir.join("results.md")).unwrap();
    assert!(md.contains("### furnace (64 spp)") && md.contains("| `independent` |"));
    let png = std::fs::read(dir.join("furnace.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn missing_directories_are_named_in_the_error() {
    let e =
        bench::discover_scenes(&root().join("scenes"), &root().join("no-such-dir")).unwrap_err();
    assert!(e.contains("no-such-dir"), "{e}");
}

/// The `adaptive` variant spends the same budget as the uniform baseline
/// (the CLI's default allocation moves samples between pixels, not their
/// total), and on the furnace, where every pixel has the same expected
/// value and the same variance, it is not much worse than uniform
/// allocation (what it loses there is the rounds' rounding and its floor).
#[test]
fn the_adaptive_variant_spends_the_same_budget() {
    let scenes = furnace();
    let variants: Vec<_> = bench::standard_variants()
        .into_iter()
        .filter(|v| v.name == "adaptive" || v.name == "mis")
        .collect();
    assert_eq!(variants.len(), 2);
    assert!(variants.iter().any(|v| v.adaptive && v.threads == 1));
    let cfg = BenchConfig {
        scenes,
        variants,
        spp: vec![16],
        seeds: 4,
    };
    let runs = bench::run_all(&cfg, &mut |_| {}).unwrap();
    assert_eq!(runs.len(), 8);
    let mse = |name: &str| -> f64 {
        runs.iter()
            .filter(|r| r.variant == name)
            .map(|r| {
                assert_eq!(r.paths, 32 * 32 * 16, "{r:?}");
                r.mse - r.ref_noise_mse
            })
            .sum()
    };
    let (adaptive, uniform) = (mse("adaptive"), mse("mis"));
    assert!(
        adaptive > 0.0 && adaptive < 1.5 * uniform,
        "adaptive {adaptive:e} uniform {uniform:e}"
    );
}
