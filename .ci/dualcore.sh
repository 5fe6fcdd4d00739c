#!/usr/bin/env bash
# Dual-core firmware CI (called by .ci/run after .ci/firmware.sh; runs alone
# too): the micropt core on both Cortex-M33 of an Arm SSE-200 (MPS2+ AN521)
# in QEMU's mps2-an521.
#
#  - builds the instruction-count plugin (per vCPU on a machine of several);
#  - clippy on examples/dualcore.rs;
#  - builds the release firmware (links with panic-never) for cornell.scene
#    64x64, 16 spp, seed 0, twice: MICROPT_FW_CORES=2 (both cores share the
#    render) and MICROPT_FW_CORES=1 (the same code, core 1 left in reset);
#  - runs both in QEMU (`-icount shift=0`: deterministic; core 0 given the
#    FPU, `-global sse-200.CPU0_FPU=true`, see examples/dualcore.rs) and
#    fails unless both images are byte-identical to the host CLI's render;
#  - prints each core's instructions (its render, split into its own work and
#    its waits at the barriers) and the speed-up: the one-core render's
#    instructions over the busier core's, and writes them to
#    $OUT/an521.size, printing a diff against firmware/expected/an521.size
#    (`.ci/dualcore.sh --bless` rewrites it). A speed-up below 1.8 is
#    reported, not failed: the figure is the check's output, the images are
#    its condition.
set -euo pipefail
cd "$(dirname "$0")/.."
. .ci/qemu-arm.sh

BLESS=0
if [ "${1:-}" = "--bless" ]; then BLESS=1; fi

TARGET=thumbv8m.main-none-eabihf
OUT=${DUALCORE_OUT:-target/dualcore}
ELF=target/$TARGET/release/examples/dualcore
QEMU=(qemu-system-arm -machine mps2-an521 -global sse-200.CPU0_FPU=true
    -global sse-200.CPU0_DSP=true -nographic
    -semihosting-config enable=on,target=native -icount shift=0)
SCENE=scenes/cornell.scene
# DUALCORE_SIZE: another image size (tools/frame.sh measures 240x240)
SIZE=${DUALCORE_SIZE:-64x64}
SPP=16
mkdir -p "$OUT"

dstep() { printf '\n---- dualcore: %s (%ss)\n' "$*" "$SECONDS"; }
fail() {
    echo "error: $*" >&2
    exit 1
}

install_qemu_arm "$TARGET"

dstep "instruction-count plugin"
gcc -O2 -Wall -Wextra -Werror -shared -fPIC -o "$OUT/libicount.so" tools/qemu-icount/icount.c

dstep "clippy: the dual-core example"
cargo clippy -p micropt --release --example dualcore --features firmware-an521 --target "$TARGET" \
    -- -D warnings

dstep "host CLI render"
cargo build --profile test -p micropt-host --bin micropt
target/debug/micropt render "$SCENE" --size "$SIZE" --spp "$SPP" --seed 0 --exposure 1 \
    -o "$OUT/cornell.host.rgb565"

# run CORES: build for CORES cores, run in QEMU, compare with the host
run() {
    local cores=$1 status=0
    MICROPT_FW_SCENE=$SCENE MICROPT_FW_SIZE=$SIZE MICROPT_FW_SPP=$SPP MICROPT_FW_SEED=0 \
        MICROPT_FW_CORES="$cores" MICROPT_FW_OUT="$OUT/cores$cores.board.rgb565" \
        cargo build -p micropt --release --example dualcore --features firmware-an521 --target "$TARGET"
    rm -f "$OUT/cores$cores.board.rgb565"
    timeout 1800 "${QEMU[@]}" -plugin "$OUT/libicount.so" -d plugin -D "$OUT/cores$cores.icount" \
        -kernel "$ELF" >"$OUT/cores$cores.run" || status=$?
    cat "$OUT/cores$cores.run" "$OUT/cores$cores.icount"
    [ "$status" = 0 ] || fail "$cores core(s): the firmware exited with status $status"
    cmp "$OUT/cores$cores.board.rgb565" "$OUT/cornell.host.rgb565" ||
        fail "$cores core(s): the board's image differs from the host's"
    echo "$cores core(s): board and host images are bit-identical"
}

dstep "one core (core 1 held in reset)"
run 1
dstep "two cores"
run 2

dstep "instructions per core"
# marks of one vCPU: cpuK marks: ... (core 0: main, render start, preview
# done, barrier passed, refinement done, all done, dump; core 1: start,
# preview done, barrier passed, refinement done)
marks() { sed -n "s/^cpu$2 marks: //p" "$OUT/cores$1.icount"; }
read -r -a one <<<"$(marks 1 0)"
read -r -a c0 <<<"$(marks 2 0)"
read -r -a c1 <<<"$(marks 2 1)"
[ "${#one[@]}" = 7 ] && [ "${#c0[@]}" = 7 ] && [ "${#c1[@]}" = 4 ] ||
    fail "could not read the per-core marks"
