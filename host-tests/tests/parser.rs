//! Scene format parser (version 2): one test per error kind of docs/scene-format.md, each
//! checking the reported line (arbitrary-input property tests that no input
//! panics are in `stress_parse.rs`).

use micropt::parse::{ParseError, ParseErrorKind, parse, parse_bytes, parse_with_capacity};
use micropt::{CameraError, Material, SceneError, Vec3};
use proptest::prelude::*;

const CAM: &str = "camera 0 0 4  0 0 0  0 1 0  40\n";

fn err(text: &str) -> ParseError {
    match parse(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e,
    }
}

/// The error of `body` placed after a valid camera line: its line number is
/// shifted by one.
fn err_after_camera(body: &str) -> ParseError {
    err(&format!("{CAM}{body}"))
}

#[test]
fn all_shared_scenes_parse() {
    let names = micropt_host::reference::shipped_scenes();
    // the other tests that go over every shipped scene take this list
    assert_eq!(
        names,
        [
            "cornell",
            "dof",
            "furnace",
            "gloss",
            "many",
            "smallpt",
            "sphere-over-plane",
            "spheres"
        ]
    );
    for name in &names {
        let path = micropt_host::reference::scenes_dir().join(format!("{name}.scene"));
        let text = std::fs::read_to_string(&path).unwrap();
        let s = micropt_host::render::parse_host(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(s.resolution().is_some(), "{name}");
    }
}

#[test]
fn cornell_means_what_the_format_says() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/cornell.scene"
    ))
    .unwrap();
    let s = parse(&text).unwrap();
    assert_eq!(s.planes().len(), 6);
    assert_eq!(s.spheres().len(), 3);
    assert_eq!(s.materials().len(), 6);
    assert_eq!(s.lights(), &[0]);
    assert_eq!(s.resolution(), Some((64, 64)));
    assert_eq!(s.camera().vfov_deg, 60.0);
    assert_eq!(s.materials()[5], Material::Light(Vec3::splat(20.0)));
    // "plane 1 0 0   -1 0 0   green": unit normal -x, offset -1
    assert_eq!(s.planes()[5].normal, Vec3::new(-1.0, 0.0, 0.0));
    assert_eq!(s.planes()[5].offset, -1.0);
    assert_eq!(s.background(), Vec3::ZERO);
}

#[test]
fn comments_blank_lines_tabs_and_crlf() {
    let s = parse("# c\n\n\tcamera 0 0 4 0 0 0 0 1 0 40 # trailing\r\nmaterial a_b-1 diffuse .25 1 0\r\nsphere 0 0 0 1e0 a_b-1\n").unwrap();
    assert_eq!(
        s.materials()[0],
        Material::Diffuse(Vec3::new(0.25, 1.0, 0.0))
    );
}

#[test]
fn unknown_statement() {
    let e = err_after_camera("material m diffuse 1 1 1\ncube 0 0 0 1 m\n");
    assert_eq!((e.line, e.kind), (3, ParseErrorKind::UnknownStatement));
}

#[test]
fn unknown_material_kind() {
    let e = err_after_camera("material m velvet 1 1 1\n");
    assert_eq!((e.line, e.kind), (2, ParseErrorKind::UnknownMaterialKind));
}

#[test]
fn wrong_number_of_values() {
    let cases = [
        ("sphere 0 0 0 1\n", 5, 4),
        ("material m diffuse 1 1\n", 5, 4),
        ("material m glass 1.5 2\n", 3, 4),
        ("plane 0 0 0 0 1 0 m x\n", 7, 8),
        ("background 1 1\n", 3, 2),
        ("resolution 64\n", 2, 1),
        ("material m\n", 5, 1),
        ("material m metal 1 1 1\n", 6, 5),
        ("material m metal 1 1 1 0.5 2\n", 6, 7),
        ("material m checker 1 1 1  0 0 0\n", 9, 8),
        ("material m checker 1 1 1  0 0 0  1 1\n", 9, 10),
        // beyond the token limit: the count the kind takes
        ("material m checker 1 1 1  0 0 0  1 1 1 1 1\n", 9, 13),
        ("material m metal 1 1 1  0 0 0  1 1 1 1 1\n", 6, 13),
    ];
    for (body, expected, found) in cases {
        let e = err_after_camera(&format!("material m diffuse 1 1 1\n{body}"));
        assert_eq!(
            (e.line, e.kind),
            (3, ParseErrorKind::WrongArgCount { expected, found }),
            "{body}"
        );
    }
    let e = err("camera 0 0 4 0 0 0 0 1 0\n");
    assert_eq!(
        (e.line, e.kind),
        (1, ParseErrorKind::CameraArgCount { found: 9 })
    );
    // far too many tokens is still a count error, not a panic
    let long = format!("sphere{}\n", " 1".repeat(500));
    let e = err_after_camera(&long);
    assert_eq!(
        (e.line, e.kind),
        (
            2,
            ParseErrorKind::WrongArgCount {
                expected: 5,
                found: 255
            }
        )
    );
}

