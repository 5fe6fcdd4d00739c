#!/usr/bin/env python3
"""Render a reference with Mitsuba 3 in independent batches: the mean image,
its per-pixel standard error (from the batches' spread) and a JSON record.

    PYTHONPATH=tools/mitsuba /work/mitsuba-venv/bin/python tools/mitsuba/reference.py \\
        scenes/sphere-over-plane.scene --spp 16384 --batches 16 --out host-tests/data/NAME

writes NAME.pfm, NAME.se.pfm and NAME.json (scalar_rgb, path tracer, the
independent sampler, box filter, the scene converted by scene_to_mitsuba.py
as check.py converts it). Batch k renders with seed 7919 * (k + 101), apart
from check.py's seeds.
"""

import argparse
import json
import os
import time

import numpy as np

from common import render, write_pfm
from scene_to_mitsuba import PLANE_CORE, PLANE_FAR, load, mitsuba_dict, parse_scene


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("--spp", type=int, default=16384, help="samples a pixel in each batch")
    ap.add_argument("--batches", type=int, default=16)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rr-depth", type=int, default=5)
    ap.add_argument("--out", required=True, help="path without extension")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    dr.set_thread_count(a.threads)
    with open(a.scene) as f:
        scene = parse_scene(f.read())
    d = mitsuba_dict(mi, scene, spp=a.spp, rr_depth=a.rr_depth, plane_far=PLANE_FAR, plane_core=PLANE_CORE)
    sc = load(mi, d)
    imgs = []
    t0 = time.perf_counter()
    for k in range(a.batches):
        img, _, _ = render(mi, sc, a.spp, 7919 * (k + 101))
        imgs.append(img)
    seconds = time.perf_counter() - t0
    imgs = np.stack(imgs)
    mean = imgs.mean(axis=0)
    se = imgs.std(axis=0, ddof=1) / np.sqrt(a.batches)
    write_pfm(a.out + ".pfm", mean)
    write_pfm(a.out + ".se.pfm", se)
    info = {
        "scene": os.path.basename(a.scene),
        "renderer": f"mitsuba {mi.__version__} scalar_rgb path, independent sampler, box filter, rr_depth {a.rr_depth}",
        "spp": a.spp * a.batches,
        "batches": a.batches,
        "spp_per_batch": a.spp,
        "seconds": round(seconds, 1),
        "width": int(mean.shape[1]),
        "height": int(mean.shape[0]),
        "mean_rgb": mean.mean(axis=(0, 1)).round(6).tolist(),
        "rms_standard_error": float(np.sqrt((se ** 2).mean())),
        "nan_count": int(np.isnan(imgs).sum()),
        "standard_error_map": "NAME.se.pfm: the standard error of each pixel and channel of the mean, "
                              "from the spread of the batches",
        "command": "tools/mitsuba/reference.py " + " ".join(
            [os.path.relpath(a.scene), "--spp", str(a.spp), "--batches", str(a.batches)]),
    }
    with open(a.out + ".json", "w") as f:
        json.dump(info, f, indent=1)
        f.write("\n")
    print(json.dumps(info))


if __name__ == "__main__":
    main()
