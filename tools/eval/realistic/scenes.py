#!/usr/bin/env python3
"""Deterministic path-traced evaluation corpus (Blender Cycles, CPU), run with a Python that has `bpy`.

Three scenes (room, outdoor, extreme), each rendered from a panorama camera at the world origin:
  colour.exr      linear RGB (combined pass, film opaque, view transform Standard)
  depth.exr       one float32 channel Z: metres along the ray (rendered as an emission of Light Path's Ray
                  Length, one sample at each pixel centre); sky is +inf
  bg_colour.exr, bg_depth.exr   the same with the scene's foreground objects hidden from camera rays only
                  (they still cast shadows and show in reflections): the truth behind them
  views/NN.exr    perspective ground-truth views (linear RGB) from eyes inside the freedom ball (0.9 m)
  cameras.json    per view: eye, look_at, up, horizontal fov (degrees), size [w, h]
The equirect follows `pomc build --convention blender`: azimuth pi(1 - 2u), centre column along +X, +Z
up (camera rotation PANO_ROTATION, verified with the `probe` scene: see docs/evaluation.md).

Outputs are cached: <cache-root>/<hash of this file + options>/<scene>/, rendered only when the scene's
done.json is missing. The last line printed is the corpus directory.

  python scenes.py [--small] [--size 1024x512] [--spp 16] [--views 8] [--view-size 480x270]
                   [--view-spp 32] [--scenes room,outdoor,extreme] [--cache-root DIR]
"""
import argparse
import hashlib
import json
import math
import os
import random
import shutil
import sys
import time

import numpy as np
import OpenEXR

import bpy
from mathutils import Matrix, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", "..", ".."))
RADIUS = 0.9  # freedom radius the views are spread over
# Blender cameras look along local -Z with +Y up. This rotation puts the equirect's centre column on +X
# and the top row on +Z, with +Y at u = 1/4 (azimuth pi(1 - 2u)): pomc's `blender` convention.
PANO_ROTATION = (math.radians(90), 0.0, math.radians(-90))


# ---------------------------------------------------------------- scene building helpers

def material(name, kind="plain", c1=(0.8, 0.8, 0.8), c2=(0.2, 0.2, 0.2), scale=1.0, rough=0.6, metal=0.0):
    """Principled BSDF; base colour a plain colour, a 3D checker or a brick texture in object space."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    bsdf = nt.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = rough
    bsdf.inputs["Metallic"].default_value = metal
    if kind == "plain":
        bsdf.inputs["Base Color"].default_value = (*c1, 1)
        return m
    coord = nt.nodes.new("ShaderNodeTexCoord")
    tex = nt.nodes.new("ShaderNodeTexChecker" if kind == "checker" else "ShaderNodeTexBrick")
    tex.inputs["Color1"].default_value = (*c1, 1)
    tex.inputs["Color2"].default_value = (*c2, 1)
    tex.inputs["Scale"].default_value = scale
    if kind == "brick":
        tex.inputs["Mortar"].default_value = (0.85, 0.85, 0.8, 1)
        tex.inputs["Mortar Size"].default_value = 0.03
    nt.links.new(coord.outputs["Object"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    return m


def finish(obj, mat, smooth=False, fg=False):
    obj.data.materials.clear()
    obj.data.materials.append(mat)
    if smooth:
        for p in obj.data.polygons:
            p.use_smooth = True
    obj["fg"] = fg
    return obj


def box_mesh(name, lo, hi, inward=False):
    """Axis-aligned box from corner lo to hi, in world coordinates (object at the origin)."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    v = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0), (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    f = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    if inward:
        f = [tuple(reversed(t)) for t in f]
    me = bpy.data.meshes.new(name)
    me.from_pydata(v, [], f)
    me.update()
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def plane(name, size, z):
    me = bpy.data.meshes.new(name)
    h = size / 2
    me.from_pydata([(-h, -h, z), (h, -h, z), (h, h, z), (-h, h, z)], [], [(0, 1, 2, 3)])
    me.update()
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def sphere(name, loc, r, mat, fg=True, seg=64):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=seg, ring_count=seg // 2, radius=r, location=loc)
    o = bpy.context.active_object
    o.name = name
    return finish(o, mat, smooth=True, fg=fg)


