#!/usr/bin/env python3
"""Convert a micropt scene file (format v1 and v2, docs/scene-format.md) into a
Mitsuba 3 scene dict for `mi.load_dict`.

The mapping (docs/mitsuba.md says how each part was checked against the
Mitsuba references):

- integrator `path`, max_depth -1 (no depth limit: unbiased), rr_depth 5
  (Mitsuba's default; Russian roulette only changes the variance);
- camera: `perspective` with fov_axis y and the scene's VFOV, or `thinlens`
  (aperture_radius, focus_distance) for a v2 camera with APERTURE > 0; the
  orientation is `look_at(eye, target, up)`, which puts +x of the world on the
  right of the image when looking down -z with +y up, as the format says;
- film `hdrfilm`, linear RGB, `box` reconstruction filter (uniform sample
  positions over each pixel, each sample counts in its own pixel only);
- background: a `constant` emitter of that radiance (omitted when black);
- diffuse: `diffuse`; mirror: `conductor`, material none (Fresnel factor 1),
  specular_reflectance = tint; glass: `dielectric`, int_ior = IOR,
  ext_ior = 1 (Mitsuba's default ext_ior is air, 1.000277); metal:
  `roughconductor`, ggx, alpha, sample_visible, material none,
  specular_reflectance = tint (Mitsuba's G is the separable G1(wi) G1(wo));
  light: an `area` emitter on a sphere with a black `diffuse` BSDF (Mitsuba
  would otherwise give the emitter a grey BSDF);
- checker on a plane: Mitsuba's `checkerboard` texture with a `to_uv` matrix
  that maps the rectangle's (u, v) to the two world axes the format names,
  divided by 2 SIZE (one texture period is two squares; its color0 is where
  floor(a/SIZE) + floor(b/SIZE) is even);
- checker on a sphere: a Python texture (`micropt_solid_checker`) that
  evaluates the 3D checker at the hit point (Mitsuba's checkerboard is a 2D UV
  texture; a Python texture is slow, so efficiency figures should not use it);
- planes: Mitsuba has no infinite plane. Each plane is five rectangles: a
  central square of half-size `PLANE_CORE` x the scene's size around the
  camera's foot on the plane (where the checker's UV must be precise in
  float32), framed by four strips out to half-size `PLANE_FAR` x the scene's
  size. Every surface on a plane is two-sided (planes reflect on both sides).

Usage as a module: `scene = parse_scene(text); d = mitsuba_dict(mi, scene)`.
As a script it prints the statistics of the converted scene (counts of each
shape and material) to check a conversion: `python3 scene_to_mitsuba.py FILE`.
"""

import math
import sys

import numpy as np

# Half-sizes of a plane's central square and of its outer frame, in units of
# the scene's size (the largest distance of the camera or a non-emitting object
# from the camera's foot on the plane).
PLANE_CORE = 8.0
PLANE_FAR = 1.0e5


class SceneError(Exception):
    """A scene file that cannot be converted; the message names the line."""


def parse_scene(text):
    """The statements of a scene file (v1 or v2) as a dict."""
    scene = {"materials": {}, "spheres": [], "planes": [], "background": (0.0, 0.0, 0.0), "resolution": None}
    counts = {
        "diffuse": 3,
        "mirror": 3,
        "glass": 1,
        "light": 3,
        "metal": 4,
        "checker": 7,
    }
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].split()
        if not line:
            continue
        kw, args = line[0], line[1:]

        def num(xs):
            try:
                v = [float(x) for x in xs]
            except ValueError as e:
                raise SceneError(f"line {lineno}: {e}") from None
            if not all(math.isfinite(x) for x in v):
                raise SceneError(f"line {lineno}: a value is not finite")
            return v

        if kw == "camera":
            if len(args) not in (10, 12):
                raise SceneError(f"line {lineno}: camera takes 10 or 12 values, got {len(args)}")
            if "camera" in scene:
                raise SceneError(f"line {lineno}: a second camera")
            v = num(args)
            cam = {"eye": v[0:3], "target": v[3:6], "up": v[6:9], "vfov": v[9], "aperture": 0.0, "focus": 1.0}
            if len(v) == 12:
                cam["aperture"], cam["focus"] = v[10], v[11]
            scene["camera"] = cam
        elif kw == "resolution":
            scene["resolution"] = (int(args[0]), int(args[1]))
        elif kw == "background":
            scene["background"] = tuple(num(args))
        elif kw == "material":
            if len(args) < 2 or args[1] not in counts:
                raise SceneError(f"line {lineno}: unknown material kind")
            name, kind = args[0], args[1]
            if len(args) - 2 != counts[kind]:
                raise SceneError(f"line {lineno}: {kind} takes {counts[kind]} values")
            if name in scene["materials"]:
                raise SceneError(f"line {lineno}: material {name!r} redefined")
            scene["materials"][name] = (kind, num(args[2:]))
        elif kw == "sphere":
            v = num(args[:4])
            if args[4] not in scene["materials"]:
                raise SceneError(f"line {lineno}: unknown material {args[4]!r}")
            scene["spheres"].append((v[0:3], v[3], args[4]))
        elif kw == "plane":
            v = num(args[:6])
            if args[6] not in scene["materials"]:
                raise SceneError(f"line {lineno}: unknown material {args[6]!r}")
            if scene["materials"][args[6]][0] == "light":
                raise SceneError(f"line {lineno}: a light material on a plane")
            scene["planes"].append((v[0:3], v[3:6], args[6]))
        else:
            raise SceneError(f"line {lineno}: unknown statement {kw!r}")
    if "camera" not in scene:
        raise SceneError("no camera")
    return scene


