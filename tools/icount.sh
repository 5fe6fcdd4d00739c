#!/usr/bin/env bash
# Instructions per path of a host render, counted by callgrind (repeatable,
# unlike seconds on a shared machine): tools/icount.sh BIN SCENE SPP [SIZE [RENDER ARGS...]]
# (e.g. --no-skip bvh)
set -euo pipefail
bin=$1; scene=$2; spp=$3; size=${4:-}
args=(render "$scene" --spp "$spp" --threads 1 --uniform --json -o /tmp/icount.$$.pfm)
[ -n "$size" ] && args+=(--size "$size")
shift $(( $# < 4 ? $# : 4 ))
args+=("$@")
out=$(valgrind --tool=callgrind --callgrind-out-file=/tmp/icount.$$.cg "$bin" "${args[@]}" 2>/tmp/icount.$$.err)
total=$(grep -oE 'Collected : [0-9]+' /tmp/icount.$$.err | grep -oE '[0-9]+')
paths=$(echo "$out" | grep -oE '"paths":[0-9]+' | grep -oE '[0-9]+')
rays=$(echo "$out" | grep -oE '"rays":[0-9]+' | grep -oE '[0-9]+')
rm -f /tmp/icount.$$.*
echo "$scene spp=$spp instructions=$total paths=$paths rays=$rays per_path=$((total / paths)) per_ray=$((total / rays))"