def cylinder(name, loc, r, depth, mat, fg=True, rot=(0, 0, 0), seg=48):
    bpy.ops.mesh.primitive_cylinder_add(vertices=seg, radius=r, depth=depth, location=loc, rotation=rot)
    o = bpy.context.active_object
    o.name = name
    return finish(o, mat, smooth=True, fg=fg)


def cube(name, lo, hi, mat, fg=True):
    return finish(box_mesh(name, lo, hi), mat, fg=fg)


def light(name, kind, loc, power, size=0.0, rot=(0, 0, 0), colour=(1, 1, 1)):
    ld = bpy.data.lights.new(name, kind)
    ld.energy = power
    ld.color = colour
    if kind == "AREA":
        ld.size = size
    elif kind in ("POINT", "SPOT"):
        ld.shadow_soft_size = size
    elif kind == "SUN":
        ld.angle = size
    o = bpy.data.objects.new(name, ld)
    o.location = loc
    o.rotation_euler = rot
    bpy.context.scene.collection.objects.link(o)
    return o


def world(sky=None, colour=(0.05, 0.05, 0.05), strength=1.0):
    """Plain world colour, or a sky gradient (horizon -> zenith, grey below the horizon)."""
    w = bpy.data.worlds.new("scene")
    bpy.context.scene.world = w
    w.use_nodes = True
    nt = w.node_tree
    bg = nt.nodes["Background"]
    bg.inputs["Strength"].default_value = strength
    if sky is None:
        bg.inputs["Color"].default_value = (*colour, 1)
        return
    coord = nt.nodes.new("ShaderNodeTexCoord")
    sep = nt.nodes.new("ShaderNodeSeparateXYZ")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    fac = nt.nodes.new("ShaderNodeMath")  # z of the view direction -> 0.5 + z / 2
    fac.operation = "MULTIPLY_ADD"
    fac.inputs[1].default_value = fac.inputs[2].default_value = 0.5
    nt.links.new(coord.outputs["Generated"], sep.inputs["Vector"])  # world Generated = view direction
    nt.links.new(sep.outputs["Z"], fac.inputs[0])
    nt.links.new(fac.outputs["Value"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], bg.inputs["Color"])
    ramp.color_ramp.interpolation = "LINEAR"
    e = ramp.color_ramp.elements
    e[0].position, e[0].color = 0.49, (0.35, 0.33, 0.3, 1)  # below the horizon
    e[1].position, e[1].color = 1.0, (0.10, 0.25, 0.75, 1)  # zenith
    mid = e.new(0.5)
    mid.color = (0.75, 0.85, 1.0, 1)  # horizon


# ---------------------------------------------------------------- the scenes

