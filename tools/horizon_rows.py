#!/usr/bin/env python3
"""Exact pixel values of image rows that show only an infinite ground and
the sky: an independent reference of the horizon rows (docs/mitsuba.md,
"Regional bias of micropt against the references").

    python3 tools/horizon_rows.py scenes/many.scene --rows 4 \
        --csv host-tests/data/many.horizon.csv
    python3 tools/horizon_rows.py scenes/gloss.scene --rows 20 --ny 16384 \
        --csv host-tests/data/gloss.horizon.csv
    python3 tools/horizon_rows.py scenes/many.scene --rows 4 --converge

Needs numpy; everything is float64. The scene must have one plane (a
diffuse or checker ground), a constant background, a pinhole camera whose
right-hand axis is parallel to the plane (no roll), lights on spheres that
lie wholly above the plane, and any number of other spheres.

What a pixel is (the scene format's box filter): the mean over its film
square [px, px+1) x [py, py+1) of the radiance along the pinhole ray through
each film position, the camera built exactly as src/camera.rs builds it
(vertical field of view, aspect width/height, pixel y down). A ray that
escapes above the horizon sees the background; one that meets the ground at
p sees albedo(p)/pi x E(p), where the irradiance of a ground point is

    E(p) = pi Lbg + sum over lights l of pi (r_l/D_l)^2 cos(theta_l) (L_l - Lbg)

(the sky's hemisphere, with each light's disk replacing the sky it hides: a
sphere wholly above the tangent plane sends pi (r/D)^2 cos(theta) L, exactly;
a light that crossed the plane would need a clipped cap, and is refused).
That is the whole radiance of a ground point that no other sphere shadows,
hides sky from or lights.

Integration: the horizon is the film line d.n = 0, which is a film row line
y = fy_h because the camera has no roll. The sky's share of a pixel is exact.
Over the ground share the film rows fy are stratified with one jittered
position per stratum (--ny strata per pixel row); along one film row the
ground points lie on a straight line, linear in fx, so each pixel's row
segment is cut into --nx equal pieces, E taken at each piece's centre and the
checker's albedo averaged over the piece exactly (closed form: the camera's
right-hand axis runs along one checker axis, so the other checker coordinate
is constant along a film row). The jitter makes each run an unbiased
estimate; --seeds independent runs give the value and its standard error;
--converge prints how the value moves with --ny and --nx.

Which pixels are settled: a pixel is left out when any ray through its film
square may meet a sphere (a grid of --grid^2 rays, each sphere widened by the
grid's half-diagonal in angle, so that no sphere slips between grid rays), or
when a ground point seen through it may be shadowed from a light by a sphere:
the pixel's ground region (the film square below the horizon mapped onto the
plane: convex, unbounded when it holds the horizon) comes within a sphere's
shadow reach of its centre's foot (a segment from a ground point to a point
of the light rises at least at the light's lowest elevation, so it clears
the sphere's top beyond (h + r)/tan(elevation) from that point). The other
spheres still hide a little sky from a settled pixel's ground and send it a
little light; per sphere that changes E by at most
(Omega/pi) cos_max max(pi Lbg, k Phi), where Omega is the sphere's solid
angle seen from the nearest point of the pixel's ground region, cos_max the
largest cosine towards it, Phi the radiance integrated over all directions
at the sphere (sky, ground at its brightest, lights) and k r^2 Phi a bound
of the sphere's radiant intensity (INTENSITY_FACTOR). The sum over spheres
times albedo_max/pi is the column `bound`; a pixel is settled only if it is
below --max-bound times its value (default 2e-5; the settled pixels of many's
row 4 and gloss's row 20 have bounds below 4e-8 and 3e-6 of their values,
under a thirtieth of the standard error of those rows in bias_blocks.rs even
if every pixel were off by its whole bound, in one direction).

Output (--csv): one line per settled pixel, x,y,r,g,b,se_r,se_g,se_b,bound;
`se_*` is the seeds' standard error, `bound` the bound above (the test adds
both). Figures of many (row 4) and gloss (row 20): docs/mitsuba.md.

--compare LABEL PFM SE_PFM (repeatable) prints, per row and for all settled
pixels, the mean difference of that image from the values, its z against
both errors, the bound, and the z of its difference from a lower bound:
the other spheres only add light except for the sky they hide (bounded as
above with the sky's radiance alone), so the truth is at least the value
minus that. With --max-bound 1 and --columns X0 X1 it checks a renderer's
ground pixels below the horizon rows too (docs/mitsuba.md).
"""

