#!/usr/bin/env bash
# Firmware on every target (called by .ci/run after firmware.sh; runs alone
# too): examples/firmware built for six cores, each run in QEMU on every
# scene in scenes/, each image byte-identical with the host CLI's render.
#
#   id          target                        QEMU machine              real chip (clock)
#   cortex-m0   thumbv6m-none-eabi            microbit (nRF51, 16 KiB)  RP2040 (133 MHz)
#   cortex-m3   thumbv7m-none-eabi            netduino2 (STM32F205)     STM32F205 (120 MHz)
#   cortex-m4f  thumbv7em-none-eabihf         netduinoplus2 (STM32F405) STM32F405 (168 MHz)
#   cortex-m7   thumbv7em-none-eabihf         mps2-an500                STM32F7 / H7 (216 / 480 MHz)
#   cortex-m33  thumbv8m.main-none-eabihf     mps2-an505                RP2350 (150 MHz)
#   rv32imc     riscv32imc-unknown-none-elf   virt                      ESP32-C3 (160 MHz)
#
# Every scene runs at half its resolution (cornell 32x32, furnace 16x16,
# sphere-over-plane 32x24), smallpt, spheres, many, gloss and dof at a
# quarter (16x12, 24x16), all at 16 spp but spheres, many, gloss and dof (4 spp): the soft-float cores (M0, M3, RV32IMC)
# execute 20-60 times the instructions of the FPU cores, and QEMU with the
# plugin runs 50-100 M instructions a second. The same workload on every target, so the instructions per path
# compare across them (the M4F's full-size figures are firmware.sh's). A
# scene whose image and stack do not fit in the microbit's 16 KiB of RAM runs
# the same ARMv6-M binary on netduinoplus2 (a Cortex-M4 executes the ARMv6-M
# subset; the instruction counts are the M0 binary's).
#
# `.ci/targets.sh cortex-m0 rv32imc` runs only those targets.
#
# It checks that no firmware links soft-double routines and that the eabihf
# ones (M4F, M7, M33) use the FPU's vsqrt.f32. Per target it records, for
# every scene, flash, static RAM, framebuffer, stack high-water, render
# instructions, traced paths and instructions per path in
# target/targets/<id>.size, printing a diff against
# firmware/expected/<id>.size (informational; `--bless` rewrites them), and
# prints the table of docs/firmware.md ("Targets"): per target the
# instructions per path on cornell and smallpt, and the frame time they imply
# for 240x240 at 16 spp at the real chip's clock at one instruction per cycle
# (an estimate).
set -euo pipefail
cd "$(dirname "$0")/.."

BLESS=0
if [ "${1:-}" = "--bless" ]; then
    BLESS=1
    shift
fi

OUT=target/targets
mkdir -p "$OUT"

tstep() { printf '\n---- targets: %s (%ss)\n' "$*" "$SECONDS"; }
fail() {
    echo "error: $*" >&2
    exit 1
}

SUDO=""
if [ "$(id -u)" != 0 ] && command -v sudo >/dev/null; then SUDO=sudo; fi

tstep "install qemu-system-arm, qemu-system-misc (riscv32), binutils, gcc"
if ! command -v qemu-system-arm >/dev/null || ! command -v qemu-system-riscv32 >/dev/null ||
    ! command -v readelf >/dev/null || ! command -v arm-none-eabi-objdump >/dev/null ||
    ! command -v gcc >/dev/null; then
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
        qemu-system-arm qemu-system-misc binutils binutils-arm-none-eabi gcc libc6-dev >/dev/null
fi
rustup target add thumbv6m-none-eabi thumbv7m-none-eabi thumbv7em-none-eabihf \
    thumbv8m.main-none-eabihf riscv32imc-unknown-none-elf >/dev/null
qemu-system-riscv32 --version | head -n 1

tstep "build the QEMU instruction-count plugin"
gcc -O2 -Wall -Wextra -Werror -shared -fPIC -o "$OUT/libicount.so" tools/qemu-icount/icount.c

tstep "clippy: the firmware example on ARMv6-M (no atomic read-modify-write) and RISC-V"
cargo clippy -p micropt --release --examples --features firmware --target thumbv6m-none-eabi -- -D warnings
cargo clippy -p micropt --release --examples --features firmware-riscv \
    --target riscv32imc-unknown-none-elf -- -D warnings

tstep "host CLI (test profile, shared with cargo test)"
cargo build --profile test -p micropt-host --bin micropt
HOST=target/debug/micropt

