//! The scene text format, version 2 (docs/scene-format.md) → [`Scene`].
//!
//! `no_std` and allocation-free: material names are borrowed from the input
//! while parsing. Every error carries the 1-based line it was found on and
//! its kind, and the parser never panics, whatever bytes it is given.

use crate::camera::CameraSpec;
use crate::geometry::Vec3;
use crate::material::{Checker, Material, Metal};
use crate::scene::builder::{Lists, Settings};
use crate::scene::{MaterialId, Scene, SceneError};
use heapless::Vec;

mod decimal;
pub use decimal::{parse_f32, residual};

/// Longest material name, in bytes.
pub const MAX_NAME_LEN: usize = 32;
/// Most whitespace-separated tokens a statement may have (a camera with a
/// lens has 13).
const MAX_TOKENS: usize = 13;

/// What is wrong with a scene file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParseErrorKind {
    /// The line is not valid UTF-8.
    InvalidUtf8,
    /// The first word is not a statement of the format.
    UnknownStatement,
    /// `material NAME KIND …` with an unknown KIND.
    UnknownMaterialKind,
    /// A statement with the wrong number of values.
    WrongArgCount {
        /// Number of values the statement takes.
        expected: u8,
        /// Number of values found (capped at the token limit).
        found: u8,
    },
    /// A `camera` statement with neither 10 values (a pinhole) nor 12 (with
    /// a lens: APERTURE FOCUS).
    CameraArgCount {
        /// Number of values found (capped at 255).
        found: u8,
    },
    /// A value that is not a decimal number (or, for `resolution`, not a
    /// positive integer).
    NotANumber,
    /// A number that is not finite (`nan`, `inf`, or overflowing f32).
    NotFinite,
    /// A name that does not match `[A-Za-z_][A-Za-z0-9_-]*` or is longer than
    /// 32 bytes.
    BadName,
    /// A material used before it is defined.
    UnknownMaterial,
    /// A material name defined twice.
    RedefinedMaterial,
    /// A second `resolution` or `background` statement.
    Repeated(&'static str),
    /// The scene has no `camera` statement (reported at the last line).
    MissingCamera,
    /// A scene-level error at this line (range, capacity, camera, light on a
    /// plane …).
    Scene(SceneError),
}

/// A scene file error: the line (1-based) and what is wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ParseError {
    /// 1-based line number.
    pub line: u32,
    /// What is wrong.
    pub kind: ParseErrorKind,
}

impl core::fmt::Display for ParseError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "line {}: ", self.line)?;
        match self.kind {
            ParseErrorKind::InvalidUtf8 => f.write_str("not valid UTF-8"),
            ParseErrorKind::UnknownStatement => f.write_str(
                "unknown statement (expected camera, resolution, background, material, sphere or plane)",
            ),
            ParseErrorKind::UnknownMaterialKind => {
                f.write_str(
                "unknown material kind (expected diffuse, mirror, glass, metal, checker or light)",
            )
            }
            ParseErrorKind::WrongArgCount { expected, found } => {
                write!(f, "wrong number of values: expected {expected}, found {found}")
            }
            ParseErrorKind::CameraArgCount { found } => write!(
                f,
                "wrong number of camera values: expected 10 (pinhole) or 12 (with APERTURE FOCUS), found {found}"
            ),
            ParseErrorKind::NotANumber => f.write_str("value is not a number"),
            ParseErrorKind::NotFinite => f.write_str("value is not finite"),
            ParseErrorKind::BadName => {
                f.write_str("bad name (must match [A-Za-z_][A-Za-z0-9_-]*, at most 32 bytes)")
            }
            ParseErrorKind::UnknownMaterial => f.write_str("unknown material (define it before use)"),
            ParseErrorKind::RedefinedMaterial => f.write_str("material defined twice"),
            ParseErrorKind::Repeated(what) => {
                // pieces, not `{what}` (see `SceneError`'s `Display`)
                f.write_str("second ")?;
                f.write_str(what)?;
                f.write_str(" statement")
            }
            ParseErrorKind::MissingCamera => f.write_str("no camera statement in the scene"),
            ParseErrorKind::Scene(e) => write!(f, "{e}"),
        }
    }
}

fn is_name(s: &str) -> bool {
    let b = s.as_bytes();
    match b.first() {
        Some(c) if c.is_ascii_alphabetic() || *c == b'_' => {}
        _ => return false,
    }
    b.len() <= MAX_NAME_LEN
        && b.iter()
            .all(|c| c.is_ascii_alphanumeric() || *c == b'_' || *c == b'-')
}