#[test]
fn value_not_a_number() {
    for bad in ["abc", "1,5", "0x10", "1..2", "--1", "1e", ""] {
        if bad.is_empty() {
            continue;
        }
        let e = err_after_camera(&format!("material m diffuse 1 {bad} 1\n"));
        assert_eq!((e.line, e.kind), (2, ParseErrorKind::NotANumber), "{bad}");
    }
    let e = err_after_camera("resolution 64.5 48\n");
    assert_eq!((e.line, e.kind), (2, ParseErrorKind::NotANumber));
}

#[test]
fn value_not_finite() {
    for bad in ["nan", "inf", "-inf", "NaN", "infinity", "1e39", "-3.5e38"] {
        let e = err_after_camera(&format!("material m light 1 {bad} 1\n"));
        assert_eq!((e.line, e.kind), (2, ParseErrorKind::NotFinite), "{bad}");
    }
}

const METAL_ALPHA: SceneError = SceneError::OutOfRange("metal alpha (GGX width, [0.001, 1])");

/// The v2 materials mean what the format says: values in order, the ends of
/// the ranges accepted.
#[test]
fn metal_and_checker_statements() {
    use micropt::material::{Checker, Metal};
    let s = parse(&format!(
        "{CAM}material a metal 0.9 0.8 0.7 0.001\nmaterial b metal 0 0 1 1\n\
         material c checker 1 0.5 0  0 0.25 1  0.125\nsphere 0 0 0 1 a\n"
    ))
    .unwrap();
    assert_eq!(
        s.materials(),
        &[
            Material::Metal(Metal {
                tint: Vec3::new(0.9, 0.8, 0.7),
                alpha: 0.001
            }),
            Material::Metal(Metal {
                tint: Vec3::new(0.0, 0.0, 1.0),
                alpha: 1.0
            }),
            Material::Checker(Checker {
                even: Vec3::new(1.0, 0.5, 0.0),
                odd: Vec3::new(0.0, 0.25, 1.0),
                size: 0.125
            }),
        ]
    );
    // a non-number and a non-finite value name their line
    let e = err_after_camera("material m metal 1 1 1 x\n");
    assert_eq!((e.line, e.kind), (2, ParseErrorKind::NotANumber));
    let e = err_after_camera("material m checker 1 1 1  0 0 0  inf\n");
    assert_eq!((e.line, e.kind), (2, ParseErrorKind::NotFinite));
    let e = err_after_camera("material m checker 1 1 1  0 0 0  1e-60\n");
    assert_eq!(
        (e.line, e.kind),
        (
            2,
            ParseErrorKind::Scene(SceneError::OutOfRange("checker size"))
        )
    );
    assert_eq!(
        err_after_camera("material m metal 1 1 1 2\n").to_string(),
        "line 2: metal alpha (GGX width, [0.001, 1]) out of range"
    );
}

