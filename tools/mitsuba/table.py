#!/usr/bin/env python3
"""Markdown tables of efficiency.csv: per scene every (sampler, spp) row, then
the best efficiency of each sampler.

    python3 tools/mitsuba/table.py docs/mitsuba/efficiency.csv
"""

import csv
import sys


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    scenes = []
    for r in rows:
        if r["scene"] not in scenes:
            scenes.append(r["scene"])
    for s in scenes:
        rs = [r for r in rows if r["scene"] == s]
        print(f"#### {s}\n")
        print("| sampler | spp | seeds | CPU s | wall s | MSE | MSE x spp | efficiency 1/(MSE s) |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|")
        for r in rs:
            eff = f"{float(r['efficiency']):.1f}" if r["efficiency"] else "n/a"
            print(f"| {r['sampler']} | {r['spp']} | {r['seeds']} | {float(r['cpu_seconds']):.3f} | "
                  f"{float(r['wall_seconds']):.3f} | {float(r['mse']):.3e} | {float(r['mse_x_spp']):.3f} | {eff} |")
        print()
        print("| sampler | best efficiency | at spp | efficiency at the largest spp |")
        print("|---|---:|---:|---:|")
        best = {}
        for r in rs:
            e = float(r["efficiency"]) if r["efficiency"] else 0.0
            b = best.setdefault(r["sampler"], [0.0, 0, 0.0, 0])
            if e > b[0]:
                b[0], b[1] = e, int(r["spp"])
            if int(r["spp"]) >= b[3]:
                b[2], b[3] = e, int(r["spp"])
        for name, (e, spp, elast, spplast) in best.items():
            print(f"| {name} | {e:.1f} | {spp} | {elast:.1f} (spp {spplast}) |")
        print()


if __name__ == "__main__":
    main()
