#!/usr/bin/env bash
# Instructions per ray of a host render without the scene's load (parse,
# analysis, tree build): the difference of two callgrind counts
# (tools/icount.sh) at SPP1 and SPP2 samples per pixel, divided by the
# difference in rays. tools/ray_cost.sh BIN SCENE SIZE SPP1 SPP2 [RENDER ARGS...]
set -euo pipefail
bin=$1; scene=$2; size=$3; s1=$4; s2=$5
shift 5
here=$(dirname "$0")
a=$("$here/icount.sh" "$bin" "$scene" "$s1" "$size" "$@")
b=$("$here/icount.sh" "$bin" "$scene" "$s2" "$size" "$@")
ia=$(grep -oE 'instructions=[0-9]+' <<<"$a" | cut -d= -f2); ra=$(grep -oE 'rays=[0-9]+' <<<"$a" | cut -d= -f2)
ib=$(grep -oE 'instructions=[0-9]+' <<<"$b" | cut -d= -f2); rb=$(grep -oE 'rays=[0-9]+' <<<"$b" | cut -d= -f2)
echo "$scene $* per_ray=$(( (ib - ia) / (rb - ra) )) rays=$((rb - ra)) load=$(( ia - (ib - ia) * ra / (rb - ra) ))"