#[test]
fn values_out_of_range() {
    let cases = [
        (
            "material m diffuse 0.5 1.01 0\n",
            SceneError::OutOfRange("albedo"),
        ),
        (
            "material m diffuse -0.1 0 0\n",
            SceneError::OutOfRange("albedo"),
        ),
        (
            "material m mirror 0 2 0\n",
            SceneError::OutOfRange("mirror reflectance"),
        ),
        (
            "material m light 1 -1 0\n",
            SceneError::OutOfRange("radiance"),
        ),
        (
            "material m glass 0\n",
            SceneError::OutOfRange("index of refraction"),
        ),
        (
            "material m glass -1.5\n",
            SceneError::OutOfRange("index of refraction"),
        ),
        (
            "background 0 -1 0\n",
            SceneError::OutOfRange("background radiance"),
        ),
        // v2: the metal's tint in [0, 1] and width ALPHA in [0.001, 1]
        (
            "material m metal 1 1.5 1 0.5\n",
            SceneError::OutOfRange("metal reflectance"),
        ),
        ("material m metal 1 1 1 0.0009\n", METAL_ALPHA),
        ("material m metal 1 1 1 0\n", METAL_ALPHA),
        ("material m metal 1 1 1 -0.5\n", METAL_ALPHA),
        ("material m metal 1 1 1 1.0001\n", METAL_ALPHA),
        // v2: the checker's colours in [0, 1] and SIZE > 0
        (
            "material m checker 1 1 1  0 -0.1 0  1\n",
            SceneError::OutOfRange("albedo"),
        ),
        (
            "material m checker 1 1 2  0 0 0  1\n",
            SceneError::OutOfRange("albedo"),
        ),
        (
            "material m checker 1 1 1  0 0 0  0\n",
            SceneError::OutOfRange("checker size"),
        ),
        (
            "material m checker 1 1 1  0 0 0  -1\n",
            SceneError::OutOfRange("checker size"),
        ),
        ("resolution 0 48\n", SceneError::Resolution),
        ("resolution 64 99999999999\n", SceneError::Resolution),
    ];
    for (body, want) in cases {
        let e = err_after_camera(body);
        assert_eq!((e.line, e.kind), (2, ParseErrorKind::Scene(want)), "{body}");
    }
    let e = err_after_camera("material m diffuse 1 1 1\nsphere 0 0 0 0 m\n");
    assert_eq!(
        (e.line, e.kind),
        (3, ParseErrorKind::Scene(SceneError::OutOfRange("radius")))
    );
    let e = err_after_camera("material m diffuse 1 1 1\nsphere 0 0 0 -2 m\n");
    assert_eq!(
        (e.line, e.kind),
        (3, ParseErrorKind::Scene(SceneError::OutOfRange("radius")))
    );
    let e = err_after_camera("material m diffuse 1 1 1\nplane 0 0 0 0 0 0 m\n");
    assert_eq!(
        (e.line, e.kind),
        (
            3,
            ParseErrorKind::Scene(SceneError::OutOfRange(
                "plane normal (largest component under 2.9e-39)"
            ))
        )
    );
}

/// What the checks test, at the edges of f32: a radius whose square is
/// not a normal f32, a normal too small to normalise, an eye and target
/// too far apart, an up vector too short; each error names its line and
/// says what was tested.
#[test]
fn range_errors_at_the_edges_of_f32_say_what_was_tested() {
    for (text, line, words) in [
        (
            "material m diffuse 1 1 1\nsphere 0 0 0 1e-20 m\n",
            3,
            "its square must be a normal f32",
        ),
        (
            "material m diffuse 1 1 1\nsphere 0 0 0 2e19 m\n",
            3,
            "its square must be a normal f32",
        ),
        (
            "material m diffuse 1 1 1\n\nplane 0 0 0 0 1e-40 0 m\n",
            4,
            "largest component under 2.9e-39",
        ),
    ] {
        let e = err_after_camera(text);
        let msg = e.to_string();
        assert!(
            msg.starts_with(&format!("line {line}: ")) && msg.contains(words),
            "{msg}"
        );
    }
    // the smallest and largest radii and normals that pass
    for text in [
        "material m diffuse 1 1 1\nsphere 0 0 0 1.1e-19 m\n",
        "material m diffuse 1 1 1\nsphere 0 0 0 1.8e19 m\n",
        "material m diffuse 1 1 1\nplane 0 0 0 0 3e-39 0 m\n",
        "material m diffuse 1 1 1\nplane 0 0 0 0 1e30 0 m\n",
    ] {
        assert!(
            parse(&format!("camera 0 0 4 0 0 0 0 1 0 40\n{text}")).is_ok(),
            "{text}"
        );
    }
    for (text, words) in [
        (
            "camera 1e30 0 0  0 0 0  0 1 0  40\n",
            "distance squared is not a normal f32",
        ),
        (
            "camera 0 0 1e-20  0 0 0  0 1 0  40\n",
            "distance squared is not a normal f32",
        ),
        (
            "camera 0 0 4  0 0 0  1e-30 0 0  40\n",
            "length squared is 0 or not finite",
        ),
        (
            "camera 0 0 4  0 0 0  0 1e20 0  40\n",
            "length squared is 0 or not finite",
        ),
        (
            "camera 0 0 4  0 0 0  1e-7 0 1  40\n",
            "sine of its angle to the view under 1e-6",
        ),
    ] {
        let msg = err(&format!("# a comment\n{text}")).to_string();
        assert!(
            msg.starts_with("line 2: ") && msg.contains(words),
            "{text}: {msg}"
        );
    }
    // a long eye-target distance and a short up vector that still pass
    assert!(parse("camera 1e18 0 0  0 0 0  0 1 0  40\n").is_ok());
    assert!(parse("camera 0 0 4  0 0 0  1e-20 0 0  40\n").is_ok());
}

