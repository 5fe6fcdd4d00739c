#!/usr/bin/env bash
# The board's cost of the bounding volume hierarchy against the number of
# spheres: instructions per path of examples/firmware on random fields
# (tools/field.py N), with the tree and with the list (docs/bvh.md, "On the
# board").
#
# For each N a field of N spheres (tools/field.py N FIELD_SEED) is rendered by
# the firmware twice, tree on and tree off:
#
#   tree  the default build; below the board's tree threshold (24 spheres) with
#         MICROPT_FW_FORCE_BVH=1 (the CLI's --force-bvh)
#   list  MICROPT_FW_SKIP_OFF=bvh (the CLI's --no-skip bvh; from 24 spheres on
#         the tree is still built at load, and left unused); below 24 spheres
#         the plain build, which has no tree code at all
#
# on QEMU's Cortex-M7 (mps2-an500, thumbv7em-none-eabihf: the M4F's code and
# instruction counts) with all 4 MiB of its RAM
# (examples/board/memory-mps2-an500-4m.x: 4,096 spheres need 786 KB of
# statics and 232 KB of parse stack), at SIZE, Budget::Spp(SPP) adaptive
# (the CLI's default), seed SEED, `-icount shift=0` with tools/qemu-icount.
# Figures: render = instructions between the firmware's 3rd and 4th marks
# (the budget executor: previews, refinement, tone mapping) divided by the
# paths traced (SPP + 1 per pixel); load = between the 2nd and 3rd marks
# (parse, analysis, tree build, camera); flash (loaded sections: code,
# read-only data with the embedded scene text, vector table), static RAM
# (.data + .bss + .uninit) and stack high-water. Every board image is
# checked byte-identical with the host CLI's render of the same field, size,
# spp and seed (`micropt render FIELD --size SIZE --spp SPP --seed SEED
# --exposure 1 -o x.rgb565`, as .ci/firmware.sh).
#
#   bash tools/board_field_cost.sh                # N = 8 16 24 32 64 128 512 2048 4096
#   bash tools/board_field_cost.sh 8 128          # only these fields
#   SIZE=24x16 SPP=4 bash tools/board_field_cost.sh
#   bash tools/board_field_cost.sh --table        # the table of the last run
#   OUT=target/other bash tools/board_field_cost.sh 16 64   # elsewhere (default target/board-field)
#
# Needs what .ci/firmware.sh installs (qemu-system-arm, binutils, gcc, the
# thumbv7em-none-eabihf target). Two firmware builds per field (fat LTO,
# ~20 s each on 2 cores), each QEMU run in the background while the next
# builds; the list at 4,096 spheres executes 1.7 G instructions (about a
# minute in QEMU). About 6 minutes in all on 2 cores (5 min 32 s here); not run by CI.
set -euo pipefail
cd "$(dirname "$0")/.."

SIZE=${SIZE:-32x32}
SPP=${SPP:-4}
SEED=${SEED:-0}
FIELD_SEED=${FIELD_SEED:-1}
TARGET=thumbv7em-none-eabihf
MACHINE=mps2-an500
MEMORY=examples/board/memory-mps2-an500-4m.x
RAM=$((4 * 1024 * 1024))
OUT=${OUT:-target/board-field}
mkdir -p "$OUT"

fail() {
    echo "error: $*" >&2
    exit 1
}

TABLE_ONLY=0
if [ "${1:-}" = --table ]; then
    TABLE_ONLY=1
    shift
