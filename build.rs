//! Build script of the `micropt` package.
//!
//! It does nothing for the core library or host builds. For firmware builds
//! only — the `firmware` or `board-st7789` feature on a bare-metal target
//! (`target_os = "none"`) — it
//!
//! * copies the memory map of the QEMU machine the firmware is linked for
//!   (`MICROPT_FW_MACHINE`, by default the target's machine below:
//!   `examples/board/memory-<machine>.x`, or `memory-stm32f405.x` for the
//!   netduinos and the ST7789 board; `memory-mps2-an521.x` for the
//!   `firmware-an521` feature) into `OUT_DIR` as `board-memory.x`, which the
//!   package root's `memory.x` includes, and puts that directory on the
//!   linker path (in a workspace the linker runs from the root, so a
//!   relative path would not do; the root's `memory.x`, found there first,
//!   is the one the runtime's script includes), and passes the runtime's
//!   linker script to the examples' links only (`-Tlink.x`, from cortex-m-rt
//!   or riscv-rt, which include `memory.x`),
//!   so that the core and the `micropt-host` no_std stub still build for the
//!   board targets:
//!
//!   | target                       | default machine  | also              |
//!   | ---------------------------- | ---------------- | ----------------- |
//!   | `thumbv6m-none-eabi`         | `microbit`       | `netduinoplus2`   |
//!   | `thumbv7m-none-eabi`         | `netduino2`      | `mps2-an385`      |
//!   | `thumbv7em-none-eabihf`      | `netduinoplus2`  | `mps2-an500`      |
//!   | `thumbv8m.main-none-eabihf`  | `mps2-an505`     | `mps2-an521` (`firmware-an521`) |
//!   | `riscv32imc-unknown-none-elf`| `virt`           |                   |
//!
//! * for the `firmware` feature, writes `firmware_config.rs` and
//!   `firmware.scene` into `OUT_DIR`: the compile-time choice of scene, image
//!   size, samples per pixel, seed and output file, read from the
//!   environment variables of [`SETTINGS`] (see `docs/firmware.md`), and the
//!   machine's clock. `MICROPT_FW_MACHINE` chooses the machine (table
//!   above); `MICROPT_FW_MEMORY` another memory map of the same machine,
//!   relative to the package root or absolute (`memory-mps2-an500-4m.x`:
//!   all 4 MiB of the `mps2-an500`'s RAM, for scenes of thousands of
//!   spheres).
//!
//!   The scene's fixed capacities (spheres, planes, materials) are the counts
//!   of those statements in the file, so the firmware's static RAM is what
//!   that scene needs; a scene of fewer spheres than the bounding volume
//!   hierarchy's threshold gets the `micropt_no_bvh` cfg, which leaves the
//!   tree's code out, and a scene of at most one sphere with a `light`
//!   material (built with the `specialize` skip on) gets the
//!   `micropt_one_light` cfg, which leaves out the integrator's
//!   several-lights variant (light choice, its pdfs, the outlined shadow
//!   test).