#[test]
fn camera_errors() {
    let fov = |v: &str| err(&format!("camera 0 0 4 0 0 0 0 1 0 {v}\n"));
    for v in ["0", "180", "-10", "200"] {
        assert_eq!(
            fov(v).kind,
            ParseErrorKind::Scene(SceneError::Camera(CameraError::FovOutOfRange)),
            "{v}"
        );
    }
    let e = err("# eye = target\n\ncamera 1 2 3  1 2 3  0 1 0  40\n");
    assert_eq!(
        (e.line, e.kind),
        (
            3,
            ParseErrorKind::Scene(SceneError::Camera(CameraError::EyeEqualsTarget))
        )
    );
    let e = err("camera 0 0 4  0 0 0  0 0 1  40\n");
    assert_eq!(
        (e.line, e.kind),
        (
            1,
            ParseErrorKind::Scene(SceneError::Camera(CameraError::UpParallelToView))
        )
    );
    let e = err("camera 0 0 4  0 0 0  0 0 0  40\n");
    assert_eq!(
        (e.line, e.kind),
        (
            1,
            ParseErrorKind::Scene(SceneError::Camera(CameraError::UpParallelToView))
        )
    );
}

/// Version 2's thin-lens camera: 12 values (APERTURE FOCUS after VFOV),
/// both optional together; aperture 0 is the pinhole of the 10-value form.
#[test]
fn lens_camera() {
    let s = parse("camera 0 0 4  0 0 0  0 1 0  40  0.25 3.5\n").unwrap();
    let c = s.camera();
    assert_eq!((c.aperture, c.focus, c.vfov_deg), (0.25, 3.5, 40.0));
    assert!(c.has_lens());
    // the 10-value form: a pinhole
    let c = *parse(CAM).unwrap().camera();
    assert!(!c.has_lens() && c.aperture == 0.0);
    let c = *parse("camera 0 0 4  0 0 0  0 1 0  40  0 2\n")
        .unwrap()
        .camera();
    assert!(!c.has_lens());
    assert_eq!((c.aperture, c.focus), (0.0, 2.0));
    // wrong counts, the 11-value one being an aperture without its focus
    for (values, found) in [
        (" 0.25", 11),
        (" 0.25 3 1", 13),
        (" 0.25 3 1 1 1 1 1 1 1 1", 20),
    ] {
        let e = err_after_camera(&format!("\ncamera 0 0 4  0 0 0  0 1 0  40{values}\n"));
        assert_eq!(
            (e.line, e.kind),
            (3, ParseErrorKind::CameraArgCount { found }),
            "{values}"
        );
        let msg = e.to_string();
        assert!(
            msg.starts_with("line 3: ") && msg.contains("expected 10 (pinhole) or 12"),
            "{msg}"
        );
    }
    let lens = |tail: &str| {
        err(&format!(
            "# a lens\ncamera 0 0 4  0 0 0  0 1 0  40  {tail}\n"
        ))
    };
    for (tail, kind) in [
        (
            "-0.1 3",
            ParseErrorKind::Scene(SceneError::Camera(CameraError::ApertureOutOfRange)),
        ),
        (
            "-1e-30 3",
            ParseErrorKind::Scene(SceneError::Camera(CameraError::ApertureOutOfRange)),
        ),
        (
            "0.1 0",
            ParseErrorKind::Scene(SceneError::Camera(CameraError::FocusOutOfRange)),
        ),
        (
            "0.1 -3",
            ParseErrorKind::Scene(SceneError::Camera(CameraError::FocusOutOfRange)),
        ),
        // a pinhole's focus must be valid too: FOCUS > 0 is the format's rule
        (
            "0 0",
            ParseErrorKind::Scene(SceneError::Camera(CameraError::FocusOutOfRange)),
        ),
        ("nan 3", ParseErrorKind::NotFinite),
        ("0.1 inf", ParseErrorKind::NotFinite),
        ("1e39 3", ParseErrorKind::NotFinite),
        ("0.1 1e39", ParseErrorKind::NotFinite),
        ("0.1 f", ParseErrorKind::NotANumber),
        ("wide 3", ParseErrorKind::NotANumber),
    ] {
        let e = lens(tail);
        assert_eq!((e.line, e.kind), (2, kind), "{tail}");
    }
    for (tail, words) in [
        ("-0.1 3", "aperture"),
        ("0.1 0", "focus distance must be > 0"),
    ] {
        let msg = lens(tail).to_string();
        assert!(msg.starts_with("line 2: ") && msg.contains(words), "{msg}");
    }
}

