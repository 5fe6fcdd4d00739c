#!/usr/bin/env python3
"""Efficiency of micropt against Mitsuba 3 on the same scene, one thread each.

Converts a micropt scene file (format v1, docs/scene-format.md) into a Mitsuba 3
scene dict with the conventions of the references in host-tests/data/
(docs/bench.md, "Mitsuba 3"): integrator
`path` with max_depth -1, box reconstruction filter, two-sided diffuse, mirror
= conductor of tint R, glass = dielectric with ext_ior 1.0, emitters = spheres
with an `area` emitter and a black BSDF, planes = rectangles 1000x the size of
the scene. Then it renders the scene with Mitsuba (variant scalar_rgb) and with
micropt (`micropt render --threads 1 --uniform`: unbiased, every pixel the
same spp) at the same spp, several seeds each,
measures seconds and MSE against the reference PFM (its own noise,
rms_standard_error^2 from the .json, subtracted), and prints and writes the
efficiency 1 / (MSE x seconds) of each and their ratio.

Run it pinned to one core so that neither renderer can use more:

    pip install mitsuba numpy
    cargo build --release -p micropt-host
    taskset -c 0 python3 tools/mitsuba_cornell.py --out docs/bench/mitsuba

Not run by CI (it needs Mitsuba, ~30 MB, and minutes of CPU).
"""

import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def parse_scene(text):
    """The statements of a scene file as a dict (the subset of v1 it needs)."""
    scene = {"materials": {}, "spheres": [], "planes": [], "background": (0.0, 0.0, 0.0)}
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].split()
        if not line:
            continue
        kw, args = line[0], line[1:]
        num = lambda xs: [float(x) for x in xs]  # noqa: E731
        if kw == "camera":
            v = num(args)
            scene["camera"] = {"eye": v[0:3], "target": v[3:6], "up": v[6:9], "vfov": v[9]}
        elif kw == "resolution":
            scene["resolution"] = (int(args[0]), int(args[1]))
        elif kw == "background":
            scene["background"] = tuple(num(args))
        elif kw == "material":
            name, kind = args[0], args[1]
            scene["materials"][name] = (kind, num(args[2:]))
        elif kw == "sphere":
            v = num(args[:4])
            scene["spheres"].append((v[0:3], v[3], args[4]))
        elif kw == "plane":
            v = num(args[:6])
            scene["planes"].append((v[0:3], v[3:6], args[6]))
        else:
            raise SystemExit(f"line {lineno}: unknown statement {kw!r}")
    return scene


def bsdf_dict(kind, v):
    rgb = lambda c: {"type": "rgb", "value": list(c)}  # noqa: E731
    if kind == "diffuse":
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": rgb(v)}}
    if kind == "mirror":
        return {"type": "conductor", "material": "none", "specular_reflectance": rgb(v)}
    if kind == "glass":
        return {"type": "dielectric", "int_ior": v[0], "ext_ior": 1.0}
    if kind == "light":
        return {"type": "diffuse", "reflectance": rgb((0.0, 0.0, 0.0))}
    raise SystemExit(f"unknown material kind {kind!r}")


