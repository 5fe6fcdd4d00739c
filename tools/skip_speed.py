#!/usr/bin/env python3
"""Wall-clock speed of each skip-optimisation on the host: M rays/s and
paths/s of every shipped scene with the default options and with one skip
turned off (`--no-skip`), one thread, uniform allocation, the scene's own
resolution. The configurations are interleaved and repeated (REPS rounds),
and the median of each is reported, so that drifts of a shared machine hit
every configuration alike. Prints a markdown table: per scene and
configuration, the default's M rays/s and, for a skip turned off, the speed
that skip buys (paths/s on / paths/s off; > 1: the skip is a win).

    [SCENES="cornell spheres"] tools/skip_speed.py [BIN] [SECONDS] [REPS]

Each scene renders at the power-of-two spp that takes about SECONDS (default
0.5) with the default options, found from one 16-spp render.
"""
import json, os, statistics, subprocess, sys, tempfile

BIN = sys.argv[1] if len(sys.argv) > 1 else "target/release/micropt"
TARGET_S = float(sys.argv[2]) if len(sys.argv) > 2 else 0.5
REPS = int(sys.argv[3]) if len(sys.argv) > 3 else 5
CONFIGS = ["default", "shadow-occluders", "view-culling", "specialize", "horizon",
           "unreachable-lights", "closed", "slabs", "whole-light", "all"]


def run(scene, config, out, spp):
    args = [BIN, "render", scene, "--uniform", "--spp", str(spp), "--threads", "1", "--json", "-o", out]
    if config != "default":
        args += ["--no-skip", config]
    j = json.loads(subprocess.run(args, capture_output=True, text=True, check=True).stdout)
    return j["paths"] / j["seconds"], j["rays"] / j["seconds"] / 1e6, j["seconds"]


print("| scene | spp | default M rays/s | " + " | ".join(CONFIGS[1:]) + " |")
print("|---|---:|---:|" + "---:|" * (len(CONFIGS) - 1))
with tempfile.TemporaryDirectory() as tmp:
    only = os.environ.get("SCENES", "").split()
    for scene in sorted(f for f in os.listdir("scenes") if f.endswith(".scene")):
        if only and scene[:-6] not in only:
            continue
        path = f"scenes/{scene}"
        secs = run(path, "default", f"{tmp}/cal.pfm", 16)[2]
        spp = 16
        while spp < 65536 and secs * spp / 16 < TARGET_S / 1.5:
            spp *= 2
        pps = {c: [] for c in CONFIGS}
        rays = {c: [] for c in CONFIGS}
        for rnd in range(REPS):
            # a different configuration first in each round
            for c in CONFIGS[rnd % len(CONFIGS):] + CONFIGS[:rnd % len(CONFIGS)]:
                p, r, _ = run(path, c, f"{tmp}/{c}.pfm", spp)
                pps[c].append(p)
                rays[c].append(r)
        med = {c: statistics.median(pps[c]) for c in CONFIGS}
        cells = [str(spp), f"{statistics.median(rays['default']):.1f}"]
        for c in CONFIGS[1:]:
            cells.append(f"{med['default'] / med[c]:.3f}x")
        print(f"| {scene[:-6]} | " + " | ".join(cells) + " |")
print()
print(f"Medians of {REPS} interleaved rounds, one thread, `--uniform`; "
      "a cell is paths/s with every skip on divided by paths/s with that skip off.")