#[test]
fn missing_and_second_camera() {
    let e = err("material m diffuse 1 1 1\nsphere 0 0 0 1 m\n");
    assert_eq!((e.line, e.kind), (2, ParseErrorKind::MissingCamera));
    let e = err("");
    assert_eq!(e.kind, ParseErrorKind::MissingCamera);
    let e = err(&format!("{CAM}\n{CAM}"));
    assert_eq!(
        (e.line, e.kind),
        (3, ParseErrorKind::Scene(SceneError::SecondCamera))
    );
}

#[test]
fn unknown_and_redefined_material() {
    let e = err_after_camera("sphere 0 0 0 1 grey\nmaterial grey diffuse 1 1 1\n");
    assert_eq!((e.line, e.kind), (2, ParseErrorKind::UnknownMaterial));
    let e = err_after_camera("material grey diffuse 1 1 1\nplane 0 0 0 0 1 0 gray\n");
    assert_eq!((e.line, e.kind), (3, ParseErrorKind::UnknownMaterial));
    let e = err_after_camera("material grey diffuse 1 1 1\nmaterial grey mirror 1 1 1\n");
    assert_eq!((e.line, e.kind), (3, ParseErrorKind::RedefinedMaterial));
}

#[test]
fn bad_names() {
    for name in ["1abc", "-x", "a.b", "é", &"n".repeat(33)] {
        let e = err_after_camera(&format!("material {name} diffuse 1 1 1\n"));
        assert_eq!((e.line, e.kind), (2, ParseErrorKind::BadName), "{name}");
    }
    parse(&format!("{CAM}material {} diffuse 1 1 1\n", "n".repeat(32))).unwrap();
}

#[test]
fn light_material_on_a_plane() {
    let e = err_after_camera("material lamp light 5 5 5\nplane 0 0 0 0 1 0 lamp\n");
    assert_eq!(
        (e.line, e.kind),
        (3, ParseErrorKind::Scene(SceneError::LightOnPlane))
    );
}

/// A resolution larger than the renderers can hold is refused at its line,
/// and the message names the limits: no render of a 60000x60000 scene
/// starts only to run out of time or memory.
#[test]
fn huge_resolutions_are_line_errors_that_name_the_limits() {
    use micropt::scene::{MAX_PIXELS, MAX_SIDE};
    let side_limit = format!("each side from 1 to {MAX_SIDE}, at most {MAX_PIXELS} pixels");
    for body in [
        "resolution 60000 60000\n".to_string(),
        format!("resolution {} 1\n", MAX_SIDE + 1),
        format!("resolution 1 {}\n", MAX_SIDE + 1),
        // each side within the limit, the product not
        format!("resolution {MAX_SIDE} {MAX_SIDE}\n"),
        "resolution 65535 65535\n".to_string(),
        "resolution 4294967295 4294967295\n".to_string(),
        "resolution 4294967296 1\n".to_string(),
    ] {
        let e = err_after_camera(&body);
        assert_eq!(
            (e.line, e.kind),
            (2, ParseErrorKind::Scene(SceneError::Resolution)),
            "{body}"
        );
        assert!(e.to_string().contains(&side_limit), "{e}");
    }
    // the largest allowed
    for (w, h) in [(MAX_SIDE, MAX_PIXELS / MAX_SIDE), (1, MAX_SIDE)] {
        let s = parse(&format!("{CAM}resolution {w} {h}\n")).unwrap();
        assert_eq!(s.resolution(), Some((w, h)));
    }
}

#[test]
fn repeated_resolution_and_background() {
    let e = err_after_camera("resolution 4 4\nresolution 8 8\n");
    assert_eq!(
        (e.line, e.kind),
        (3, ParseErrorKind::Repeated("resolution"))
    );
    let e = err_after_camera("background 1 1 1\nbackground 0 0 0\n");
    assert_eq!(
        (e.line, e.kind),
        (3, ParseErrorKind::Repeated("background"))
    );
}