def scene_room():
    # Room 6 x 5 x 3 m, off-centre around the camera: x -2.6..3.4, y -2.2..2.8, z -1.4..1.6 (floor 1.4 m below).
    walls = material("walls", "checker", (0.75, 0.7, 0.6), (0.3, 0.35, 0.45), scale=2.5)
    floor = material("floor", "brick", (0.55, 0.25, 0.12), (0.35, 0.18, 0.1), scale=1.2, rough=0.8)
    ceil = material("ceiling", "checker", (0.9, 0.9, 0.9), (0.6, 0.6, 0.65), scale=1.5)
    room = box_mesh("room", (-2.6, -2.2, -1.4), (3.4, 2.8, 1.6), inward=True)
    for m in (walls, floor, ceil):
        room.data.materials.append(m)
    for p in room.data.polygons:  # faces 0: floor, 1: ceiling, rest walls
        p.material_index = {0: 1, 1: 2}.get(p.index, 0)
    room["fg"] = False
    red = material("red", "checker", (0.8, 0.1, 0.1), (0.9, 0.8, 0.2), scale=6)
    green = material("green", "checker", (0.1, 0.6, 0.2), (0.05, 0.2, 0.5), scale=8)
    blue = material("blue", "plain", (0.15, 0.3, 0.85), rough=0.3)
    metal = material("metal", "plain", (0.8, 0.8, 0.85), rough=0.25, metal=1.0)
    wood = material("wood", "checker", (0.5, 0.3, 0.15), (0.35, 0.2, 0.1), scale=10)
    white = material("lamp", "plain", (0.95, 0.95, 0.9))
    sphere("ball", (1.8, 0.9, -0.6), 0.4, red)
    cylinder("column", (-1.2, 1.6, -0.8), 0.25, 1.2, green)
    bpy.ops.mesh.primitive_torus_add(location=(1.2, -1.3, 0.2), rotation=(0.6, 0.3, 0), major_radius=0.35,
                                     minor_radius=0.1, major_segments=64, minor_segments=24)
    finish(bpy.context.active_object, blue, smooth=True, fg=True).name = "torus"
    cube("crate", (2.1, -1.5, -1.4), (2.7, -0.9, -0.8), wood)
    cylinder("pole", (1.3, 0.5, 0.1), 0.0125, 3.0, metal)  # 2.5 cm thick, floor to ceiling
    # A stool: seat and four 3 cm legs.
    cube("stool-seat", (-1.6, -1.5, -0.95), (-1.2, -1.1, -0.9), wood)
    for i, (x, y) in enumerate([(-1.57, -1.47), (-1.23, -1.47), (-1.23, -1.13), (-1.57, -1.13)]):
        cylinder(f"stool-leg{i}", (x, y, -1.175), 0.015, 0.45, wood, seg=16)
    sphere("near", (0.22, -0.17, -0.12), 0.06, blue)  # 0.3 m from the centre
    sphere("seam", (-1.9, 0.0, 0.0), 0.35, green)  # straddles azimuth +-180 degrees (-X)
    # Ceiling lamp right above the camera (cord + shade), a bowl-ish box on the floor right below.
    cylinder("lamp-cord", (0, 0, 1.45), 0.006, 0.3, white, seg=12)
    bpy.ops.mesh.primitive_cone_add(vertices=48, radius1=0.22, radius2=0.06, depth=0.2, location=(0, 0, 1.2))
    finish(bpy.context.active_object, white, smooth=True, fg=True).name = "lamp-shade"
    cube("floor-box", (-0.15, -0.12, -1.4), (0.15, 0.18, -1.25), red)
    light("bulb", "POINT", (0, 0, 1.05), 15, size=0.05, colour=(1, 0.9, 0.75))
    light("panel", "AREA", (1.5, -0.5, 1.58), 50, size=1.0)
    light("fill", "POINT", (-2.0, 2.0, 0.8), 12, size=0.2)
    world(colour=(0.05, 0.05, 0.06))


