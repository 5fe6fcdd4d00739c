#!/usr/bin/env python3
"""Log-log plot (SVG, no dependencies) of instructions per ray against the
number of spheres, with and without the tree: tools/cost_plot.py CSV
[BOARD_CSV] > SVG (CSV columns: spheres, tree_per_ray, list_per_ray: the
host's callgrind figures; BOARD_CSV, optional, columns spheres,
tree_per_path, list_per_path: the board's instructions per path from
tools/board_field_cost.sh, drawn dashed with open points; the CSV's
optional column binary_tree_per_ray: the binary tree the 4-wide one
replaced)."""
import csv
import math
import sys

rows = list(csv.DictReader(open(sys.argv[1])))
board = list(csv.DictReader(open(sys.argv[2]))) if len(sys.argv) > 2 else []
W, H, L, R, T, B = 640, 420, 70, 20, 20, 50
x0, x1 = math.log10(1), math.log10(8192)
# the board's list cost per path at 4,096 spheres is above 300,000
y0, y1 = math.log10(300), math.log10(1000000 if board else 300000)


def px(n):
    return L + (math.log10(n) - x0) / (x1 - x0) * (W - L - R)


def py(v):
    return H - B - (math.log10(v) - y0) / (y1 - y0) * (H - T - B)


out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">',
       f'<rect width="{W}" height="{H}" fill="white"/>']
for e in range(0, 5):
    n = 10 ** e
    if n <= 8192:
        out.append(f'<line x1="{px(n):.1f}" y1="{T}" x2="{px(n):.1f}" y2="{H - B}" stroke="#ddd"/>')
        out.append(f'<text x="{px(n):.1f}" y="{H - B + 16}" text-anchor="middle">{n}</text>')
for e in range(3, 7 if board else 6):
    v = 10 ** e
    out.append(f'<line x1="{L}" y1="{py(v):.1f}" x2="{W - R}" y2="{py(v):.1f}" stroke="#ddd"/>')
    out.append(f'<text x="{L - 6}" y="{py(v) + 4:.1f}" text-anchor="end">{v}</text>')
out.append(f'<text x="{(L + W - R) / 2}" y="{H - 12}" text-anchor="middle">spheres (log)</text>')
ylabel = "instructions per ray, host (per path, board) (log)" if board else "instructions per ray (log)"
out.append(f'<text x="16" y="{(T + H - B) / 2}" text-anchor="middle" transform="rotate(-90 16 {(T + H - B) / 2})">{ylabel}</text>')
series = [(rows, "list_per_ray", "#c33", "loop over the list", ""),
          (rows, "tree_per_ray", "#36c", "bounding volume hierarchy (4-wide)", "")]
if "binary_tree_per_ray" in rows[0]:
    series.append((rows, "binary_tree_per_ray", "#9ac", "binary tree (before)", ""))
if board:
    series = [(d, k, c, lab + " (host, per ray)", s) for d, k, c, lab, s in series]
    series += [(board, "list_per_path", "#c33", "loop over the list (board, per path)", "6,4"),
               (board, "tree_per_path", "#36c", "bounding volume hierarchy (board, per path)", "6,4")]
for i, (data, key, colour, label, dash) in enumerate(series):
    style = f' stroke-dasharray="{dash}"' if dash else ""
    fill = "white" if dash else colour
    pts = " ".join(f"{px(float(r['spheres'])):.1f},{py(float(r[key])):.1f}" for r in data)
    out.append(f'<polyline points="{pts}" fill="none" stroke="{colour}" stroke-width="2"{style}/>')
    for r in data:
        out.append(f'<circle cx="{px(float(r["spheres"])):.1f}" cy="{py(float(r[key])):.1f}" r="3" fill="{fill}" stroke="{colour}"/>'
                   if dash else
                   f'<circle cx="{px(float(r["spheres"])):.1f}" cy="{py(float(r[key])):.1f}" r="3" fill="{colour}"/>')
    y = T + 20 + 18 * i
    out.append(f'<line x1="{L + 20}" y1="{y - 4}" x2="{L + 44}" y2="{y - 4}" stroke="{colour}" stroke-width="2"{style}/>')
    out.append(f'<text x="{L + 50}" y="{y}">{label}</text>')
out.append("</svg>")
print("\n".join(out))
