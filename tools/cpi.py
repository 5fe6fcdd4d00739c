#!/usr/bin/env python3
"""Cycles per instruction of a Cortex-M33 firmware run, from its QEMU profile.

    tools/cpi.py ELF OUT [--paths N] [--mhz 150] [--frame-paths 936000]
                 [--speedup 1.961] [--miss 40]

OUT is the directory tools/profile.sh wrote (counts.txt: executions per
instruction address; taken.txt: taken exits per block-ending instruction;
data.txt: data reads per 8-byte line of the code region; run.txt: the
firmware's summary line, which gives the traced paths unless --paths does).

It disassembles ELF (arm-none-eabi-objdump -d), sorts every executed
instruction into a class, and prints per class the instructions per path
and the cycles per path under two timing tables (CYCLES below):

- "M4 table": the Cortex-M4's published timings (Arm Cortex-M4 TRM, DDI 0439,
  tables 3-1 and 7-1): the closest core whose timings Arm publishes (Arm
  gives no per-instruction table for the M33); the M33's FPU is the same
  single-precision datapath (1 cycle add/mul, 3 multiply-accumulate, 14
  divide and square root). Loads and stores 2 cycles, 1 when they follow
  another load or store; a taken branch 1 + P with P = 2 (P is 1 to 3).
- "M33": the M33's pipeline as Arm describes it: address generation and
  branch resolution in the second of its stages, so a single load or store
  takes 1 cycle and a taken branch refills with P = 1; FPU as above.

Then the frame: cycles per path x paths of the frame / clock / two-core
speed-up, at zero wait states (code and data in single-cycle memory, or
code always hitting a 1-cycle cache), and the code footprint: the bytes and
8-byte cache lines (the RP2350 XIP cache's line) of the hottest code (and
code-region data reads) that cover 90, 99, 99.9 and 100 % of the executed
instructions, against a 16 KiB cache; with --miss C it adds, for a cache
that holds only the lines outside the hottest 16 KiB, C cycles per
execution of an instruction on a line beyond it (an upper-bound model of
capacity misses, not a cache simulation). Every figure is an estimate.
"""
import argparse
import bisect
import collections
import re
import subprocess
import sys

# class -> (M4 table cycles, M33 cycles); "+P" classes add the refill
# penalty when taken, "N" classes take it per register
P = {"M4 table": 2, "M33": 1}
CYCLES = {
    "ALU, move, compare": (1, 1),
    "IT": (1, 1),
    "multiply (MUL, MLA, UMULL...)": (1, 1),
    "divide (SDIV, UDIV)": (12, 12),
    "load (LDR, LDRB, LDRH...)": (2, 1),
    "store (STR, STRB, STRH)": (2, 1),
    "LDRD / STRD": (3, 2),
    # (with pc in the list: + P)
    "LDM / STM / PUSH / POP": ("1+N", "N"),
    "VLDR / VSTR": (2, 1),
    "VLDM / VSTM / VPUSH / VPOP": ("1+N", "N"),
    "VMOV core <-> FP": (2, 2),
    "FP 1-cycle (VADD, VSUB, VMUL, VMOV, VABS, VCVT, VSEL...)": (1, 1),
    "VCMP": (1, 1),
    "VMRS (flags to APSR)": (1, 1),
    "VMLA / VMLS / VFMA (multiply-accumulate)": (3, 3),
    "VDIV": (14, 14),
    "VSQRT": (14, 14),
    "branch not taken": (1, 1),
    "branch taken (B, BL, BX, CBZ, TBB)": ("1+P", "1+P"),
    "other (system, hints)": (1, 1),
}
COND = "(?P<c>eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le|al)?"