def scene_outdoor():
    ground = material("ground", "checker", (0.35, 0.4, 0.25), (0.2, 0.25, 0.15), scale=0.5, rough=0.9)
    plane("ground", 400, -1.6).data.materials.append(ground)
    bpy.data.objects["ground"]["fg"] = False
    facade = material("facade", "checker", (0.6, 0.35, 0.25), (0.3, 0.2, 0.15), scale=0.6)
    concrete = material("concrete", "checker", (0.7, 0.7, 0.68), (0.45, 0.47, 0.5), scale=0.4)
    for i, (cx, cy, w, d, h, m) in enumerate([(12, 6, 4, 5, 8, facade), (-20, 15, 8, 6, 12, concrete),
                                              (25, -18, 6, 6, 6, facade), (-8, -30, 10, 6, 15, concrete),
                                              (38, 5, 6, 10, 20, concrete), (-6, 9, 3, 3, 4, facade)]):
        cube(f"building{i}", (cx - w / 2, cy - d / 2, -1.6), (cx + w / 2, cy + d / 2, -1.6 + h), m, fg=False)
    red = material("red", "checker", (0.8, 0.1, 0.1), (0.9, 0.8, 0.2), scale=3)
    blue = material("blue", "plain", (0.15, 0.3, 0.85), rough=0.3)
    green = material("green", "checker", (0.1, 0.6, 0.2), (0.05, 0.2, 0.5), scale=4)
    sphere("ball1", (4, -3, -0.6), 1.0, red)
    sphere("ball2", (-6, -2, -0.8), 0.8, blue)
    sphere("ball3", (9, 12, 0.4), 2.0, green)
    cylinder("post", (3, 2, -0.6), 0.05, 2.0, blue)
    sphere("seam", (-5, 0, -0.6), 1.0, green)  # azimuth +-180 degrees
    cube("near", (0.3, 0.15, -0.6), (0.5, 0.35, -0.4), red)  # ~0.5 m from the centre
    light("sun", "SUN", (0, 0, 10), 2.0, size=math.radians(1.0), rot=(math.radians(40), 0, math.radians(30)))
    world(sky=True)


def scene_extreme():
    ground = material("ground", "checker", (0.5, 0.45, 0.35), (0.25, 0.22, 0.18), scale=1.0, rough=0.9)
    plane("ground", 200, -1.6).data.materials.append(ground)  # edge 100 m away
    bpy.data.objects["ground"]["fg"] = False
    far = material("far", "checker", (0.6, 0.6, 0.65), (0.4, 0.4, 0.5), scale=0.004)
    sphere("planet", (2500, 4300, 300), 1000, far, fg=False)  # ~5 km away
    red = material("red", "checker", (0.8, 0.1, 0.1), (0.9, 0.8, 0.2), scale=60)
    metal = material("metal", "plain", (0.8, 0.8, 0.85), rough=0.25, metal=1.0)
    sphere("tiny", (0.05, 0.0, 0.0), 0.015, red)  # 5 cm from the centre: surface at 3.5 cm
    for i, (x, y) in enumerate([(2.0, 1.0), (-1.5, 2.5), (3.5, -2.0), (-4.0, -3.0)]):
        cylinder(f"pole{i}", (x, y, 0.4), 0.01, 4.0, metal, seg=16)
    cylinder("wire", (3.0, 0.0, 1.2), 0.005, 8.0, metal, rot=(math.radians(90), 0, 0), seg=12)
    light("sun", "SUN", (0, 0, 10), 2.0, size=math.radians(1.0), rot=(math.radians(50), 0, math.radians(-40)))
    world(sky=True)


SCENES = {"room": scene_room, "outdoor": scene_outdoor, "extreme": scene_extreme}


def scene_probe():
    """Convention check: coloured markers on +X (red), +Y (green), +Z (blue), -Z (yellow) in a grey room."""
    grey = material("grey", "checker", (0.5, 0.5, 0.5), (0.3, 0.3, 0.3), scale=2)
    box_mesh("room", (-3, -3, -3), (3, 3, 3), inward=True).data.materials.append(grey)
    bpy.data.objects["room"]["fg"] = False
    for name, loc, col in [("px", (2, 0, 0), (1, 0, 0)), ("py", (0, 2, 0), (0, 1, 0)),
                           ("pz", (0, 0, 2), (0, 0, 1)), ("nz", (0, 0, -2), (1, 1, 0))]:
        sphere(name, loc, 0.3, material(name, "plain", col))
    light("l", "POINT", (1, 1, 1), 300, size=0.3)
    world(colour=(0.2, 0.2, 0.2))


SCENES["probe"] = scene_probe


# ---------------------------------------------------------------- cameras and rendering

