#!/usr/bin/env bash
# The denoised firmware (called by .ci/run; runs alone too): examples/firmware
# built with MICROPT_FW_DENOISE=1 for the Cortex-M33 (QEMU's mps2-an505, the
# RP2350's core), run on cornell, gloss and spheres, each image
# byte-identical with the host CLI's `micropt render SCENE --spp 16 --size
# WxH --seed 0 --denoise -o x.rgb565`.
#
# Per scene it records the instructions of each phase between the
# firmware's marks (render: every pixel's samples into its moments;
# denoise: guides, filters and choice, every pixel's colour; output: the
# tone mapping into the framebuffer, which a raw frame runs too), the
# denoiser's share of the render's, its instructions a pixel, flash and
# static RAM, in
# target/denoise/denoise.size, printing a diff against
# firmware/expected/denoise.size (informational; `--bless` rewrites it).
#
#   .ci/denoise.sh                     CI: 32x32 (cornell), 24x16 (gloss, spheres)
#   .ci/denoise.sh 240x240 [SCENE]     the board's frame (cornell by default):
#                                      the denoiser's share of a 240x240,
#                                      16-spp M33 frame (about a minute)
set -euo pipefail
cd "$(dirname "$0")/.."
. .ci/qemu-arm.sh
. .ci/elf.sh

BLESS=0
if [ "${1:-}" = "--bless" ]; then
    BLESS=1
    shift
fi

TARGET=thumbv8m.main-none-eabihf
OUT=target/denoise
ELF=target/$TARGET/release/examples/firmware
mkdir -p "$OUT"
fail() {
    echo "error: $*" >&2
    exit 1
}
nstep() { printf '\n---- denoise: %s (%ss)\n' "$*" "$SECONDS"; }

nstep "install qemu-system-arm and gcc if missing (when run alone)"
install_qemu_arm "$TARGET"

nstep "instruction-count plugin, host CLI"
gcc -O2 -Wall -Wextra -Werror -shared -fPIC -o "$OUT/libicount.so" tools/qemu-icount/icount.c
cargo build -q --profile test -p micropt-host --bin micropt
HOST=target/debug/micropt

# run SCENE SIZE MEMORY: one scene, one size; appends its line to $SIZES
run() {
    local scene=$1 size=$2 memory=$3 name features=(--features firmware)
    name=$(basename "$scene" .scene)
    # cornell with the features its scene uses (as the board examples and
    # firmware.sh build it); the others with the default features
    [ "$name" = cornell ] && features=(--no-default-features --features firmware,parser,mirror)
    MICROPT_FW_SCENE=$scene MICROPT_FW_SIZE=$size MICROPT_FW_SPP=16 MICROPT_FW_SEED=0 \
        MICROPT_FW_DENOISE=1 MICROPT_FW_MEMORY=$memory MICROPT_FW_OUT="$OUT/$name-$size.rgb565" \
        cargo build -q -p micropt --release --example firmware "${features[@]}" --target "$TARGET"
    rm -f "$OUT/$name-$size.rgb565"
    timeout 3600 qemu-system-arm -machine mps2-an505 -nographic \
        -semihosting-config enable=on,target=native -icount shift=0 \
        -plugin "$OUT/libicount.so" -d plugin -D "$OUT/$name-$size.icount" \
        -kernel "$ELF" >"$OUT/$name-$size.run" || fail "$name $size: the firmware failed ($(cat "$OUT/$name-$size.run"))"
    "$HOST" render "$scene" --spp 16 --size "$size" --seed 0 --denoise -o "$OUT/$name-$size.host.rgb565"
    cmp "$OUT/$name-$size.rgb565" "$OUT/$name-$size.host.rgb565" ||
        fail "$name $size: the board's denoised image differs from the host's"
    local marks flash ram w h
    read -r -a marks <<<"$(sed -n 's/^marks: //p' "$OUT/$name-$size.icount")"
    [ "${#marks[@]}" -ge 7 ] || fail "$name $size: expected 7 marks, got ${#marks[@]}"
    read -r flash ram <<<"$(elf_figures "$ELF")"
    local render=$((marks[3] - marks[2])) dn=$((marks[4] - marks[3])) out=$((marks[5] - marks[4]))
    w=${size%x*}
    h=${size#*x}
    printf '%-10s %-8s %10s %9s %9s %13s %11s %8s %7s %10s\n' "$name" "$size" "$flash" "$ram" \
        "$(grep -o 'stack high-water [0-9]*' "$OUT/$name-$size.run" | grep -o '[0-9]*$')" \
        "$render" "$dn" "$((dn / (w * h)))" \
        "$(awk -v d="$dn" -v r="$render" 'BEGIN { printf "%.2f%%", 100 * d / r }')" "$out" >>"$SIZES"
    echo "$name $size: board = host; render $render, denoise $dn, output $out instructions"
}

HEADER=$(printf '%-10s %-8s %10s %9s %9s %13s %11s %8s %7s %10s' scene size flash static_ram stack \
    insns_render insns_denoise per_px share insns_output)
if [ "${1:-}" != "" ]; then
    # the board's frame: all of SSRAM2 and 3 for the whole-frame moments
    SIZES=$OUT/frame-$1.size
    echo "$HEADER" >"$SIZES"
    nstep "$1 ${2:-scenes/cornell.scene}"
    run "${2:-scenes/cornell.scene}" "$1" examples/board/memory-mps2-an505-4m.x
    cat "$SIZES"
    exit 0
fi

SIZES=$OUT/denoise.size
echo "$HEADER" >"$SIZES"
nstep "cornell, gloss, spheres"
run scenes/cornell.scene 32x32 examples/board/memory-mps2-an505.x
run scenes/gloss.scene 24x16 examples/board/memory-mps2-an505.x
run scenes/spheres.scene 24x16 examples/board/memory-mps2-an505.x
cat "$SIZES"
if [ $BLESS = 1 ]; then
    cp "$SIZES" firmware/expected/denoise.size
    echo "blessed firmware/expected/denoise.size"
elif [ -f firmware/expected/denoise.size ]; then
    diff -u firmware/expected/denoise.size "$SIZES" || echo "(informational: the figures moved; .ci/denoise.sh --bless records them)"
fi