import argparse
import os
import math
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), 'mitsuba'))
from common import read_pfm  # noqa: E402 (float64, rows top to bottom)


# An upper bound of a sphere's radiant intensity in any direction, over
# r^2 Phi (Phi: the radiance arriving at the sphere integrated over all
# directions), per material: a Lambertian sphere's is at most
# (rho/pi) x max over w, w' of the integral over normals n of
# (n.w)+ (n.w')+, which is 2 pi/3, so 2/3; a mirror sphere's is rho/4; a
# microfacet (metal) sphere's is at most 1/4 of the integral of its normal
# distribution over directions (1 + O(alpha^2), 2 at alpha = 1), so 1/2.
# 1 covers the three with room for light passed between spheres. A glass
# ball focuses (its caustics), so it gets 10. The checker on a sphere is
# Lambertian.
INTENSITY_FACTOR = {"diffuse": 1.0, "checker": 1.0, "mirror": 1.0, "metal": 1.0, "glass": 10.0}


def parse_scene(path):
    """The statements this tool needs, as the parser (src/parse.rs) reads
    them: camera, resolution, background, material, sphere, plane."""
    sc = {"materials": {}, "spheres": [], "planes": [], "background": (0.0, 0.0, 0.0)}
    for line in open(path):
        line = line.split("#", 1)[0].split()
        if not line:
            continue
        k, a = line[0], line[1:]
        if k == "camera":
            v = [float(x) for x in a]
            sc["camera"] = v
        elif k == "resolution":
            sc["size"] = (int(a[0]), int(a[1]))
        elif k == "background":
            sc["background"] = tuple(float(x) for x in a)
        elif k == "material":
            sc["materials"][a[0]] = (a[1], [float(x) for x in a[2:]])
        elif k == "sphere":
            sc["spheres"].append(([float(x) for x in a[:3]], float(a[3]), a[4]))
        elif k == "plane":
            sc["planes"].append(([float(x) for x in a[:3]], [float(x) for x in a[3:6]], a[6]))
        else:
            sys.exit(f"unknown statement {k}")
    return sc


class Camera:
    """src/camera.rs in float64: d(fx, fy) = corner + dx fx + dy fy."""

    def __init__(self, spec, w, h):
        if len(spec) > 10 and spec[10] > 0:
            sys.exit("a lens camera: this tool integrates pinhole rays only")
        eye, target, up = (np.array(spec[i : i + 3]) for i in (0, 3, 6))
        fwd = target - eye
        fwd /= np.linalg.norm(fwd)
        right = np.cross(fwd, up)
        right /= np.linalg.norm(right)
        upv = np.cross(right, fwd)
        t = math.tan(math.radians(spec[9]) / 2)
        half_w, half_h = t * w / h, t
        self.eye = eye
        self.dx = right * (2 * half_w / w)
        self.dy = upv * (-2 * half_h / h)
        self.corner = fwd - right * half_w + upv * half_h
        self.w, self.h = w, h

    def dirs(self, fx, fy):
        """Unnormalised directions, shape fx.shape + (3,)."""
        fx, fy = np.broadcast_arrays(np.asarray(fx, float), np.asarray(fy, float))
        return self.corner + self.dx * fx[..., None] + self.dy * fy[..., None]