def view_cameras(name, n, size, seed):
    """Deterministic eyes in the freedom ball: every third near the radius (0.75-0.85 m), the others
    anywhere inside; looking level, down or up, some rolled. Eyes keep 0.12 m from foreground objects."""
    if name == "probe":
        dirs = [(1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0)]
        return [dict(eye=[0.0, 0.0, 0.0], look_at=list(map(float, d)), up=[0.0, 0.0, 1.0] if d[2] == 0 else [1.0, 0.0, 0.0],
                     fov=90.0, size=list(size)) for d in dirs[:n]]
    rng = random.Random(f"{seed}-{name}")
    boxes = []  # world bounding boxes of the foreground objects
    for o in bpy.context.scene.objects:
        if o.type == "MESH" and o.get("fg"):
            pts = [o.matrix_world @ Vector(b) for b in o.bound_box]
            boxes.append((Vector([min(p[k] for p in pts) for k in range(3)]), Vector([max(p[k] for p in pts) for k in range(3)])))
    cams = []
    while len(cams) < n:
        i = len(cams)
        d = Vector([rng.gauss(0, 1) for _ in range(3)]).normalized()
        r = rng.uniform(0.75, 0.85) if i % 3 == 0 else RADIUS * rng.random() ** (1 / 3)
        eye = d * min(r, 0.85)
        if any(Vector([max(lo[k] - eye[k], 0, eye[k] - hi[k]) for k in range(3)]).length < 0.12 for lo, hi in boxes):
            continue
        yaw = rng.uniform(-math.pi, math.pi)
        pitch = {1: rng.uniform(-75, -40), 2: rng.uniform(35, 70)}.get(i % 3, rng.uniform(-25, 25))
        pitch = math.radians(pitch)
        fwd = Vector((math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch)))
        up = Vector((0, 0, 1))
        if i % 4 == 3:  # roll the camera by up to 25 degrees
            side = fwd.cross(up).normalized()
            a = math.radians(rng.uniform(-25, 25))
            up = up * math.cos(a) + side * math.sin(a)
        fov = rng.choice([60.0, 75.0, 90.0, 100.0])
        cams.append(dict(eye=[round(x, 4) for x in eye], look_at=[round(x, 4) for x in eye + fwd * 2],
                         up=[round(x, 4) for x in up], fov=fov, size=list(size)))
    return cams


def setup_render(w, h, spp, denoise, depth_only=False):
    s = bpy.context.scene
    s.render.engine = "CYCLES"
    c = s.cycles
    c.device = "CPU"
    c.seed = 0
    c.use_animated_seed = False
    c.use_adaptive_sampling = False
    c.samples = 1 if depth_only else spp
    c.max_bounces = 4
    c.sample_clamp_indirect = 10.0
    # Depth: one sample at the pixel centre (a tiny filter), so no edge pixel averages two surfaces' depths.
    c.filter_width = 0.01 if depth_only else 1.5
    c.use_denoising = bool(denoise and not depth_only)
    if c.use_denoising:
        c.denoiser = "OPENIMAGEDENOISE"
    s.render.resolution_x, s.render.resolution_y = w, h
    s.render.resolution_percentage = 100
    s.render.film_transparent = False
    s.render.use_persistent_data = False
    s.view_settings.view_transform = "Standard"
    s.view_settings.look = "None"
    s.view_settings.exposure = 0.0
    s.view_settings.gamma = 1.0
    # Depth: Blender 5.0's multilayer EXR output holds only the combined pass here, so depth is rendered
    # as colour: every surface emits (ray length, 1, 0) -- for a camera ray, Light Path's Ray Length is
    # the distance from the camera along the ray -- and the world is black (G = 0 marks sky).
    s.view_layers[0].material_override = depth_material() if depth_only else None
    if depth_only:
        c.max_bounces = 0
        s.world = depth_world()
    elif "scene" in bpy.data.worlds:
        s.world = bpy.data.worlds["scene"]
    im = s.render.image_settings
    im.media_type = "MULTI_LAYER_IMAGE"
    im.file_format = "OPEN_EXR_MULTILAYER"
    im.color_depth = "32"
    im.exr_codec = "ZIP"