use std::collections::BTreeMap;
use std::env;
use std::fs;
use std::path::{Path, PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(micropt_no_bvh)");
    println!("cargo::rustc-check-cfg=cfg(micropt_one_light)");
    let firmware = env::var_os("CARGO_FEATURE_FIRMWARE").is_some();
    let board = env::var_os("CARGO_FEATURE_BOARD_ST7789").is_some();
    let bare_metal = env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none");
    if !(firmware || board) || !bare_metal {
        return;
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let root = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let riscv = env::var("CARGO_CFG_TARGET_ARCH").as_deref() == Ok("riscv32");

    let machine = match machine(riscv) {
        Ok(m) => m,
        Err(e) => panic!("firmware machine: {e}"),
    };
    // MICROPT_FW_MEMORY: another memory map for the same machine (e.g. more
    // of its RAM, for a big scene); by default the machine's own
    let memory = root.join(var("MICROPT_FW_MEMORY").unwrap_or_else(|| machine.memory.into()));
    println!("cargo:rerun-if-changed={}", memory.display());
    if !memory.is_file() {
        panic!("firmware memory map: no file {}", memory.display());
    }
    println!("cargo:rerun-if-changed=memory.x");
    fs::copy(&memory, out.join("board-memory.x")).expect("copy the memory map to OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-examples=-Tlink.x");

    if firmware && let Err(e) = firmware_config(&root, &out, machine) {
        panic!("firmware configuration: {e}");
    }
}

/// A QEMU machine the firmware runs on.
struct Machine {
    /// QEMU's `-machine` name.
    name: &'static str,
    /// Its memory map, relative to the package root.
    memory: &'static str,
    /// The frequency of the clock the firmware reads, in QEMU: the SysTick's
    /// core clock, or the RISC-V timer's timebase.
    clock_hz: u32,
    /// Whether it is a RISC-V machine.
    riscv: bool,
}

const MACHINES: [Machine; 8] = [
    Machine {
        name: "netduinoplus2",
        memory: "examples/board/memory-stm32f405.x",
        clock_hz: 168_000_000,
        riscv: false,
    },
    Machine {
        name: "netduino2",
        memory: "examples/board/memory-stm32f405.x",
        clock_hz: 120_000_000,
        riscv: false,
    },
    Machine {
        name: "microbit",
        memory: "examples/board/memory-microbit.x",
        clock_hz: 16_000_000,
        riscv: false,
    },
    Machine {
        name: "mps2-an385",
        memory: "examples/board/memory-mps2-an385.x",
        clock_hz: 25_000_000,
        riscv: false,
    },
    Machine {
        name: "mps2-an500",
        memory: "examples/board/memory-mps2-an500.x",
        clock_hz: 25_000_000,
        riscv: false,
    },
    Machine {
        name: "mps2-an505",
        memory: "examples/board/memory-mps2-an505.x",
        clock_hz: 20_000_000,
        riscv: false,
    },
    Machine {
        name: "mps2-an521",
        memory: "examples/board/memory-mps2-an521.x",
        clock_hz: 20_000_000,
        riscv: false,
    },
    Machine {
        name: "virt",
        memory: "examples/board/memory-virt.x",
        clock_hz: 10_000_000,
        riscv: true,
    },
];

/// The machine: `MICROPT_FW_MACHINE`, else the target's default.
fn machine(riscv: bool) -> Result<&'static Machine, String> {
    let target = env::var("TARGET").unwrap_or_default();
    let name = match var("MICROPT_FW_MACHINE") {
        Some(name) => name,
        None => match target.as_str() {
            "thumbv6m-none-eabi" => "microbit".into(),
            "thumbv7m-none-eabi" => "netduino2".into(),
            "thumbv8m.main-none-eabihf"
                if env::var_os("CARGO_FEATURE_FIRMWARE_AN521").is_some() =>
            {
                "mps2-an521".into()
            }
            "thumbv8m.main-none-eabihf" => "mps2-an505".into(),
            t if t.starts_with("riscv32") => "virt".into(),
            _ => "netduinoplus2".into(),
        },
    };
    let m = MACHINES
        .iter()
        .find(|m| m.name == name.trim())
        .ok_or_else(|| {
            let names: Vec<&str> = MACHINES.iter().map(|m| m.name).collect();
            format!(
                "MICROPT_FW_MACHINE={name:?} is not one of {}",
                names.join(", ")
            )
        })?;
    if m.riscv != riscv {
        return Err(format!(
            "the machine {} cannot run the target {target}",
            m.name
        ));
    }
    Ok(m)
}

fn var(name: &str) -> Option<String> {
    println!("cargo:rerun-if-env-changed={name}");
    env::var(name).ok().filter(|v| !v.trim().is_empty())
}

/// One build-time setting of the `firmware` feature: an environment
/// variable, the type of its value, its default and what it selects.
struct Setting {
    var: &'static str,
    kind: Kind,
    /// The value when the variable is unset or empty (`None`: the setting
    /// is absent, and what stands in for it is said in `selects`).
    default: Option<&'static str>,
    selects: &'static str,
}

/// The type of a setting's value.
#[derive(Clone, Copy)]
enum Kind {
    /// A path relative to the package root.
    Path,
    /// `WxH`, each within 1..=1024.
    Size,
    /// An integer > 0.
    Positive,
    /// An integer within 1..=2^32 − 1.
    Count,
    /// An integer ≥ 0.
    Unsigned,
    /// `0` or `1`.
    Flag,
    /// One of these words.
    OneOf(&'static [&'static str]),
    /// A comma-separated list of [`SKIPS`] fields, or `all`.
    Skips,
    /// Text without a NUL byte.
    Text,
}