fi
NS=(8 16 24 32 64 128 512 2048 4096)
if [ $# -gt 0 ]; then NS=("$@"); fi
for n in "${NS[@]}"; do
    [[ "$n" =~ ^[0-9]+$ ]] && [ "$n" -ge 2 ] && [ "$n" -le 4096 ] ||
        fail "$n: a field has 2 to 4096 spheres (the host CLI's capacity)"
done

# elf_figures ELF: "FLASH RAM" (flash: the loaded sections, code, read-only
# data, the .data image, the vector table; static RAM: .data + .bss + .uninit)
. "$(dirname "${BASH_SOURCE[0]}")/../.ci/elf.sh"

# build_one N CONFIG: the firmware for field N, tree or list, copied to
# $OUT/field-N.CONFIG.elf
build_one() {
    local n=$1 config=$2 tag="field-$1.$2"
    local env=(MICROPT_FW_MACHINE=$MACHINE MICROPT_FW_MEMORY=$MEMORY
        MICROPT_FW_SCENE="$PWD/$OUT/field-$n.scene" MICROPT_FW_SIZE="$SIZE" MICROPT_FW_SPP="$SPP"
        MICROPT_FW_SEED="$SEED" MICROPT_FW_OUT="$OUT/$tag.board.rgb565")
    if [ "$config" = list ]; then
        env+=(MICROPT_FW_SKIP_OFF=bvh)
    elif [ "$n" -lt 24 ]; then
        env+=(MICROPT_FW_FORCE_BVH=1)
    fi
    rm -f "$OUT/$tag.elf"
    env "${env[@]}" cargo build -q -p micropt --release --example firmware --features firmware \
        --target "$TARGET"
    cp "target/$TARGET/release/examples/firmware" "$OUT/$tag.elf"
}

# check_one N CONFIG: runs the firmware in QEMU, compares its image with the
# host's, writes its figures to $OUT/field-N.CONFIG.row
check_one() {
    local n=$1 config=$2 tag="field-$1.$2" status=0
    rm -f "$OUT/$tag.board.rgb565" "$OUT/$tag.row"
    timeout 1800 qemu-system-arm -machine $MACHINE -nographic \
        -semihosting-config enable=on,target=native -icount shift=0 \
        -plugin "$OUT/libicount.so" -d plugin -D "$OUT/$tag.icount" \
        -kernel "$OUT/$tag.elf" >"$OUT/$tag.run" || status=$?
    cat "$OUT/$tag.run"
    [ "$status" = 0 ] || fail "$tag: the firmware exited with status $status"
    cmp "$OUT/$tag.board.rgb565" "$OUT/field-$n.host.rgb565" ||
        fail "$tag: the board's image differs from the host's (same field, size, spp, seed)"
    local flash ram stack paths marks
    read -r flash ram <<<"$(elf_figures "$OUT/$tag.elf")"
    stack=$(sed -n 's/.*stack high-water \([0-9]*\) bytes.*/\1/p' "$OUT/$tag.run")
    paths=$(sed -n 's/.*, \([0-9]*\) paths,.*/\1/p' "$OUT/$tag.run")
    read -r -a marks <<<"$(sed -n 's/^marks: //p' "$OUT/$tag.icount")"
    [ -n "$stack" ] && [ -n "$paths" ] && [ "${#marks[@]}" = 5 ] ||
        fail "$tag: could not read the firmware's figures"
    # the stack grows down from the top of RAM towards the statics: had it
    # reached them, the paint below it would be gone
    [ "$stack" -lt $((RAM - ram - 64)) ] ||
        fail "$tag: the stack ($stack bytes) filled the RAM left by the statics"
    echo "$n $config $paths $((marks[3] - marks[2])) $((marks[2] - marks[1])) $flash $ram $stack" \
        >"$OUT/$tag.row"
    echo "$tag $SIZE: bit-identical with the host; $(((marks[3] - marks[2]) / paths)) instructions per path"
}

# waits for the QEMU run in the background (pid $1, log $2) and shows its log
finish_check() {
    local status=0
    wait "$1" || status=$?
    cat "$2"
    [ "$status" = 0 ] || fail "a firmware run failed (above)"
}

if [ "$TABLE_ONLY" = 0 ]; then
    if ! command -v qemu-system-arm >/dev/null || ! command -v readelf >/dev/null; then
        fail "needs qemu-system-arm and binutils (as .ci/firmware.sh installs)"
    fi
    gcc -O2 -Wall -Wextra -Werror -shared -fPIC -o "$OUT/libicount.so" tools/qemu-icount/icount.c
    # the host CLI as CI builds it (test profile; same bits as release)
    cargo build -q --profile test -p micropt-host --bin micropt
    HOST=target/debug/micropt
    for n in "${NS[@]}"; do
        python3 tools/field.py "$n" "$FIELD_SEED" >"$OUT/field-$n.scene"
        "$HOST" render "$OUT/field-$n.scene" --size "$SIZE" --spp "$SPP" --seed "$SEED" \
            --exposure 1 -o "$OUT/field-$n.host.rgb565" >/dev/null
    done
    # each QEMU run goes on in the background while the next firmware builds
    pending=()
    for n in "${NS[@]}"; do
        for config in tree list; do
            build_one "$n" "$config"
            if [ "${#pending[@]}" -gt 0 ]; then finish_check "${pending[@]}"; fi
            check_one "$n" "$config" >"$OUT/field-$n.$config.log" 2>&1 &
            pending=($! "$OUT/field-$n.$config.log")
        done
    done
    finish_check "${pending[@]}"
    {
        echo "# tools/board_field_cost.sh: examples/firmware on QEMU $MACHINE ($TARGET), $SIZE,"
        echo "# Budget::Spp($SPP) adaptive, seed $SEED, fields tools/field.py N $FIELD_SEED;"
        echo "# N config paths render_insns load_insns flash static_ram stack"
        for n in "${NS[@]}"; do cat "$OUT/field-$n.tree.row" "$OUT/field-$n.list.row"; done
    } >"$OUT/results.txt"
fi

[ -f "$OUT/results.txt" ] || fail "no $OUT/results.txt: run without --table first"
head -n 2 "$OUT/results.txt"
echo
echo "| spheres | paths | tree: instructions per path | list: instructions per path | load, tree build included (tree / list) | flash (tree / list) | static RAM | stack high-water (tree / list) |"
echo "|--:|--:|--:|--:|--:|--:|--:|--:|"
awk '
    function c(x,   s, r) {
        s = sprintf("%d", x); r = ""
        while (length(s) > 3) { r = "," substr(s, length(s) - 2) r; s = substr(s, 1, length(s) - 3) }
        return s r
    }
    function pair(a, b) { return a == b ? c(a) : c(a) " / " c(b) }
    !/^#/ { n[$1] = 1; paths[$1, $2] = $3; per[$1, $2] = $4 / $3; load[$1, $2] = $5
            flash[$1, $2] = $6; ram[$1, $2] = $7; stack[$1, $2] = $8; order[++k] = $1 }
    END {
        for (i = 1; i <= k; i++) {
            m = order[i]; if (seen[m]++) continue
            if (paths[m, "tree"] != paths[m, "list"]) { print "error: paths differ at " m > "/dev/stderr"; exit 1 }
            printf "| %s | %s | %s | %s | %s | %s | %s | %s |\n", c(m), c(paths[m, "tree"]),
                c(per[m, "tree"] + 0.5), c(per[m, "list"] + 0.5), pair(load[m, "tree"], load[m, "list"]),
                pair(flash[m, "tree"], flash[m, "list"]), pair(ram[m, "tree"], ram[m, "list"]),
                pair(stack[m, "tree"], stack[m, "list"])
        }
        if ((128, "tree") in per && (2048, "tree") in per)
            printf "\nfrom 128 to 2,048 spheres: tree x%.2f, list x%.2f per path\n",
                per[2048, "tree"] / per[128, "tree"], per[2048, "list"] / per[128, "list"]
    }' "$OUT/results.txt"
# the plot's data (tools/cost_plot.py): instructions per path
awk 'BEGIN { print "spheres,tree_per_path,list_per_path" }
     !/^#/ { p[$1, $2] = $4 / $3; if (!seen[$1]++) order[++k] = $1 }
     END { for (i = 1; i <= k; i++) printf "%d,%.0f,%.0f\n", order[i], p[order[i], "tree"], p[order[i], "list"] }' \
    "$OUT/results.txt" >"$OUT/cost-board.csv"
echo
echo "wrote $OUT/results.txt and $OUT/cost-board.csv (the plot's board data)"