def rgb(c):
    return {"type": "rgb", "value": [float(x) for x in c]}


_SOLID_CHECKER_REGISTERED = False


def register_solid_checker(mi):
    """Register the Python texture `micropt_solid_checker` (a 3D checker in
    world coordinates: color0 where floor(x/s)+floor(y/s)+floor(z/s) is even)."""
    global _SOLID_CHECKER_REGISTERED
    if _SOLID_CHECKER_REGISTERED:
        return
    import drjit as dr

    class SolidChecker(mi.Texture):
        def __init__(self, props):
            mi.Texture.__init__(self, props)
            self.c0 = mi.Color3f(props["c0"])
            self.c1 = mi.Color3f(props["c1"])
            self.size = props["size"]

        def _pick(self, si):
            p = si.p / self.size
            k = dr.floor(p.x) + dr.floor(p.y) + dr.floor(p.z)
            return dr.fmod(k, 2) == 0 if hasattr(dr, "fmod") else (k - 2 * dr.floor(k / 2)) == 0

        def eval(self, si, active=True):
            return dr.select(self._pick(si), self.c0, self.c1)

        def eval_1(self, si, active=True):
            return dr.mean(self.eval(si, active))

        def mean(self):
            return float(dr.mean((self.c0 + self.c1) * 0.5))

        def is_spatially_varying(self):
            return True

        def traverse(self, callback):
            pass

        def to_string(self):
            return "micropt_solid_checker"

    mi.register_texture("micropt_solid_checker", lambda props: SolidChecker(props))
    _SOLID_CHECKER_REGISTERED = True


def _plane_axes(n):
    """The two world axes a checker uses on a plane of normal n: drop the axis
    most aligned with n (ties: the earlier of x, y, z)."""
    a = [abs(x) for x in n]
    drop = 0
    for i in (1, 2):
        if a[i] > a[drop]:
            drop = i
    return [i for i in range(3) if i != drop]


def bsdf_dict(mi, kind, v, on_plane=False, uv_map=None):
    """The Mitsuba BSDF of a material. uv_map: for a checker on a rectangle,
    the 3x3 matrix from the rectangle's (u, v, 1) to the texture's (u', v', 1)."""
    if kind == "diffuse":
        b = {"type": "diffuse", "reflectance": rgb(v)}
    elif kind == "mirror":
        b = {"type": "conductor", "material": "none", "specular_reflectance": rgb(v)}
    elif kind == "glass":
        return {"type": "dielectric", "int_ior": float(v[0]), "ext_ior": 1.0}
    elif kind == "metal":
        b = {
            "type": "roughconductor",
            "material": "none",
            "distribution": "ggx",
            "alpha": float(v[3]),
            "sample_visible": True,
            "specular_reflectance": rgb(v[0:3]),
        }
    elif kind == "checker":
        if on_plane:
            tex = {
                "type": "checkerboard",
                "color0": rgb(v[0:3]),
                "color1": rgb(v[3:6]),
                "to_uv": mi.ScalarTransform3f(np.asarray(uv_map, dtype=np.float64).tolist()),
            }
        else:
            register_solid_checker(mi)
            tex = {"type": "micropt_solid_checker", "c0": mi.ScalarColor3f(v[0:3]), "c1": mi.ScalarColor3f(v[3:6]),
                   "size": float(v[6])}
        b = {"type": "diffuse", "reflectance": tex}
    elif kind == "light":
        return {"type": "diffuse", "reflectance": rgb((0.0, 0.0, 0.0))}
    else:
        raise SceneError(f"unknown material kind {kind!r}")
    return {"type": "twosided", "bsdf": b} if on_plane else b


def scene_size(scene):
    """The largest distance of the camera or a non-emitting sphere's far side
    from the eye (planes extend this far and much further)."""
    eye = np.asarray(scene["camera"]["eye"], dtype=np.float64)
    r = np.linalg.norm(eye - np.asarray(scene["camera"]["target"]))
    for c, rad, m in scene["spheres"]:
        if scene["materials"][m][0] != "light":
            r = max(r, float(np.linalg.norm(np.asarray(c) - eye)) + rad)
    return max(r, 1.0)