/// Every `MICROPT_FW_*` setting of the `firmware` feature but the machine
/// and its memory map (read by `main`).
const SETTINGS: [Setting; 12] = [
    Setting {
        var: "MICROPT_FW_SCENE",
        kind: Kind::Path,
        default: Some("scenes/cornell.scene"),
        selects: "the scene (without the `parser` feature only cornell, built in code)",
    },
    Setting {
        var: "MICROPT_FW_SIZE",
        kind: Kind::Size,
        default: None,
        selects: "the image size; unset: the scene's `resolution`, else 64x64",
    },
    Setting {
        var: "MICROPT_FW_SPP",
        kind: Kind::Count,
        default: Some("16"),
        selects: "samples per pixel",
    },
    Setting {
        var: "MICROPT_FW_SEED",
        kind: Kind::Unsigned,
        default: Some("0"),
        selects: "the render's seed",
    },
    Setting {
        var: "MICROPT_FW_BUDGET_MS",
        kind: Kind::Positive,
        default: None,
        selects: "a deadline budget in milliseconds instead of MICROPT_FW_SPP",
    },
    Setting {
        var: "MICROPT_FW_UNIFORM",
        kind: Kind::Flag,
        default: Some("0"),
        selects: "uniform allocation (the unbiased estimator) instead of adaptive",
    },
    Setting {
        var: "MICROPT_FW_DENOISE",
        kind: Kind::Flag,
        default: Some("0"),
        selects: "uniform samples into whole-frame moments, then the core's denoiser (needs MICROPT_FW_SPP, not MICROPT_FW_BUDGET_MS)",
    },
    Setting {
        var: "MICROPT_FW_PASSES",
        kind: Kind::Unsigned,
        default: Some("0"),
        selects: "the demo's first K passes (pass k: MICROPT_FW_SPP x 2^k samples in every pixel, streamed, raw or with MICROPT_FW_DENOISE=1 denoised), K in 0..=17 (0: off); the image after the last",
    },
    Setting {
        var: "MICROPT_FW_SKIP_OFF",
        kind: Kind::Skips,
        default: Some(""),
        selects: "skips of the scene analysis turned off (needs the `tunable` feature)",
    },
    Setting {
        var: "MICROPT_FW_FORCE_BVH",
        kind: Kind::Flag,
        default: Some("0"),
        selects: "the bounding volume hierarchy whatever the scene's size (as `--force-bvh`)",
    },
    Setting {
        var: "MICROPT_FW_CORES",
        kind: Kind::OneOf(&["1", "2"]),
        default: Some("2"),
        selects: "cores that share the render (examples/dualcore.rs only)",
    },
    Setting {
        var: "MICROPT_FW_OUT",
        kind: Kind::Text,
        default: Some("firmware.rgb565"),
        selects: "the host file the image is dumped to (relative to QEMU's working directory)",
    },
];

/// The [`crate::Skip`] fields, in their order there.
const SKIPS: [&str; 10] = [
    "shadow_occluders",
    "view_culling",
    "specialize",
    "horizon",
    "unreachable_lights",
    "closed",
    "slabs",
    "bvh",
    "windows",
    "whole_light",
];

/// A setting's value, checked against its [`Kind`].
enum Value {
    Absent,
    Text(String),
    Size(u32, u32),
    Int(u64),
    Flag(bool),
    /// Per field of [`SKIPS`], whether the skip is on.
    Skips([bool; SKIPS.len()]),
}

impl Kind {
    fn parse(self, var: &str, s: &str) -> Result<Value, String> {
        let t = s.trim();
        Ok(match self {
            Kind::Path => Value::Text(s.to_string()),
            Kind::Size => {
                let (w, h) = parse_size(s)?;
                Value::Size(w, h)
            }
            Kind::Positive => Value::Int(
                t.parse()
                    .ok()
                    .filter(|&n| n > 0)
                    .ok_or_else(|| format!("{var}={s:?} is not a positive integer"))?,
            ),
            Kind::Count => Value::Int(
                t.parse::<u32>()
                    .ok()
                    .filter(|&n| n > 0)
                    .ok_or_else(|| format!("{var}={s:?} is not a positive integer"))?
                    .into(),
            ),
            Kind::Unsigned => Value::Int(
                t.parse()
                    .map_err(|_| format!("{var}={s:?} is not an unsigned integer"))?,
            ),
            Kind::Flag => match t {
                "0" => Value::Flag(false),
                "1" => Value::Flag(true),
                _ => return Err(format!("{var}={t:?} is not 0 or 1")),
            },
            Kind::OneOf(words) => match words.iter().find(|w| **w == t) {
                Some(w) => Value::Text(w.to_string()),
                None => return Err(format!("{var}={t:?} is not {}", words.join(" or "))),
            },
            Kind::Skips => Value::Skips(parse_skips(var, s)?),
            Kind::Text if s.contains('\0') => return Err(format!("{var} contains a NUL byte")),
            Kind::Text => Value::Text(s.to_string()),
        })
    }
}

