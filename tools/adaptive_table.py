#!/usr/bin/env python3
"""Adaptive against uniform allocation at equal paths, per shipped scene with a
reference: mean MSE over seeds (reference noise subtracted), their ratio, and
the adaptive image's mean difference from the reference (its bias).

    tools/adaptive_table.py [BIN] [SPP ...]
"""
import json, subprocess, sys, tempfile, os

BIN = sys.argv[1] if len(sys.argv) > 1 else "target/release/micropt"
SPPS = [int(s) for s in sys.argv[2:]] or [16, 64]
SEEDS = 4
DATA = "host-tests/data"

def mse_of(img, ref):
    out = subprocess.run([BIN, "compare", img, ref], capture_output=True, text=True, check=True).stdout
    vals = dict(line.split() for line in out.strip().splitlines())
    return float(vals["mse"]), float(vals["mean_diff"])

print("| scene | spp | uniform MSE | adaptive MSE | ratio | adaptive mean diff |")
print("|---|---|---|---|---|---|")
with tempfile.TemporaryDirectory() as tmp:
    # NAME.se.pfm is a reference's standard-error map, not a reference
    for name in sorted(f[:-4] for f in os.listdir(DATA) if f.endswith(".pfm") and not f.endswith(".se.pfm")):
        meta = json.load(open(f"{DATA}/{name}.json"))
        noise = meta["rms_standard_error"] ** 2
        for spp in SPPS:
            tot = {"uniform": 0.0, "adaptive": 0.0}
            bias = 0.0
            for seed in range(SEEDS):
                for mode in tot:
                    img = f"{tmp}/{name}-{mode}.pfm"
                    args = [BIN, "render", f"scenes/{name}.scene", "--spp", str(spp), "--seed", str(seed), "-o", img]
                    if mode == "uniform":
                        args.append("--uniform")
                    subprocess.run(args, check=True)
                    m, d = mse_of(img, f"{DATA}/{name}.pfm")
                    tot[mode] += (m - noise) / SEEDS
                    if mode == "adaptive":
                        bias += d / SEEDS
            print(f"| {name} | {spp} | {tot['uniform']:.3e} | {tot['adaptive']:.3e} | "
                  f"{tot['uniform'] / tot['adaptive']:.2f}x | {bias:+.1e} |")
print(f"\nMean over {SEEDS} seeds; MSE against the reference minus the reference's own noise "
      "(rms_standard_error^2); equal paths (spp x pixels) in both columns.")
