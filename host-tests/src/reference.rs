//! The independent reference renders shipped in `host-tests/data/`: the PFM
//! image and the facts of its `.json` (spp, mean, per-pixel standard error).

use crate::image::Image;
use std::path::{Path, PathBuf};

/// A reference render and what its `.json` says about it.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Scene name (file stem), e.g. `cornell`.
    pub name: String,
    /// The linear RGB reference image.
    pub image: Image,
    /// Samples per pixel of the reference.
    pub spp: u64,
    /// Mean RGB of the reference image.
    pub mean_rgb: [f64; 3],
    /// RMS over pixels of the per-pixel standard error of the reference: its
    /// own noise. Its square is what the reference adds to an MSE.
    pub rms_standard_error: f64,
}

/// The directory of the shipped references.
pub fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// The directory of the shipped scenes.
pub fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("scenes")
}

/// Names of all scenes that have a reference, sorted. Only `NAME.pfm`
/// counts: `NAME.se.pfm` (a reference's per-pixel standard errors) and
/// `NAME.cycles.pfm` (a second reference of the same scene, which only
/// `tests/bias_blocks.rs` reads) are not references of scenes of their own.
pub fn names() -> Vec<String> {
    let mut v = stems(&data_dir(), "pfm");
    v.retain(|n| !n.contains('.'));
    v
}

/// The per-pixel standard errors of reference `name` (`data/NAME.se.pfm`),
/// where one is shipped.
pub fn standard_error_map(name: &str) -> Option<Result<Image, String>> {
    let p = data_dir().join(format!("{name}.se.pfm"));
    p.is_file().then(|| Image::load_pfm(&p))
}

/// Names of all shipped scenes (`scenes/*.scene`), sorted.
pub fn shipped_scenes() -> Vec<String> {
    stems(&scenes_dir(), "scene")
}

/// The stems of the files in `dir` with extension `ext`, sorted.
fn stems(dir: &Path, ext: &str) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .filter_map(|e| {
                    let p = e.path();
                    if p.extension()? == ext {
                        Some(p.file_stem()?.to_string_lossy().into_owned())
                    } else {
                        None
                    }
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

impl Reference {
    /// Loads `data/<name>.pfm` and `data/<name>.json`.
    pub fn load(name: &str) -> Result<Self, String> {
        let dir = data_dir();
        let image = Image::load_pfm(&dir.join(format!("{name}.pfm")))?;
        let json_path = dir.join(format!("{name}.json"));
        let text = std::fs::read_to_string(&json_path)
            .map_err(|e| format!("{}: {e}", json_path.display()))?;
        let v: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| format!("{}: {e}", json_path.display()))?;
        let num = |k: &str| {
            v.get(k)
                .and_then(|x| x.as_f64())
                .ok_or_else(|| format!("{}: no number {k:?}", json_path.display()))
        };
        let mean = v
            .get("mean_rgb")
            .and_then(|m| m.as_array())
            .filter(|m| m.len() == 3)
            .ok_or_else(|| format!("{}: no mean_rgb", json_path.display()))?;
        let mean_rgb = [0, 1, 2].map(|i| mean[i].as_f64().unwrap_or(f64::NAN));
        Ok(Self {
            name: name.to_owned(),
            image,
            spp: num("spp")? as u64,
            mean_rgb,
            rms_standard_error: num("rms_standard_error")?,
        })
    }

    /// The scene file this reference was rendered from: a test scene of
    /// its own beside it (`data/<name>.scene`), else the shipped scene.
    pub fn scene_path(&self) -> PathBuf {
        let own = data_dir().join(format!("{}.scene", self.name));
        if own.is_file() {
            own
        } else {
            scenes_dir().join(format!("{}.scene", self.name))
        }
    }

    /// Standard error of the reference's image mean (per channel): the
    /// per-pixel standard error over √(pixels), assuming independent pixels.
    pub fn mean_standard_error(&self) -> f64 {
        self.rms_standard_error / (self.image.pixels.len() as f64).sqrt()
    }
}
