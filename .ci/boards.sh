#!/usr/bin/env bash
# Build-checks the display-board examples in examples/boards/: Raspberry Pi
# Pico 2 (RP2350, thumbv8m.main-none-eabihf), Raspberry Pi Pico (RP2040,
# thumbv6m-none-eabi) and ESP32-C3 (riscv32imc-unknown-none-elf). Each is its
# own crate outside the workspace, with its own lockfile, memory map and
# .cargo/config.toml (target, linker script), so each is built from its own
# directory. They share one target directory. Nothing runs: there is no
# board here (docs/boards.md says what QEMU verifies instead). Per board:
# rustfmt, clippy (-D warnings; with and without the `raw` feature), the
# release build (--locked: the committed
# Cargo.lock), its flash and RAM from the ELF's section headers, and which
# f32 routines it links, from its symbol and line tables (.ci/floats.py):
# on the Pico 2 none (the FPU), on the Pico and the ESP32-C3 micropt's own
# soft float (bit-exact with the host), never a boot-ROM or mask-ROM routine
# (the RP2040's flush subnormals to zero; the C3's are not checked here).
# Then what a board would reject at boot: the RP2040's 256-byte .boot2 at
# 0x10000000 with the CRC32 the boot ROM checks, the RP2350's IMAGE_DEF block
# in the first 4 KiB of flash, a UF2 for both Picos (.ci/uf2.py, checked
# block by block against the ELF), and the ESP32-C3's flash image (esptool's
# elf2image, as espflash makes it; image-info checks its header, chip id,
# checksum, SHA-256 and application descriptor). The images are left in
# target/boards/.
# Needs the three rustup targets and esptool (.ci/run installs them), the
# crates.io index, python3 and readelf.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="$PWD/target/boards"

bstep() { printf '\n==== boards: %s (%ss)\n' "$*" "$SECONDS"; }