fn number(tok: &str) -> Result<f32, ParseErrorKind> {
    // the format's numbers: optional sign, digits with an optional point,
    // optional exponent. The grammar also takes "inf"/"nan": reject those as
    // not finite, anything else non-numeric as not a number.
    match parse_f32(tok) {
        Some(v) if v.is_finite() => Ok(v),
        Some(_) => Err(ParseErrorKind::NotFinite),
        None => Err(ParseErrorKind::NotANumber),
    }
}

fn integer(tok: &str) -> Result<u32, ParseErrorKind> {
    if !tok.bytes().all(|c| c.is_ascii_digit()) {
        return Err(ParseErrorKind::NotANumber);
    }
    tok.parse::<u32>()
        .map_err(|_| ParseErrorKind::Scene(SceneError::Resolution))
}

/// The parser's state: the scene's object lists, filled in place (so that
/// its stack use does not grow with the scene's capacities), the scene-wide
/// values and the material names.
struct Parser<'a, 's, const S: usize, const P: usize, const M: usize> {
    lists: Lists<'s, S, P, M>,
    settings: Settings,
    names: Vec<&'a str, M>,
    seen_resolution: bool,
    seen_background: bool,
}

impl<'a, const S: usize, const P: usize, const M: usize> Parser<'a, '_, S, P, M> {
    fn material_id(&self, name: &str) -> Result<MaterialId, ParseErrorKind> {
        self.names
            .iter()
            .position(|n| *n == name)
            .map(|i| MaterialId(i as u16))
            .ok_or(ParseErrorKind::UnknownMaterial)
    }

    fn statement(&mut self, toks: &[&'a str]) -> Result<(), ParseErrorKind> {
        let Some((&head, args)) = toks.split_first() else {
            return Ok(());
        };
        let count = |n: u8| {
            if args.len() == n as usize {
                Ok(())
            } else {
                Err(ParseErrorKind::WrongArgCount {
                    expected: n,
                    found: args.len() as u8,
                })
            }
        };
        let nums = |range: core::ops::Range<usize>| -> Result<[f32; 12], ParseErrorKind> {
            let mut out = [0.0; 12];
            for (o, t) in out.iter_mut().zip(args.get(range).unwrap_or(&[])) {
                *o = number(t)?;
            }
            Ok(out)
        };
        let scene = ParseErrorKind::Scene;
        match head {
            "camera" => {
                let n = args.len();
                if n != 10 && n != 12 {
                    return Err(ParseErrorKind::CameraArgCount { found: n as u8 });
                }
                let v = nums(0..n)?;
                let pinhole = CameraSpec::pinhole(
                    Vec3::new(v[0], v[1], v[2]),
                    Vec3::new(v[3], v[4], v[5]),
                    Vec3::new(v[6], v[7], v[8]),
                    v[9],
                );
                let spec = if n == 12 {
                    pinhole.lens(v[10], v[11])
                } else {
                    pinhole
                };
                self.settings.camera(spec).map_err(scene)
            }
            "resolution" => {
                count(2)?;
                if self.seen_resolution {
                    return Err(ParseErrorKind::Repeated("resolution"));
                }
                self.seen_resolution = true;
                let w = integer(args.first().copied().unwrap_or(""))?;
                let h = integer(args.get(1).copied().unwrap_or(""))?;
                self.settings.resolution(w, h).map_err(scene)
            }
            "background" => {
                count(3)?;
                if self.seen_background {
                    return Err(ParseErrorKind::Repeated("background"));
                }
                self.seen_background = true;
                let v = nums(0..3)?;
                self.settings
                    .background(Vec3::new(v[0], v[1], v[2]))
                    .map_err(scene)
            }
            "material" => {
                let (Some(&name), Some(&kind)) = (args.first(), args.get(1)) else {
                    return Err(ParseErrorKind::WrongArgCount {
                        expected: 5,
                        found: args.len() as u8,
                    });
                };
                if !is_name(name) {
                    return Err(ParseErrorKind::BadName);
                }
                let m = match kind {
                    "diffuse" | "mirror" | "light" => {
                        count(5)?;
                        let v = nums(2..5)?;
                        let c = Vec3::new(v[0], v[1], v[2]);
                        match kind {
                            "diffuse" => Material::Diffuse(c),
                            "mirror" => Material::Mirror(c),
                            _ => Material::Light(c),
                        }
                    }
                    "glass" => {
                        count(3)?;
                        Material::Glass(nums(2..3)?[0])
                    }
                    "metal" => {
                        count(6)?;
                        let v = nums(2..6)?;
                        Material::Metal(Metal {
                            tint: Vec3::new(v[0], v[1], v[2]),
                            alpha: v[3],
                        })
                    }
                    "checker" => {
                        count(9)?;
                        let v = nums(2..9)?;
                        Material::Checker(Checker {
                            even: Vec3::new(v[0], v[1], v[2]),
                            odd: Vec3::new(v[3], v[4], v[5]),
                            size: v[6],
                        })
                    }
                    _ => return Err(ParseErrorKind::UnknownMaterialKind),
                };
                if self.names.contains(&name) {
                    return Err(ParseErrorKind::RedefinedMaterial);
                }
                self.lists.material(m).map_err(scene)?;
                // capacity equals the scene's, which just accepted one more
                self.names
                    .push(name)
                    .map_err(|_| scene(SceneError::Capacity("materials")))
            }
            "sphere" => {
                count(5)?;
                let v = nums(0..4)?;
                let m = self.material_id(args.get(4).copied().unwrap_or(""))?;
                let mut lo = [0.0; 4];
                for ((l, t), &hi) in lo.iter_mut().zip(args).zip(&v) {
                    *l = residual(t, hi);
                }
                self.lists
                    .sphere_precise(
                        Vec3::new(v[0], v[1], v[2]),
                        Vec3::new(lo[0], lo[1], lo[2]),
                        v[3],
                        lo[3],
                        m,
                    )
                    .map(|_| ())
                    .map_err(scene)
            }
            "plane" => {
                count(7)?;
                let v = nums(0..6)?;
                let m = self.material_id(args.get(6).copied().unwrap_or(""))?;
                self.lists
                    .plane(Vec3::new(v[0], v[1], v[2]), Vec3::new(v[3], v[4], v[5]), m)
                    .map(|_| ())
                    .map_err(scene)
            }
            _ => Err(ParseErrorKind::UnknownStatement),
        }
    }

    fn line(&mut self, text: &'a str) -> Result<(), ParseErrorKind> {
        let code = text.split('#').next().unwrap_or("");
        let mut toks: Vec<&'a str, MAX_TOKENS> = Vec::new();
        let mut total = 0usize;
        for t in code.split([' ', '\t', '\r']).filter(|t| !t.is_empty()) {
            total += 1;
            let _ = toks.push(t); // beyond MAX_TOKENS: counted, not kept
        }
        if total > toks.len() {
            // too many tokens for any statement; report the count
            let found = u8::try_from(total - 1).unwrap_or(u8::MAX);
            let expected = match toks.first().copied() {
                Some("camera") => return Err(ParseErrorKind::CameraArgCount { found }),
                Some("resolution") => 2,
                Some("background") => 3,
                Some("material") => match toks.get(2).copied() {
                    Some("glass") => 3,
                    Some("metal") => 6,
                    Some("checker") => 9,
                    Some("diffuse" | "mirror" | "light") => 5,
                    _ => return Err(ParseErrorKind::UnknownMaterialKind),
                },
                Some("sphere") => 5,
                Some("plane") => 7,
                _ => return Err(ParseErrorKind::UnknownStatement),
            };
            return Err(ParseErrorKind::WrongArgCount { expected, found });
        }
        self.statement(&toks)
    }
}

