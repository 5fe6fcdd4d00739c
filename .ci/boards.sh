#!/usr/bin/env bash
# Build-checks the display-board examples in examples/boards/: Raspberry Pi
# Pico 2 (RP2350, thumbv8m.main-none-eabihf), Raspberry Pi Pico (RP2040,
# thumbv6m-none-eabi) and ESP32-C3 (riscv32imc-unknown-none-elf). Each is its
# own crate outside the workspace, with its own lockfile, memory map and
# .cargo/config.toml (target, linker script), so each is built from its own
# directory. They share one target directory. Nothing runs: there is no
# board here (docs/boards.md says what QEMU verifies instead). Per board:
# rustfmt, clippy (-D warnings), the release build (--locked: the committed
# Cargo.lock), its flash and RAM from the ELF's section headers, and which
# f32 routines it links, from its symbol and line tables (.ci/floats.py):
# on the Pico 2 none (the FPU), on the Pico and the ESP32-C3 micropt's own
# soft float (bit-exact with the host), never a boot-ROM or mask-ROM routine
# (the RP2040's flush subnormals to zero; the C3's are not checked here).
# Needs the three rustup targets (.ci/run adds them), the crates.io index,
# python3 and readelf.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="$PWD/target/boards"

bstep() { printf '\n==== boards: %s (%ss)\n' "$*" "$SECONDS"; }

# Berkeley-style sizes of an ELF of any architecture (readelf reads them all):
# text = allocated read-only sections (flash; on the ESP32-C3 also the code
# copied to IRAM at boot, whose RAM is its .rwdata_dummy), data = allocated writable sections with contents
# (RAM, copied from flash), bss = allocated sections without contents (RAM).
elf_size() {
    local text=0 data=0 bss=0 line name type size flags
    while read -r line; do
        # "[Nr] Name Type Address Off Size ES Flg ..."
        read -r name type _ _ size _ flags _ <<<"${line#*]}"
        [[ "$flags" == *A* ]] || continue
        # esp-hal's linker script: .rotext_dummy reserves the flash cache's
        # address range (no memory), .stack is all RAM left over; its
        # .rwdata_dummy (RAM taken by the code in IRAM) counts as bss
        [[ "$name" == .rotext_dummy || "$name" == .stack ]] && continue
        size=$((16#$size))
        if [ "$type" = NOBITS ]; then
            bss=$((bss + size))
        elif [[ "$flags" == *W* ]]; then
            data=$((data + size))
        else
            text=$((text + size))
        fi
    done < <(readelf -SW "$1" | grep -E '^ *\[ *[0-9]+\] +[^ ]')
    printf '%-8s text %7d  data %6d  bss %6d  (flash %d, static RAM %d bytes)\n' \
        "$2" "$text" "$data" "$bss" "$((text + data))" "$((data + bss))"
}

# board:target:float routines (.ci/floats.py):arch:ROM address range
BOARDS="pico2:thumbv8m.main-none-eabihf:fpu:arm:0x00000000-0x00008000
pico:thumbv6m-none-eabi:micropt:arm:0x00000000-0x00004000
esp32c3:riscv32imc-unknown-none-elf:micropt:riscv:0x40000000-0x40060000"

for board in $BOARDS; do
    IFS=: read -r name target floats arch rom <<<"$board"
    bstep "$name ($target): fmt, clippy, build"
    (
        cd "examples/boards/$name"
        cargo fmt -- --check
        cargo clippy --release --locked -- -D warnings
        cargo build --release --locked
    )
    elf="$CARGO_TARGET_DIR/$target/release/micropt-$name"
    elf_size "$elf" "$name"
    echo "$name: f32 routines linked (address, size, where, whose):"
    python3 .ci/floats.py "$elf" "$floats" --arch "$arch" --rom "$rom"
done

bstep "boards done"
