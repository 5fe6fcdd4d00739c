#!/usr/bin/env python3
"""Markdown tables of efficiency.csv: per scene every (sampler, spp) row, the
best efficiency of each sampler, and (with runs.jsonl) each sampler's pooled
efficiency over all its renders of at least --min-spp samples.

Pooled: every render gives a per-sample error (MSE_raw - reference noise) x spp
and a cost CPU seconds / spp; the pooled efficiency is 1 / (mean error x mean
cost), its standard error from the spread of the renders' errors. Path-tracing
MSE is heavy-tailed (rare bright paths), so one (sampler, spp) row of three
seeds can be off by a factor of several; the pool is steadier. It assumes
MSE ~ 1/spp over the pooled range (the MSE x spp column shows how well).

    python3 tools/mitsuba/table.py docs/mitsuba/efficiency.csv [docs/mitsuba/runs.jsonl]
"""

import csv
import json
import math
import sys

MIN_SPP = 64


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
        if len(sys.argv) > 2:
            pooled(s, [json.loads(line) for line in open(sys.argv[2])], float(rs[0]["ref_noise_mse"]))


def pooled(scene, runs, noise):
    print(f"| sampler | renders (spp >= {MIN_SPP}) | MSE x spp (± s.e.) | CPU ms per spp | pooled efficiency "
          "1/(MSE x spp x s/spp) (range: ±1 s.e. of the error) |")
    print("|---|---:|---:|---:|---:|")
    for name in dict.fromkeys(r["sampler"] for r in runs if r["scene"] == scene):
        rr = [r for r in runs if r["scene"] == scene and r["sampler"] == name and r["spp"] >= MIN_SPP]
        if not rr:
            continue
        err = [(r["mse_raw"] - noise) * r["spp"] for r in rr]
        cost = sum(r["cpu_seconds"] / r["spp"] for r in rr) / len(rr)
        m = sum(err) / len(err)
        sd = math.sqrt(sum((e - m) ** 2 for e in err) / max(len(err) - 1, 1)) / math.sqrt(len(err))
        eff = 1.0 / (m * cost)
        print(f"| {name} | {len(rr)} | {m:.3f} ± {sd:.3f} | {1000 * cost:.2f} | {eff:.0f} "
              f"({1.0 / ((m + sd) * cost):.0f}-{1.0 / (max(m - sd, 1e-9) * cost):.0f}) |")
    print()


if __name__ == "__main__":
    main()
