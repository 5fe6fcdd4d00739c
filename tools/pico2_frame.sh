#!/usr/bin/env bash
# The Pico 2's frame time, estimated from the Cortex-M33 firmware's QEMU
# profile (docs/pico2-frame.md): tools/pico2_frame.sh [SIZE]
#
# Builds examples/firmware for the M33 (QEMU mps2-an505), with the Pico 2
# example's -C target-cpu=cortex-m33, and cornell.scene
# at SIZE (default 240x240, about 20 s under the profiler; 32x32 is
# .ci/targets.sh's size), 16 spp, seed 0, cornell's features; runs it
# under tools/profile.sh (per-instruction counts, taken
# branches, code-region reads, XIP cache model) and prints tools/cpi.py's
# instruction mix, cycles per path and frame times: 240x240 (936,000 paths:
# 16 spp and the preview's sample per 2x2 block) and the Pico 2 panel's
# 320x240 (1,248,000), at 150 MHz over two cores (the
# AN521 speed-up at SIZE if tools/frame.sh measured it, else that of
# target/dualcore/an521.size if .ci/dualcore.sh ran, else
# firmware/expected/an521.size). With the host CLI built (target/debug/
# micropt) it also compares the image with the host's. Output in
# target/pico2-frame/.
set -euo pipefail
cd "$(dirname "$0")/.."
size=${1:-240x240}
out=target/pico2-frame
mkdir -p "$out"
# compiled as the Pico 2 example is (-C target-cpu=cortex-m33: LLVM then
# splits VMLA into VMUL + VADD, among others), in a target directory of its
# own so that CI's build (without it) is not rebuilt
CARGO_TARGET_DIR=target/pico2-frame/cargo RUSTFLAGS="-C target-cpu=cortex-m33" \
    MICROPT_FW_MACHINE=mps2-an505 MICROPT_FW_SCENE=scenes/cornell.scene MICROPT_FW_SIZE="$size" \
    MICROPT_FW_SPP=16 MICROPT_FW_SEED=0 MICROPT_FW_OUT="$out/cornell.rgb565" \
    cargo build -q -p micropt --release --example firmware --no-default-features \
    --features firmware,parser,mirror --target thumbv8m.main-none-eabihf
elf=$out/firmware-m33-cornell-$size.elf
cp target/pico2-frame/cargo/thumbv8m.main-none-eabihf/release/examples/firmware "$elf"
QEMU_MACHINE=mps2-an505 QEMU_CPU=cortex-m33 OUT=$out TOP=15 tools/profile.sh "$elf"
# the image against the host's, if the host CLI is built (cargo build -p micropt-host)
if [ -x target/debug/micropt ]; then
    target/debug/micropt render scenes/cornell.scene --size "$size" --spp 16 --seed 0 --exposure 1 \
        -o "$out/cornell.host.rgb565" >/dev/null
    if cmp -s "$out/cornell.rgb565" "$out/cornell.host.rgb565"; then
        echo "image: bit-identical with the host's"
    else
        echo "image: DIFFERS from the host's (target/debug/micropt)"
    fi
fi
# the speed-up at this size if tools/frame.sh measured it, else the 64x64 one
an521=target/frame/an521-$size/an521.size
[ -f "$an521" ] || an521=target/dualcore/an521.size
[ -f "$an521" ] || an521=firmware/expected/an521.size
speedup=$(sed -n 's/^speedup_busier_core: \([0-9.]*\).*/\1/p' "$an521")
echo
echo "two-core speed-up $speedup ($an521)"
tools/cpi.py "$elf" "$out" --speedup "$speedup" --miss 100
echo
echo "320x240 (the Pico 2's panel):"
tools/cpi.py "$elf" "$out" --speedup "$speedup" --frame-paths $((320 * 240 * 16 + 160 * 120)) | grep -E 'CPI|instruction per cycle'
