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
//!   size, samples per pixel, seed and output file, read from environment
//!   variables (see `docs/firmware.md`), and the machine's clock:
//!
//!   | variable            | default                   |
//!   | ------------------- | ------------------------- |
//!   | `MICROPT_FW_SCENE`  | `scenes/cornell.scene`    |
//!   | `MICROPT_FW_SIZE`   | the scene's `resolution`, else `64x64` |
//!   | `MICROPT_FW_SPP`    | `16`                      |
//!   | `MICROPT_FW_SEED`   | `0`                       |
//!   | `MICROPT_FW_OUT`    | `firmware.rgb565` (host path, relative to QEMU's working directory) |
//!   | `MICROPT_FW_CORES`  | `2` (cores sharing the render: `examples/dualcore.rs` only) |
//!   | `MICROPT_FW_MACHINE`| the target's machine (table above) |
//!   | `MICROPT_FW_MEMORY` | the machine's memory map (table above); another map of the same machine, relative to the package root or absolute (`memory-mps2-an500-4m.x`: all 4 MiB of the `mps2-an500`'s RAM, for scenes of thousands of spheres) |
//!   | `MICROPT_FW_FORCE_BVH` | `0`; `1` builds the bounding volume hierarchy whatever the scene's size (as the host CLI's `--force-bvh`; `MICROPT_FW_SKIP_OFF=bvh` still leaves it unused) |
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

