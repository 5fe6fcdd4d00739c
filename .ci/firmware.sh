#!/usr/bin/env bash
# Firmware CI (called by .ci/run; runs alone too): the micropt core on a
# Cortex-M4F (STM32F405) in QEMU.
#
#  - installs qemu-system-arm, binutils-arm-none-eabi and gcc (apt) if missing,
#    and builds the instruction-count plugin tools/qemu-icount;
#  - clippy on the firmware examples (`-p micropt`: the workspace's other
#    package has host examples that do not build for the board);
#  - builds the release firmware, which links with panic-never: the link
#    fails if any panic path is left (core included);
#  - runs it in QEMU (netduinoplus2, `-icount shift=0`: one virtual ns per
#    instruction, so the SysTick clock and every count are deterministic) for
#    every scene in scenes/ and checks that its Rgb565 dump is byte-identical
#    to the host CLI's default render (adaptive budget) of the same scene,
#    size, spp and seed, and records each run's flash, static RAM, stack
#    high-water, parse and render instructions (scenes.size);
#  - builds the variant without the parser and the glass code
#    (`--no-default-features --features firmware,mirror`: the Cornell box built
#    in code), checks its image against the host's and records the flash it
#    saves;
#  - runs a deadline budget (SysTick clock) and checks that it stops in time;
#  - for the default build (cornell.scene 64x64, 16 spp, with the features
#    its scene uses: parser, mirror) checks the budgets:
#    flash <= 64 KiB, renderer state (static RAM but the framebuffer)
#    <= 16 KiB, stack high-water <= 4 KiB; no soft-double symbols; the FPU
#    vsqrt.f32 in the render code; and writes the measured figures, printing
#    a diff against the committed firmware/expected/ files
#    (`.ci/firmware.sh --bless` rewrites them);
#  - builds the STM32F405 + ST7789 board example.
set -euo pipefail
cd "$(dirname "$0")/.."

BLESS=0
if [ "${1:-}" = "--bless" ]; then BLESS=1; fi

TARGET=thumbv7em-none-eabihf
OUT=target/firmware
ELF=target/$TARGET/release/examples/firmware
QEMU=(qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 -nographic
    -semihosting-config enable=on,target=native -icount shift=0)
mkdir -p "$OUT"

fstep() { printf '\n---- firmware: %s (%ss)\n' "$*" "$SECONDS"; }
fail() {
    echo "error: $*" >&2
    exit 1
}

SUDO=""
if [ "$(id -u)" != 0 ] && command -v sudo >/dev/null; then SUDO=sudo; fi

fstep "install qemu-system-arm, binutils-arm-none-eabi, gcc"
if ! command -v qemu-system-arm >/dev/null || ! command -v arm-none-eabi-size >/dev/null ||
    ! command -v gcc >/dev/null; then
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
        qemu-system-arm binutils-arm-none-eabi gcc libc6-dev >/dev/null
fi
rustup target add "$TARGET" >/dev/null
qemu-system-arm --version | head -n 1

fstep "build the QEMU instruction-count plugin"
gcc -O2 -Wall -Wextra -Werror -shared -fPIC -o "$OUT/libicount.so" tools/qemu-icount/icount.c

fstep "clippy: firmware examples"
cargo clippy -p micropt --release --examples --features firmware --target "$TARGET" -- -D warnings
cargo clippy -p micropt --release --examples --no-default-features --features firmware,mirror \
    --target "$TARGET" -- -D warnings
cargo clippy -p micropt --release --examples --features board-st7789 --target "$TARGET" -- -D warnings

fstep "core without the parser, mirror and glass features: unit tests (a scene using a left-out material is refused)"
cargo test -p micropt --lib --no-default-features --features parser
cargo build -p micropt --release --no-default-features --target "$TARGET"

fstep "host CLI (test profile: shares its build with cargo test; same bits as release)"
cargo build --profile test -p micropt-host --bin micropt
HOST=target/debug/micropt

# qemu_run NAME: runs $ELF in QEMU with the plugin: $OUT/NAME.run (the
# firmware's line), $OUT/NAME.icount (the counts); fails on a non-zero exit.
qemu_run() {
    local name=$1 status=0
    timeout 300 "${QEMU[@]}" -plugin "$OUT/libicount.so" -d plugin -D "$OUT/$name.icount" \
        -kernel "$ELF" >"$OUT/$name.run" || status=$?
    cat "$OUT/$name.run" "$OUT/$name.icount"
    [ "$status" = 0 ] || fail "$name: the firmware exited with status $status"
}