def depth_material():
    m = bpy.data.materials.get("depth")
    if m is None:
        m = bpy.data.materials.new("depth")
        m.use_nodes = True
        nt = m.node_tree
        nt.nodes.clear()
        lp, comb = nt.nodes.new("ShaderNodeLightPath"), nt.nodes.new("ShaderNodeCombineXYZ")
        em, out = nt.nodes.new("ShaderNodeEmission"), nt.nodes.new("ShaderNodeOutputMaterial")
        comb.inputs["Y"].default_value = 1.0
        nt.links.new(lp.outputs["Ray Length"], comb.inputs["X"])
        nt.links.new(comb.outputs["Vector"], em.inputs["Color"])
        nt.links.new(em.outputs["Emission"], out.inputs["Surface"])
    return m


def depth_world():
    w = bpy.data.worlds.get("depth")
    if w is None:
        w = bpy.data.worlds.new("depth")
        w.use_nodes = True
        w.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    return w


def render(path_tmp):
    bpy.context.scene.render.filepath = path_tmp
    bpy.ops.render.render(write_still=True)
    f = OpenEXR.File(path_tmp, separate_channels=True)
    ch = f.channels()
    rgb = np.stack([ch[k].pixels for k in sorted(ch) if k.endswith("Combined.R") or k.endswith("Combined.G")
                    or k.endswith("Combined.B")], -1)  # sorted: B, G, R
    rgb = rgb[..., ::-1].astype(np.float32)
    os.remove(path_tmp)
    return rgb


def write_rgb(path, rgb):
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    ch = {"R": np.ascontiguousarray(rgb[..., 0]), "G": np.ascontiguousarray(rgb[..., 1]),
          "B": np.ascontiguousarray(rgb[..., 2])}
    OpenEXR.File(hdr, ch).write(path)


def write_depth(path, rgb):
    """Depth render (ray length, 1, 0) -> one channel Z; sky (G = 0) is +inf."""
    z = np.array(rgb[..., 0], dtype=np.float32)
    z[rgb[..., 1] < 0.5] = np.inf
    hdr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(hdr, {"Z": z}).write(path)


def render_scene(name, out, o):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    SCENES[name]()
    s = bpy.context.scene
    tmp = os.path.join(out, "_tmp.exr")
    pano = bpy.data.objects.new("pano", bpy.data.cameras.new("pano"))
    s.collection.objects.link(pano)
    pano.data.type = "PANO"
    pano.data.panorama_type = "EQUIRECTANGULAR"
    pano.data.clip_start, pano.data.clip_end = 0.001, 1e5
    pano.location = (0, 0, 0)
    pano.rotation_euler = PANO_ROTATION
    s.camera = pano
    fg = [ob for ob in s.objects if ob.type == "MESH" and ob.get("fg")]
    w, h = o.size
    t0 = time.time()
    for prefix, hide in (("", False), ("bg_", True)):
        for ob in fg:
            ob.visible_camera = not hide
        setup_render(w, h, o.spp, o.denoise)
        write_rgb(os.path.join(out, prefix + "colour.exr"), render(tmp))
        setup_render(w, h, o.spp, o.denoise, depth_only=True)
        write_depth(os.path.join(out, prefix + "depth.exr"), render(tmp))
    for ob in fg:
        ob.visible_camera = True
    print(f"[scenes] {name}: panoramas {time.time() - t0:.0f} s", flush=True)
    vw, vh = o.view_size
    cams = view_cameras(name, o.views, (vw, vh), o.seed)
    cam = bpy.data.objects.new("view", bpy.data.cameras.new("view"))
    s.collection.objects.link(cam)
    cam.data.sensor_fit = "HORIZONTAL"
    cam.data.clip_start, cam.data.clip_end = 0.001, 1e5
    s.camera = cam
    os.makedirs(os.path.join(out, "views"), exist_ok=True)
    setup_render(vw, vh, o.view_spp, o.denoise)
    for i, c in enumerate(cams):
        eye, at, up = Vector(c["eye"]), Vector(c["look_at"]), Vector(c["up"])
        f = (at - eye).normalized()
        r = f.cross(up).normalized()
        u = r.cross(f)
        m = Matrix((r, u, -f)).transposed().to_4x4()  # columns: camera X, Y, Z (looks along -Z)
        m.translation = eye
        cam.matrix_world = m
        cam.data.angle = math.radians(c["fov"])  # horizontal, sensor_fit HORIZONTAL
        write_rgb(os.path.join(out, "views", f"{i:02d}.exr"), render(tmp))
        c["file"] = f"views/{i:02d}.exr"
    with open(os.path.join(out, "cameras.json"), "w") as fh:
        json.dump(dict(scene=name, radius=RADIUS, views=cams), fh, indent=1)
    print(f"[scenes] {name}: {len(cams)} views {time.time() - t0:.0f} s", flush=True)


