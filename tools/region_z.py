#!/usr/bin/env python3
"""Row and 8x8-block z-scores of the difference of two images, each with its
per-pixel standard-error map: what host-tests/tests/bias_blocks.rs computes,
for any pair (two references, or micropt's pooled renders against one).

    python3 tools/region_z.py A.pfm A.se.pfm B.pfm B.se.pfm \
        [--skip-rows 4 5] [--skip-rect X0 X1 Y0 Y1] [--top 8]

    # the two references of many, the horizon row left out
    python3 tools/region_z.py host-tests/data/many.pfm host-tests/data/many.se.pfm \
        host-tests/data/many.cycles.pfm host-tests/data/many.cycles.se.pfm --skip-rows 4
    # micropt's pooled renders: MICROPT_BIAS_DUMP=DIR cargo test ... bias_blocks
    # writes DIR/NAME.SEEDSxSPP.mean.pfm and .se.pfm

A group's z is the mean over its pixels of A - B over the square root of
the sum of both squared errors over the pixel count squared; pixels left out
(--skip-rows, --skip-rect: inclusive pixel ranges) add nothing to either,
groups without noise are skipped (bias_blocks.rs compares those exactly).
Prints, per channel, the largest |z| of rows and of blocks, chi^2 per
degree of freedom, and the --top groups by |z| with their relative
difference. Needs numpy.
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), 'mitsuba'))
from common import read_pfm  # noqa: E402 (float64, rows top to bottom)


def groups(a, sa, b, sb, keep, key):
    """(key, z per channel, relative difference per channel) per group."""
    h, w, _ = a.shape
    keys = np.array([[key(x, y) for x in range(w)] for y in range(h)])
    out = []
    for k in np.unique(keys):
        whole = keys == k
        m = whole & keep
        if not m.any():
            continue
        n = whole.sum()
        d = (a[m] - b[m]).sum(0) / n
        v = (sa[m] ** 2 + sb[m] ** 2).sum(0) / n**2
        if (v == 0).any():
            continue
        out.append((int(k), d / np.sqrt(v), d / (b[m].sum(0) / n)))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("a_se")
    ap.add_argument("b")
    ap.add_argument("b_se")
    ap.add_argument("--skip-rows", type=int, nargs="*", default=[])
    ap.add_argument("--skip-rect", type=int, nargs=4, action="append", default=[])
    ap.add_argument("--top", type=int, default=8)
    a = ap.parse_args()
    A, SA, B, SB = (read_pfm(p) for p in (a.a, a.a_se, a.b, a.b_se))
    h, w, _ = A.shape
    keep = np.ones((h, w), bool)
    keep[a.skip_rows, :] = False
    for x0, x1, y0, y1 in a.skip_rect:
        keep[y0 : y1 + 1, x0 : x1 + 1] = False
    bw = (w + 7) // 8
    for name, key, show in [
        ("rows", lambda x, y: y, lambda k: f"row {k}"),
        ("blocks", lambda x, y: (y // 8) * bw + x // 8, lambda k: f"x {k % bw * 8}-{k % bw * 8 + 7}, y {k // bw * 8}-{k // bw * 8 + 7}"),
    ]:
        res = groups(A, SA, B, SB, keep, key)
        z = np.array([r[1] for r in res])
        print(f"{name}: max |z| {np.abs(z).max():.2f}, chi2/dof {np.mean(z**2):.2f} ({z.size} values)")
        for k, zz, rel in sorted(res, key=lambda r: -np.abs(r[1]).max())[: a.top]:
            print(f"  {show(k)}: z {' '.join(f'{v:+.2f}' for v in zz)}, difference {' '.join(f'{100 * v:+.3f}' for v in rel)} %")


if __name__ == "__main__":
    main()