def cell_odd_measure(a, b, s):
    """Length of [a, b] (a <= b, arrays) where floor(u/s) is odd."""

    def g(u):
        k = np.floor(u / s)
        # whole pairs of cells below cell k hold one odd cell each
        odd_below = s * np.floor(k / 2)
        return odd_below + np.where(np.mod(k, 2) == 1, u - k * s, 0.0)

    return g(b) - g(a)


class Ground:
    """The scene's one plane and everything that lights it."""

    def __init__(self, sc):
        if len(sc["planes"]) != 1:
            sys.exit("exactly one plane is needed")
        p0, n, mat = sc["planes"][0]
        self.p0 = np.array(p0)
        self.n = np.array(n) / np.linalg.norm(n)
        kind, v = sc["materials"][mat]
        self.bg = np.array(sc["background"])
        if kind == "diffuse":
            self.even = self.odd = np.array(v[:3])
            self.size = None
        elif kind == "checker":
            self.even, self.odd, self.size = np.array(v[:3]), np.array(v[3:6]), v[6]
            # the two axes the checker keeps: drop the one most aligned with n
            a = np.abs(self.n)
            drop = 0 if (a[0] >= a[1] and a[0] >= a[2]) else (1 if a[1] >= a[2] else 2)
            self.axes = [i for i in range(3) if i != drop]
        else:
            sys.exit(f"ground material {kind}: only diffuse and checker")
        self.lights, self.others = [], []
        for c, r, m in sc["spheres"]:
            kind, v = sc["materials"][m]
            c = np.array(c)
            if kind == "light":
                h = float(np.dot(c - self.p0, self.n))
                if h <= r:
                    sys.exit(f"light at {c} r {r} crosses or lies below the plane: its cap is clipped")
                self.lights.append((c, r, np.array(v[:3])))
            else:
                self.others.append((c, r, INTENSITY_FACTOR[kind]))
        self.albedo_max = float(max(self.even.max(), self.odd.max()))

    def irradiance(self, p):
        """E(p) per channel, p of shape (..., 3): sky plus the lights."""
        e = np.pi * self.bg * np.ones(p.shape[:-1] + (1,))
        for c, r, L in self.lights:
            q = c - p
            d2 = np.einsum("...i,...i", q, q)
            cos = np.einsum("...i,i", q, self.n) / np.sqrt(d2)
            e = e + (np.pi * r * r / d2 * cos)[..., None] * (L - self.bg)
        return e

    def phi_bound(self, c):
        """Radiance integrated over all directions at point c, bounded:
        sky and ground hemispheres at their largest radiance, plus each
        light's solid angle times its radiance."""
        # the ground's irradiance is largest under each light at its nearest
        e_max = np.pi * self.bg.max() + sum(
            np.pi * r * r / (np.dot(lc - self.p0, self.n) - r) ** 2 * L.max() for lc, r, L in self.lights
        )
        ground_max = self.albedo_max / np.pi * e_max
        phi = 2 * np.pi * self.bg.max() + 2 * np.pi * ground_max
        for lc, r, L in self.lights:
            d2 = float(np.dot(lc - c, lc - c))
            phi += 2 * np.pi * (1 - math.sqrt(max(0.0, 1 - r * r / d2))) * L.max()
        return phi


def hit_ground(cam, g, d):
    """Ground points of directions d (those below the horizon)."""
    t = np.dot(g.p0 - cam.eye, g.n) / np.einsum("...i,i", d, g.n)
    return cam.eye + t[..., None] * d


def horizon_fy(cam, g):
    dn_x = float(np.dot(cam.dx, g.n))
    if abs(dn_x) > 1e-12 * np.linalg.norm(cam.dx):
        sys.exit("the camera's right-hand axis is not parallel to the plane (roll)")
    # d.n = corner.n + dy.n fy = 0; the eye must be above the plane
    if np.dot(cam.eye - g.p0, g.n) <= 0:
        sys.exit("the eye is not above the plane")
    return -float(np.dot(cam.corner, g.n)) / float(np.dot(cam.dy, g.n))