def mitsuba_dict(mi, scene, spp_sampler="independent"):
    T = mi.ScalarTransform4f
    cam = scene["camera"]
    w, h = scene["resolution"]
    # the size of the scene: spread of the objects and the camera
    pts = [cam["eye"]] + [c for c, _, _ in scene["spheres"]] + [p for p, _, _ in scene["planes"]]
    extent = max(1.0, max(max(abs(x) for x in p) for p in pts))
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sensor": {
            "type": "perspective",
            "fov": cam["vfov"],
            "fov_axis": "y",
            "to_world": T().look_at(origin=cam["eye"], target=cam["target"], up=cam["up"]),
            "film": {
                "type": "hdrfilm",
                "width": w,
                "height": h,
                "pixel_format": "rgb",
                "rfilter": {"type": "box"},
            },
            "sampler": {"type": spp_sampler, "sample_count": 1},
        },
    }
    bg = scene["background"]
    if max(bg) > 0.0:
        d["sky"] = {"type": "constant", "radiance": {"type": "rgb", "value": list(bg)}}
    for i, (c, r, m) in enumerate(scene["spheres"]):
        kind, v = scene["materials"][m]
        s = {"type": "sphere", "center": c, "radius": r, "bsdf": bsdf_dict(kind, v)}
        if kind == "light":
            s["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": list(v)}}
        d[f"sphere{i}"] = s
    for i, (p, n, m) in enumerate(scene["planes"]):
        kind, v = scene["materials"][m]
        n = np.asarray(n, dtype=float)
        n = n / np.linalg.norm(n)
        helper = np.array([0.0, 1.0, 0.0]) if abs(n[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
        size = 1000.0 * extent
        to_world = T().look_at(origin=list(p), target=list(np.asarray(p) + n), up=list(helper)) @ T().scale(
            [size, size, 1.0]
        )
        d[f"plane{i}"] = {"type": "rectangle", "to_world": to_world, "bsdf": bsdf_dict(kind, v)}
    return d


def read_pfm(path):
    with open(path, "rb") as f:
        data = f.read()
    parts = re.match(rb"PF\s+(\d+)\s+(\d+)\s+(\S+)\s", data)
    if not parts:
        raise SystemExit(f"{path}: not a colour PFM")
    w, h, scale = int(parts.group(1)), int(parts.group(2)), float(parts.group(3))
    px = np.frombuffer(data[parts.end():], dtype="<f4" if scale < 0 else ">f4", count=w * h * 3)
    return px.reshape(h, w, 3)[::-1].astype(np.float64)  # rows top to bottom


def mse(img, ref):
    return float(np.mean((img - ref) ** 2))


def run_mitsuba(mi, scene_dict, spp, seed):
    scene = mi.load_dict(scene_dict)
    t0, c0 = time.perf_counter(), time.process_time()
    img = mi.render(scene, spp=spp, seed=seed)
    arr = np.array(img, dtype=np.float64)
    t1, c1 = time.perf_counter(), time.process_time()
    return arr[:, :, :3], t1 - t0, c1 - c0


def run_micropt(binary, scene_path, spp, seed, tmp):
    out = os.path.join(tmp, f"micropt-{spp}-{seed}.pfm")
    r = subprocess.run(
        # --uniform: the unbiased estimator (the CLI's default allocation is
        # adaptive, which trades a measured bias for lower error)
        [binary, "render", scene_path, "--spp", str(spp), "--seed", str(seed), "--threads", "1", "--uniform",
         "-o", out, "--json"],
        check=True,
        capture_output=True,
        text=True,
    )
    info = json.loads(r.stdout.strip().splitlines()[-1])
    return read_pfm(out), info["seconds"], info


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default=os.path.join(ROOT, "scenes", "cornell.scene"))
    ap.add_argument("--reference", default=None, help="PFM [default: host-tests/data/STEM.pfm]")
    ap.add_argument("--spp", default="4,16,64,256", help="comma-separated sample counts")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--micropt", default=os.path.join(ROOT, "target", "release", "micropt"))
    ap.add_argument("--out", default=None, help="directory for STEM[-SAMPLER].json and .md")
    ap.add_argument(
        "--sampler",
        default="independent",
        help="Mitsuba sampler: independent (its default), stratified, multijitter, ldsampler",
    )
    a = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    # one worker thread (taskset -c 0 pins the process to one core as well)
    dr.set_thread_count(1)

    stem = os.path.splitext(os.path.basename(a.scene))[0]
    ref_path = a.reference or os.path.join(ROOT, "host-tests", "data", stem + ".pfm")
    ref = read_pfm(ref_path)
    ref_json = os.path.splitext(ref_path)[0] + ".json"
    noise = 0.0
    if os.path.exists(ref_json):
        with open(ref_json) as f:
            noise = json.load(f).get("rms_standard_error", 0.0) ** 2
    with open(a.scene) as f:
        scene = parse_scene(f.read())
    scene.setdefault("resolution", (ref.shape[1], ref.shape[0]))
    d = mitsuba_dict(mi, scene, a.sampler)
    affinity = sorted(os.sched_getaffinity(0))
    print(f"# {stem}: reference {ref_path} (noise MSE {noise:.3e}); CPU affinity {affinity}", file=sys.stderr)
    if len(affinity) != 1:
        print("# warning: not pinned to one core; run under `taskset -c 0`", file=sys.stderr)

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for spp in [int(s) for s in a.spp.split(",")]:
            for renderer in ("mitsuba", "micropt"):
                ms, secs, cpus = [], [], []
                for k in range(a.seeds):
                    seed = 1000 * spp + k + 1
                    if renderer == "mitsuba":
                        img, s, c = run_mitsuba(mi, d, spp, seed)
                    else:
                        img, s, info = run_micropt(a.micropt, a.scene, spp, seed, tmp)
                        c = s
                    ms.append(mse(img, ref))
                    secs.append(s)
                    cpus.append(c)
                m = float(np.mean(ms)) - noise
                s = float(np.median(secs))
                row = {
                    "renderer": renderer,
                    "spp": spp,
                    "seeds": a.seeds,
                    "seconds_median": s,
                    "cpu_seconds_median": float(np.median(cpus)),
                    "mse_mean": float(np.mean(ms)),
                    "mse_corrected": m,
                    "mean_rgb": [float(x) for x in img.reshape(-1, 3).mean(axis=0)],
                    "efficiency": (1.0 / (m * s)) if m > 0 else None,
                }
                rows.append(row)
                print(
                    f"{renderer:8s} spp {spp:5d}  {s:9.4f} s  MSE {m:.4e}  eff {row['efficiency']}",
                    file=sys.stderr,
                )
    ratios = []
    for spp in sorted({r["spp"] for r in rows}):
        mt = next(r for r in rows if r["renderer"] == "mitsuba" and r["spp"] == spp)
        mp = next(r for r in rows if r["renderer"] == "micropt" and r["spp"] == spp)
        ratio = mp["efficiency"] / mt["efficiency"] if mp["efficiency"] and mt["efficiency"] else None
        ratios.append(
            {
                "spp": spp,
                "time_ratio_mitsuba_over_micropt": mt["seconds_median"] / mp["seconds_median"],
                "mse_ratio_mitsuba_over_micropt": mt["mse_corrected"] / mp["mse_corrected"],
                "efficiency_ratio_micropt_over_mitsuba": ratio,
            }
        )
    result = {
        "scene": stem,
        "mitsuba": mi.__version__,
        "variant": "scalar_rgb",
        "sampler": a.sampler,
        "threads": "1 each (dr.set_thread_count(1), micropt --threads 1)",
        "affinity": affinity,
        "reference_noise_mse": noise,
        "rows": rows,
        "ratios": ratios,
    }
    md = [
        f"### micropt against Mitsuba {mi.__version__} (scalar_rgb, path, {a.sampler} sampler) on {stem}, "
        "one thread each\n",
        "| spp | Mitsuba s | micropt s | Mitsuba MSE | micropt MSE | time ratio | MSE ratio | efficiency ratio micropt/Mitsuba |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for q in ratios:
        mt = next(r for r in rows if r["renderer"] == "mitsuba" and r["spp"] == q["spp"])
        mp = next(r for r in rows if r["renderer"] == "micropt" and r["spp"] == q["spp"])
        eff = q["efficiency_ratio_micropt_over_mitsuba"]
        eff_text = f"{eff:.1f}x" if eff else "n/a"
        md.append(
            f"| {q['spp']} | {mt['seconds_median']:.3f} | {mp['seconds_median']:.3f} | "
            f"{mt['mse_corrected']:.3e} | {mp['mse_corrected']:.3e} | "
            f"{q['time_ratio_mitsuba_over_micropt']:.1f}x | {q['mse_ratio_mitsuba_over_micropt']:.2f}x | "
            f"{eff_text} |"
        )
    md.append(
        f"\nMSE is the mean over {a.seeds} seeds less the reference's own noise ({noise:.2e}); "
        "seconds are medians of the render call alone (Mitsuba: `mi.render`, scene loading excluded; "
        "micropt: the render, parsing and file output excluded)."
    )
    text = "\n".join(md) + "\n"
    print(text)
    if a.out:
        os.makedirs(a.out, exist_ok=True)
        name = stem if a.sampler == "independent" else f"{stem}-{a.sampler}"
        with open(os.path.join(a.out, f"{name}.json"), "w") as f:
            json.dump(result, f, indent=1)
        with open(os.path.join(a.out, f"{name}.md"), "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