# target id -> rust target, QEMU machine, QEMU command, real chip, its clock
# in MHz (two for the M7: STM32F7 and STM32H7)
declare -A TRIPLE MACHINE CHIP MHZ
declare -A QEMU_CMD
TRIPLE=([cortex-m0]=thumbv6m-none-eabi [cortex-m3]=thumbv7m-none-eabi
    [cortex-m4f]=thumbv7em-none-eabihf [cortex-m7]=thumbv7em-none-eabihf
    [cortex-m33]=thumbv8m.main-none-eabihf [rv32imc]=riscv32imc-unknown-none-elf)
MACHINE=([cortex-m0]=microbit [cortex-m3]=netduino2 [cortex-m4f]=netduinoplus2
    [cortex-m7]=mps2-an500 [cortex-m33]=mps2-an505 [rv32imc]=virt)
CHIP=([cortex-m0]=RP2040 [cortex-m3]=STM32F205 [cortex-m4f]=STM32F405
    [cortex-m7]="STM32F7/H7" [cortex-m33]=RP2350 [rv32imc]=ESP32-C3)
MHZ=([cortex-m0]=133 [cortex-m3]=120 [cortex-m4f]=168 [cortex-m7]="216 480"
    [cortex-m33]=150 [rv32imc]=160)
# the QEMU command line per machine (-icount shift=0: one virtual ns per
# instruction, so every clock and count is deterministic); the RISC-V CPU
# without the A, F and D extensions, as an RV32IMC chip
QEMU_CMD=(
    [microbit]="qemu-system-arm -machine microbit"
    [netduino2]="qemu-system-arm -machine netduino2"
    [netduinoplus2]="qemu-system-arm -cpu cortex-m4 -machine netduinoplus2"
    [mps2-an500]="qemu-system-arm -machine mps2-an500"
    [mps2-an505]="qemu-system-arm -machine mps2-an505"
    [virt]="qemu-system-riscv32 -machine virt -cpu rv32,a=false,f=false,d=false -bios none"
)
# RAM of each machine's memory map (examples/board/memory-*.x)
declare -A RAM=([microbit]=16384 [netduino2]=131072 [netduinoplus2]=131072
    [mps2-an500]=524288 [mps2-an505]=524288 [virt]=409600)
IDS=(cortex-m0 cortex-m3 cortex-m4f cortex-m7 cortex-m33 rv32imc)
# `.ci/targets.sh [--bless] [ID...]`: only these targets
if [ $# -gt 0 ]; then IDS=("$@"); fi
# scenes that do not fit in the microbit's RAM (image + renderer + stack)
MICROBIT_TOO_SMALL=" spheres many "

# scene -> image size and samples per pixel of the runs here: a fraction of
# its resolution (a half; a quarter for the costliest: smallpt, spheres,
# many, gloss, dof), 16 spp (spheres, many, gloss and dof 4)
plan_size() {
    local div=2
    case $(basename "$1" .scene) in smallpt | spheres | many | gloss | dof) div=4 ;; esac
    awk -v d="$div" '$1 == "resolution" { w = int($2 / d); h = int($3 / d); f = 1 }
         END { if (!f) { w = 32; h = 32 } if (w < 8) w = 8; if (h < 8) h = 8; print w "x" h }' "$1"
}
plan_spp() {
    case $(basename "$1" .scene) in spheres | many | gloss | dof) echo 4 ;; *) echo 16 ;; esac
}

# elf_figures ELF: "FLASH RAM" (flash: the loaded sections, code, read-only
# data, the .data image, the vector table; static RAM: .data + .bss + .uninit)
. "$(dirname "${BASH_SOURCE[0]}")/elf.sh"

# compiler-builtins' soft-double routines (as firmware.sh checks)
SOFT_DOUBLE=' (__aeabi_(d[a-z0-9]+|(f|i|ui|l|ul)2d)|__(add|sub|mul|div|neg)df3|__(eq|ne|lt|le|gt|ge|un|cmp)df2|__(extendsfdf2|truncdfsf2)|__fix(uns)?df[sdt]i|__float(un)?[sdt]idf|__powidf2)$'

