#!/usr/bin/env python3
"""Before/after images of the denoiser for docs/denoise.md.

For each scene: `micropt render SCENE --spp 16 --seed 0 --denoise` at the
reference's size, the raw image of the same samples (`--aov-albedo` without
`--denoise` writes it), and the reference from host-tests/data/. Writes
docs/denoise/NAME.png: raw | denoised | reference side by side, tone mapped
as the CLI's PNG (clamp, sRGB), scaled up 3x (nearest), and prints each
image's relMSE and MSE against the reference.

    cargo build --release -p micropt-host
    python3 tools/denoise_crops.py [SCENE ...]   # default: cornell gloss dof many

Needs numpy.
"""

import json
import struct
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
BIN = ROOT / "target" / "release" / "micropt"
DATA = ROOT / "host-tests" / "data"
OUT = ROOT / "docs" / "denoise"
SCALE = 3


def read_pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    return data.reshape(h, w, 3)[::-1].astype(np.float64)


def srgb8(img):
    x = np.clip(img, 0.0, 1.0)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (x * 255 + 0.5).astype(np.uint8)


def write_png(path, rgb):
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(png)


def errors(img, ref):
    d = (img - ref) ** 2
    return float(np.mean(d / (ref**2 + 0.01))), float(np.mean(d))


def main(scenes):
    OUT.mkdir(parents=True, exist_ok=True)
    for name in scenes:
        meta = json.loads((DATA / f"{name}.json").read_text())
        size = f"{meta['width']}x{meta['height']}"
        ref = read_pfm(DATA / f"{name}.pfm")
        with tempfile.TemporaryDirectory() as tmp:
            dn, raw, alb = (Path(tmp) / n for n in ("dn.pfm", "raw.pfm", "albedo.pfm"))
            common = [str(BIN), "render", str(ROOT / "scenes" / f"{name}.scene"),
                      "--spp", "16", "--seed", "0", "--size", size]
            subprocess.run(common + ["--denoise", "-o", str(dn)], check=True)
            subprocess.run(common + ["--aov-albedo", str(alb), "-o", str(raw)], check=True)
            images = [read_pfm(raw), read_pfm(dn), ref]
        (r_rel, r_mse), (d_rel, d_mse) = errors(images[0], ref), errors(images[1], ref)
        print(f"{name} {size} 16 spp seed 0: relMSE {r_rel:.4g} -> {d_rel:.4g}, "
              f"MSE {r_mse:.4g} -> {d_mse:.4g}")
        gap = np.full((ref.shape[0], 2, 3), 255, dtype=np.uint8)
        row = np.concatenate([srgb8(images[0]), gap, srgb8(images[1]), gap, srgb8(ref)], axis=1)
        row = row.repeat(SCALE, axis=0).repeat(SCALE, axis=1)
        write_png(OUT / f"{name}.png", np.ascontiguousarray(row))


if __name__ == "__main__":
    main(sys.argv[1:] or ["cornell", "gloss", "dof", "many"])
