#!/usr/bin/env bash
# Instructions per function of a firmware run in QEMU: tools/profile.sh ELF [PATHS]
#
# Runs ELF (netduinoplus2, -icount shift=0) with the per-instruction counter
# tools/qemu-profile, then attributes every executed instruction to the ELF
# symbol whose range ([address, address + size) from `nm -S`) holds it: the
# out-of-line functions as the linker kept them (compiler-builtins' soft-float
# routines, libm, the core's non-inlined functions). Inlined code counts for
# the function it was inlined into; tools/profile_report.py splits that by
# inline frame and source line. With PATHS (from the firmware's summary line)
# the counts are also given per path. The whole run is counted, setup and
# image dump included (a few 10⁵ instructions). Calls per path of some
# functions, from the same counts: tools/calls.py ELF OUT/counts.txt PATHS NAME...
#
# It also writes, for tools/cpi.py, OUT/taken.txt (taken branches),
# OUT/data.txt (data reads from the code region) and OUT/cache.txt (an
# RP2350 XIP cache model's misses): tools/qemu-profile/profile.c.
#
# Env: NM (default arm-none-eabi-nm), QEMU_MACHINE (netduinoplus2; mps2-an505
# for the Cortex-M33 build), QEMU_CPU (cortex-m4; cortex-m33 there), TOP (30),
# OUT (directory for the plugin and the counts; default target/profile).
set -euo pipefail
cd "$(dirname "$0")/.."
elf=$1
paths=${2:-}
out=${OUT:-target/profile}
mkdir -p "$out"
gcc -O2 -Wall -Wextra -shared -fPIC -o "$out/libprofile.so" tools/qemu-profile/profile.c
timeout 3600 qemu-system-arm -cpu "${QEMU_CPU:-cortex-m4}" -machine "${QEMU_MACHINE:-netduinoplus2}" \
    -nographic -semihosting-config enable=on,target=native -icount shift=0 \
    -plugin "$out/libprofile.so,out=$out/counts.txt,taken=$out/taken.txt,data=$out/data.txt,cache=$out/cache.txt" \
    -d plugin -kernel "$elf" >"$out/run.txt"
cat "$out/run.txt"
if [ -z "$paths" ]; then
    paths=$(sed -n 's/.*, \([0-9]*\) paths,.*/\1/p' "$out/run.txt")
fi
"${NM:-arm-none-eabi-nm}" -S -C "$elf" | awk '$2 ~ /^[0-9a-f]+$/ && $3 ~ /^[tTwW]$/' >"$out/syms.txt"
python3 - "$out/syms.txt" "$out/counts.txt" "${paths:-1}" "${TOP:-30}" <<'PY'
import bisect, collections, sys
syms = []
for line in open(sys.argv[1]):
    a, s, _t, name = line.rstrip("\n").split(" ", 3)
    # Thumb symbols have bit 0 set in some tools' output
    syms.append((int(a, 16) & ~1, int(s, 16), name))
syms.sort()
starts = [a for a, _, _ in syms]
paths, top = float(sys.argv[3]), int(sys.argv[4])
per = collections.Counter()
total = 0
for line in open(sys.argv[2]):
    a, c = line.split()
    a, c = int(a, 16), int(c)
    total += c
    i = bisect.bisect_right(starts, a) - 1
    name = "?"
    if i >= 0 and a < syms[i][0] + max(syms[i][1], 2):
        name = syms[i][2]
    per[name] += c
print(f"total {total}  paths {paths:.0f}  per path {total / paths:.0f}")
print(f"{'per path':>10} {'share':>6}  function")
for name, c in per.most_common(top):
    print(f"{c / paths:10.0f} {100 * c / total:5.1f}%  {name[:100]}")
PY