single=$((one[4] - one[1]))
# a core's render: from its start to the end of its refinement tiles; its
# waits: at the preview barrier (and core 0's for core 1 at the end, after)
r0=$((c0[4] - c0[1]))
w0=$((c0[3] - c0[2]))
r1=$((c1[3] - c1[0]))
w1=$((c1[2] - c1[1]))
busier=$((r0 > r1 ? r0 : r1))
# the render's critical path: each pass as long as its slower core
p0=$((c0[2] - c0[1]))
p1=$((c1[1] - c1[0]))
f0=$((c0[4] - c0[3]))
f1=$((c1[3] - c1[2]))
path=$((p0 > p1 ? p0 : p1))
path=$((path + (f0 > f1 ? f0 : f1)))
speedup=$(awk -v a="$single" -v b="$busier" 'BEGIN { printf "%.3f", a / b }')
speedup_path=$(awk -v a="$single" -v b="$path" 'BEGIN { printf "%.3f", a / b }')
insns1=$(sed -n 's/^insns: //p' "$OUT/cores1.icount")
insns2=$(sed -n 's/^insns: //p' "$OUT/cores2.icount")
{
    echo "# examples/dualcore, release, cornell.scene $SIZE, Budget::Spp(16) adaptive, seed 0"
    echo "# (QEMU mps2-an521, both Cortex-M33 with FPU, -icount shift=0); written by"
    echo "# .ci/dualcore.sh; executed instructions per core (tiles dealt out in turn)"
    echo "one_core_render: $single  (MICROPT_FW_CORES=1: previews and refinement on core 0)"
    echo "core0_render: $r0  (preview $p0 + barrier wait $w0 + refinement $f0)"
    echo "core1_render: $r1  (preview $p1 + barrier wait $w1 + refinement $f1)"
    echo "speedup_busier_core: $speedup  (one_core_render / max(core0_render, core1_render))"
    echo "speedup_critical_path: $speedup_path  (one_core_render / (max preview + max refinement))"
    echo "insns_total_one_core: $insns1"
    echo "insns_total_two_cores: $insns2  (both cores: setup, render, dump, waits)"
} >"$OUT/an521.size"
cat "$OUT/an521.size"
if awk -v s="$speedup" 'BEGIN { exit !(s < 1.8) }'; then
    echo "note: speed-up $speedup below 1.8"
fi

if [ "$BLESS" = 1 ]; then
    mkdir -p firmware/expected
    cp "$OUT/an521.size" firmware/expected/an521.size
    echo "wrote firmware/expected/an521.size"
elif ! diff -u firmware/expected/an521.size "$OUT/an521.size"; then
    echo "note: measured figures differ from firmware/expected/an521.size" \
        "(informational; .ci/dualcore.sh --bless updates)"
fi

dstep "the demo's passes on two cores (raw, denoised) = host CLI --passes 4"
for dn in 0 1; do
    rm -f "$OUT/passes-$dn.board.rgb565"
    MICROPT_FW_SCENE=$SCENE MICROPT_FW_SIZE=48x32 MICROPT_FW_SPP=1 MICROPT_FW_SEED=0 \
        MICROPT_FW_PASSES=4 MICROPT_FW_DENOISE=$dn MICROPT_FW_CORES=2 \
        MICROPT_FW_OUT="$OUT/passes-$dn.board.rgb565" \
        cargo build -p micropt --release --example dualcore --features firmware-an521 --target "$TARGET"
    timeout 600 "${QEMU[@]}" -kernel "$ELF" >"$OUT/passes-$dn.run" ||
        fail "the demo's passes (denoise $dn): the firmware failed"
    cat "$OUT/passes-$dn.run"
    # both cores rendered: core 1 the odd pixels, half of them
    grep -Eq 'core 0 11520 paths, core 1 11520 paths' "$OUT/passes-$dn.run" ||
        fail "the demo's passes (denoise $dn): the cores did not split the pixels"
    flag=()
    [ $dn = 1 ] && flag=(--denoise)
    target/debug/micropt render "$SCENE" --size 48x32 --spp 1 --passes 4 --seed 0 "${flag[@]}" \
        -o "$OUT/passes-$dn.host.rgb565"
    cmp "$OUT/passes-$dn.board.rgb565" "$OUT/passes-$dn.host.rgb565" ||
        fail "the demo's passes (denoise $dn): two cores' image differs from the host's"
    echo "denoise $dn: two cores = host after 4 passes"
done

dstep "dualcore done"
