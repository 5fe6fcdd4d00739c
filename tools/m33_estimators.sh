#!/usr/bin/env bash
# What the estimators of the images of lights through mirror and glass
# balls (the `highlight` feature: highlights, chains, caustics) cost on the
# Cortex-M33: instructions a path of the firmware's render phase (QEMU's
# mps2-an505, exact counts), 96x64, 16 spp uniform, seed 0, for many, dof
# and cornell, built with the default features and with the same but
# `highlight`. Needs qemu-system-arm and the thumbv8m.main-none-eabihf
# target (.ci/run installs both).
#
#   bash tools/m33_estimators.sh
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=target/m33-estimators
mkdir -p $OUT
gcc -O2 -shared -fPIC -o $OUT/libicount.so tools/qemu-icount/icount.c
FEAT_ALL="firmware,parser,mirror,glass,metal,checker,windows,lens,highlight,fast-math,tunable"
FEAT_NO="firmware,parser,mirror,glass,metal,checker,windows,lens,fast-math,tunable"
for scene in many dof cornell; do
  for v in with without; do
    f=$FEAT_ALL; [ $v = without ] && f=$FEAT_NO
    MICROPT_FW_SCENE=scenes/$scene.scene MICROPT_FW_SIZE=96x64 MICROPT_FW_SPP=16 MICROPT_FW_SEED=0 MICROPT_FW_UNIFORM=1 \
      MICROPT_FW_MEMORY=examples/board/memory-mps2-an505-4m.x MICROPT_FW_OUT=$OUT/$scene-$v.rgb565 \
      cargo build -q -p micropt --release --example firmware --no-default-features --features $f --target thumbv8m.main-none-eabihf
    timeout 1800 qemu-system-arm -machine mps2-an505 -nographic -semihosting-config enable=on,target=native -icount shift=0 \
      -plugin $OUT/libicount.so -d plugin -D $OUT/$scene-$v.icount -kernel target/thumbv8m.main-none-eabihf/release/examples/firmware > $OUT/$scene-$v.run
    read -r -a m <<<"$(sed -n 's/^marks: //p' $OUT/$scene-$v.icount)"
    paths=$(sed -n 's/.* \([0-9]*\) paths,.*/\1/p' $OUT/$scene-$v.run)
    r=$((m[3]-m[2])); echo "$scene $v: render $r instructions, $paths paths, $((r / paths)) a path"
  done
done