def classify(mn, ops):
    """(class, registers moved, writes pc, conditional) of one instruction."""
    base = mn.split(".")[0]
    regs = 0
    m = re.search(r"\{([^}]*)\}", ops)
    if m:
        for part in m.group(1).split(","):
            part = part.strip()
            r = re.fullmatch(r"([rsd])(\d+)-[rsd](\d+)", part)
            k = int(r.group(3)) - int(r.group(2)) + 1 if r else 1
            # a double register moves two words
            regs += 2 * k if part.startswith("d") else k
    writes_pc = bool(re.search(r"\bpc\b", ops.split(",")[0])) or (m is not None and "pc" in m.group(1))

    def cond(pat):
        r = re.fullmatch(pat + COND, base)
        return r is not None, bool(r and r.group("c"))

    for pat, cls in (
        (r"vdiv", "VDIV"),
        (r"vsqrt", "VSQRT"),
        (r"v(fma|fms|fnma|fnms|mla|mls|nmla|nmls)", "VMLA / VMLS / VFMA (multiply-accumulate)"),
        (r"vcmpe?", "VCMP"),
        (r"vmrs", "VMRS (flags to APSR)"),
        (r"v(ldr|str)", "VLDR / VSTR"),
        (r"v(ldm|stm)(ia|db)?|vpush|vpop", "VLDM / VSTM / VPUSH / VPOP"),
    ):
        ok, c = cond(pat)
        if ok:
            return cls, regs, False, c
    if re.fullmatch(r"vmov" + COND, base) and re.search(r"\br\d+|\b(sb|sl|fp|ip|lr)\b", ops):
        return "VMOV core <-> FP", 1, False, False
    if base.startswith("v"):
        return "FP 1-cycle (VADD, VSUB, VMUL, VMOV, VABS, VCVT, VSEL...)", 0, False, False
    if re.fullmatch(r"it[te]{0,3}", base):
        return "IT", 0, False, False
    for pat, cls, branch in (
        (r"(b|bl|blx|bx)", None, True),
        (r"(cbz|cbnz)", None, True),
        (r"(tbb|tbh)", None, True),
        (r"(ldrd|strd)", "LDRD / STRD", False),
        (r"(ldm|stm)(ia|db|fd|ea)?|push|pop", "LDM / STM / PUSH / POP", False),
        (r"(ldr|lda)(b|h|sb|sh|ex|exb|exh|t|bt|ht)?", "load (LDR, LDRB, LDRH...)", False),
        (r"(str|stl)(b|h|ex|exb|exh|t|bt|ht)?", "store (STR, STRB, STRH)", False),
        (r"(s|u)div", "divide (SDIV, UDIV)", False),
        (r"(mul|muls|mla|mls|umull|smull|umlal|smlal|smmul|smmla|smla\w*|smul\w*)", "multiply (MUL, MLA, UMULL...)", False),
        (r"(nop|yield|wfi|wfe|sev|bkpt|dsb|dmb|isb|msr|mrs|cpsid|cpsie|udf|svc)", "other (system, hints)", False),
    ):
        ok, c = cond(pat)
        if ok:
            if branch:
                # cbz/cbnz are conditional without a condition suffix
                return "branch", 0, True, c or base in ("cbz", "cbnz")
            return cls, regs, writes_pc, c
    return "ALU, move, compare", 0, writes_pc, False