def plane_rectangles(mi, p, n, kind, v, size, core=PLANE_CORE, far=PLANE_FAR, eye=None):
    """Rectangles covering the plane through p with normal n: a central square
    of half-size core*size around the foot of `eye` on the plane, framed by four
    strips out to half-size far*size (each overlapping its neighbours by a
    relative 1e-6 so that no ray slips between them)."""
    T = mi.ScalarTransform4f
    p = np.asarray(p, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    n = n / np.linalg.norm(n)
    e = np.asarray(eye if eye is not None else p, dtype=np.float64)
    centre = e - np.dot(e - p, n) * n
    # an orthonormal frame (e1, e2, n), right-handed
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, n)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    c, f = core * size, far * size
    eps = 1e-6 * f
    # (x0, x1, y0, y1) in the plane's frame
    pieces = [
        (-c, c, -c, c),
        (-f, f, c - eps, f),
        (-f, f, -f, -c + eps),
        (-f, -c + eps, -c, c),
        (c - eps, f, -c, c),
    ]
    if kind == "checker":
        axes = _plane_axes(n)
        s = float(v[6])
    out = []
    for x0, x1, y0, y1 in pieces:
        cx, cy, hx, hy = (x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2
        o = centre + cx * e1 + cy * e2
        # local (x, y, z) -> o + x hx e1 + y hy e2 + z n
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = hx * e1, hy * e2, n, o
        uv_map = None
        if kind == "checker":
            # the rectangle's uv = ((x+1)/2, (y+1)/2), so world point =
            # o + (2u-1) hx e1 + (2v-1) hy e2; texture coordinate = world[axis] / (2 s)
            uv_map = np.zeros((3, 3))
            for row, ax in enumerate(axes):
                uv_map[row, 0] = 2 * hx * e1[ax] / (2 * s)
                uv_map[row, 1] = 2 * hy * e2[ax] / (2 * s)
                uv_map[row, 2] = (o[ax] - hx * e1[ax] - hy * e2[ax]) / (2 * s)
            uv_map[2, 2] = 1.0
        out.append({"type": "rectangle", "to_world": T(m.tolist()),
                    "bsdf": bsdf_dict(mi, kind, v, on_plane=True, uv_map=uv_map)})
    return out


def mitsuba_dict(mi, scene, sampler="independent", spp=1, rr_depth=5, plane_far=PLANE_FAR, plane_core=PLANE_CORE,
                 resolution=None):
    """The Mitsuba 3 scene dict of a parsed micropt scene."""
    T = mi.ScalarTransform4f
    cam = scene["camera"]
    w, h = resolution or scene["resolution"] or (96, 64)
    film = {"type": "hdrfilm", "width": w, "height": h, "pixel_format": "rgb", "rfilter": {"type": "box"}}
    sensor = {
        "type": "perspective",
        "fov": float(cam["vfov"]),
        "fov_axis": "y",
        "to_world": T().look_at(origin=cam["eye"], target=cam["target"], up=cam["up"]),
        "film": film,
        "sampler": {"type": sampler, "sample_count": spp},
    }
    if cam["aperture"] > 0.0:
        sensor["type"] = "thinlens"
        sensor["aperture_radius"] = float(cam["aperture"])
        sensor["focus_distance"] = float(cam["focus"])
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1, "rr_depth": rr_depth},
        "sensor": sensor,
    }
    bg = scene["background"]
    if max(bg) > 0.0:
        d["sky"] = {"type": "constant", "radiance": rgb(bg)}
    for i, (c, r, m) in enumerate(scene["spheres"]):
        kind, v = scene["materials"][m]
        s = {"type": "sphere", "center": [float(x) for x in c], "radius": float(r), "bsdf": bsdf_dict(mi, kind, v)}
        if kind == "light":
            s["emitter"] = {"type": "area", "radiance": rgb(v)}
        d[f"sphere{i}"] = s
    size = scene_size(scene)
    for i, (p, n, m) in enumerate(scene["planes"]):
        kind, v = scene["materials"][m]
        for j, rect in enumerate(
            plane_rectangles(mi, p, n, kind, v, size, core=plane_core, far=plane_far, eye=cam["eye"])
        ):
            d[f"plane{i}_{j}"] = rect
    return d


def load(mi, d):
    """Load a scene dict without Mitsuba's optimisation pass: that pass merges
    the rectangles of a plane that share a BSDF into one triangle mesh, whose
    float32 vertices (millions of units away) would make hit points imprecise;
    the analytic rectangles intersect in their own local frame."""
    return mi.load_dict(d, optimize=False)


def main():
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    for path in sys.argv[1:]:
        with open(path) as f:
            scene = parse_scene(f.read())
        d = mitsuba_dict(mi, scene)
        kinds = {}
        for m in [s[2] for s in scene["spheres"]] + [p[2] for p in scene["planes"]]:
            k = scene["materials"][m][0]
            kinds[k] = kinds.get(k, 0) + 1
        loaded = load(mi, d)
        print(f"{path}: {len(scene['spheres'])} spheres, {len(scene['planes'])} planes "
              f"({5 * len(scene['planes'])} rectangles), uses {kinds}, scene size {scene_size(scene):.2f}, "
              f"camera {d['sensor']['type']}, {len(loaded.shapes())} Mitsuba shapes, "
              f"{len(loaded.emitters())} emitters")


if __name__ == "__main__":
    main()