/// Parses a scene from text with the default capacities.
///
/// ```
/// let scene = micropt::parse::parse(
///     "camera 0 0 4  0 0 0  0 1 0  40\nmaterial grey diffuse 0.5 0.5 0.5\nsphere 0 0 0 1 grey\n",
/// )?;
/// assert_eq!(scene.spheres().len(), 1);
/// let err = micropt::parse::parse("camera 0 0 4  0 0 0  0 1 0  40\nsphere 0 0 0 1 nope\n").unwrap_err();
/// assert_eq!(err.line, 2);
/// assert_eq!(err.to_string(), "line 2: unknown material (define it before use)");
/// # Ok::<(), micropt::parse::ParseError>(())
/// ```
pub fn parse(text: &str) -> Result<Scene, ParseError> {
    parse_with_capacity(text)
}

/// Parses a scene from text into a scene of chosen capacities.
pub fn parse_with_capacity<const S: usize, const P: usize, const M: usize>(
    text: &str,
) -> Result<Scene<S, P, M>, ParseError> {
    parse_bytes_with_capacity(text.as_bytes())
}

/// Parses a scene from raw bytes (a line that is not UTF-8 is an error at
/// that line), with the default capacities.
pub fn parse_bytes(bytes: &[u8]) -> Result<Scene, ParseError> {
    parse_bytes_with_capacity(bytes)
}