#[test]
fn more_objects_than_capacity_names_the_line() {
    let mut text = String::from(CAM);
    text.push_str("material m diffuse 1 1 1\n");
    for i in 0..4 {
        text.push_str(&format!("sphere {i} 0 0 0.5 m\n"));
    }
    let e = parse_with_capacity::<3, 2, 2>(&text).unwrap_err();
    assert_eq!(
        (e.line, e.kind),
        (6, ParseErrorKind::Scene(SceneError::Capacity("spheres")))
    );
    let mut planes = String::from(CAM);
    planes.push_str("material m diffuse 1 1 1\n");
    for _ in 0..3 {
        planes.push_str("plane 0 0 0 0 1 0 m\n");
    }
    let e = parse_with_capacity::<3, 2, 2>(&planes).unwrap_err();
    assert_eq!(
        (e.line, e.kind),
        (5, ParseErrorKind::Scene(SceneError::Capacity("planes")))
    );
    let mats = format!(
        "{CAM}material a diffuse 1 1 1\nmaterial b diffuse 1 1 1\nmaterial c diffuse 1 1 1\n"
    );
    let e = parse_with_capacity::<3, 2, 2>(&mats).unwrap_err();
    assert_eq!(
        (e.line, e.kind),
        (4, ParseErrorKind::Scene(SceneError::Capacity("materials")))
    );
    // the default build takes 128 spheres, and rejects the 129th at its line
    let mut many = format!("{CAM}material m diffuse 1 1 1\n");
    for i in 0..129 {
        many.push_str(&format!("sphere {i} 0 0 0.5 m\n"));
    }
    let e = parse(&many).unwrap_err();
    assert_eq!(
        (e.line, e.kind),
        (131, ParseErrorKind::Scene(SceneError::Capacity("spheres")))
    );
}

#[test]
fn invalid_utf8_names_its_line() {
    let e = parse_bytes(b"camera 0 0 4 0 0 0 0 1 0 40\n# ok\nmaterial m diffuse 1 1 \xff\n")
        .unwrap_err();
    assert_eq!((e.line, e.kind), (3, ParseErrorKind::InvalidUtf8));
}

#[test]
fn errors_display_their_line() {
    let e = err_after_camera("sphere 0 0 0 1 nope\n");
    assert_eq!(
        e.to_string(),
        "line 2: unknown material (define it before use)"
    );
    let e = err_after_camera("material m diffuse 1 1\n");
    assert_eq!(
        e.to_string(),
        "line 2: wrong number of values: expected 5, found 4"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    // Arbitrary bytes and token soups: tests/stress_parse.rs.

    /// Valid scenes with a random prefix of statements: a valid scene
    /// followed by garbage fails at the garbage's line.
    #[test]
    fn error_line_is_the_garbage_line(n in 0usize..20, junk in "[a-z]{1,8} [0-9]{1,3}") {
        let mut text = String::from(CAM);
        text.push_str("material m diffuse 0.5 0.5 0.5\n");
        for i in 0..n {
            text.push_str(&format!("sphere {i} 0 0 0.5 m\n"));
        }
        text.push_str(&junk);
        text.push('\n');
        let words: Vec<&str> = junk.split(' ').collect();
        if !["camera", "resolution", "background", "material", "sphere", "plane"].contains(&words[0]) {
            let e = parse(&text).unwrap_err();
            prop_assert_eq!(e.line as usize, n + 3);
        }
    }
}

/// The parse fills the scene where it lies, so its stack use does not grow
/// with the scene's capacity: many.scene (482 spheres) parses into the
/// host's scene (4,096 spheres, 64 planes, 1,024 materials; on the heap) in
/// a thread of 32 KiB of stack, less than a quarter of what a scene builder of
/// those capacities would take on the stack by itself.
#[test]
fn parsing_a_large_scene_takes_a_small_stack() {
    use micropt_host::render::{HOST_MATERIALS, HOST_PLANES, HOST_SPHERES, HostScene};
    const STACK: usize = 32 * 1024;
    let builder =
        std::mem::size_of::<micropt::SceneBuilder<HOST_SPHERES, HOST_PLANES, HOST_MATERIALS>>();
    assert!(builder > 4 * STACK, "{builder}");
    let path = micropt_host::reference::scenes_dir().join("many.scene");
    let text = std::fs::read_to_string(path).unwrap();
    // made here: a debug build's `Box::new` builds its value on the stack
    let mut scene = Box::new(HostScene::EMPTY);
    let spheres = std::thread::Builder::new()
        .stack_size(STACK)
        .spawn(move || {
            micropt::parse::parse_into(&text, &mut scene).map(|()| scene.spheres().len())
        })
        .unwrap()
        .join()
        .unwrap();
    assert_eq!(spheres, Ok(482));
}