def shadow_reach(g, oc, orad, oh):
    """How far (along the plane) from a sphere's centre its shadow from
    each light can fall: a segment from a ground point p to a point of the
    light rises at an elevation >= theta, so it is above the sphere's top
    (height h + r) beyond (h + r)/tan(theta) from p, and the sphere lies
    within r of its centre. theta is the lowest elevation of the light seen
    from anywhere within that reach (fixed point, from reach 0)."""
    out = np.zeros((len(g.lights), len(oc)))
    for j, (lc, lr, _) in enumerate(g.lights):
        lh = float(np.dot(lc - g.p0, g.n))
        flat = (lc - g.p0) - lh * g.n
        for i, c in enumerate(oc):
            ch = (c - g.p0) - oh[i] * g.n
            dh = float(np.linalg.norm(flat - ch))
            rho = 0.0
            for _ in range(50):
                tan = (lh - lr) / (dh + lr + rho)
                new = orad[i] + (oh[i] + orad[i]) / tan if tan > 0 else np.inf
                if new <= rho * (1 + 1e-12):
                    break
                rho = new
            out[j, i] = rho if np.isfinite(rho) else np.inf
    return out


def ground_region_distance(cam, g, to2, px, row, fyh, c):
    """Distance along the plane from the foot of point c to the ground seen
    through pixel (px, row): 0 inside; else to the nearest edge, the images
    of the film square's edges (segments, or rays towards the horizon)."""
    q = to2(c)
    # inside? the film position of the foot
    foot = c - np.dot(c - g.p0, g.n) * g.n
    rel = foot - cam.eye
    fwd = cam.corner + cam.dx * (cam.w / 2) + cam.dy * (cam.h / 2)
    fwd /= np.linalg.norm(fwd)
    depth = np.dot(rel, fwd)
    if depth > 0:
        off = rel / depth - cam.corner
        fx = np.dot(off, cam.dx) / np.dot(cam.dx, cam.dx)
        fy = np.dot(off, cam.dy) / np.dot(cam.dy, cam.dy)
        # a point with depth > 0 on the plane is seen below the horizon
        if px <= fx <= px + 1 and row <= fy <= row + 1 and fy > fyh:
            return 0.0

    def seg(a, b):
        ab = b - a
        t = np.clip(np.dot(q - a, ab) / max(np.dot(ab, ab), 1e-300), 0, 1)
        return float(np.linalg.norm(q - a - t * ab))

    def ray(a, u):
        t = max(0.0, np.dot(q - a, u))
        return float(np.linalg.norm(q - a - t * u))

    pt = lambda fx, fy: to2(hit_ground(cam, g, cam.dirs(fx, fy)))
    b0, b1 = pt(px, row + 1.0), pt(px + 1.0, row + 1.0)
    if row > fyh:
        t0, t1 = pt(px, float(row)), pt(px + 1.0, float(row))
        return min(seg(b0, b1), seg(t0, t1), seg(b0, t0), seg(b1, t1))
    # the side edges run to the horizon: rays along the horizon's direction
    ups = []
    for fx in (px, px + 1.0):
        h = cam.dirs(fx, fyh)
        h = h - np.dot(h, g.n) * g.n
        hv = to2(g.p0 + h) - to2(g.p0)
        ups.append(hv / np.linalg.norm(hv))
    return min(seg(b0, b1), ray(b0, ups[0]), ray(b1, ups[1]))


