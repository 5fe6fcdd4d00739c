#!/usr/bin/env python3
"""Instruction profile by (inlined) function and by source line.

    profile_report.py ELF COUNTS [PATHS] [--objdump arm-none-eabi-objdump]

COUNTS has one "ADDR COUNT" line per executed instruction (hex address,
decimal count): from the QEMU plugin tools/qemu-profile (firmware), or from a
callgrind run converted with --callgrind (host):

    valgrind --tool=callgrind --dump-instr=yes --dump-line=no --compress-pos=no \\
        --callgrind-out-file=cg.out target/release/micropt render scenes/cornell.scene \\
        --spp 16 --threads 1 --uniform -o /tmp/x.pfm
    profile_report.py --callgrind cg.out > counts.txt
    profile_report.py target/release/micropt counts.txt 65536

Every address is mapped with `addr2line -i` (the release profiles keep line
tables), so code inlined into one big function is still attributed to the
functions and lines it came from: "inclusive" counts an instruction once for
every function on its inline chain, "self" for the innermost one. With PATHS,
counts are per path sample.
"""
import collections
import re
import subprocess
import sys


def callgrind_counts(path):
    """Self cost per instruction address of a callgrind file written with
    --dump-instr=yes --dump-line=no --compress-pos=no."""
    counts = collections.Counter()
    last, skip = 0, False
    for line in open(path):
        line = line.strip()
        if not line:
            continue
        if line.startswith("calls="):
            skip = True  # the next cost line is the call's inclusive cost
            continue
        if line[0].isdigit() or line[0] in "+-*":
            parts = line.split()
            p = parts[0]
            if p.startswith("0x"):
                addr = int(p, 16)
            elif p[0] in "+-":
                d = int(p[1:], 16) if p[1:].startswith("0x") else int(p[1:])
                addr = last + d if p[0] == "+" else last - d
            elif p == "*":
                addr = last
            else:
                addr = int(p)
            last = addr
            if skip:
                skip = False
                continue
            if len(parts) > 1:
                counts[addr] += int(parts[1])
    return counts


def short(fn):
    while True:
        s = re.sub(r"<[^<>]*>", "", fn)
        if s == fn:
            return fn[-80:]
        fn = s


def main():
    args = sys.argv[1:]
    if args and args[0] == "--callgrind":
        for a, c in sorted(callgrind_counts(args[1]).items()):
            print(f"{a:x} {c}")
        return
    elf, prof = args[0], args[1]
    paths = float(args[2]) if len(args) > 2 and not args[2].startswith("--") else 1.0
    counts = collections.Counter()
    for line in open(prof):
        a, c = line.split()
        counts[int(a, 16)] += int(c)
    addrs = sorted(counts)
    out = subprocess.run(["addr2line", "-i", "-f", "-C", "-a", "-e", elf],
                         input="\n".join(hex(a) for a in addrs), capture_output=True, text=True).stdout
    chains, cur, lines = {}, None, out.splitlines()
    i = 0
    while i < len(lines):
        if lines[i].startswith("0x"):
            cur = int(lines[i], 16)
            chains[cur] = []
            i += 1
            continue
        chains[cur].append((lines[i], lines[i + 1]))
        i += 2
    total = sum(counts.values())
    incl, selfc, linec = collections.Counter(), collections.Counter(), collections.Counter()
    for a, c in counts.items():
        ch = chains.get(a) or [("?", "?")]
        for fn in {short(f) for f, _ in ch}:
            incl[fn] += c
        selfc[short(ch[0][0])] += c
        linec[re.sub(r"^.*/(src|library)/", r"\1/", ch[0][1].split(" ")[0])] += c
    print(f"total {total}  per path {total / paths:.0f}")
    for title, table, n in (("inclusive", incl, 40), ("self", selfc, 25), ("lines", linec, 40)):
        print(f"== {title} (per path)")
        for k, c in table.most_common(n):
            print(f"{c / paths:9.1f} {100 * c / total:5.1f}%  {k}")


if __name__ == "__main__":
    main()