# plan ID SCENE: sets NAME, SIZE, SPP, MACHINE, TAG, ELF for this run
plan() {
    NAME=$(basename "$2" .scene)
    SIZE=$(plan_size "$2")
    SPP=$(plan_spp "$2")
    MACHINE_NOW=${MACHINE[$1]}
    if [ "$1" = cortex-m0 ] && [[ "$MICROBIT_TOO_SMALL" == *" $NAME "* ]]; then
        MACHINE_NOW=netduinoplus2
    fi
    TAG="$1-$NAME"
    ELF="$OUT/$TAG.elf"
}

# build_one ID SCENE: builds the firmware for this run into $ELF
build_one() {
    local triple=${TRIPLE[$1]} features=(--features firmware)
    plan "$1" "$2"
    [ "$triple" = riscv32imc-unknown-none-elf ] && features=(--features firmware-riscv)
    # cornell with the features its scene uses, as firmware.sh's default
    # build (cornell.size); the other scenes with the default features
    if [ "$NAME" = cornell ]; then
        features=(--no-default-features --features "${features[1]},parser,mirror")
    elif [ "$MACHINE_NOW" = microbit ]; then
        # 16 KiB of RAM: the highlight list of 16 pairs and no chains (its
        # scenes have none)
        features=(--features "${features[1]},small-ram")
    fi
    MICROPT_FW_MACHINE="$MACHINE_NOW" MICROPT_FW_SCENE="$2" MICROPT_FW_SIZE="$SIZE" \
        MICROPT_FW_SPP="$SPP" MICROPT_FW_SEED=0 MICROPT_FW_OUT="$OUT/$TAG.board.rgb565" \
        cargo build -q -p micropt --release --example firmware "${features[@]}" --target "$triple"
    cp "target/$triple/release/examples/firmware" "$ELF"
}

