#!/usr/bin/env python3
"""A random field of N small spheres on a ground plane, at constant density
(the field's side grows as sqrt(N)), under a sky and a small sun, seen from
above one corner: the scenes of the cost-against-n measurement
(docs/bvh.md). Usage: tools/field.py N [SEED] > field.scene"""
import random
import sys

n = int(sys.argv[1])
rng = random.Random(int(sys.argv[2]) if len(sys.argv) > 2 else 1)
side = 2.0 * n ** 0.5  # about one sphere per 4 square units
print(f"# random field of {n} spheres (tools/field.py)")
print(f"camera {-0.6 * side:.3f} {0.35 * side + 1:.3f} {-0.6 * side:.3f}  0 0 0  0 1 0  50")
print("background 0.5 0.7 1.0")
print("material ground diffuse 0.5 0.5 0.5")
print("material sun light 400 380 340")
print("material a diffuse 0.7 0.3 0.2")
print("material b diffuse 0.2 0.6 0.3")
print("material c mirror 0.8 0.8 0.8")
print("plane 0 0 0  0 1 0  ground")
print(f"sphere {side} {side} {-side}  {0.02 * side + 0.5:.3f}  sun")
for _ in range(n - 1):
    r = rng.uniform(0.15, 0.35)
    x = rng.uniform(-side / 2, side / 2)
    z = rng.uniform(-side / 2, side / 2)
    m = rng.choice("aabbc")
    print(f"sphere {x:.4f} {r:.4f} {z:.4f}  {r:.4f}  {m}")
