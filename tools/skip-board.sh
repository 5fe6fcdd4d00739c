#!/usr/bin/env bash
# Measures every skip-optimisation (`micropt::Skip`) on the board (QEMU netduinoplus2,
# exact instruction counts from tools/qemu-icount) and writes
# docs/skip-board.md.
#
# For each shared scene (its own resolution, seed 0, Budget::Spp(SPP) with
# uniform allocation, so that every configuration traces the same number of
# paths) and each configuration: `Options::default()` (every `Skip` on), the
# same with one `Skip` field off, and `Skip::NONE`. The firmware is rebuilt
# per configuration (MICROPT_FW_SKIP_OFF, read by build.rs) and run with
# `-icount shift=0`; the figure is the render phase's instructions (between
# the firmware's 3rd and 4th marks: the budget executor, tone mapping
# included) divided by the paths traced.
#
#   bash tools/skip-board.sh            # SPP=16
#   SPP=4 bash tools/skip-board.sh
#   bash tools/skip-board.sh --table    # rewrite the table from the last run
#
# Needs what .ci/firmware.sh installs (qemu-system-arm, gcc, the
# thumbv7em-none-eabihf target). About 40 firmware builds: ~10 minutes on 2
# cores.
set -euo pipefail
cd "$(dirname "$0")/.."

SPP=${SPP:-16}
TARGET=thumbv7em-none-eabihf
ELF=target/$TARGET/release/examples/firmware
OUT=target/skip-board
DOC=docs/skip-board.md
mkdir -p "$OUT"
gcc -O2 -Wall -Wextra -Werror -shared -fPIC -o "$OUT/libicount.so" tools/qemu-icount/icount.c

CONFIGS=(default shadow_occluders view_culling specialize horizon unreachable_lights closed slabs whole_light none)
SCENES=(cornell furnace smallpt sphere-over-plane spheres)

# run SCENE CONFIG: build and run; prints "paths render_insns"
run() {
    local scene=$1 config=$2 off size
    case $config in
        default) off="" ;;
        none) off=all ;;
        *) off=$config ;;
    esac
    size=$(awk '$1 == "resolution" { print $2 "x" $3; exit }' "scenes/$scene.scene")
    MICROPT_FW_SCENE="scenes/$scene.scene" MICROPT_FW_SIZE="${size:-64x64}" MICROPT_FW_SPP=$SPP \
        MICROPT_FW_SEED=0 MICROPT_FW_UNIFORM=1 MICROPT_FW_SKIP_OFF=$off \
        MICROPT_FW_OUT="$OUT/$scene.$config.rgb565" \
        cargo build -q -p micropt --release --example firmware --features firmware --target "$TARGET" ||
        return 1
    timeout 600 qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 -nographic \
        -semihosting-config enable=on,target=native -icount shift=0 \
        -plugin "$OUT/libicount.so" -d plugin -D "$OUT/$scene.$config.icount" \
        -kernel "$ELF" >"$OUT/$scene.$config.run"
    local paths marks
    paths=$(sed -n 's/.*, \([0-9]*\) paths,.*/\1/p' "$OUT/$scene.$config.run")
    read -r -a marks <<<"$(sed -n 's/^marks: //p' "$OUT/$scene.$config.icount")"
    echo "$paths $((marks[3] - marks[2]))"
}

# `--table`: only rewrite the table from the last run's results
if [ "${1:-}" != --table ]; then
    : >"$OUT/results.txt"
    for scene in "${SCENES[@]}"; do
        for config in "${CONFIGS[@]}"; do
            # a failed build must not measure the previous configuration's ELF
            rm -f "$ELF"
            result=$(run "$scene" "$config") || { echo "error: $scene $config failed" >&2; exit 1; }
            read -r paths insns <<<"$result"
            same=no
            cmp -s "$OUT/$scene.default.rgb565" "$OUT/$scene.$config.rgb565" && same=yes
            echo "$scene $config $paths $insns $same" | tee -a "$OUT/results.txt"
        done
    done
fi

# per-path figures and the markdown table
{
    echo "# Skip-optimisations on the board: instructions per path"
    echo
    echo "Written by \`bash tools/skip-board.sh\` (SPP=$SPP). Each scene at its own"
    echo "resolution, seed 0, \`Budget::Spp($SPP)\` with uniform allocation"
    echo "(\`MICROPT_FW_UNIFORM=1\`: every configuration traces the same paths), rendered"
    echo "by \`examples/firmware\` (release, the core's single-core budget executor) in"
    echo "QEMU's STM32F405 (\`netduinoplus2\`, \`-icount shift=0\`). A figure is the"
    echo "render phase's executed instructions (exact counts from \`tools/qemu-icount\`,"
    echo "between the firmware's 3rd and 4th marks: preview and refinement passes,"
    echo "tone mapping into the framebuffer included) divided by the paths traced"
    echo "(${SPP} + 1 per pixel: the executor recomputes each tile's preview sample)."
    echo
    echo "Columns: \`Options::default()\` (every \`Skip\` on); the same with one \`Skip\`"
    echo "field off (\`MICROPT_FW_SKIP_OFF=<field>\` at build time, read by \`build.rs\`),"
    echo "with the instructions per path that skip saves in parentheses"
    echo "(off − on, as a share of the cost with it off); and \`Skip::NONE\`"
    echo "(\`MICROPT_FW_SKIP_OFF=all\`). A \`*\` marks an image that is not bit-identical"
    echo "to the default's: \`specialize\` (the general integrator draws a light-selection"
    echo "number the one-light variant does not), \`horizon\` with several lights (other"
    echo "selection probabilities) and \`unreachable_lights\` change the random numbers"
    echo "drawn; host-tests/tests/budget.rs checks that those images agree within noise."
    echo "The switches are run-time values in the firmware (\`core::hint::black_box\`), so"
    echo "the optimiser cannot specialise the code on them, as on the host; without it"
    echo "the counts were the same."
    echo
    printf '| scene | paths | default |'
    for c in "${CONFIGS[@]:1}"; do
        if [ "$c" = none ]; then printf ' Skip::NONE |'; else printf ' %s off |' "$c"; fi
    done
    echo
    printf '| --- | ---: | ---: |'
    for _ in "${CONFIGS[@]:1}"; do printf ' ---: |'; done
    echo
    for scene in "${SCENES[@]}"; do
        awk -v s="$scene" '
            $1 == s { p[$2] = $4 / $3; paths = $3; same[$2] = $5; order[++n] = $2 }
            END {
                printf "| %s | %d | %.0f |", s, paths, p["default"]
                for (i = 2; i <= n; i++) {
                    c = order[i]; d = p[c] - p["default"]
                    mark = same[c] == "yes" ? "" : " *"
                    printf " %.0f (%+.0f, %.1f %%)%s |", p[c], d, 100 * d / p[c], mark
                }
                printf "\n"
            }' "$OUT/results.txt"
    done
    echo
    echo "Raw figures (scene, configuration, paths, render instructions, image"
    echo "identical to the default's):"
    echo
    echo '```text'
    cat "$OUT/results.txt"
    echo '```'
} >"$DOC"
echo "wrote $DOC"
