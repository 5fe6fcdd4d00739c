#!/usr/bin/env python3
"""Calls per path of functions: the executions of each one's first instruction.

    calls.py ELF COUNTS PATHS NAME...   (NAME: a substring of the symbol)
"""
import collections, subprocess, sys
elf, counts, paths = sys.argv[1], sys.argv[2], float(sys.argv[3])
syms = {}
for line in subprocess.run(["arm-none-eabi-nm", "-C", elf], capture_output=True, text=True).stdout.splitlines():
    p = line.split(" ", 2)
    if len(p) == 3 and p[1] in "tTwW":
        syms[p[2]] = int(p[0], 16) & ~1
c = collections.Counter()
for line in open(counts):
    a, n = line.split()
    c[int(a, 16)] += int(n)
for name in sys.argv[4:]:
    for s, a in syms.items():
        if name in s:
            print(f"{c[a] / paths:10.1f}  {s[:90]}")
