#!/usr/bin/env python3
"""MSE over seeds, run time and efficiency against Mitsuba 3 at equal spp.

usage: python3 tools/seeds_mse.py SCENE "16 64 256" SEEDS [render flags...]

For each spp: renders scenes/SCENE.scene with `micropt render --uniform
--threads 1 --seed S` for S in 0..SEEDS (env MICROPT: the binary, default
target/release/micropt), MSE against host-tests/data/SCENE.pfm minus the
reference's own noise (the mean square of SCENE.se.pfm where present), the
median of the renders' seconds, efficiency 1/(MSE x s), and that over
Mitsuba 3's default sampler at the same spp (docs/mitsuba/efficiency.csv),
and the share of the squared error held by the worst 1 % of pixels.
"""
import json, os, subprocess, sys, tempfile
import numpy as np

def read_pfm(path):
    with open(path, 'rb') as f:
        f.readline()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype='<f4' if scale < 0 else '>f4')
    return data.reshape(h, w, 3)[::-1]

def main():
    scene, spps, seeds, extra = sys.argv[1], [int(x) for x in sys.argv[2].split()], int(sys.argv[3]), sys.argv[4:]
    exe = os.environ.get('MICROPT', 'target/release/micropt')
    ref = read_pfm(f'host-tests/data/{scene}.pfm').astype(np.float64)
    se_path = f'host-tests/data/{scene}.se.pfm'
    ref_noise = float((read_pfm(se_path).astype(np.float64) ** 2).mean()) if os.path.exists(se_path) else 0.0
    mitsuba = {}
    for line in open('docs/mitsuba/efficiency.csv'):
        t = line.strip().split(',')
        if t[0] == scene and t[1] == 'independent':
            mitsuba[int(t[2])] = float(t[10])
    with tempfile.TemporaryDirectory() as tmp:
        for spp in spps:
            mses, secs, errs = [], [], []
            for s in range(seeds):
                out = os.path.join(tmp, f'{s}.pfm')
                r = subprocess.run([exe, 'render', f'scenes/{scene}.scene', '--spp', str(spp), '--uniform',
                                    '--seed', str(s), '--threads', '1', '-o', out, '--json'] + extra,
                                   capture_output=True, text=True, check=True)
                secs.append(json.loads(r.stdout)['seconds'])
                e = ((read_pfm(out) - ref) ** 2).mean(2)
                errs.append(e)
                mses.append(e.mean())
            mse = float(np.mean(mses)) - ref_noise
            t = float(np.median(secs))
            eff = 1.0 / (mse * t)
            e = np.sort(np.mean(errs, 0).ravel())[::-1]
            worst = e[: max(1, len(e) // 100)].sum() / e.sum()
            vs = f'{eff / mitsuba[spp]:.1f}x' if spp in mitsuba else '-'
            print(f'{scene} spp {spp}: MSE {mse:.3e} (seed sd {np.std(mses):.1e}), {t:.3f} s, '
                  f'efficiency {eff:.0f}, Mitsuba default at {spp} spp: {vs}, worst 1 % of pixels {100 * worst:.1f} %',
                  flush=True)

if __name__ == '__main__':
    main()