def options(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--small", action="store_true", help="CI preset: 512x256, 3 views per scene, few samples")
    p.add_argument("--size", help="panorama WxH (default 1024x512)")
    p.add_argument("--spp", type=int, help="panorama samples per pixel (default 16)")
    p.add_argument("--views", type=int, help="perspective truth views per scene (default 8)")
    p.add_argument("--view-size", help="view WxH (default 480x270)")
    p.add_argument("--view-spp", type=int, help="view samples per pixel (default 32)")
    p.add_argument("--scenes", default="room,outdoor,extreme")
    p.add_argument("--no-denoise", action="store_true", help="skip OIDN denoising")
    p.add_argument("--seed", type=int, default=10)
    p.add_argument("--cache-root", default=os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")),
                                                        "realistic-corpus"))
    p.add_argument("--print-dir", action="store_true", help="print the corpus directory and exit")
    o = p.parse_args(argv)
    small = dict(size="512x256", spp=8, views=3, view_size="320x180", view_spp=16)
    full = dict(size="1024x512", spp=16, views=8, view_size="480x270", view_spp=32)
    for k, v in (small if o.small else full).items():
        if getattr(o, k) is None:
            setattr(o, k, v)
    o.size = tuple(int(x) for x in o.size.split("x"))
    o.view_size = tuple(int(x) for x in o.view_size.split("x"))
    import _cycles
    o.denoise = bool(_cycles.with_openimagedenoise) and not o.no_denoise
    return o


def corpus_dir(o):
    with open(os.path.abspath(__file__), "rb") as fh:
        h = hashlib.sha256(fh.read())
    h.update(json.dumps([o.size, o.spp, o.views, o.view_size, o.view_spp, o.denoise, o.seed]).encode())
    return os.path.join(o.cache_root, h.hexdigest()[:12])


def main():
    o = options(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1:])
    base = corpus_dir(o)
    if o.print_dir:
        print(base)
        return
    for name in o.scenes.split(","):
        out = os.path.join(base, name)
        if os.path.exists(os.path.join(out, "done.json")):
            print(f"[scenes] {name}: cached in {out}", flush=True)
            continue
        shutil.rmtree(out, ignore_errors=True)
        os.makedirs(out)
        t = time.time()
        render_scene(name, out, o)
        with open(os.path.join(out, "done.json"), "w") as fh:
            json.dump(dict(scene=name, size=o.size, spp=o.spp, views=o.views, view_size=o.view_size,
                           view_spp=o.view_spp, denoise=o.denoise, seed=o.seed, blender=bpy.app.version_string,
                           seconds=round(time.time() - t, 1)), fh, indent=1)
    print(base)


if __name__ == "__main__":
    main()
