#!/usr/bin/env python3
"""Check a conversion: render a micropt scene with Mitsuba (scalar_rgb, path,
independent sampler) at several seeds and compare with the scene's reference
image within the standard errors.

Prints, per channel, the image mean against the reference's mean (z-score
with both standard errors), and per pixel and per 8x8 block the z-scores
(difference / sqrt(se_ref^2 + se_this^2)). se_this of a pixel is the spread of
the seeds' values of that pixel / sqrt(seeds); the reference's per-pixel
standard error is its .se.pfm. If the two images estimate the same thing,
mean z^2 is near 1 and |z| > 4 is rare (a few pixels in 6144 from the heavy
tails of path tracing noise).

    PYTHONPATH=tools/mitsuba taskset -c 1 nice -n 5 /work/mitsuba-venv/bin/python \
        tools/mitsuba/check.py scenes/gloss.scene --ref-dir REFDIR --spp 1024 --seeds 4
"""

import argparse
import json
import os
import sys

import numpy as np

from common import reference, render, write_pfm
from scene_to_mitsuba import PLANE_CORE, PLANE_FAR, load, mitsuba_dict, parse_scene


def block_means(a, b=8):
    h, w = a.shape[:2]
    a = a[: h - h % b, : w - w % b]
    return a.reshape(h // b, b, w // b, b, -1).mean(axis=(1, 3))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--ref-dir", required=True)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--plane-far", type=float, default=PLANE_FAR)
    ap.add_argument("--plane-core", type=float, default=PLANE_CORE)
    ap.add_argument("--rr-depth", type=int, default=5)
    ap.add_argument("--save", default=None, help="write the mean image (PFM) here")
    ap.add_argument("--json", default=None, help="append the result as one JSON line to this file")
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    dr.set_thread_count(a.threads)
    stem = os.path.splitext(os.path.basename(a.scene))[0]
    ref, ref_se, info = reference(a.ref_dir, stem)
    with open(a.scene) as f:
        scene = parse_scene(f.read())
    d = mitsuba_dict(mi, scene, spp=a.spp, rr_depth=a.rr_depth, plane_far=a.plane_far, plane_core=a.plane_core,
                     resolution=(ref.shape[1], ref.shape[0]))
    sc = load(mi, d)
    imgs = []
    cpu = 0.0
    for k in range(a.seeds):
        img, _, c = render(mi, sc, a.spp, 7919 * (k + 1))
        imgs.append(img)
        cpu += c
    imgs = np.stack(imgs)
    mean = imgs.mean(axis=0)
    se = imgs.std(axis=0, ddof=1) / np.sqrt(a.seeds)
    if a.save:
        write_pfm(a.save, mean)
    if ref_se is None:
        # no per-pixel map: the same estimator's per-pixel variance scaled to the reference's spp
        ref_se = se * np.sqrt(a.seeds * a.spp / info["spp"])
    npx = ref.shape[0] * ref.shape[1]
    # image mean per channel: the seeds' spread, and the reference's pixels as independent
    m_this = imgs.mean(axis=(1, 2))  # (seeds, 3)
    se_mean_this = m_this.std(axis=0, ddof=1) / np.sqrt(a.seeds)
    se_mean_ref = np.sqrt((ref_se ** 2).sum(axis=(0, 1))) / npx
    z_mean = (mean.mean(axis=(0, 1)) - ref.mean(axis=(0, 1))) / np.sqrt(se_mean_this ** 2 + se_mean_ref ** 2)
    # pixels without noise in either image (every path sees the same constant
    # sky, say) are compared by their relative difference instead of a z-score
    comb = np.sqrt(ref_se ** 2 + se ** 2)
    quiet = comb <= 1e-6 * np.maximum(np.abs(ref), 1e-3)
    z = ((mean - ref) / np.where(quiet, 1.0, comb))[~quiet]
    quiet_rel = np.abs(mean - ref)[quiet] / np.maximum(np.abs(ref[quiet]), 1e-6)
    # blocks: means of 8x8 pixels, their variance the mean of the pixels' variances / 64
    bvar = (block_means(ref_se ** 2) + block_means(se ** 2)) / 64
    bq = bvar <= 1e-12 * np.maximum(block_means(ref) ** 2, 1e-6)
    bz = np.where(bq, 0.0, (block_means(mean) - block_means(ref)) / np.sqrt(np.where(bq, 1.0, bvar)))
    # the same pixels with this render's standard error predicted from the
    # reference's (same estimator, fewer samples): steadier than 4-8 seeds' spread
    se_pred = ref_se * np.sqrt(info["spp"] / (a.seeds * a.spp))
    zp = ((mean - ref) / np.where(quiet, 1.0, np.sqrt(ref_se ** 2 + se_pred ** 2)))[~quiet]
    bzp_var = (block_means(ref_se ** 2) + block_means(se_pred ** 2)) / 64
    bzp = np.where(bq, 0.0, (block_means(mean) - block_means(ref)) / np.sqrt(np.where(bq, 1.0, bzp_var)))
    # per-sample variance of this render over the reference's, per pixel: near 1
    # when the two use the same Russian roulette (rr_depth) and sampler
    noisy = ~quiet & (ref_se > 0)
    var_ratio = ((se ** 2 * a.seeds * a.spp)[noisy] / (ref_se ** 2 * info["spp"])[noisy])
    res = {
        "scene": stem,
        "spp": a.spp,
        "seeds": a.seeds,
        "rr_depth": a.rr_depth,
        "plane_far": a.plane_far,
        "plane_core": a.plane_core,
        "cpu_seconds": cpu,
        "mean_this": mean.mean(axis=(0, 1)).round(6).tolist(),
        "mean_ref": ref.mean(axis=(0, 1)).round(6).tolist(),
        "mean_rel_diff": ((mean.mean(axis=(0, 1)) / ref.mean(axis=(0, 1))) - 1).round(5).tolist(),
        "z_mean": z_mean.round(2).tolist(),
        "noiseless_pixel_values": int(quiet.sum()),
        "noiseless_max_rel_diff": float(quiet_rel.max()) if quiet_rel.size else 0.0,
        "pixel_mean_z2": float(np.mean(z ** 2)),
        "pixel_median_z2": float(np.median(z ** 2)),
        "pixel_frac_abs_z_gt_3": float(np.mean(np.abs(z) > 3)),
        "pixel_frac_abs_z_gt_4": float(np.mean(np.abs(z) > 4)),
        "block_mean_z2": float(np.mean(bz ** 2)),
        "block_max_abs_z": float(np.abs(bz).max()),
        "blocks": int(bz.size),
        "pred_pixel_mean_z2": float(np.mean(zp ** 2)),
        "pred_pixel_frac_abs_z_gt_4": float(np.mean(np.abs(zp) > 4)),
        "pred_block_mean_z2": float(np.mean(bzp ** 2)),
        "pred_block_max_abs_z": float(np.abs(bzp).max()),
        "var_ratio_median": float(np.median(var_ratio)),
        "var_ratio_mean": float(np.mean(var_ratio)),
        "rms_diff": float(np.sqrt(np.mean((mean - ref) ** 2))),
        "rms_se_this": float(np.sqrt(np.mean(se ** 2))),
        "rms_se_ref": float(np.sqrt(np.mean(ref_se ** 2))),
    }
    # the worst blocks (row, column of the 8x8 block, channel, z)
    flat = np.argsort(-np.abs(bz).ravel())[:3]
    res["worst_blocks"] = [
        [int(i) for i in np.unravel_index(j, bz.shape)] + [round(float(bz.ravel()[j]), 2)] for j in flat
    ]
    print(json.dumps(res))
    if a.json:
        with open(a.json, "a") as f:
            f.write(json.dumps(res) + "\n")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
