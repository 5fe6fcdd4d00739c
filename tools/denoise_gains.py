#!/usr/bin/env python3
"""The denoiser's gains over seeds: relMSE and MSE of raw and denoised images.

usage: python3 tools/denoise_gains.py SPP SEEDS [SCENE ...] [-- render flags...]

For each scene (default: every scene with a reference in host-tests/data,
(its scene in scenes/, or beside it in host-tests/data for a test scene)
and the denoiser's own test scenes, host-tests/data/denoise/NAME.scene,
named denoise/NAME) and each seed S in 0..SEEDS: renders SCENE with `micropt render
--uniform --spp SPP --seed S` at the reference's size, once raw and once
with `--denoise` (the same samples), and prints the means over seeds of
relMSE = mean((x - r)^2 / (r^2 + 0.01)) and MSE = mean((x - r)^2) against
host-tests/data/SCENE.pfm, the gains raw / denoised (of the means), and the
worst seed's denoised / raw MSE. Env MICROPT: the binary (default
target/release/micropt).
"""
import os, subprocess, sys, tempfile
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), 'mitsuba'))
from common import read_pfm  # noqa: E402 (float64, rows top to bottom)


def main():
    args = sys.argv[1:]
    extra = []
    if '--' in args:
        i = args.index('--')
        args, extra = args[:i], args[i + 1:]
    spp, seeds, scenes = int(args[0]), int(args[1]), args[2:]
    if not scenes:
        scenes = sorted(f[:-4] for f in os.listdir('host-tests/data') if f.endswith('.pfm') and '.' not in f[:-4])
        scenes += sorted('denoise/' + f[:-6] for f in os.listdir('host-tests/data/denoise') if f.endswith('.scene'))
    exe = os.environ.get('MICROPT', 'target/release/micropt')
    print(f'{"scene":<18} {"relMSE raw":>10} {"denoised":>10} {"gain":>6} {"MSE raw":>10} {"denoised":>10} {"gain":>6} {"worst seed":>10}')
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            ref = read_pfm(f'host-tests/data/{scene}.pfm')
            # the denoiser's own test scenes sit beside their references
            # a test scene beside its reference (host-tests/data), else a shipped one
            own = f'host-tests/data/{scene}.scene'
            path = own if os.path.exists(own) else f'scenes/{scene}.scene'
            h, w, _ = ref.shape
            rel = {False: [], True: []}
            mse = {False: [], True: []}
            for s in range(seeds):
                for dn in (False, True):
                    out = os.path.join(tmp, f'{s}{dn}.pfm')
                    cmd = [exe, 'render', path, '--spp', str(spp), '--uniform', '--seed', str(s),
                           '--size', f'{w}x{h}', '-o', out] + (['--denoise'] if dn else []) + extra
                    subprocess.run(cmd, capture_output=True, check=True)
                    x = read_pfm(out)
                    rel[dn].append((((x - ref) ** 2) / (ref ** 2 + 0.01)).mean())
                    mse[dn].append(((x - ref) ** 2).mean())
            rr, rd = np.mean(rel[False]), np.mean(rel[True])
            mr, md = np.mean(mse[False]), np.mean(mse[True])
            worst = max(d / r for d, r in zip(mse[True], mse[False]))
            print(f'{scene:<18} {rr:10.3e} {rd:10.3e} {rr / rd:5.2f}x {mr:10.3e} {md:10.3e} {mr / md:5.2f}x {worst:10.3f}', flush=True)

if __name__ == '__main__':
    main()
