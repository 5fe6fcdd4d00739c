#!/usr/bin/env python3
"""Blender Cycles on a micropt scene: MSE over seeds and run time, one thread.

usage (bpy 5.2 for Python 3.13, from the package index):
  python3.13 tools/cycles/efficiency.py SCENE "16 64 256" SEEDS [--out CSV]

The conversion (scenes of spheres and planes with diffuse, mirror, glass and
light materials, a pinhole camera; what many.scene uses):
- Cycles on the CPU, one thread (`threads_mode` FIXED, 1), box filter 1 px,
  no denoising, no clamping, no adaptive sampling, no filter glossy, 1024
  bounces of every kind, reflective and refractive caustics on, light tree
  and MIS as Cycles defaults, `seed` = the seed;
- camera: perspective, vertical fit, the scene's VFOV; its matrix from the
  format's eye, target and up (+x of the image = forward × up);
- background: the world's colour, strength 1;
- diffuse: Diffuse BSDF; mirror: Glossy BSDF, GGX, roughness 0, colour =
  tint; glass: Glass BSDF, GGX, roughness 0, IOR; light: Emission of that
  radiance (the sphere has no other BSDF);
- diffuse and mirror spheres: Cycles' exact point-cloud spheres, one cloud
  per material; glass and light spheres: smooth icosphere meshes, 7
  subdivisions (81,920 faces). Cycles culls the back faces of its point
  spheres, so a path inside one would escape; and it does not sample the
  emission of a point cloud as a light (a point-cloud sun reached the
  ground by BSDF samples only: many's 16-spp MSE was 2.7, ten times
  Mitsuba's, its ground pixels in steps of one sample's hit of the sun);
  an emissive mesh is a light it samples;
- planes: a two-sided square of 1000 × the scene's size around the camera's
  foot on the plane (Cycles has no infinite plane: the row that holds the
  horizon differs).
Only `bpy.ops.render.render` is timed, with persistent data on and after an
untimed first render that builds the scene's BVH (Mitsuba's figures exclude
its scene loading likewise); the image is read back from a 32-bit OpenEXR.
Setting the sample count, or loading an image, makes the next render
re-sync the scene (about 1.6-1.8 s on many at 96 x 64, against 0.03 s a
sample): each budget starts with an untimed render, the timed ones change
only the seed, and their images are read back after the timing (a 1-spp
render so timed takes 0.035 s). MSE against host-tests/data/SCENE.pfm minus the mean square
of SCENE.se.pfm (the reference's own noise), as tools/seeds_mse.py does.
"""
import math, os, sys, tempfile, time

import bpy
import numpy as np
from mathutils import Matrix, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "mitsuba"))
from scene_to_mitsuba import parse_scene, scene_size  # noqa: E402
from common import read_pfm  # noqa: E402


def material(name, kind, v):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    if kind == "diffuse":
        b = nt.nodes.new("ShaderNodeBsdfDiffuse")
        b.inputs["Color"].default_value = (*v, 1.0)
    elif kind == "mirror":
        b = nt.nodes.new("ShaderNodeBsdfGlossy")
        b.distribution = "GGX"
        b.inputs["Color"].default_value = (*v, 1.0)
        b.inputs["Roughness"].default_value = 0.0
    elif kind == "glass":
        b = nt.nodes.new("ShaderNodeBsdfGlass")
        b.distribution = "GGX"
        b.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        b.inputs["Roughness"].default_value = 0.0
        b.inputs["IOR"].default_value = v[0]
    elif kind == "light":
        b = nt.nodes.new("ShaderNodeEmission")
        s = max(v)
        b.inputs["Color"].default_value = (v[0] / s, v[1] / s, v[2] / s, 1.0)
        b.inputs["Strength"].default_value = s
    else:
        raise SystemExit(f"material kind {kind} not converted")
    nt.links.new(b.outputs[0], out.inputs["Surface"])
    return m


