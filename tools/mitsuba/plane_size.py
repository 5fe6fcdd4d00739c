#!/usr/bin/env python3
"""Does the size of the rectangles that stand in for infinite planes matter?

Renders a scene with the same seed (the same random numbers) for several
outer half-sizes (PLANE_FAR) and core half-sizes (PLANE_CORE) and prints the
difference of each image from the default one: the mean difference per
channel (to compare with the reference's standard error of the image mean)
and the RMS and largest per-pixel difference.

    PYTHONPATH=tools/mitsuba taskset -c 0 /work/mitsuba-venv/bin/python \
        tools/mitsuba/plane_size.py scenes/dof.scene --spp 64
"""

import argparse
import json

import numpy as np

from common import render
from scene_to_mitsuba import PLANE_CORE, PLANE_FAR, load, mitsuba_dict, parse_scene


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--seed", type=int, default=5)
    ap.add_argument("--far", default="1e3,1e4,1e7")
    ap.add_argument("--core", default="2,32")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    dr.set_thread_count(1)
    with open(a.scene) as f:
        scene = parse_scene(f.read())

    def image(far, core):
        d = mitsuba_dict(mi, scene, spp=a.spp, plane_far=far, plane_core=core)
        return render(mi, load(mi, d), a.spp, a.seed)[0]

    base = image(PLANE_FAR, PLANE_CORE)
    variants = [(float(f), PLANE_CORE) for f in a.far.split(",")] + [(PLANE_FAR, float(c)) for c in a.core.split(",")]
    for far, core in variants:
        diff = image(far, core) - base
        print(json.dumps({
            "scene": a.scene, "spp": a.spp, "plane_far": far, "plane_core": core,
            "mean_diff": diff.mean(axis=(0, 1)).tolist(),
            "rms_diff": float(np.sqrt(np.mean(diff ** 2))),
            "max_abs_diff": float(np.abs(diff).max()),
            "pixels_changed": int(np.any(diff != 0, axis=2).sum()),
        }))


if __name__ == "__main__":
    main()