/// Parses a scene from raw bytes into a scene of chosen capacities.
pub fn parse_bytes_with_capacity<const S: usize, const P: usize, const M: usize>(
    bytes: &[u8],
) -> Result<Scene<S, P, M>, ParseError> {
    let mut scene = Scene::EMPTY;
    parse_bytes_into(bytes, &mut scene)?;
    Ok(scene)
}

/// Parses a scene from text into `scene`, in place: all of it replaced, or
/// on error left empty (as [`Scene::EMPTY`], which cannot be rendered). The
/// scene is filled where it lies, so the parse's stack use is small and does
/// not grow with the scene's capacities: a board parses a scene held in
/// static memory without room for any copy of its lists on the stack.
///
/// ```
/// use micropt::Scene;
/// static TEXT: &str = "camera 0 0 4  0 0 0  0 1 0  40\nmaterial g diffuse 0.5 0.5 0.5\nsphere 0 0 0 1 g\n";
/// let mut scene: Scene<4, 2, 4> = Scene::EMPTY;
/// micropt::parse::parse_into(TEXT, &mut scene)?;
/// assert_eq!(scene.spheres().len(), 1);
/// # Ok::<(), micropt::parse::ParseError>(())
/// ```
pub fn parse_into<const S: usize, const P: usize, const M: usize>(
    text: &str,
    scene: &mut Scene<S, P, M>,
) -> Result<(), ParseError> {
    parse_bytes_into(text.as_bytes(), scene)
}

/// [`parse_into`] from raw bytes.
pub fn parse_bytes_into<const S: usize, const P: usize, const M: usize>(
    bytes: &[u8],
    scene: &mut Scene<S, P, M>,
) -> Result<(), ParseError> {
    let result = parse_in_place(bytes, scene);
    if result.is_err() {
        // the lists hold the scene up to the error, the rest the previous
        // scene's: nothing consistent to keep
        scene.clear();
    }
    result
}

