"""Helpers shared by check.py and efficiency.py: PFM input and output, the
reference of a scene, and one timed Mitsuba render."""

import json
import os
import re
import time

import numpy as np


def read_pfm(path):
    """A colour PFM as an (H, W, 3) float64 array, rows top to bottom."""
    with open(path, "rb") as f:
        data = f.read()
    m = re.match(rb"PF\s+(\d+)\s+(\d+)\s+(\S+)\s", data)
    if not m:
        raise SystemExit(f"{path}: not a colour PFM")
    w, h, scale = int(m.group(1)), int(m.group(2)), float(m.group(3))
    px = np.frombuffer(data[m.end():], dtype="<f4" if scale < 0 else ">f4", count=w * h * 3)
    return px.reshape(h, w, 3)[::-1].astype(np.float64)


def write_pfm(path, img):
    h, w, _ = img.shape
    with open(path, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(img[::-1], dtype="<f4").tobytes())


def reference(ref_dir, stem):
    """(image, per-pixel standard error or None, json) of a reference."""
    img = read_pfm(os.path.join(ref_dir, stem + ".pfm"))
    se_path = os.path.join(ref_dir, stem + ".se.pfm")
    se = read_pfm(se_path) if os.path.exists(se_path) else None
    with open(os.path.join(ref_dir, stem + ".json")) as f:
        info = json.load(f)
    return img, se, info


def render(mi, scene, spp, seed):
    """One render of a loaded scene: (image (H, W, 3), wall seconds, CPU
    seconds of this process). Only the `mi.render` call is timed (scene loading
    and the conversion are excluded); the image's conversion to numpy is inside
    the timing, as it forces the render to finish (a few microseconds here)."""
    t0, c0 = time.perf_counter(), time.process_time()
    img = mi.render(scene, spp=spp, seed=seed)
    arr = np.array(img, dtype=np.float64)
    t1, c1 = time.perf_counter(), time.process_time()
    return arr[:, :, :3], t1 - t0, c1 - c0