# check_one ID SCENE: runs $ELF in QEMU, compares its image with the host's,
# writes its figures to $OUT/$TAG.row
check_one() {
    plan "$1" "$2"
    local board="$OUT/$TAG.board.rgb565" host="$OUT/$TAG.host.rgb565" status=0
    rm -f "$board" "$OUT/$TAG.row"
    # shellcheck disable=SC2086 # the command line is a list of words
    timeout 600 ${QEMU_CMD[$MACHINE_NOW]} -nographic -semihosting-config enable=on,target=native \
        -icount shift=0 -plugin "$OUT/libicount.so" -d plugin -D "$OUT/$TAG.icount" \
        -kernel "$ELF" >"$OUT/$TAG.run" || status=$?
    cat "$OUT/$TAG.run"
    [ "$status" = 0 ] || fail "$TAG: the firmware exited with status $status on $MACHINE_NOW"
    "$HOST" render "$2" --size "$SIZE" --spp "$SPP" --seed 0 --exposure 1 -o "$host" >/dev/null
    cmp "$board" "$host" ||
        fail "$TAG: the board's image differs from the host's (same scene, size, spp, seed)"

    # no double precision anywhere (soft-double routines would be linked),
    # and the FPU square root on the eabihf targets
    if nm "$ELF" | grep -E "$SOFT_DOUBLE"; then fail "$TAG: soft-double symbols in the firmware"; fi
    # (grep -c reads to the end: grep -q would stop early and fail the pipe)
    if [[ "${TRIPLE[$1]}" == *eabihf ]] &&
        [ "$(arm-none-eabi-objdump -d "$ELF" | grep -c vsqrt.f32)" = 0 ]; then
        fail "$TAG: no vsqrt.f32 in the firmware"
    fi

    local flash ram fb stack paths render marks
    read -r flash ram <<<"$(elf_figures "$ELF")"
    # (awk reads to the end: an early exit would fail the pipe under pipefail)
    fb=$(nm -S "$ELF" | awk '$4 ~ /FRAMEBUFFER/ && !f { print $2; f = 1 }')
    [ -z "$fb" ] || fb=$((16#$fb))
    stack=$(sed -n 's/.*stack high-water \([0-9]*\) bytes.*/\1/p' "$OUT/$TAG.run")
    paths=$(sed -n 's/.*, \([0-9]*\) paths,.*/\1/p' "$OUT/$TAG.run")
    read -r -a marks <<<"$(sed -n 's/^marks: //p' "$OUT/$TAG.icount")"
    [ -n "$fb" ] && [ -n "$stack" ] && [ -n "$paths" ] && [ "${#marks[@]}" = 5 ] ||
        fail "$TAG: could not read the firmware's figures"
    render=$((marks[3] - marks[2]))
    # the stack grows down from the top of RAM towards the statics: had it
    # reached them, the paint below it would be gone
    local room=$((RAM[$MACHINE_NOW] - ram))
    [ "$stack" -lt $((room - 64)) ] ||
        fail "$TAG: the stack ($stack bytes) filled the RAM left by the statics ($room bytes) on $MACHINE_NOW"
    echo "$TAG $SIZE: bit-identical with the host on $MACHINE_NOW; $((render / paths)) instructions per path"
    printf '%-18s %-14s %-6s %4s %7s %7s %6s %6s %12s %7s %8s\n' "$NAME" "$MACHINE_NOW" "$SIZE" \
        "$SPP" "$flash" "$ram" "$fb" "$stack" "$render" "$paths" "$((render / paths))" >"$OUT/$TAG.row"
}

# waits for the QEMU run in the background (pid $1, log $2) and shows its log
finish_check() {
    local status=0
    wait "$1" || status=$?
    cat "$2"
    [ "$status" = 0 ] || fail "a firmware run failed (above)"
}

for id in "${IDS[@]}"; do
    tstep "$id: ${TRIPLE[$id]} on ${MACHINE[$id]}"
    rm -f "$OUT/$id.rows"
    # each scene's QEMU run goes on in the background while the next
    # scene's firmware builds (2 cores)
    pending=()
    for scene in scenes/*.scene; do
        build_one "$id" "$scene"
        if [ "${#pending[@]}" -gt 0 ]; then finish_check "${pending[@]}"; fi
        check_one "$id" "$scene" >"$OUT/$TAG.log" 2>&1 &
        pending=($! "$OUT/$TAG.log")
    done
    finish_check "${pending[@]}"
    for scene in scenes/*.scene; do
        plan "$id" "$scene"
        cat "$OUT/$TAG.row" >>"$OUT/$id.rows"
    done
    {
        echo "# examples/firmware on $id (${TRIPLE[$id]}, QEMU ${MACHINE[$id]} -icount shift=0),"
        echo "# release, every scene at half or a quarter of its resolution, seed 0, adaptive; written by"
        echo "# .ci/targets.sh. Bytes and executed instructions; render: the budget"
        echo "# executor (previews, refinement, tone mapping); paths: traced paths."
        printf '%-18s %-14s %-6s %4s %7s %7s %6s %6s %12s %7s %8s\n' "# scene" machine size spp \
            flash static fb stack render paths per_path
        cat "$OUT/$id.rows"
    } >"$OUT/$id.size"
done

tstep "table: instructions per path and the 240x240, 16 spp frame time they imply"
# traced paths of a 240x240 frame at 16 spp: the image samples plus the
# preview sample recomputed per pixel (firmware.sh's 240x240 run: 979,200)
FRAME_PATHS=$((240 * 240 * 17))
per_path() { awk -v s="$2" '$1 == s { print $11 }' "$OUT/$1.size"; }
printf '%-11s %-14s %-10s %9s %9s %7s %7s %6s  %s\n' target machine chip cornell smallpt \
    flash static stack "frame at 1 IPC (cornell / smallpt)"
for id in "${IDS[@]}"; do
    c=$(per_path "$id" cornell)
    s=$(per_path "$id" smallpt)
    read -r flash ram stack <<<"$(awk '$1 == "cornell" { print $5, $6, $8 }' "$OUT/$id.size")"
    times=""
    for mhz in ${MHZ[$id]}; do
        times+=$(awk -v p="$FRAME_PATHS" -v c="$c" -v s="$s" -v f="$mhz" \
            'BEGIN { printf "%s MHz: %.1f s / %.1f s; ", f, p * c / f / 1e6, p * s / f / 1e6 }')
    done
    printf '%-11s %-14s %-10s %9s %9s %7s %7s %6s  %s\n' "$id" "${MACHINE[$id]}" "${CHIP[$id]}" \
        "$c" "$s" "$flash" "$ram" "$stack" "${times%; }"
done

if [ "$BLESS" = 1 ]; then
    mkdir -p firmware/expected
    for id in "${IDS[@]}"; do cp "$OUT/$id.size" "firmware/expected/$id.size"; done
    echo "wrote firmware/expected/{$(
        IFS=,
        echo "${IDS[*]}"
    )}.size"
else
    for id in "${IDS[@]}"; do
        if ! diff -u "firmware/expected/$id.size" "$OUT/$id.size"; then
            echo "note: measured figures differ from firmware/expected/$id.size" \
                "(informational; .ci/targets.sh --bless updates)"
        fi
    done
fi

tstep "targets done"