# run_scene SCENE [NAME [CARGO FEATURE ARGS...]]: build the firmware for SCENE
# (its own resolution, 16 spp, adaptive, seed 0), run it in QEMU, compare with
# the host CLI's default render.
run_scene() {
    local scene=$1 name=${2:-} size
    shift 2 || shift $#
    local features=("$@")
    [ "${#features[@]}" -gt 0 ] || features=(--features firmware)
    [ -n "$name" ] || name=$(basename "$scene" .scene)
    size=$(awk '$1 == "resolution" { print $2 "x" $3; exit }' "$scene")
    size=${size:-64x64}
    local env=(MICROPT_FW_SIZE="$size" MICROPT_FW_SPP=16 MICROPT_FW_SEED=0
        MICROPT_FW_OUT="$OUT/$name.board.rgb565")
    # without the parser the scene is the one built in code (cornell)
    if [ "${features[0]}" != --no-default-features ] || [[ "${features[*]}" == *parser* ]]; then
        env+=(MICROPT_FW_SCENE="$scene")
    fi
    env "${env[@]}" cargo build -p micropt --release --example firmware "${features[@]}" --target "$TARGET"
    rm -f "$OUT/$name.board.rgb565"
    local start=$SECONDS
    qemu_run "$name"
    local qemu_s=$((SECONDS - start))
    "$HOST" render "$scene" --size "$size" --spp 16 --seed 0 --exposure 1 \
        -o "$OUT/$name.host.rgb565"
    if ! cmp "$OUT/$name.board.rgb565" "$OUT/$name.host.rgb565"; then
        fail "$name: the board's image differs from the host's (same scene, size, spp, seed)"
    fi
    echo "$name $size: board and host images are bit-identical (QEMU ${qemu_s} s)"
    scene_row "$name" "$size"
}

section() { arm-none-eabi-size -A "$ELF" | awk -v s="$1" '$1 == s { print $2; f = 1 } END { if (!f) print 0 }'; }

# scene_row NAME SIZE: the figures of the run just made ($ELF, $OUT/NAME.run,
# $OUT/NAME.icount), one row of $OUT/scenes.size
scene_row() {
    local name=$1 size=$2 flash ram fb stack paths marks render
    flash=$(($(section .vector_table) + $(section .text) + $(section .rodata) + $(section .data)))
    ram=$(($(section .data) + $(section .bss) + $(section .uninit)))
    fb=$(arm-none-eabi-nm -C -S "$ELF" | awk '$4 ~ /::FRAMEBUFFER$/ { print $2 }')
    stack=$(sed -n 's/.*stack high-water \([0-9]*\) bytes.*/\1/p' "$OUT/$name.run")
    paths=$(sed -n 's/.*, \([0-9]*\) paths,.*/\1/p' "$OUT/$name.run")
    read -r -a marks <<<"$(sed -n 's/^marks: //p' "$OUT/$name.icount")"
    [ -n "$fb" ] && [ -n "$stack" ] && [ -n "$paths" ] && [ "${#marks[@]}" = 5 ] ||
        fail "$name: could not read the firmware's figures"
    render=$((marks[3] - marks[2]))
    # the stack grows down from the top of the 128 KiB of RAM towards the
    # statics: had it reached them, the paint below it would be gone
    [ "$stack" -lt $((131072 - ram - 64)) ] ||
        fail "$name: the stack ($stack bytes) filled the RAM left by the statics ($((131072 - ram)) bytes)"
    printf '%-18s %-6s %7s %7s %6s %6s %10s %12s %7s %8s\n' "$name" "$size" "$flash" "$ram" \
        "$((16#$fb))" "$stack" "$((marks[2] - marks[1]))" "$render" "$paths" \
        "$((render / paths))" >>"$OUT/scenes.rows"
}

fstep "firmware on every scene, bit-identical with the host"
rm -f "$OUT/scenes.rows"
for scene in scenes/*.scene; do
    # cornell last (below): its default build is the one measured
    [ "$scene" = scenes/cornell.scene ] && continue
    run_scene "$scene"
done

fstep "deadline budget: SysTick clock, 150 ms of QEMU virtual time (150 M instructions)"
MICROPT_FW_BUDGET_MS=150 MICROPT_FW_OUT="$OUT/cornell-deadline.board.rgb565" \
    cargo build -p micropt --release --example firmware --features firmware --target "$TARGET"
qemu_run cornell-deadline
total_us=$(sed -n 's/.*, total \([0-9]*\) us;.*/\1/p' "$OUT/cornell-deadline.run")
[ -n "$total_us" ] || fail "could not read the deadline run's time"
# stops within one batch (256 paths, ~1.5 ms here) plus a tile's drawing
[ "$total_us" -le 152000 ] || fail "deadline 150 ms overrun: $total_us us"
echo "deadline 150 ms: rendered in $total_us us of virtual time"

