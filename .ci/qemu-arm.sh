# Sourced by the scripts that run an Arm firmware in QEMU alone
# (.ci/dualcore.sh, .ci/denoise.sh; .ci/targets.sh installs more).

# install_qemu_arm TARGET: qemu-system-arm, the Arm binutils and gcc (for
# the instruction-count plugin) if missing, and the Rust target.
install_qemu_arm() {
    local sudo=""
    if [ "$(id -u)" != 0 ] && command -v sudo >/dev/null; then sudo=sudo; fi
    if ! command -v qemu-system-arm >/dev/null || ! command -v gcc >/dev/null; then
        $sudo apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
            qemu-system-arm binutils-arm-none-eabi gcc libc6-dev >/dev/null
    fi
    rustup target add "$1" >/dev/null
}
