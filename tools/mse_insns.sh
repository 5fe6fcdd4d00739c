#!/usr/bin/env bash
# Error times time on the board: tools/mse_insns.sh SIZES [SEEDS]
#
# For cornell, smallpt, gloss and dof at the firmware's settings (the
# scene's resolution, 16 spp, adaptive): the MSE against the reference
# (host-tests/data), averaged over SEEDS renders (default 8, seeds 0..7) of
# the host CLI, whose images are bit for bit the board's; the board's render
# instructions from SIZES (a firmware/expected/scenes.size, or
# cornell.size's figure for cornell when SIZES is a directory holding both);
# and their product, the figure a change must lower: a change that keeps
# the bits keeps the MSE, so the product falls with the instructions.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-firmware/expected}
seeds=${2:-8}
cargo build -q --profile test -p micropt-host --bin micropt
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-8s %12s %14s %14s\n' scene mse render_insns mse_x_insns
for s in cornell smallpt gloss dof; do
    total=0
    for ((k = 0; k < seeds; k++)); do
        target/debug/micropt render "scenes/$s.scene" --spp 16 --seed "$k" -o "$tmp/$s.pfm" 2>/dev/null
        mse=$(target/debug/micropt compare "$tmp/$s.pfm" "host-tests/data/$s.pfm" | awk '$1 == "mse" { print $2 }')
        total=$(awk -v a="$total" -v b="$mse" 'BEGIN { printf "%.9e", a + b }')
    done
    mse=$(awk -v a="$total" -v n="$seeds" 'BEGIN { printf "%.4e", a / n }')
    # cornell: its own firmware (cornell.size); the others: every feature
    if [ "$s" = cornell ]; then
        insns=$(awk '$1 == "insns_render:" { print $2 }' "$dir/cornell.size")
    else
        insns=$(awk -v s="$s" '$1 == s { print $8 }' "$dir/scenes.size")
    fi
    printf '%-8s %12s %14s %14s\n' "$s" "$mse" "$insns" \
        "$(awk -v m="$mse" -v i="$insns" 'BEGIN { printf "%.4e", m * i }')"
done
