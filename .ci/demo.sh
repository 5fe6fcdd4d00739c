#!/usr/bin/env bash
# The demo (called by .ci/run; runs alone too): the desktop window builds
# (embedded-graphics-simulator through SDL2: installs libsdl2-dev if
# missing), the headless demo's passes are the host CLI's `--passes`
# images, and the firmware built with MICROPT_FW_PASSES=K (the demo's
# passes, streamed, raw and denoised) dumps the same bytes on the
# Cortex-M33 (QEMU's mps2-an505, the RP2350's core).
set -euo pipefail
cd "$(dirname "$0")/.."
. .ci/qemu-arm.sh

TARGET=thumbv8m.main-none-eabihf
OUT=target/demo
ELF=target/$TARGET/release/examples/firmware
mkdir -p "$OUT"
fail() {
    echo "error: $*" >&2
    exit 1
}
dstep() { printf '\n---- demo: %s (%ss)\n' "$*" "$SECONDS"; }

dstep "install libsdl2-dev, qemu-system-arm and gcc if missing"
SUDO=""
if [ "$(id -u)" != 0 ] && command -v sudo >/dev/null; then SUDO=sudo; fi
if ! pkg-config --exists sdl2 2>/dev/null; then
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
        libsdl2-dev pkg-config >/dev/null
fi
install_qemu_arm "$TARGET"

dstep "clippy: the demo's window (--features window)"
cargo clippy -p micropt-host --example demo --features window -- -D warnings

dstep "headless demo = host CLI --passes"
cargo build -q --profile test -p micropt-host --bin micropt --example demo
HOST=target/debug/micropt
rm -rf "$OUT/headless"
target/debug/examples/demo --headless --passes 4 --size 96x64 --seed 2 --no-status \
    --out "$OUT/headless"
for k in 0 3; do
    "$HOST" render scenes/cornell.scene --size 96x64 --seed 2 --spp 1 --passes $((k + 1)) \
        --denoise -o "$OUT/host-pass-$k.rgb565"
    cmp "$OUT/headless/pass-0$k.rgb565" "$OUT/host-pass-$k.rgb565" ||
        fail "the headless demo's pass $k differs from micropt render --passes $((k + 1))"
    echo "pass $k: headless demo = host CLI"
done

dstep "firmware MICROPT_FW_PASSES=3 (Cortex-M33) = host CLI --passes 3"
for dn in 0 1; do
    rm -f "$OUT/fw-$dn.rgb565"
    MICROPT_FW_SCENE=scenes/cornell.scene MICROPT_FW_SIZE=32x24 MICROPT_FW_SPP=2 MICROPT_FW_SEED=0 \
        MICROPT_FW_PASSES=3 MICROPT_FW_DENOISE=$dn MICROPT_FW_MACHINE=mps2-an505 \
        MICROPT_FW_OUT="$PWD/$OUT/fw-$dn.rgb565" \
        cargo build -q -p micropt --release --example firmware --no-default-features \
        --features firmware,parser,mirror --target "$TARGET"
    timeout 600 qemu-system-arm -machine mps2-an505 -nographic \
        -semihosting-config enable=on,target=native -kernel "$ELF" ||
        fail "the passes firmware failed (denoise $dn)"
    flag=()
    [ $dn = 1 ] && flag=(--denoise)
    "$HOST" render scenes/cornell.scene --size 32x24 --spp 2 --passes 3 --seed 0 "${flag[@]}" \
        -o "$OUT/host-fw-$dn.rgb565"
    cmp "$OUT/fw-$dn.rgb565" "$OUT/host-fw-$dn.rgb565" ||
        fail "the firmware's 3 passes differ from the host's (denoise $dn)"
    echo "denoise $dn: board = host after 3 passes"
done
dstep "demo done"