fstep "firmware without the parser and glass code: cornell built in code"
run_scene scenes/cornell.scene cornell-code --no-default-features --features firmware,mirror
code_text=$(section .text)
code_rodata=$(section .rodata)
code_flash=$(($(section .vector_table) + code_text + code_rodata + $(section .data)))
code_stack=$(sed -n 's/.*stack high-water \([0-9]*\) bytes.*/\1/p' "$OUT/cornell-code.run")

# the default build last: its ELF is the one measured below
fstep "default firmware (cornell.scene, parsed on the board)"
# the default firmware: built with the features its scene uses (the parser
# and the mirror; no glass, no light windows)
run_scene scenes/cornell.scene cornell --no-default-features --features firmware,parser,mirror

fstep "budgets and guarantees of the default firmware (cornell.scene)"
vt=$(section .vector_table)
text=$(section .text)
rodata=$(section .rodata)
data=$(section .data)
bss=$(section .bss)
uninit=$(section .uninit)
flash=$((vt + text + rodata + data))
fb_hex=$(arm-none-eabi-nm -C -S "$ELF" | awk '$4 ~ /::FRAMEBUFFER$/ { print $2 }')
[ -n "$fb_hex" ] || fail "no FRAMEBUFFER symbol in $ELF"
fb=$((16#$fb_hex))
static_ram=$((data + bss + uninit))
state=$((static_ram - fb))
stack=$(sed -n 's/.*stack high-water \([0-9]*\) bytes.*/\1/p' "$OUT/cornell.run")
samples=$(sed -n 's/.*: \([0-9]*\) samples,.*/\1/p' "$OUT/cornell.run")
paths=$(sed -n 's/.*, \([0-9]*\) paths,.*/\1/p' "$OUT/cornell.run")
insns=$(sed -n 's/^insns: //p' "$OUT/cornell.icount")
read -r -a marks <<<"$(sed -n 's/^marks: //p' "$OUT/cornell.icount")"
[ -n "$stack" ] && [ -n "$samples" ] && [ -n "$paths" ] && [ -n "$insns" ] &&
    [ -n "$code_stack" ] && [ "${#marks[@]}" = 5 ] ||
    fail "could not read the firmware's figures"
render=$((marks[3] - marks[2]))
{
    echo "# examples/firmware, release, cornell.scene 64x64, Budget::Spp(16) adaptive, seed 0"
    echo "# (QEMU netduinoplus2 -icount shift=0); written by .ci/firmware.sh; bytes and"
    echo "# executed instructions"
    echo "flash: $flash  (.vector_table $vt + .text $text + .rodata $rodata + .data $data; budget 65536)"
    echo "static_ram: $static_ram  (.data $data + .bss $bss + .uninit $uninit)"
    echo "framebuffer: $fb"
    echo "renderer_state: $state  (static RAM but the framebuffer: TileAccum, scene, clock; budget 16384)"
    echo "stack_high_water: $stack  (budget 4096)"
    echo "insns_total: $insns"
    echo "insns_reset_to_main: ${marks[0]}  (vector table, stack paint, RAM init)"
    echo "insns_sqrt_selftest: $((marks[1] - marks[0]))  (4111 vsqrt.f32 vs libm::sqrtf, SysTick start)"
    echo "insns_parse_and_setup: $((marks[2] - marks[1]))  (parse the scene, analysis, camera)"
    echo "insns_render: $render  (budget executor: previews, refinement, tone mapping into the framebuffer)"
    echo "insns_dump: $((marks[4] - marks[3]))  (semihosting write of the image)"
    echo "insns_after: $((insns - marks[4]))  (stack scan, summary line, exit)"
    echo "samples: $samples  (in the image: the budget)"
    echo "paths: $paths  (traced: samples + the preview's sample per 2x2 block)"
    echo "insns_per_path: $((render / paths))"
    echo "insns_per_sample: $((render / samples))"
} >"$OUT/cornell.size"
{
    echo "# examples/firmware without the parser and glass code (cornell built in code):"
    echo "# cargo build -p micropt --release --example firmware --no-default-features --features firmware,mirror"
    echo "# written by .ci/firmware.sh; bytes; same image as the parser build"
    echo "flash: $code_flash  (parser build: $flash; saved $((flash - code_flash)))"
    echo "text_rodata: $((code_text + code_rodata))  (parser build: $((text + rodata)); saved $((text + rodata - code_text - code_rodata)))"
    echo "stack_high_water: $code_stack  (parser build: $stack)"
} >"$OUT/cornell-code.size"
{
    echo "# examples/firmware, release, every scene at its resolution, Budget::Spp(16)"
    echo "# adaptive, seed 0 (QEMU netduinoplus2 -icount shift=0; cornell-code: without"
    echo "# the parser); written by .ci/firmware.sh. Bytes and executed instructions; parse:"
    echo "# parse the scene, analysis, tree, camera; render: the budget executor; paths:"
    echo "# traced paths."
    printf '%-18s %-6s %7s %7s %6s %6s %10s %12s %7s %8s\n' "# scene" size flash static fb \
        stack parse render paths per_path
    cat "$OUT/scenes.rows"
} >"$OUT/scenes.size"
cat "$OUT/cornell-code.size"
cat "$OUT/cornell.size"
cat "$OUT/scenes.size"

ok=1
[ "$flash" -le 65536 ] || { echo "error: flash $flash > 65536 bytes" >&2; ok=0; }
[ "$state" -le 16384 ] || { echo "error: renderer state $state > 16384 bytes" >&2; ok=0; }
[ "$stack" -le 4096 ] || { echo "error: stack high-water $stack > 4096 bytes" >&2; ok=0; }

# no double precision: the M4F FPU is single precision, so any f64 arithmetic
# would link compiler-builtins' soft-double routines
if arm-none-eabi-nm "$ELF" | grep -E ' (__aeabi_(d[a-z0-9]+|(f|i|ui|l|ul)2d)|__(add|sub|mul|div|neg)df3|__(eq|ne|lt|le|gt|ge|un|cmp)df2|__(extendsfdf2|truncdfsf2)|__fix(uns)?df[sdt]i|__float(un)?[sdt]idf|__powidf2)$'; then
    echo "error: soft-double symbols in the firmware" >&2
    ok=0
fi
# the render path uses the FPU square root, not libm's software one
arm-none-eabi-objdump -d -C --no-show-raw-insn "$ELF" >"$OUT/firmware.dis"
# the render code: the core's sampling, integrator, ray queries and budget
# executor (whichever of them the compiler kept as functions)
render_re='<micropt::(integrator|material|light|render|budget|scene::(query::SceneView|bvh::BvhView)|geometry)[^>]*>:$'
render_fn=$(awk -v re="$render_re" '/^[0-9a-f]+ <.*>:$/ { f = ($0 ~ re); next } f' "$OUT/firmware.dis")
[ -n "$render_fn" ] || fail "no render function of the core found in the disassembly"
grep -q 'vsqrt.f32' <<<"$render_fn" || { echo "error: no vsqrt.f32 in the render code" >&2; ok=0; }
if grep -E 'bl.*<.*sqrtf.*>' <<<"$render_fn"; then
    echo "error: the render code calls a software sqrtf" >&2
    ok=0
fi
[ "$ok" = 1 ] || fail "firmware budgets or guarantees not met"
echo "budgets met; no soft-double symbols; vsqrt.f32 in the render code; links with panic-never"

if [ "$BLESS" = 1 ]; then
    mkdir -p firmware/expected
    for f in cornell.size cornell.run cornell-code.size scenes.size; do
        cp "$OUT/$f" "firmware/expected/$f"
    done
    echo "wrote firmware/expected/cornell.{size,run}, cornell-code.size and scenes.size"
else
    for f in cornell.size cornell.run cornell-code.size scenes.size; do
        if ! diff -u "firmware/expected/$f" "$OUT/$f"; then
            echo "note: measured figures differ from firmware/expected/$f" \
                "(informational; budgets above are the check; .ci/firmware.sh --bless updates)"
        fi
    done
fi

fstep "board example: STM32F405 + ST7789 (mipidsi)"
cargo build -p micropt --release --example st7789 --features board-st7789 --target "$TARGET"
arm-none-eabi-size "target/$TARGET/release/examples/st7789"

fstep "firmware done"