# Berkeley-style sizes of an ELF of any architecture (readelf reads them all):
# text = allocated read-only sections (flash; on the ESP32-C3 also the code
# copied to IRAM at boot, whose RAM is its .rwdata_dummy), data = allocated writable sections with contents
# (RAM, copied from flash), bss = allocated sections without contents (RAM).
# The Pico 2's .ram_text (code copied to SRAM at reset) counts as text and
# also as static RAM.
elf_size() {
    local text=0 data=0 bss=0 ramcode=0 line name type size flags
    while read -r line; do
        # "[Nr] Name Type Address Off Size ES Flg ..."
        read -r name type _ _ size _ flags _ <<<"${line#*]}"
        [[ "$flags" == *A* ]] || continue
        # esp-hal's linker script: .rotext_dummy reserves the flash cache's
        # address range (no memory), .stack is all RAM left over; its
        # .rwdata_dummy (RAM taken by the code in IRAM) counts as bss
        [[ "$name" == .rotext_dummy || "$name" == .stack ]] && continue
        size=$((16#$size))
        [ "$name" = .ram_text ] && ramcode=$((ramcode + size))
        if [ "$type" = NOBITS ]; then
            bss=$((bss + size))
        elif [[ "$flags" == *W* ]]; then
            data=$((data + size))
        else
            text=$((text + size))
        fi
    done < <(readelf -SW "$1" | grep -E '^ *\[ *[0-9]+\] +[^ ]')
    printf '%-8s text %7d  data %6d  bss %6d  (flash %d, static RAM %d bytes)\n' \
        "$2" "$text" "$data" "$bss" "$((text + data))" "$((data + bss + ramcode))"
}

# The boot block and the flash image of board $1's ELF $2 (fails if either
# is missing or malformed).
boot_image() {
    local out="$CARGO_TARGET_DIR/micropt-$1"
    case "$1" in
    pico)
        readelf -SW "$2" | grep -E ' \.boot2 ' # the section
        python3 .ci/uf2.py boot2 "$2"
        python3 .ci/uf2.py convert "$2" "$out.uf2" rp2040
        ;;
    pico2)
        readelf -SW "$2" | grep -E ' \.start_block ' # the section holding it
        python3 .ci/uf2.py imagedef "$2"
        python3 .ci/uf2.py convert "$2" "$out.uf2" rp2350-arm-s
        # cortex-m-rt copies __sdata..__edata from __sidata as one block:
        # every section loaded into RAM (.data, memory.x's .ram_text) must
        # sit in flash at the same offset from __sidata as in RAM from
        # __sdata (a flash section placed between them, or .ram_text's
        # 8-byte alignment padded differently in flash and RAM, breaks the
        # copy: both were caught)
        python3 - "$2" <<'PY'
import subprocess, sys
elf = sys.argv[1]
syms = {}
for line in subprocess.run(["readelf", "-sW", elf], capture_output=True, text=True, check=True).stdout.splitlines():
    f = line.split()
    if len(f) == 8 and f[7] in ("__sdata", "__edata", "__sidata"):
        syms[f[7]] = int(f[1], 16)
bad = []
loaded = 0
for line in subprocess.run(["readelf", "-lW", elf], capture_output=True, text=True, check=True).stdout.splitlines():
    f = line.split()
    if not f or f[0] != "LOAD":
        continue
    vaddr, paddr, filesz = int(f[2], 16), int(f[3], 16), int(f[4], 16)
    if filesz and vaddr != paddr:
        loaded += filesz
        if not syms["__sdata"] <= vaddr <= vaddr + filesz <= syms["__edata"]:
            bad.append(f"segment at {vaddr:#x} is copied to RAM outside __sdata..__edata")
        elif paddr - syms["__sidata"] != vaddr - syms["__sdata"]:
            bad.append(f"segment at {vaddr:#x} loads from {paddr:#x}, not __sidata + {vaddr - syms['__sdata']:#x}")
if bad:
    sys.exit("error: " + "; ".join(bad))
print(f"RAM sections: {loaded} bytes, at their RAM offsets in the block the reset handler copies from {syms['__sidata']:#x}")
PY
        ;;
    esp32c3)
        rm -f "$out.bin"
        # espflash's defaults: DIO, 4 MB (the flash of most C3 boards)
        python3 -m esptool --chip esp32c3 elf2image --flash-mode dio --flash-size 4MB \
            --output "$out.bin" "$2" >/dev/null
        local info
        info=$(python3 -m esptool --chip esp32c3 image-info "$out.bin")
        local want
        for want in 'Chip ID: 5 \(ESP32-C3\)' 'Checksum: 0x[0-9a-f]+ \(valid\)' \
            'Validation hash: [0-9a-f]{64} \(valid\)' 'Project name: micropt-esp32c3' \
            'IROM' 'DROM'; do
            if ! grep -Eq "$want" <<<"$info"; then
                echo "error: $out.bin: image-info does not show '$want':" >&2
                echo "$info" >&2
                return 1
            fi
        done
        echo "$out.bin: $(stat -c %s "$out.bin") bytes; chip id 5, checksum and SHA-256 valid, app descriptor micropt-esp32c3"
        ;;
    esac
}

bstep "UF2 and boot-block checker: rejects broken input"
python3 .ci/uf2.py selftest

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
        # the progressive raw frame instead of the denoised one
        cargo clippy --release --locked --features raw -- -D warnings
        # the Picos' other Display Pack (examples/board/display_pack.rs)
        case "$name" in
            pico) cargo clippy --release --locked --no-default-features --features pack-20 -- -D warnings ;;
            pico2) cargo clippy --release --locked --no-default-features --features pack-114 -- -D warnings ;;
        esac
        cargo build --release --locked
    )
    elf="$CARGO_TARGET_DIR/$target/release/micropt-$name"
    elf_size "$elf" "$name"
    echo "$name: f32 routines linked (address, size, where, whose):"
    python3 .ci/floats.py "$elf" "$floats" --arch "$arch" --rom "$rom"
    boot_image "$name" "$elf"
done

bstep "boards done"