def disassemble(elf, objdump):
    """address -> (size in bytes, mnemonic, operands)"""
    out = subprocess.run([objdump, "-d", elf], check=True, capture_output=True, text=True).stdout
    insns = {}
    for line in out.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\t([0-9a-f ]+?)\s*\t(\S+)\s*(.*)", line)
        if not m:
            continue
        words = m.group(2).split()
        size = sum(len(w) // 2 for w in words)
        insns[int(m.group(1), 16)] = (size, m.group(3), m.group(4))
    return insns


def read_counts(path, required=True):
    """address -> count of a profile file ("ADDR COUNT" lines)"""
    counts = collections.Counter()
    try:
        for line in open(path):
            a, c = line.split()
            counts[int(a, 16)] += int(c)
    except FileNotFoundError:
        if required:
            sys.exit(f"error: no {path}: run tools/profile.sh (its plugin writes it)")
    return counts


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("elf")
    ap.add_argument("out", help="tools/profile.sh's output directory")
    ap.add_argument("--paths", type=float, help="traced paths (default: from OUT/run.txt)")
    ap.add_argument("--mhz", type=float, default=150.0, help="core clock (default 150, the RP2350's)")
    ap.add_argument("--frame-paths", type=float, default=240 * 240 * 16 + 120 * 120,
                    help="paths of the frame (default 240x240 at 16 spp plus the preview's "
                         "sample per 2x2 block: 936,000)")
    ap.add_argument("--speedup", type=float, default=1.0, help="two-core speed-up (the AN521's)")
    ap.add_argument("--miss", type=float, default=0.0,
                    help="cycles per cache miss (the model's misses, else the accesses beyond the hottest 16 KiB)")
    ap.add_argument("--objdump", default="arm-none-eabi-objdump")
    args = ap.parse_args()

    counts = read_counts(f"{args.out}/counts.txt")
    taken = read_counts(f"{args.out}/taken.txt")
    data = read_counts(f"{args.out}/data.txt", required=False)
    run = open(f"{args.out}/run.txt").read()
    paths = args.paths
    if paths is None:
        m = re.search(r", (\d+) paths,", run)
        if not m:
            sys.exit(f"error: no traced paths in {args.out}/run.txt; give --paths")
        paths = float(m.group(1))
    # the render's instructions: its time under -icount shift=0 (1 ns each)
    m = re.search(r"total (\d+) us", run)
    render = float(m.group(1)) * 1000 if m else None
    insns = disassemble(args.elf, args.objdump)
    order = sorted(insns)

    # per class: executions, cycles under each table
    tables = list(P)
    n = collections.Counter()
    cyc = {t: collections.Counter() for t in tables}
    unknown = 0
    for a, c in counts.items():
        if a not in insns:
            unknown += c
            continue
        _, mn, ops = insns[a]
        cls, regs, writes_pc, conditional = classify(mn, ops)
        if cls == "branch" or writes_pc:
            # taken: all of an unconditional one's executions
            t = min(taken.get(a, 0), c) if conditional else c
            if cls != "branch":
                # a load or POP that writes pc: its own cost plus the refill
                for i, tab in enumerate(tables):
                    base = CYCLES[cls][i]
                    base = regs + (1 if base == "1+N" else 0) if isinstance(base, str) else base
                    cyc[tab][cls] += c * base + t * P[tab]
                n[cls] += c
                continue
            tb = mn.split(".")[0] in ("tbb", "tbh")
            n["branch taken (B, BL, BX, CBZ, TBB)"] += t
            n["branch not taken"] += c - t
            for tab in tables:
                cyc[tab]["branch taken (B, BL, BX, CBZ, TBB)"] += t * (1 + P[tab] + tb)
                cyc[tab]["branch not taken"] += c - t
            continue
        n[cls] += c
        i_prev = bisect.bisect_left(order, a) - 1
        prev_mem = False
        if i_prev >= 0:
            pc_ = classify(*insns[order[i_prev]][1:])[0]
            prev_mem = pc_.startswith(("load", "store", "VLDR", "LDRD"))
        for i, tab in enumerate(tables):
            base = CYCLES[cls][i]
            if isinstance(base, str):
                base = regs + (1 if base.startswith("1+") else 0)
            elif tab == "M4 table" and cls in ("load (LDR, LDRB, LDRH...)", "store (STR, STRB, STRH)", "VLDR / VSTR") and prev_mem:
                base = 1  # pipelined after the previous load or store
            cyc[tab][cls] += c * base

    total = sum(n.values())
    render = render or total
    print(f"{args.elf}: {render / paths:.0f} render instructions per path ({render:.0f} over {paths:.0f} paths); "
          f"the mix below is the whole run's, {total} instructions{f', {unknown} not in the disassembly' if unknown else ''}")
    print()
    print(f"| class | per path | share | cycles each: {' / '.join(tables)} | cycles per path: {' / '.join(tables)} |")
    print("| ----- | -------: | ----: | ---: | ---: |")
    for cls in CYCLES:
        if not n[cls]:
            continue
        each = " / ".join(str(CYCLES[cls][i]).replace("P", str(P[t])) for i, t in enumerate(tables))
        per = " / ".join(f"{cyc[t][cls] / paths:.0f}" for t in tables)
        print(f"| {cls} | {n[cls] / paths:.1f} | {100 * n[cls] / total:.1f} % | {each} | {per} |")
    print()
    # the mix's CPI applied to the render's instructions
    cpi = {t: sum(cyc[t].values()) / total for t in tables}
    for t in tables:
        c = cpi[t] * render
        frame = args.frame_paths * c / paths / (args.mhz * 1e6) / args.speedup
        print(f"{t} (P = {P[t]}): CPI {cpi[t]:.3f}, {c / paths:.0f} cycles per path; frame of "
              f"{args.frame_paths:.0f} paths at {args.mhz:g} MHz / {args.speedup:g}: {frame:.1f} s")
    ipc1 = args.frame_paths * render / paths / (args.mhz * 1e6) / args.speedup
    print(f"at 1 instruction per cycle: {ipc1:.1f} s")

    # footprint: the hottest instructions first (and code-region data reads)
    print()
    code = [(c, insns[a][0], {(a + k) >> 3 for k in range(insns[a][0])}) for a, c in counts.items() if a in insns]
    reads = [(c, 8, {a >> 3}) for a, c in data.items()]
    print("| executed instructions covered | code bytes | 8-byte lines | KiB of lines |")
    print("| ----------------------------: | ---------: | -----------: | -----------: |")
    for frac, nbytes, nlines, _ in footprint(code, (0.9, 0.99, 0.999, 1.0)):
        print(f"| {100 * frac:g} % | {nbytes} | {nlines} | {nlines * 8 / 1024:.1f} |")
    _, _, nlines, beyond = footprint(code + reads, (1.0,))[0]
    nreads = sum(c for c, _, _ in reads)
    print(f"with the code-region data reads ({nreads / paths:.1f} per path): {nlines * 8 / 1024:.1f} KiB of lines; "
          f"fetches and reads beyond the hottest 16 KiB of lines: {beyond / paths:.2f} per path "
          f"({100 * beyond / (total + nreads):.4f} %)")
    try:
        sim = open(f"{args.out}/cache.txt").read().split()
        fetches, fmiss, reads, rmiss = (int(sim[i]) for i in (1, 3, 5, 7))
        print(f"XIP cache model (tools/qemu-profile, one core): {fetches} line fetches, {fmiss} misses; "
              f"{reads} code-region reads, {rmiss} misses: {(fmiss + rmiss) / paths:.2f} misses per path")
        beyond = fmiss + rmiss
    except FileNotFoundError:
        pass
    if args.miss:
        for t in tables:
            c = cpi[t] * render + args.miss * beyond * render / total
            frame = args.frame_paths * c / paths / (args.mhz * 1e6) / args.speedup
            print(f"{t} with {args.miss:g} cycles per miss: {c / paths:.0f} cycles per path, {frame:.1f} s")


def footprint(items, fracs):
    """[(fraction, bytes, lines, accesses beyond 16 KiB of lines)] of items
    (count, bytes, lines), hottest first"""
    items = sorted(items, key=lambda x: -x[0])
    weight = sum(c for c, _, _ in items)
    lines, nbytes, acc, k, in16 = set(), 0, 0, 0, None
    rows = []
    for frac in fracs:
        while k < len(items) and (acc < frac * weight or frac == 1.0):
            c, size, ls = items[k]
            lines |= ls
            if in16 is None and len(lines) * 8 > 16384:
                in16 = acc
            acc += c
            nbytes += size
            k += 1
        rows.append((frac, nbytes, len(lines), weight - in16 if in16 is not None else 0))
    return rows


if __name__ == "__main__":
    main()
