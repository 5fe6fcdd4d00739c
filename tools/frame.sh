#!/usr/bin/env bash
# The cost of a whole frame on the boards, from exact QEMU instruction
# counts: tools/frame.sh [SIZE] (default 240x240; scenes/cornell.scene with
# its own features, parser and mirror, 16 spp, seed 0, adaptive).
#
#   1. Cortex-M4F firmware (netduinoplus2): render instructions, traced
#      paths, instructions per path at SIZE.
#   2. Cortex-M33 firmware (mps2-an505, the RP2350's core): the same.
#   3. Two Cortex-M33 (mps2-an521, .ci/dualcore.sh at SIZE): the two-core
#      speed-up of the same scene and size.
#   4. The Pico 2 estimate: M33 render instructions / 150 MHz / speed-up, at
#      one instruction per cycle (an estimate: no board here; docs/boards.md
#      says what real cycles add).
#
# Every board image is compared with the host CLI's (bit-identical).
# Writes target/frame/frame-SIZE.txt. Takes a few minutes at 240x240.
set -euo pipefail
cd "$(dirname "$0")/.."
. .ci/elf.sh
SIZE=${1:-240x240}
SCENE=scenes/cornell.scene
OUT=target/frame
mkdir -p "$OUT"
gcc -O2 -shared -fPIC -o "$OUT/libicount.so" tools/qemu-icount/icount.c
cargo build -q --profile test -p micropt-host --bin micropt
target/debug/micropt render "$SCENE" --size "$SIZE" --spp 16 --seed 0 --exposure 1 \
    -o "$OUT/host-$SIZE.rgb565"

# one core: TARGET MACHINE NAME -> "render paths per_path flash"
one() {
    local target=$1 machine=$2 name=$3 cpu=()
    [ "$machine" = netduinoplus2 ] && cpu=(-cpu cortex-m4)
    MICROPT_FW_SCENE=$SCENE MICROPT_FW_SIZE=$SIZE MICROPT_FW_SPP=16 MICROPT_FW_SEED=0 \
        MICROPT_FW_OUT="$OUT/$name-$SIZE.rgb565" \
        cargo build -q -p micropt --release --example firmware --no-default-features \
        --features firmware,parser,mirror --target "$target"
    local elf=target/$target/release/examples/firmware
    rm -f "$OUT/$name-$SIZE.rgb565"
    timeout 3600 qemu-system-arm "${cpu[@]}" -machine "$machine" -nographic \
        -semihosting-config enable=on,target=native -icount shift=0 \
        -plugin "$OUT/libicount.so" -d plugin -D "$OUT/$name-$SIZE.icount" \
        -kernel "$elf" >"$OUT/$name-$SIZE.run"
    cmp "$OUT/$name-$SIZE.rgb565" "$OUT/host-$SIZE.rgb565" >&2 || {
        echo "error: $name: the board's image differs from the host's" >&2
        exit 1
    }
    local marks paths flash
    read -r -a marks <<<"$(sed -n 's/^marks: //p' "$OUT/$name-$SIZE.icount")"
    paths=$(sed -n 's/.*, \([0-9]*\) paths,.*/\1/p' "$OUT/$name-$SIZE.run")
    read -r flash _ <<<"$(elf_figures "$elf")"
    local render=$((marks[3] - marks[2]))
    echo "$render $paths $((render / paths)) $flash"
}

read -r m4_render m4_paths m4_per m4_flash <<<"$(one thumbv7em-none-eabihf netduinoplus2 m4f)"
read -r m33_render m33_paths m33_per m33_flash <<<"$(one thumbv8m.main-none-eabihf mps2-an505 m33)"
# the AN521's 128 KiB of internal SRAM cannot hold a 240x240 framebuffer and
# two cores' accumulators: data in 512 KiB of its SSRAM2 instead
MICROPT_FW_MEMORY=examples/board/memory-mps2-an521-512k.x \
    DUALCORE_SIZE=$SIZE DUALCORE_OUT=$OUT/an521-$SIZE bash .ci/dualcore.sh >"$OUT/an521-$SIZE.log" 2>&1 || {
    tail -20 "$OUT/an521-$SIZE.log"
    echo "error: .ci/dualcore.sh at $SIZE failed" >&2
    exit 1
}
speedup=$(sed -n 's/^speedup_busier_core: \([0-9.]*\).*/\1/p' "$OUT/an521-$SIZE/an521.size")
{
    echo "# tools/frame.sh $SIZE: scenes/cornell.scene, parser + mirror, 16 spp, seed 0, adaptive;"
    echo "# exact QEMU instruction counts (-icount shift=0); board images == host's"
    echo "m4f_netduinoplus2: render $m4_render  paths $m4_paths  per_path $m4_per  flash $m4_flash"
    echo "m33_mps2-an505: render $m33_render  paths $m33_paths  per_path $m33_per  flash $m33_flash"
    echo "an521_two_core_speedup: $speedup"
    awk -v r="$m33_render" -v s="$speedup" 'BEGIN {
        printf "pico2_frame_estimate: %.2f s  (M33 render / 150 MHz / %s; one instruction per cycle)\n",
            r / 150e6 / s, s }'
} | tee "$OUT/frame-$SIZE.txt"
