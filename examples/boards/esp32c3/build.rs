//! Keeps the f32 arithmetic off the ESP32-C3's mask ROM.
//!
//! esp-rom-sys's linker script (`rom-functions.x`, included by esp-hal's
//! `linkall.x`) includes `rom/esp32c3.rom.libgcc.ld`, which assigns the
//! libgcc names (`__addsf3 = 0x40000770;`, `__mulsf3`, ...) to the chip's
//! ROM routines. A linker-script assignment overrides a definition in the
//! program, so without this every `f32` operator would call the ROM, whose
//! bits are not checked against the host's, even with micropt's routines
//! exported under those names (`examples/board/softfloat.rs`). This build
//! script puts an empty `rom/esp32c3.rom.libgcc.ld` first on the linker's
//! search path: the include finds it instead, the names stay undefined for
//! the linker script, and the calls bind to micropt's routines (the
//! arithmetic) and compiler-builtins' (float to integer conversions).
//! `.ci/boards.sh` checks the ELF's symbol table for it.

use std::path::PathBuf;
use std::{env, fs};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let rom = out.join("rom");
    fs::create_dir_all(&rom).expect("create OUT_DIR/rom");
    fs::write(
        rom.join("esp32c3.rom.libgcc.ld"),
        "/* empty: micropt-esp32c3's build.rs keeps f32 routines off the ROM */\n",
    )
    .expect("write OUT_DIR/rom/esp32c3.rom.libgcc.ld");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
}