/// Every setting of [`SETTINGS`], read and checked.
fn read_settings() -> Result<BTreeMap<&'static str, Value>, String> {
    let mut values = BTreeMap::new();
    for s in &SETTINGS {
        let value = match (var(s.var), s.default) {
            (Some(v), _) => s.kind.parse(s.var, &v),
            (None, Some(d)) => s.kind.parse(s.var, d),
            (None, None) => Ok(Value::Absent),
        }
        .map_err(|e| format!("{e} ({} selects {})", s.var, s.selects))?;
        values.insert(s.var, value);
    }
    Ok(values)
}

/// The settings' values by name, typed.
struct Settings(BTreeMap<&'static str, Value>);

impl Settings {
    fn get(&self, var: &str) -> &Value {
        self.0.get(var).unwrap_or(&Value::Absent)
    }
    fn text(&self, var: &str) -> String {
        match self.get(var) {
            Value::Text(t) => t.clone(),
            _ => String::new(),
        }
    }
    fn int(&self, var: &str) -> Option<u64> {
        match self.get(var) {
            Value::Int(n) => Some(*n),
            _ => None,
        }
    }
    fn flag(&self, var: &str) -> bool {
        matches!(self.get(var), Value::Flag(true))
    }
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("MICROPT_FW_SIZE={s:?} is not WxH (e.g. 64x64)"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width {w:?}"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height {h:?}"))?;
    if w == 0 || h == 0 || w > 1024 || h > 1024 {
        return Err(format!("image size {w}x{h} must be within 1..=1024"));
    }
    Ok((w, h))
}

/// `MICROPT_FW_SKIP_OFF`: per field of [`SKIPS`], whether the skip stays
/// on.
fn parse_skips(var: &str, list: &str) -> Result<[bool; SKIPS.len()], String> {
    let mut skip_on = [true; SKIPS.len()];
    if !list.trim().is_empty() && env::var_os("CARGO_FEATURE_TUNABLE").is_none() {
        return Err(format!(
            "{var}={list:?} needs the `tunable` feature: without it every skip is compiled in"
        ));
    }
    for name in list.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        if name == "all" {
            skip_on = [false; SKIPS.len()];
            continue;
        }
        let i = SKIPS.iter().position(|s| *s == name).ok_or_else(|| {
            format!(
                "{var}: unknown Skip field {name:?} (expected all or some of {})",
                SKIPS.join(", ")
            )
        })?;
        skip_on[i] = false;
    }
    Ok(skip_on)
}

/// What the build needs to know of a scene file: its statements' counts
/// (the fixed capacities; the parser on the board reports a capacity
/// error, not a panic, if a count were short), its resolution and the
/// spheres with a `light` material.
struct SceneCounts {
    spheres: usize,
    planes: usize,
    materials: usize,
    resolution: Option<(u32, u32)>,
    light_spheres: usize,
}

fn scene_counts(text: &str) -> SceneCounts {
    let mut c = SceneCounts {
        spheres: 0,
        planes: 0,
        materials: 0,
        resolution: None,
        light_spheres: 0,
    };
    // names of `light` materials (a sphere names its material last:
    // `sphere X Y Z R NAME`)
    let mut light_names: Vec<&str> = Vec::new();
    for line in text.lines() {
        let code = line.split('#').next().unwrap_or("");
        let toks: Vec<&str> = code.split_whitespace().collect();
        match toks.first().copied() {
            Some("material") => {
                c.materials += 1;
                if let (Some(&name), Some(&"light")) = (toks.get(1), toks.get(2)) {
                    light_names.push(name);
                }
            }
            Some("sphere") => {
                c.spheres += 1;
                if toks.last().is_some_and(|m| light_names.contains(m)) {
                    c.light_spheres += 1;
                }
            }
            Some("plane") => c.planes += 1,
            Some("resolution") if toks.len() == 3 => {
                if let (Ok(w), Ok(h)) = (toks[1].parse::<u32>(), toks[2].parse::<u32>()) {
                    c.resolution = Some((w, h));
                }
            }
            _ => {}
        }
    }
    c
}