/// [`parse_bytes_into`] but for the clean-up on error.
fn parse_in_place<const S: usize, const P: usize, const M: usize>(
    bytes: &[u8],
    scene: &mut Scene<S, P, M>,
) -> Result<(), ParseError> {
    let mut p: Parser<'_, '_, S, P, M> = Parser {
        lists: scene.lists_to_fill(),
        settings: Settings::NEW,
        names: Vec::new(),
        seen_resolution: false,
        seen_background: false,
    };
    let mut line_no = 0u32;
    for raw in bytes.split(|&b| b == b'\n') {
        line_no = line_no.saturating_add(1);
        let text = core::str::from_utf8(raw).map_err(|_| ParseError {
            line: line_no,
            kind: ParseErrorKind::InvalidUtf8,
        })?;
        p.line(text).map_err(|kind| ParseError {
            line: line_no,
            kind,
        })?;
    }
    // a trailing newline ends the last line; it does not start a new one
    if bytes.last() == Some(&b'\n') {
        line_no = line_no.saturating_sub(1).max(1);
    }
    p.settings.finish(scene).map_err(|e| ParseError {
        line: line_no.max(1),
        kind: match e {
            SceneError::NoCamera => ParseErrorKind::MissingCamera,
            other => ParseErrorKind::Scene(other),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// In-place parsing gives the same scene as parsing by value, also into
    /// a slot that held another scene, and a failed parse leaves the slot
    /// empty, a scene the renderer refuses. (Cornell has a mirror.)
    #[cfg(feature = "mirror")]
    #[test]
    fn parse_into_fills_the_slot_and_empties_it_on_error() {
        let text = include_str!("../scenes/cornell.scene");
        let by_value: Scene<8, 8, 8> = parse_with_capacity(text).unwrap();
        let same = |slot: &Scene<8, 8, 8>| {
            assert_eq!(slot.spheres(), by_value.spheres());
            assert_eq!(slot.planes(), by_value.planes());
            assert_eq!(slot.materials(), by_value.materials());
            assert_eq!(slot.lights(), by_value.lights());
            assert_eq!(slot.analysis().view_order, by_value.analysis().view_order);
            assert_eq!(slot.analysis().view_keys, by_value.analysis().view_keys);
            assert_eq!(slot.analysis().slabs, by_value.analysis().slabs);
            assert_eq!(slot.camera(), by_value.camera());
            assert_eq!(slot.resolution(), by_value.resolution());
        };
        let mut slot: Scene<8, 8, 8> = Scene::EMPTY;
        parse_into(text, &mut slot).unwrap();
        same(&slot);
        // an error after some objects were added, and one at the end (no
        // camera): the slot is empty either way
        for bad in [
            "camera 0 0 4 0 0 0 0 1 0 40\nmaterial g diffuse 0.5 0.5 0.5\nsphere 0 0 0 1 g\nsphere 0 0 0 1 nope\n",
            "material g diffuse 0.5 0.5 0.5\nsphere 0 0 0 1 g\n",
        ] {
            parse_into(text, &mut slot).unwrap();
            assert!(parse_into(bad, &mut slot).is_err());
            assert!(slot.spheres().is_empty() && slot.planes().is_empty());
            assert!(slot.materials().is_empty() && slot.lights().is_empty());
            assert!(slot.analysis().view_order.is_empty() && slot.bvh().is_empty());
            assert!(slot.resolution().is_none());
            assert!(crate::Renderer::new(&slot, 8, 8).is_err());
        }
        // a slot re-parsed with another scene holds only that one
        parse_into("camera 0 0 4 0 0 0 0 1 0 40\n", &mut slot).unwrap();
        assert!(slot.spheres().is_empty() && slot.lights().is_empty());
        assert!(slot.analysis().view_order.is_empty());
        parse_into(text, &mut slot).unwrap();
        same(&slot);
    }

    /// A lens camera in a build without the lens code is an error at the
    /// camera's line; aperture 0 (the 12-value form) is a pinhole in every
    /// build.
    #[test]
    fn lens_cameras_left_out_of_the_build_are_line_errors() {
        let lens = parse("# depth of field\ncamera 0 0 4  0 0 0  0 1 0  40  0.1 4\n");
        if cfg!(feature = "lens") {
            let s = lens.unwrap();
            assert_eq!((s.camera().aperture, s.camera().focus), (0.1, 4.0));
        } else {
            assert_eq!(
                lens.err(),
                Some(ParseError {
                    line: 2,
                    kind: ParseErrorKind::Scene(SceneError::Camera(
                        crate::CameraError::LensNotBuilt
                    )),
                })
            );
        }
        let pinhole = parse("camera 0 0 4  0 0 0  0 1 0  40  0 4\n").unwrap();
        assert!(!pinhole.camera().has_lens());
        let v1 = parse("camera 0 0 4  0 0 0  0 1 0  40\n").unwrap();
        assert_eq!(pinhole.camera().eye, v1.camera().eye);
        assert_eq!(pinhole.camera().vfov_deg, v1.camera().vfov_deg);
    }

    /// A scene with a material this build has no code for is an error at
    /// the material's line, never a silently different image (`cargo test
    /// -p micropt --lib --no-default-features --features parser` runs the
    /// refusing side).
    #[test]
    fn materials_left_out_of_the_build_are_line_errors() {
        for (kind, def, built) in [
            (
                "mirror",
                "material m mirror 1 1 1",
                cfg!(feature = "mirror"),
            ),
            ("glass", "material m glass 1.5", cfg!(feature = "glass")),
            (
                "metal",
                "material m metal 0.9 0.9 0.9 0.2",
                cfg!(feature = "metal"),
            ),
            (
                "checker",
                "material m checker 1 1 1  0 0 0  0.5",
                cfg!(feature = "checker"),
            ),
        ] {
            let mut text: heapless::String<128> = heapless::String::new();
            for part in [
                "camera 0 0 4  0 0 0  0 1 0  40\n",
                def,
                "\nsphere 0 0 0 1 m\n",
            ] {
                text.push_str(part).unwrap();
            }
            let got = parse(&text);
            if built {
                assert!(got.is_ok(), "{kind}: {got:?}");
            } else {
                assert_eq!(
                    got.err(),
                    Some(ParseError {
                        line: 2,
                        kind: ParseErrorKind::Scene(SceneError::MaterialNotBuilt(kind)),
                    })
                );
            }
        }
    }
}