def build(scene, w, h):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    for k in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
              "volume_bounces", "transparent_max_bounces"):
        setattr(cy, k, 1024)
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    sc.render.threads_mode = "FIXED"
    sc.render.threads = 1
    sc.render.resolution_x, sc.render.resolution_y = w, h
    sc.render.resolution_percentage = 100
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.view_settings.view_transform = "Standard"
    world = bpy.data.worlds.new("w")
    if hasattr(world, "use_nodes"):
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs[0].default_value = (*scene["background"], 1.0)
    world.node_tree.nodes["Background"].inputs[1].default_value = 1.0
    sc.world = world
    cam = scene["camera"]
    eye, target, up = (Vector(cam[k]) for k in ("eye", "target", "up"))
    f = (target - eye).normalized()
    r = f.cross(up).normalized()
    u = r.cross(f)
    cd = bpy.data.cameras.new("cam")
    cd.sensor_fit = "VERTICAL"
    cd.angle_y = math.radians(cam["vfov"])
    cd.clip_start, cd.clip_end = 1e-4, 1e8
    co = bpy.data.objects.new("cam", cd)
    co.matrix_world = Matrix(((r.x, u.x, -f.x, eye.x), (r.y, u.y, -f.y, eye.y),
                              (r.z, u.z, -f.z, eye.z), (0, 0, 0, 1)))
    sc.collection.objects.link(co)
    sc.camera = co
    mats = {n: material(n, k, v) for n, (k, v) in scene["materials"].items()}
    groups = {}
    for c, rad, mn in scene["spheres"]:
        groups.setdefault(mn, []).append((c, rad))
    for mn, items in groups.items():
        kind = scene["materials"][mn][0]
        if kind in ("glass", "light"):
            for i, (c, rad) in enumerate(items):
                me = bpy.data.meshes.new(f"{mn}{i}")
                import bmesh
                bm = bmesh.new()
                bmesh.ops.create_icosphere(bm, subdivisions=7, radius=1.0)
                bm.to_mesh(me)
                bm.free()
                me.shade_smooth()
                me.materials.append(mats[mn])
                ob = bpy.data.objects.new(f"{mn}{i}", me)
                ob.location = c
                ob.scale = (rad, rad, rad)
                sc.collection.objects.link(ob)
        else:
            pc = bpy.data.pointclouds.new(mn)
            pc.resize(len(items))
            pc.attributes["position"].data.foreach_set("vector", [x for c, _ in items for x in c])
            if "radius" not in pc.attributes:
                pc.attributes.new("radius", "FLOAT", "POINT")
            pc.attributes["radius"].data.foreach_set("value", [rad for _, rad in items])
            pc.materials.append(mats[mn])
            ob = bpy.data.objects.new(mn, pc)
            sc.collection.objects.link(ob)
    size = 1000.0 * scene_size(scene)
    for i, (p, n, mn) in enumerate(scene["planes"]):
        p, n = Vector(p), Vector(n).normalized()
        foot = eye - n * (eye - p).dot(n)
        a = n.orthogonal().normalized()
        b = n.cross(a)
        me = bpy.data.meshes.new(f"plane{i}")
        vs = [foot + (a * sx + b * sy) * size for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        me.from_pydata([tuple(v) for v in vs], [], [(0, 1, 2, 3)])
        me.materials.append(mats[mn])
        ob = bpy.data.objects.new(f"plane{i}", me)
        sc.collection.objects.link(ob)
    return sc


def main():
    args = sys.argv[1:]
    name, spps, seeds = args[0], [int(x) for x in args[1].split()], int(args[2])
    root = os.path.join(HERE, "..", "..")
    scene = parse_scene(open(os.path.join(root, "scenes", f"{name}.scene")).read())
    ref = read_pfm(os.path.join(root, "host-tests", "data", f"{name}.pfm"))
    se_path = os.path.join(root, "host-tests", "data", f"{name}.se.pfm")
    ref_noise = float((read_pfm(se_path) ** 2).mean()) if os.path.exists(se_path) else 0.0
    h, w, _ = ref.shape
    sc = build(scene, w, h)
    # the scene's BVH kept between renders and built once in an untimed
    # first render (Mitsuba's figures exclude its scene loading likewise)
    sc.render.use_persistent_data = True
    with tempfile.TemporaryDirectory() as tmp:
        sc.cycles.samples = 1
        sc.render.filepath = os.path.join(tmp, "warm.exr")
        bpy.ops.render.render(write_still=True)
        for spp in spps:
            # a budget starts with an untimed render (the new sample count
            # re-syncs the scene); the timed renders change only the seed
            # and write their own files, read back after the timing (an
            # image loaded between renders re-syncs the scene too: about
            # 1.6 s a call on many at 96 x 64, against 0.03 s a sample)
            sc.cycles.samples = spp
            sc.cycles.seed = seeds
            sc.render.filepath = os.path.join(tmp, "warm.exr")
            bpy.ops.render.render(write_still=True)
            secs = []
            for s in range(seeds):
                sc.cycles.seed = s
                sc.render.filepath = os.path.join(tmp, f"r{spp}_{s}.exr")
                t0 = time.perf_counter()
                bpy.ops.render.render(write_still=True)
                secs.append(time.perf_counter() - t0)
            mses = []
            for s in range(seeds):
                img = bpy.data.images.load(os.path.join(tmp, f"r{spp}_{s}.exr"))
                px = np.array(img.pixels[:], dtype=np.float64).reshape(h, w, 4)[::-1, :, :3]
                bpy.data.images.remove(img)
                mses.append(((px - ref) ** 2).mean())
            mse = float(np.mean(mses)) - ref_noise
            t = float(np.median(secs))
            print(f"cycles {name} spp {spp}: MSE {mse:.3e} (seed sd {np.std(mses):.1e}), {t:.3f} s, "
                  f"efficiency {1.0 / (mse * t):.1f}", flush=True)


if __name__ == "__main__":
    main()