/// `Skip { .. }`'s fields and the summary line's label of the skips on.
fn skip_source(skip_on: &[bool; SKIPS.len()]) -> (String, String) {
    let fields: String = SKIPS
        .iter()
        .zip(skip_on)
        .map(|(n, on)| format!("{n}: {on}, "))
        .collect();
    let label = if skip_on.iter().all(|&on| on) {
        "all".to_string()
    } else if skip_on.iter().all(|&on| !on) {
        "none".to_string()
    } else {
        let off: Vec<&str> = SKIPS
            .iter()
            .zip(skip_on)
            .filter(|(_, on)| !**on)
            .map(|(n, _)| *n)
            .collect();
        format!("all but {}", off.join(","))
    };
    (fields, label)
}

/// Reads the settings and the scene, sets the cfgs that leave code out,
/// and writes `firmware.scene` and `firmware_config.rs` into `out`.
fn firmware_config(root: &Path, out: &Path, machine: &Machine) -> Result<(), String> {
    let settings = Settings(read_settings()?);
    if settings.flag("MICROPT_FW_DENOISE") && settings.int("MICROPT_FW_BUDGET_MS").is_some() {
        return Err(
            "MICROPT_FW_DENOISE=1 renders MICROPT_FW_SPP samples in every pixel: \
             unset MICROPT_FW_BUDGET_MS"
                .into(),
        );
    }
    let passes = settings.int("MICROPT_FW_PASSES").unwrap_or(0);
    if passes > 17 {
        return Err(format!(
            "MICROPT_FW_PASSES={passes}: the demo has passes 0..=16 (K at most 17)"
        ));
    }
    if passes > 0 && settings.int("MICROPT_FW_BUDGET_MS").is_some() {
        return Err(
            "MICROPT_FW_PASSES renders MICROPT_FW_SPP x 2^k samples in every pixel: \
             unset MICROPT_FW_BUDGET_MS"
                .into(),
        );
    }
    let scene_rel = settings.text("MICROPT_FW_SCENE");
    let scene_path = root.join(&scene_rel);
    println!("cargo:rerun-if-changed={}", scene_path.display());
    let text = fs::read_to_string(&scene_path)
        .map_err(|e| format!("cannot read scene {}: {e}", scene_path.display()))?;
    let counts = scene_counts(&text);
    let parser = env::var_os("CARGO_FEATURE_PARSER").is_some();
    if !parser && scene_rel != "scenes/cornell.scene" {
        return Err(format!(
            "MICROPT_FW_SCENE={scene_rel}: without the `parser` feature the firmware renders \
             the Cornell box built in code; unset MICROPT_FW_SCENE or enable `parser`"
        ));
    }
    let skip_on = match settings.get("MICROPT_FW_SKIP_OFF") {
        Value::Skips(on) => *on,
        _ => [true; SKIPS.len()],
    };
    // a scene below the board's tree threshold (analysis::TREE_MIN_SPHERES
    // on a target without an OS: 24) never gets a bounding volume hierarchy:
    // leave its code out of the firmware (about 30 KB of flash: the build,
    // both traversals and the integrator's tree variants)
    let force_bvh = settings.flag("MICROPT_FW_FORCE_BVH");
    if counts.spheres < 24 && !force_bvh {
        println!("cargo:rustc-cfg=micropt_no_bvh");
    }
    // one light at most, and the integrator's one-light variant in use
    // (`specialize` on): the several-lights variant is never run, so leave
    // it out (about 9 KB of flash on a Cortex-M4F)
    let specialize = SKIPS
        .iter()
        .zip(skip_on)
        .any(|(n, on)| *n == "specialize" && on);
    if counts.light_spheres <= 1 && specialize {
        println!("cargo:rustc-cfg=micropt_one_light");
    }
    let scene_name = if parser {
        Path::new(&scene_rel)
            .file_name()
            .map_or_else(|| scene_rel.clone(), |n| n.to_string_lossy().into_owned())
    } else {
        "cornell (built in code)".to_string()
    };
    fs::write(out.join("firmware.scene"), &text).map_err(|e| e.to_string())?;
    let source = config_source(&settings, &counts, &skip_on, &scene_name, machine);
    fs::write(out.join("firmware_config.rs"), source).map_err(|e| e.to_string())
}

