//! Fuzz target: the scene parser on arbitrary bytes.
//!
//! The parser must never panic (docs/scene-format.md: "Parsing never panics,
//! whatever bytes it is given"). Beyond not crashing, every outcome is
//! checked for consistency: an error names a line that exists in the input
//! and formats without panicking; an accepted scene holds only finite,
//! in-range values (the validation really ran), and its camera (pinhole or
//! thin lens) makes finite rays.
#![no_main]

use core::fmt::Write;
use libfuzzer_sys::fuzz_target;
use micropt::Material;
use micropt::parse::parse_bytes;

/// A `fmt::Write` sink that only counts bytes (formatting must not panic).
struct Count(usize);

impl Write for Count {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.0 += s.len();
        Ok(())
    }
}

fuzz_target!(|data: &[u8]| {
    match parse_bytes(data) {
        Err(e) => {
            let lines = data.split(|&b| b == b'\n').count().max(1);
            assert!(e.line >= 1 && e.line as usize <= lines, "{e:?} of {lines} lines");
            let mut sink = Count(0);
            write!(sink, "{e}").unwrap();
            assert!(sink.0 > 0);
        }
        Ok(scene) => {
            for s in scene.spheres() {
                assert!(s.center.is_finite() && s.radius.is_finite() && s.radius > 0.0);
                assert!((s.material as usize) < scene.materials().len());
            }
            for p in scene.planes() {
                assert!(p.normal.is_finite() && p.offset.is_finite());
                assert!((p.material as usize) < scene.materials().len());
                assert!(!matches!(
                    scene.materials()[p.material as usize],
                    Material::Light(_)
                ));
            }
            for m in scene.materials() {
                match *m {
                    Material::Diffuse(c) | Material::Mirror(c) => {
                        for v in [c.x, c.y, c.z] {
                            assert!((0.0..=1.0).contains(&v));
                        }
                    }
                    Material::Glass(ior) => assert!(ior.is_finite() && ior > 0.0),
                    Material::Metal(m) => {
                        for v in [m.tint.x, m.tint.y, m.tint.z] {
                            assert!((0.0..=1.0).contains(&v));
                        }
                        assert!((0.001..=1.0).contains(&m.alpha));
                    }
                    Material::Checker(c) => {
                        for v in [c.even.x, c.even.y, c.even.z, c.odd.x, c.odd.y, c.odd.z] {
                            assert!((0.0..=1.0).contains(&v));
                        }
                        assert!(c.size.is_finite() && c.size > 0.0);
                    }
                    Material::Light(c) => {
                        assert!(c.is_finite() && c.x >= 0.0 && c.y >= 0.0 && c.z >= 0.0)
                    }
                }
            }
            let b = scene.background();
            assert!(b.is_finite() && b.x >= 0.0 && b.y >= 0.0 && b.z >= 0.0);
            let c = scene.camera();
            assert!(c.validate().is_ok());
            // the thin lens (format version 2): a radius >= 0, a focus > 0
            assert!(c.aperture.is_finite() && c.aperture >= 0.0);
            assert!(c.focus.is_finite() && c.focus > 0.0);
            // and its rays, which never panic, are finite for values of
            // sane magnitude (an aperture near f32::MAX overflows a lens
            // position, an aperture / focus near it the direction: the
            // renderer counts such samples as non-finite)
            if let Ok(cam) = micropt::Camera::new(c, 7, 5) {
                let r = if cam.has_lens() {
                    cam.lens_ray(3.5, 2.5, [0.999, 0.001])
                } else {
                    cam.ray(3.5, 2.5)
                };
                let sane = |v: f32| v.abs() < 1e30;
                let moderate = [c.eye, c.target]
                    .iter()
                    .all(|p| sane(p.x) && sane(p.y) && sane(p.z))
                    && sane(c.aperture)
                    && c.aperture / c.focus < 1e15;
                if moderate {
                    assert!(r.origin.is_finite() && r.dir.is_finite(), "{c:?}");
                }
            }
        }
    }
});
