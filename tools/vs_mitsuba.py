#!/usr/bin/env python3
"""micropt's efficiency beside Mitsuba 3's, per scene and spp, in CPU seconds.

    python3 tools/vs_mitsuba.py docs/bench/vs-mitsuba/points.csv \
        docs/mitsuba/efficiency.csv docs/mitsuba/runs.jsonl

micropt: the points of `micropt bench` (one row per scene, variant and spp:
CPU seconds the median over the seeds, MSE their mean with the reference's
noise subtracted). Mitsuba: its efficiency.csv rows at the same spp, and its
pooled efficiency per sampler (every render of at least 64 spp, as
tools/mitsuba/table.py computes it). Efficiency = 1 / (MSE x CPU seconds).
The Mitsuba sampler with the best pooled efficiency is its "best". A micropt
MSE below the reference's own noise (rms_standard_error^2) is a difference of
two nearly equal numbers: its efficiency is not shown.
"""

import csv
import json
import sys

MIN_SPP = 64


def pooled(runs, scene, noise):
    out = {}
    for name in dict.fromkeys(r["sampler"] for r in runs if r["scene"] == scene):
        rr = [r for r in runs if r["scene"] == scene and r["sampler"] == name and r["spp"] >= MIN_SPP]
        if rr:
            err = sum((r["mse_raw"] - noise) * r["spp"] for r in rr) / len(rr)
            cost = sum(r["cpu_seconds"] / r["spp"] for r in rr) / len(rr)
            out[name] = 1.0 / (err * cost)
    return out


def main():
    points = list(csv.DictReader(open(sys.argv[1])))
    mitsuba = list(csv.DictReader(open(sys.argv[2])))
    runs = [json.loads(line) for line in open(sys.argv[3])]
    for scene in dict.fromkeys(p["scene"] for p in points):
        ms = [r for r in mitsuba if r["scene"] == scene]
        if not ms:
            continue
        noise = float(ms[0]["ref_noise_mse"])
        pool = pooled(runs, scene, noise)
        default = pool["independent"]
        best_name = max(pool, key=pool.get)
        best = pool[best_name]
        at_spp = {int(r["spp"]): float(r["efficiency"]) for r in ms if r["sampler"] == "independent"}
        print(f"#### {scene}\n")
        print(f"Mitsuba pooled (spp >= {MIN_SPP}): `independent` (default) {default:.0f}, "
              f"best `{best_name}` {best:.0f}.\n")
        print("| micropt variant | spp | CPU s | MSE | mean − reference | efficiency | Mitsuba default at this spp "
              "| × Mitsuba default (pooled) | × Mitsuba best (pooled) |")
        print("|---|--:|--:|--:|--:|--:|--:|--:|--:|")
        for p in points:
            spp = int(p["spp"])
            if p["scene"] != scene or spp < 16:
                continue
            cpu, mse = float(p["cpu_seconds_median"]), float(p["mse_corrected"])
            same = f"{at_spp[spp]:.0f}" if spp in at_spp else ""
            head = f"| `{p['variant']}` | {spp} | {cpu:.3f} | {mse:.2e} | {float(p['mean_diff']):+.1e} |"
            if mse < noise:
                print(f"{head} (MSE below the reference's noise {noise:.2e}) | {same} | | |")
                continue
            eff = 1.0 / (mse * cpu)
            print(f"{head} {eff:.0f} | {same} | {eff / default:.1f}× | {eff / best:.1f}× |")
        print()


if __name__ == "__main__":
    main()
