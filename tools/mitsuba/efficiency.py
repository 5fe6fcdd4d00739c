#!/usr/bin/env python3
"""Efficiency 1 / (MSE x seconds) of Mitsuba 3's `path` integrator (variant
scalar_rgb, one thread) on micropt scenes, for each of Mitsuba's samplers.

For each scene, sampler and sample count of the ladder, renders several seeds,
and measures the CPU seconds of the `mi.render` call alone (scene loading and
conversion excluded; `time.process_time`, all threads of the process) and its
wall seconds, and the MSE against the scene's reference PFM (mean over pixels
and channels of the squared difference). The reported MSE is the mean over the
seeds minus the reference's own noise (rms_standard_error^2 from its .json),
and efficiency = 1 / (MSE x mean CPU seconds). A sampler stops climbing the
ladder after a render takes more than --max-seconds CPU seconds.

Run it on one core, with one Mitsuba worker thread (set here with
`dr.set_thread_count(1)`):

    PYTHONPATH=tools/mitsuba taskset -c 1 nice -n 5 /work/mitsuba-venv/bin/python \
        tools/mitsuba/efficiency.py scenes/many.scene --ref-dir REFDIR --csv docs/mitsuba/efficiency.csv

Each render appends one row to --runs (raw figures); each (scene, sampler,
spp) one row to --csv (the aggregate).
"""

import argparse
import csv
import json
import os
import sys

import numpy as np

from common import reference, render
from scene_to_mitsuba import load, mitsuba_dict, parse_scene

SAMPLERS = ["independent", "stratified", "multijitter", "orthogonal", "ldsampler"]

CSV_FIELDS = [
    "scene",
    "sampler",
    "spp",
    "seeds",
    "cpu_seconds",
    "wall_seconds",
    "mse",
    "mse_raw",
    "mse_seed_sd",
    "mse_x_spp",
    "efficiency",
    "ref_noise_mse",
    "rr_depth",
    "threads_busy",
]


def busy_threads():
    """Threads of this process that have used at least 10 ms of CPU."""
    n = 0
    tick = os.sysconf("SC_CLK_TCK")
    for t in os.listdir("/proc/self/task"):
        with open(f"/proc/self/task/{t}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        if (int(fields[11]) + int(fields[12])) / tick >= 0.01:  # utime + stime
            n += 1
    return n


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="+")
    ap.add_argument("--ref-dir", required=True)
    ap.add_argument("--samplers", default=",".join(SAMPLERS))
    ap.add_argument("--spp", default="16,64,256,1024")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--max-seconds", type=float, default=60.0)
    ap.add_argument("--rr-depth", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--csv", default=None, help="append aggregate rows here")
    ap.add_argument("--runs", default=None, help="append one JSON line per render here")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    dr.set_thread_count(a.threads)
    affinity = sorted(os.sched_getaffinity(0))
    print(f"# mitsuba {mi.__version__}, drjit threads {dr.thread_count()}, CPU affinity {affinity}", file=sys.stderr)
    if len(affinity) != 1:
        print("# warning: not pinned to one core; run under `taskset -c 1`", file=sys.stderr)

    new_csv = a.csv and not os.path.exists(a.csv)
    csv_file = open(a.csv, "a", newline="") if a.csv else None
    writer = csv.DictWriter(csv_file, CSV_FIELDS) if csv_file else None
    if new_csv:
        writer.writeheader()
    for scene_path in a.scenes:
        stem = os.path.splitext(os.path.basename(scene_path))[0]
        ref, _, info = reference(a.ref_dir, stem)
        noise = info["rms_standard_error"] ** 2
        with open(scene_path) as f:
            scene = parse_scene(f.read())
        for sampler in a.samplers.split(","):
            for spp in [int(s) for s in a.spp.split(",")]:
                d = mitsuba_dict(mi, scene, sampler=sampler, spp=spp, rr_depth=a.rr_depth,
                                 resolution=(ref.shape[1], ref.shape[0]))
                sc = load(mi, d)
                # the sample count the sampler really takes (orthogonal rounds up to a prime squared)
                actual = sc.sensors()[0].sampler().sample_count()
                mses, cpus, walls = [], [], []
                for k in range(a.seeds):
                    seed = 1_000_003 * (k + 1) + spp
                    img, wall, cpu = render(mi, sc, actual, seed)
                    mses.append(float(np.mean((img - ref) ** 2)))
                    cpus.append(cpu)
                    walls.append(wall)
                    if a.runs:
                        with open(a.runs, "a") as f:
                            f.write(json.dumps({"scene": stem, "sampler": sampler, "spp": actual, "seed": seed,
                                                "cpu_seconds": cpu, "wall_seconds": wall, "mse_raw": mses[-1],
                                                "mean_rgb": img.mean(axis=(0, 1)).round(6).tolist()}) + "\n")
                mse = float(np.mean(mses)) - noise
                cpu = float(np.mean(cpus))
                row = {
                    "scene": stem,
                    "sampler": sampler,
                    "spp": actual,
                    "seeds": a.seeds,
                    "cpu_seconds": f"{cpu:.4f}",
                    "wall_seconds": f"{np.mean(walls):.4f}",
                    "mse": f"{mse:.5e}",
                    "mse_raw": f"{np.mean(mses):.5e}",
                    "mse_seed_sd": f"{np.std(mses, ddof=1) if a.seeds > 1 else 0.0:.3e}",
                    "mse_x_spp": f"{mse * actual:.4f}",
                    "efficiency": f"{1.0 / (mse * cpu):.4f}" if mse > 0 else "",
                    "ref_noise_mse": f"{noise:.4e}",
                    "rr_depth": a.rr_depth,
                    "threads_busy": busy_threads(),
                }
                print(json.dumps(row), file=sys.stderr)
                if writer:
                    writer.writerow(row)
                    csv_file.flush()
                if max(cpus) > a.max_seconds:
                    break
    if csv_file:
        csv_file.close()


if __name__ == "__main__":
    main()
