#!/usr/bin/env python3
"""Which f32 routines a board ELF links, and where they come from, checked
against the board's choice (for .ci/boards.sh).

    floats.py ELF fpu     --arch arm|riscv [--rom LO-HI]
    floats.py ELF micropt --arch arm|riscv [--rom LO-HI]

Reads the symbol table (`readelf -sW`) and the line table
(`readelf --debug-dump=decodedline`; the board crates build with `debug = 1`).

The arithmetic routines (add, subtract, multiply, divide, compare, int to
float: the ones whose rounding and subnormals decide an image's bits):
  fpu      none may be linked: the FPU does f32 arithmetic.
  micropt  each one linked is micropt's (`examples/board/softfloat.rs`
           over `src/math/soft.rs`, checked bit for bit against the host's
           IEEE arithmetic), by the line table at its address; and at least
           add and multiply are linked (else the check would be vacuous).
Every other float routine (f32 to integer, 64-bit integer to f32: exact or
correctly rounded by definition) may come from compiler-builtins. No float
routine may bind to a ROM address (--rom, or an absolute symbol), and no f64
routine may be linked at all.
"""

import re
import subprocess
import sys

ARITH = {
    "arm": [
        "__aeabi_fadd", "__aeabi_fsub", "__aeabi_frsub", "__aeabi_fmul", "__aeabi_fdiv",
        "__aeabi_fcmpeq", "__aeabi_fcmplt", "__aeabi_fcmple", "__aeabi_fcmpge",
        "__aeabi_fcmpgt", "__aeabi_fcmpun", "__aeabi_ui2f", "__aeabi_i2f",
    ],
    "riscv": [],
}
# the libgcc names, on both (compiler-builtins defines them on Arm too)
GNU = [
    "__addsf3", "__subsf3", "__mulsf3", "__divsf3", "__eqsf2", "__nesf2", "__ltsf2",
    "__lesf2", "__gtsf2", "__gesf2", "__unordsf2", "__floatunsisf", "__floatsisf",
    "__cmpsf2",
]
REQUIRED = {"arm": ["__aeabi_fadd", "__aeabi_fmul"], "riscv": ["__addsf3", "__mulsf3"]}
# any other f32 routine of the runtimes (conversions, powers, negation)
OTHER_F32 = re.compile(r"^__(aeabi_(f2|[a-z]*2f$)|fix(uns)?sf|float(un)?[dt]isf|powisf|negsf|.*sf[23]$)")
F64 = re.compile(r"^__(aeabi_d|aeabi_[a-z0-9]*2d$|aeabi_d2|.*df[23]$|fix(uns)?df|float(un)?[sdt]idf|extendsfdf|truncdfsf|powidf|negdf)")
MICROPT_FILES = ("board/softfloat.rs", "src/math/soft.rs")


def symbols(elf):
    """name -> (address, size, section index) of the defined and absolute
    symbols (FUNC, NOTYPE or OBJECT)."""
    out = subprocess.run(["readelf", "-sW", elf], check=True, capture_output=True, text=True).stdout
    syms = {}
    for line in out.splitlines():
        f = line.split()
        if len(f) != 8 or not f[0][:-1].isdigit() or f[6] == "UND":
            continue
        syms[f[7]] = (int(f[1], 16), int(f[2], 0), f[6])
    return syms


def line_files(elf):
    """(address, file) of every row of the line table, sorted."""
    out = subprocess.run(
        ["readelf", "--debug-dump=decodedline", elf], check=True, capture_output=True, text=True
    ).stdout
    rows, path = [], None
    for line in out.splitlines():
        if line.endswith(":") and " " not in line.strip():
            path = line[:-1]
            continue
        f = line.split()
        if path and len(f) >= 3 and f[2].startswith("0x") and f[1] != "-":
            rows.append((int(f[2], 16), path))
    rows.sort()
    return rows


def files_in(rows, lo, hi):
    return {p for a, p in rows if lo <= a < hi}


def main(argv):
    if len(argv) < 4 or argv[1] not in ("fpu", "micropt") or argv[2] != "--arch":
        sys.exit(__doc__)
    elf, policy, arch = argv[0], argv[1], argv[3]
    rom = None
    if len(argv) == 6 and argv[4] == "--rom":
        lo, hi = (int(x, 0) for x in argv[5].split("-"))
        rom = (lo, hi)
    syms = symbols(elf)
    rows = line_files(elf)
    arith = ARITH[arch] + GNU
    errors = []
    report = []
    for name in sorted(syms):
        is_arith = name in arith
        is_f64 = bool(F64.match(name))
        if not (is_arith or is_f64 or OTHER_F32.match(name)):
            continue
        addr, size, shndx = syms[name]
        code = addr & ~1  # Thumb bit
        where = "ROM" if shndx == "ABS" or (rom and rom[0] <= code < rom[1]) else "flash"
        files = files_in(rows, code, code + max(size, 1)) if rows else set()
        start = {p for a, p in rows if a == code}
        if any(p.endswith(MICROPT_FILES) for p in start):
            origin = "micropt"
        elif any("compiler-builtins" in p for p in files | start):
            origin = "compiler-builtins"
        elif where == "ROM":
            origin = "mask ROM"
        else:
            origin = "?"
        report.append(f"  {name:<16} {addr:#010x} {size:5d} bytes  {where:<5}  {origin}")
        if where == "ROM":
            errors.append(f"{name} binds to the ROM address {addr:#010x}")
        if is_f64:
            errors.append(f"{name}: an f64 routine is linked")
        if is_arith and policy == "fpu":
            errors.append(f"{name}: soft-float arithmetic linked on a board whose FPU does it")
        if is_arith and policy == "micropt" and origin != "micropt":
            errors.append(f"{name} is {origin}'s, not micropt's (lines from {sorted(files | start)[:3]})")
    if policy == "micropt":
        for name in REQUIRED[arch]:
            if name not in syms:
                errors.append(f"{name} is not linked: the f32 arithmetic is not micropt's")
    print("\n".join(report) if report else "  (no float routines linked)")
    if errors:
        sys.exit("error: " + "\nerror: ".join(errors))
    print(f"  float routines as chosen: {policy}")


if __name__ == "__main__":
    main(sys.argv[1:])