fn firmware_config(root: &Path, out: &Path, machine: &Machine) -> Result<(), String> {
    let scene_rel = var("MICROPT_FW_SCENE").unwrap_or_else(|| "scenes/cornell.scene".into());
    let scene_path = root.join(&scene_rel);
    println!("cargo:rerun-if-changed={}", scene_path.display());
    let text = fs::read_to_string(&scene_path)
        .map_err(|e| format!("cannot read scene {}: {e}", scene_path.display()))?;

    // capacities: the number of statements of each kind (the parser on the
    // board reports a capacity error, not a panic, if this count were short)
    let (mut spheres, mut planes, mut materials) = (0usize, 0usize, 0usize);
    let mut resolution = None;
    // names of `light` materials, and the spheres that use one (a sphere
    // names its material last: `sphere X Y Z R NAME`)
    let mut light_names: Vec<&str> = Vec::new();
    let mut light_spheres = 0usize;
    for line in text.lines() {
        let code = line.split('#').next().unwrap_or("");
        let toks: Vec<&str> = code.split_whitespace().collect();
        match toks.first().copied() {
            Some("material") => {
                materials += 1;
                if let (Some(&name), Some(&"light")) = (toks.get(1), toks.get(2)) {
                    light_names.push(name);
                }
            }
            Some("sphere") => {
                spheres += 1;
                if toks.last().is_some_and(|m| light_names.contains(m)) {
                    light_spheres += 1;
                }
            }
            Some("plane") => planes += 1,
            Some("resolution") if toks.len() == 3 => {
                if let (Ok(w), Ok(h)) = (toks[1].parse::<u32>(), toks[2].parse::<u32>()) {
                    resolution = Some((w, h));
                }
            }
            _ => {}
        }
    }
    // a scene below the board's tree threshold (analysis::TREE_MIN_SPHERES
    // on a target without an OS: 24) never gets a bounding volume hierarchy:
    // leave its code out of the firmware (about 30 KB of flash: the build,
    // both traversals and the integrator's tree variants)
    let force_bvh = match var("MICROPT_FW_FORCE_BVH").as_deref().map(str::trim) {
        None | Some("0") => false,
        Some("1") => true,
        Some(s) => return Err(format!("MICROPT_FW_FORCE_BVH={s:?} is not 0 or 1")),
    };
    if spheres < 24 && !force_bvh {
        println!("cargo:rustc-cfg=micropt_no_bvh");
    }
    let (width, height) = match var("MICROPT_FW_SIZE") {
        Some(s) => parse_size(&s)?,
        None => resolution.unwrap_or((64, 64)),
    };
    let spp: u32 = match var("MICROPT_FW_SPP") {
        Some(s) => s
            .trim()
            .parse()
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| format!("MICROPT_FW_SPP={s:?} is not a positive integer"))?,
        None => 16,
    };
    let seed: u64 = match var("MICROPT_FW_SEED") {
        Some(s) => s
            .trim()
            .parse()
            .map_err(|_| format!("MICROPT_FW_SEED={s:?} is not an unsigned integer"))?,
        None => 0,
    };
    let parser = env::var_os("CARGO_FEATURE_PARSER").is_some();
    if !parser && scene_rel != "scenes/cornell.scene" {
        return Err(format!(
            "MICROPT_FW_SCENE={scene_rel}: without the `parser` feature the firmware renders \
             the Cornell box built in code; unset MICROPT_FW_SCENE or enable `parser`"
        ));
    }
    let deadline_ms: Option<u64> =
        match var("MICROPT_FW_BUDGET_MS") {
            Some(s) => {
                Some(s.trim().parse().ok().filter(|&n| n > 0).ok_or_else(|| {
                    format!("MICROPT_FW_BUDGET_MS={s:?} is not a positive integer")
                })?)
            }
            None => None,
        };
    let uniform = match var("MICROPT_FW_UNIFORM").as_deref().map(str::trim) {
        None | Some("0") => false,
        Some("1") => true,
        Some(s) => return Err(format!("MICROPT_FW_UNIFORM={s:?} is not 0 or 1")),
    };
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
    let mut skip_on = [true; SKIPS.len()];
    let skip_off = var("MICROPT_FW_SKIP_OFF").unwrap_or_default();
    if !skip_off.trim().is_empty() && var("CARGO_FEATURE_TUNABLE").is_none() {
        return Err(format!(
            "MICROPT_FW_SKIP_OFF={skip_off:?} needs the `tunable` feature: without it \
             every skip is compiled in"
        ));
    }
    for name in skip_off.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        if name == "all" {
            skip_on = [false; SKIPS.len()];
            continue;
        }
        let i = SKIPS.iter().position(|s| *s == name).ok_or_else(|| {
            format!(
                "MICROPT_FW_SKIP_OFF: unknown Skip field {name:?} (expected all or some of {})",
                SKIPS.join(", ")
            )
        })?;
        skip_on[i] = false;
    }
    // one light at most, and the integrator's one-light variant in use
    // (`specialize` on): the several-lights variant is never run, so leave
    // it out (about 9 KB of flash on a Cortex-M4F)
    let specialize = SKIPS
        .iter()
        .zip(skip_on)
        .any(|(n, on)| *n == "specialize" && on);
    if light_spheres <= 1 && specialize {
        println!("cargo:rustc-cfg=micropt_one_light");
    }
    let skip_fields: String = SKIPS
        .iter()
        .zip(skip_on)
        .map(|(n, on)| format!("{n}: {on}, "))
        .collect();
    let skip_label = if skip_on.iter().all(|&on| on) {
        "all".to_string()
    } else if skip_on.iter().all(|&on| !on) {
        "none".to_string()
    } else {
        let off: Vec<&str> = SKIPS
            .iter()
            .zip(skip_on)
            .filter(|(_, on)| !on)
            .map(|(n, _)| *n)
            .collect();
        format!("all but {}", off.join(","))
    };
    let budget = match deadline_ms {
        Some(ms) => format!("micropt::Budget::Deadline({})", ms * 1000),
        None => "micropt::Budget::Spp(SPP)".to_string(),
    };
    let cores: usize = match var("MICROPT_FW_CORES").as_deref().map(str::trim) {
        None | Some("2") => 2,
        Some("1") => 1,
        Some(s) => return Err(format!("MICROPT_FW_CORES={s:?} is not 1 or 2")),
    };
    let output = var("MICROPT_FW_OUT").unwrap_or_else(|| "firmware.rgb565".into());
    if output.contains('\0') {
        return Err("MICROPT_FW_OUT contains a NUL byte".into());
    }
    let scene_name = if parser {
        Path::new(&scene_rel)
            .file_name()
            .map_or_else(|| scene_rel.clone(), |n| n.to_string_lossy().into_owned())
    } else {
        "cornell (built in code)".to_string()
    };

    fs::write(out.join("firmware.scene"), &text).map_err(|e| e.to_string())?;
    let config = format!(
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
        spheres.max(1),
        planes.max(1),
        materials.max(1),
        !uniform,
        clock_hz = machine.clock_hz,
    );
    fs::write(out.join("firmware_config.rs"), config).map_err(|e| e.to_string())
}
