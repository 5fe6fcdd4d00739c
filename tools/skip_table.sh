#!/usr/bin/env bash
# The cost of each skip-optimisation on the host: instructions per path
# (callgrind, repeatable on a shared machine) for every shipped scene with
# the default options and with one skip turned off (--no-skip), and whether
# the image is bit-identical. Prints a markdown table.
#   tools/skip_table.sh [BIN] [SPP] [SIZE]
set -euo pipefail
bin=${1:-target/release/micropt}
spp=${2:-4}
size=${3:-48x36}
configs=(default shadow-occluders view-culling specialize horizon unreachable-lights closed slabs whole-light all)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
count() { # scene config -> "instructions paths"
    local args=(render "$1" --uniform --spp "$spp" --size "$size" --threads 1 --json -o "$tmp/$2.pfm")
    [ "$2" != default ] && args+=(--no-skip "$2")
    local json
    json=$(valgrind --tool=callgrind --callgrind-out-file="$tmp/cg" "$bin" "${args[@]}" 2>"$tmp/err")
    local ins paths
    ins=$(grep -oE 'Collected : [0-9]+' "$tmp/err" | grep -oE '[0-9]+')
    paths=$(echo "$json" | grep -oE '"paths":[0-9]+' | grep -oE '[0-9]+')
    echo "$ins $paths"
}
printf '| scene |'; for c in "${configs[@]}"; do printf ' %s |' "$c"; done; echo
printf '|---|'; for _ in "${configs[@]}"; do printf '%s' '---|'; done; echo
for scene in scenes/*.scene; do
    name=$(basename "$scene" .scene)
    printf '| %s |' "$name"
    base=""
    for c in "${configs[@]}"; do
        read -r ins paths < <(count "$scene" "$c")
        per=$((ins / paths))
        if [ "$c" = default ]; then
            base=$per
            printf ' %d |' "$per"
        else
            same=$(cmp -s "$tmp/default.pfm" "$tmp/$c.pfm" && echo "=" || echo "~")
            printf ' %d (%+.1f%%) %s |' "$per" "$(echo "100 * ($per - $base) / $base" | bc -l)" "$same"
        fi
    done
    echo
done
echo
echo "Instructions per path (callgrind, whole process, ${size} at ${spp} spp uniform, one thread); in brackets the extra work with that skip off; '=' image bit-identical to the default, '~' same expectation, other random numbers."