/// The generated `firmware_config.rs`.
fn config_source(
    settings: &Settings,
    counts: &SceneCounts,
    skip_on: &[bool; SKIPS.len()],
    scene_name: &str,
    machine: &Machine,
) -> String {
    let (width, height) = match settings.get("MICROPT_FW_SIZE") {
        Value::Size(w, h) => (*w, *h),
        _ => counts.resolution.unwrap_or((64, 64)),
    };
    let spp = settings.int("MICROPT_FW_SPP").unwrap_or(16);
    let seed = settings.int("MICROPT_FW_SEED").unwrap_or(0);
    let budget = match settings.int("MICROPT_FW_BUDGET_MS") {
        Some(ms) => format!("micropt::Budget::Deadline({})", ms * 1000),
        None => "micropt::Budget::Spp(SPP)".to_string(),
    };
    let uniform = settings.flag("MICROPT_FW_UNIFORM");
    let denoise = settings.flag("MICROPT_FW_DENOISE");
    let passes = settings.int("MICROPT_FW_PASSES").unwrap_or(0);
    let demo = passes > 0;
    let force_bvh = settings.flag("MICROPT_FW_FORCE_BVH");
    let cores = settings.text("MICROPT_FW_CORES");
    let output = settings.text("MICROPT_FW_OUT");
    let (skip_fields, skip_label) = skip_source(skip_on);
    format!(
        "// generated by build.rs from the MICROPT_FW_* environment variables\n\
         /// Frequency of the clock the firmware reads (SysTick's core clock,\n\
         /// or the RISC-V timer's timebase), in QEMU.\n\
         pub const CLOCK_HZ: u32 = {clock_hz};\n\
         /// Scene file name (for the summary line).\n\
         pub const SCENE_NAME: &str = {scene_name:?};\n\
         /// Image width in pixels.\n\
         pub const WIDTH: usize = {width};\n\
         /// Image height in pixels.\n\
         pub const HEIGHT: usize = {height};\n\
         /// Samples per pixel.\n\
         #[allow(dead_code)] // unused with a deadline budget\n\
         pub const SPP: u32 = {spp};\n\
         /// Render seed.\n\
         pub const SEED: u64 = {seed};\n\
         /// Host file the Rgb565 dump is written to (NUL-terminated).\n\
         pub const OUTPUT: &str = \"{}\\0\";\n\
         /// Sphere capacity of the scene.\n\
         pub const MAX_SPHERES: usize = {};\n\
         /// Plane capacity of the scene.\n\
         pub const MAX_PLANES: usize = {};\n\
         /// Material capacity of the scene.\n\
         pub const MAX_MATERIALS: usize = {};\n\
         /// The render budget.\n\
         pub const BUDGET: micropt::Budget = {budget};\n\
         /// Adaptive allocation (false: uniform).\n\
         pub const ADAPTIVE: bool = {};\n\
         /// Denoised: uniform samples into moments, then the denoiser.\n\
         #[allow(dead_code)] // only the single-core firmware reads it\n\
         pub const DENOISE: bool = {denoise};\n\
         /// The demo's passes (0: not the demo's).\n\
         #[allow(dead_code)] // only the single-core firmware reads it\n\
         pub const PASSES: u32 = {passes};\n\
         /// Whether the firmware runs the demo's passes (`PASSES` > 0).\n\
         #[allow(dead_code)] // only the single-core firmware reads it\n\
         pub const DEMO: bool = {demo};\n\
         /// The integrator's skip switches.\n\
         pub const SKIP: micropt::Skip = micropt::Skip {{ {skip_fields}}};\n\
         /// The skip switches, for the summary line.\n\
         pub const SKIP_LABEL: &str = {skip_label:?};\n\
         /// Build the tree whatever the scene's size (the single-core\n\
         /// firmware).\n\
         #[allow(dead_code)] // only the single-core firmware reads it\n\
         pub const FORCE_BVH: bool = {force_bvh};\n\
         /// Cores that share the render (the dual-core firmware).\n\
         #[allow(dead_code)] // only the dual-core firmware reads it\n\
         pub const CORES: usize = {cores};\n",
        output.escape_default(),
        counts.spheres.max(1),
        counts.planes.max(1),
        counts.materials.max(1),
        !uniform,
        clock_hz = machine.clock_hz,
    )
}