def pixel_masks(cam, g, spheres, row, grid):
    """Per pixel of `row`: whether a ray may meet a sphere, whether a ground
    point may be shadowed from a light, and the bound on the other spheres'
    change of E (largest over the pixel's ground grid, per unit albedo)."""
    w = cam.w
    u = (np.arange(grid) + 0.5) / grid
    fx = np.arange(w)[:, None, None] + u[None, :, None]
    fy = row + u[None, None, :]
    d = cam.dirs(fx, fy)
    dl = np.linalg.norm(d, axis=-1)
    un = d / dl[..., None]
    # the grid's half-diagonal in angle, at its widest on the film
    step = np.hypot(np.linalg.norm(cam.dx), np.linalg.norm(cam.dy)) / grid
    margin = 0.5 * step / dl.min()
    hits = np.zeros(w, bool)
    for c, r in spheres:
        q = c - cam.eye
        D = np.linalg.norm(q)
        ang = math.asin(min(1.0, r / D)) + margin
        cosang = np.einsum("...i,i", un, q / D)
        hits |= (cosang > math.cos(min(ang, math.pi))).any(axis=(1, 2))
    # the pixel's ground region: the film square's part below the horizon,
    # mapped onto the plane (convex; unbounded when it holds the horizon).
    # Distances from a sphere to it are exact, so nothing slips between
    # sample points.
    e1 = np.cross(g.n, [1.0, 0.0, 0.0] if abs(g.n[0]) < 0.9 else [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(g.n, e1)
    to2 = lambda q: np.array([np.dot(q - g.p0, e1), np.dot(q - g.p0, e2)])
    fyh = horizon_fy(cam, g)
    shadow = np.zeros(w, bool)
    bound = np.zeros(w)
    sky = np.zeros(w)
    oc = np.array([c for c, _, _ in g.others]) if g.others else np.zeros((0, 3))
    orad = np.array([r for _, r, _ in g.others]) if g.others else np.zeros(0)
    factor = np.array([f for _, _, f in g.others]) if g.others else np.zeros(0)
    oh = (oc - g.p0) @ g.n  # heights of the centres
    phis = np.array([g.phi_bound(c) for c in oc])
    kmax = np.maximum(np.pi * g.bg.max(), factor * phis)
    reach = shadow_reach(g, oc, orad, oh)  # (lights, spheres)
    for px in range(w):
        if fyh >= row + 1.0:
            continue
        dist = np.array([ground_region_distance(cam, g, to2, px, row, fyh, c) for c in oc])
        if (dist <= reach).any():
            shadow[px] = True
        # nearest point of each sphere, and the largest cosine towards it
        D = np.hypot(dist, oh)
        near = np.maximum(D - orad, 1e-300)
        cos_max = np.clip((oh + orad) / near, 0, 1)
        # the sphere's solid angle over pi (>= (r/D)^2, its far-field value)
        rr = 2.0 * (1.0 - np.sqrt(1.0 - np.minimum(1.0, (orad / np.maximum(D, orad)) ** 2)))
        bound[px] = (rr * cos_max * kmax).sum()
        sky[px] = (rr * cos_max).sum() * np.pi * g.bg.max()
    return hits, shadow, bound, sky


def integrate_row(cam, g, row, ny, nx, rng):
    """One jittered estimate of every pixel of `row`, shape (w, 3)."""
    w = cam.w
    fyh = horizon_fy(cam, g)
    lo = min(max(row, fyh), row + 1.0)
    sky_share = lo - row
    out = np.tile(sky_share * g.bg, (w, 1))
    if lo >= row + 1.0:
        return out
    # ny strata of the ground share of the pixel row, one jittered fy each
    fy = lo + (np.arange(ny) + rng.random(ny)) * ((row + 1.0 - lo) / ny)
    weight = (row + 1.0 - lo) / ny
    # pieces along fx: nx per pixel, E at each piece's centre
    edges = np.arange(w * nx + 1) / nx  # film fx of piece edges
    mids = 0.5 * (edges[1:] + edges[:-1])
    acc = np.zeros((w * nx, 3))
    chunk = max(1, 2_000_000 // (w * nx))
    for i in range(0, ny, chunk):
        f = fy[i : i + chunk]
        d = cam.dirs(mids[None, :], f[:, None])
        p = hit_ground(cam, g, d)
        e = g.irradiance(p)
        if g.size is None:
            alb = g.even
            acc += (e * alb).sum(axis=0)
        else:
            de = cam.dirs(edges[None, :], f[:, None])
            pe = hit_ground(cam, g, de)
            ua, va = (pe[..., ax] for ax in g.axes)
            if np.abs(np.diff(va, axis=1)).max() > 1e-9 * (1 + np.abs(va).max()):
                sys.exit("the second checker axis varies along a film row: not supported")
            a, b = ua[:, :-1], ua[:, 1:]
            lo_u, hi_u = np.minimum(a, b), np.maximum(a, b)
            span = hi_u - lo_u
            odd_u = cell_odd_measure(lo_u, hi_u, g.size) / span
            v_odd = (np.floor(va[:, :-1] / g.size) % 2) == 1
            # share of the piece where floor(u)+floor(v) is odd
            odd = np.where(v_odd, 1 - odd_u, odd_u)
            alb = g.even * (1 - odd)[..., None] + g.odd * odd[..., None]
            acc += (e * alb).sum(axis=0)
    ground = acc.reshape(w, nx, 3).sum(axis=1) / nx * weight / np.pi
    return out + ground


def estimate(cam, g, row, ny, nx, seeds, seed0=1):
    runs = np.array([integrate_row(cam, g, row, ny, nx, np.random.default_rng(seed0 + s)) for s in range(seeds)])
    return runs.mean(axis=0), runs.std(axis=0, ddof=1) / math.sqrt(seeds)


def fmt_diff(d, var, ex, bound, sky):
    """Relative difference, z against the errors, the bound (relative), and
    the z of the difference from the lower bound: the other spheres only
    add light, except the sky they hide (`sky`, bounded like `bound` with
    the sky's radiance alone), so the truth is at least value - sky."""
    rel = d / ex
    z = d / np.sqrt(var)
    b = np.full(3, bound) / ex
    zlow = (d + sky) / np.sqrt(var)
    return (
        f"difference {' '.join(f'{100 * x:+.4f}' for x in rel)} %, "
        f"z {' '.join(f'{x:+.2f}' for x in z)}, bound {' '.join(f'{100 * x:.4f}' for x in b)} %, "
        f"z above the lower bound {' '.join(f'{x:+.2f}' for x in zlow)}"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--rows", type=int, nargs="+", required=True)
    ap.add_argument("--ny", type=int, default=4096, help="film-row strata per pixel row")
    ap.add_argument("--nx", type=int, default=16, help="pieces per pixel along a film row")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--grid", type=int, default=64, help="rays per side for the sphere test")
    ap.add_argument("--max-bound", type=float, default=2e-5, help="largest bound / value settled")
    ap.add_argument("--csv", help="write the settled pixels here")
    ap.add_argument("--converge", action="store_true", help="print the value against ny and nx")
    ap.add_argument("--pixels", type=int, nargs="*", default=[], help="x of pixels to print")
    ap.add_argument("--columns", type=int, nargs=2, default=None, help="settle only x in [X0, X1]")
    ap.add_argument(
        "--compare",
        nargs=3,
        action="append",
        default=[],
        metavar=("LABEL", "PFM", "SE_PFM"),
        help="print the settled pixels' mean difference of this image (and its error map) from the exact values",
    )
    a = ap.parse_args()
    sc = parse_scene(a.scene)
    w, h = sc["size"]
    cam = Camera(sc["camera"], w, h)
    g = Ground(sc)
    spheres = [(np.array(c), r) for c, r, _ in sc["spheres"]]
    fyh = horizon_fy(cam, g)
    print(f"horizon at film y = {fyh:.6f} (row {math.floor(fyh)})")
    lines = []
    found = []
    for row in a.rows:
        if a.converge:
            # the far-ground limit: E -> pi Lbg (the lights' share falls as
            # 1/D^3), so a pixel's ground tends to albedo x Lbg at the horizon
            for eps in (1e-2, 1e-4, 1e-6, 1e-8):
                p = hit_ground(cam, g, cam.dirs(w / 2, fyh + eps))
                e = g.irradiance(p)
                print(
                    f"far ground, film y horizon + {eps:g} (distance {np.linalg.norm(p - cam.eye):.3g}): "
                    f"E / (pi Lbg) - 1 = {' '.join(f'{x:.3e}' for x in e / (np.pi * g.bg) - 1)}"
                )
            for ny, nx in [(256, 4), (1024, 4), (1024, 16), (4096, 16), (16384, 16), (4096, 64)]:
                v, se = estimate(cam, g, row, ny, nx, 4)
                xs = a.pixels or [0, w // 2, w - 1]
                print(f"row {row} ny {ny:6d} nx {nx:3d}: " + "  ".join(f"x{x} {v[x, 1]:.8f}+-{se[x, 1]:.1e}" for x in xs))
            continue
        hits, shadow, bound, sky = pixel_masks(cam, g, spheres, row, a.grid)
        sky_rad = sky * g.albedo_max / np.pi
        v, se = estimate(cam, g, row, a.ny, a.nx, a.seeds)
        # the bound on E, per unit albedo, into radiance: albedo_max / pi
        # times the ground share of the pixel (<= 1)
        brad = bound * g.albedo_max / np.pi
        settled = ~hits & ~shadow & (brad <= a.max_bound * v.min(axis=1))
        if a.columns:
            settled &= (np.arange(w) >= a.columns[0]) & (np.arange(w) <= a.columns[1])
        print(
            f"row {row}: {settled.sum()} of {w} settled; left out: {hits.sum()} meet a sphere, "
            f"{shadow.sum()} possibly shadowed, {(~hits & ~shadow & ~settled).sum()} bound too large; "
            f"largest relative SE {np.max(se / v):.2e}, largest relative bound {np.max(brad[settled] / v[settled].min(axis=1)) if settled.any() else 0:.2e}"
        )
        for x in a.pixels:
            print(f"  ({x},{row}) {v[x]} se {se[x]} bound {brad[x]:.2e} settled {settled[x]}")
        found.append((row, settled, v, se, brad, sky_rad))
        for x in np.nonzero(settled)[0]:
            lines.append(f"{x},{row},{v[x,0]:.9g},{v[x,1]:.9g},{v[x,2]:.9g},{se[x,0]:.3g},{se[x,1]:.3g},{se[x,2]:.3g},{brad[x]:.3g}")
    for label, path, se_path in a.compare:
        img, img_se = read_pfm(path), read_pfm(se_path)
        tot = [np.zeros(3) for _ in range(5)]
        for row, settled, v, se, brad, sky_rad in found:
            xs = np.nonzero(settled)[0]
            if not xs.size:
                continue
            d, var = (img[row, xs] - v[xs]).sum(0), (img_se[row, xs] ** 2 + se[xs] ** 2).sum(0)
            ex, b, sk = v[xs].sum(0), brad[xs].sum(), sky_rad[xs].sum()
            for t, q in zip(tot, (d, var, ex, b, sk)):
                t += q
            print(f"{label} row {row} ({xs.size} px): {fmt_diff(d, var, ex, b, sk)}")
        if tot[2].any():
            print(f"{label} all settled: {fmt_diff(*tot)}")
    if a.csv:
        with open(a.csv, "w") as f:
            f.write(f"# {a.scene.split('/')[-1]}: exact pixel values of ground-and-sky pixels, tools/horizon_rows.py\n")
            f.write(f"# --rows {' '.join(map(str, a.rows))} --ny {a.ny} --nx {a.nx} --seeds {a.seeds} --grid {a.grid} --max-bound {a.max_bound}\n")
            f.write("# x,y,r,g,b: value; se_*: standard error of the value over the seeds; bound: largest change other spheres can make\n")
            f.write("x,y,r,g,b,se_r,se_g,se_b,bound\n")
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
