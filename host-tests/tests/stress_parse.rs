//! The parser on arbitrary input (the CI counterpart of the cargo-fuzz
//! target in `fuzz/`, which needs nightly): it never panics, an error names
//! a line that exists, and an accepted scene holds only valid values.
//! docs/scene-format.md: "Parsing never panics, whatever bytes it is given."

mod common;

use common::{figure, random_runner, runner};
use micropt::Material;
use micropt::parse::parse_bytes;
use proptest::prelude::*;
use proptest::test_runner::TestRunner;
use std::cell::Cell;

/// Tokens of the format and its edge cases, to build near-valid lines.
const WORDS: &[&str] = &[
    "camera",
    "resolution",
    "background",
    "material",
    "sphere",
    "plane",
    "diffuse",
    "mirror",
    "glass",
    "light",
    "metal",
    "checker",
    "0.001",
    "g",
    "lamp",
    "0",
    "1",
    "-1",
    "0.5",
    ".5",
    "1e5",
    "1e38",
    "1e39",
    "-1e-45",
    "nan",
    "inf",
    "-inf",
    "180",
    "16384",
    "16385",
    "65536",
    "4294967296",
    "#",
    "x#y",
    "\t",
    "é",
];

fn line_strategy() -> impl Strategy<Value = String> {
    proptest::collection::vec(proptest::sample::select(WORDS), 0..14).prop_map(|w| w.join(" "))
}

/// Near-valid scenes: a valid header, then random lines of format tokens.
fn scene_strategy() -> impl Strategy<Value = Vec<u8>> {
    (
        0u8..3,
        proptest::collection::vec(line_strategy(), 0..12),
        any::<bool>(),
    )
        .prop_map(|(header, lines, newline)| {
            let mut s = String::new();
            if header > 0 {
                // a pinhole, or a thin lens (format version 2)
                s.push_str(if header == 1 {
                    "camera 0 0 4  0 0 0  0 1 0  40\n"
                } else {
                    "camera 0 0 4  0 0 0  0 1 0  40  0.1 4\n"
                });
                s.push_str("material g diffuse 0.5 0.5 0.5\nmaterial lamp light 1 1 1\n");
            }
            s.push_str(&lines.join("\n"));
            if newline {
                s.push('\n');
            }
            s.into_bytes()
        })
}

fn bytes_strategy() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        proptest::collection::vec(any::<u8>(), 0..512),
        scene_strategy(),
        // a shipped scene with random bytes overwritten
        (
            proptest::collection::vec((any::<u16>(), any::<u8>()), 1..6),
            0usize..5
        )
            .prop_map(|(edits, which)| {
                let text = [
                    include_str!("../../scenes/cornell.scene"),
                    include_str!("../../scenes/furnace.scene"),
                    include_str!("../../scenes/smallpt.scene"),
                    include_str!("../../scenes/sphere-over-plane.scene"),
                    include_str!("../../scenes/spheres.scene"),
                ][which];
                let mut b = text.as_bytes().to_vec();
                for (at, v) in edits {
                    let i = at as usize % b.len();
                    b[i] = v;
                }
                b
            }),
    ]
}

fn check(data: &[u8], accepted: &Cell<u64>) -> Result<(), TestCaseError> {
    match parse_bytes(data) {
        Err(e) => {
            let lines = data.split(|&b| b == b'\n').count().max(1);
            prop_assert!(
                e.line >= 1 && e.line as usize <= lines,
                "{:?} of {}",
                e,
                lines
            );
            let prefix = format!("line {}: ", e.line);
            prop_assert!(e.to_string().starts_with(&prefix));
        }
        Ok(scene) => {
            accepted.set(accepted.get() + 1);
            for s in scene.spheres() {
                prop_assert!(s.center.is_finite() && s.radius > 0.0 && s.radius.is_finite());
            }
            for p in scene.planes() {
                prop_assert!(p.normal.is_finite() && p.offset.is_finite());
                prop_assert!(!matches!(
                    scene.materials()[p.material as usize],
                    Material::Light(_)
                ));
            }
            prop_assert!(scene.camera().validate().is_ok());
            prop_assert!(scene.background().is_finite());
            if let Some((w, h)) = scene.resolution() {
                // a size every renderer can hold
                prop_assert!(
                    micropt_host::render::check_size(w, h).is_ok(),
                    "{}x{}",
                    w,
                    h
                );
            }
        }
    }
    Ok(())
}

fn run(mut runner: TestRunner, name: &str) {
    let accepted = Cell::new(0);
    runner
        .run(&bytes_strategy(), |data| check(&data, &accepted))
        .unwrap();
    figure(name, "inputs accepted as scenes", accepted.get());
}

#[test]
fn parser_never_panics_on_arbitrary_input() {
    run(runner(50_000), "parse_arbitrary");
}

#[test]
#[ignore = "deep run: cargo test -- --ignored"]
fn parser_never_panics_on_arbitrary_input_deep() {
    run(random_runner(2_000_000), "parse_arbitrary_deep");
}
